//! The glTF JSON read the way the specification allows, not the way the `gltf` crate's strict
//! serde types insist on: integers written as `1.0` are normalised to `1`, scenes without a
//! `nodes` property get an empty list, animations (not shown) are dropped, and the crate's own
//! validation (which refuses valid
//! files: accessors without a buffer view, textures whose image comes from an extension) is not
//! run. Every index is instead checked where the loader follows it (see `get`).

use gltf::json;
use serde_json::Value;

/// A parsed file: the typed JSON, the raw JSON (for extension data the typed JSON does not
/// keep) and the GLB's BIN chunk.
pub(super) struct Parsed {
    pub(super) root: json::Root,
    pub(super) raw: Value,
    pub(super) blob: Option<Vec<u8>>,
}

/// GLB or glTF JSON bytes to a [`Parsed`] file, or the one-line reason it is not glTF.
pub(super) fn parse(bytes: &[u8]) -> Result<Parsed, String> {
    let (text, blob) = if bytes.starts_with(b"glTF") {
        let corrupt = |why: String| format!("the GLB file is truncated or corrupt ({why})");
        // The header's length is checked here, and the slice cut to it (data after the
        // declared length is not part of the file; the crate would read it as a chunk).
        let declared = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
            .ok_or_else(|| corrupt("no complete header".into()))?;
        if declared < 20 || declared > bytes.len() {
            return Err(corrupt(format!(
                "the header declares {declared} bytes, the file has {}",
                bytes.len()
            )));
        }
        let glb = gltf::Glb::from_slice(&bytes[..declared]).map_err(|e| corrupt(e.to_string()))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes.to_vec(), None)
    };
    let mut raw: Value =
        serde_json::from_slice(&text).map_err(|e| format!("not valid glTF ({e})"))?;
    if !raw.is_object() {
        return Err("not valid glTF (the JSON is not an object)".into());
    }
    normalize_integers(&mut raw);
    // Animations are not shown; their typed JSON is stricter than the specification (a channel
    // target without a node is valid), so they are not read at all.
    if let Some(o) = raw.as_object_mut() {
        o.remove("animations");
    }
    if let Some(scenes) = raw.get_mut("scenes").and_then(Value::as_array_mut) {
        for scene in scenes.iter_mut().filter_map(Value::as_object_mut) {
            scene
                .entry("nodes")
                .or_insert_with(|| Value::Array(Vec::new()));
        }
    }
    // Through text, not `from_value`: the typed JSON keeps `extras` as raw JSON text.
    let normalized = serde_json::to_vec(&raw).map_err(|e| format!("not valid glTF ({e})"))?;
    // (The error's line and column would point into the normalised text, not the file's.)
    let root = json::Root::from_slice(&normalized).map_err(|e| {
        let e = e.to_string();
        format!(
            "not valid glTF ({})",
            e.split(" at line ").next().unwrap_or(&e)
        )
    })?;
    Ok(Parsed { root, raw, blob })
}

/// Every number with an integer value written as a float (`3.0`) becomes an integer: JSON does
/// not distinguish them and glTF allows both, but the crate's serde types refuse `3.0` where
/// they expect an index, a count or an enum. Float fields accept integers, so this is safe for
/// every field. Only values exactly representable in an f64 mantissa are touched.
fn normalize_integers(v: &mut Value) {
    match v {
        Value::Number(n) if !n.is_i64() && !n.is_u64() => {
            if let Some(f) = n.as_f64()
                && f.fract() == 0.0
                && f.abs() < 9.0e15
            {
                *v = if f < 0.0 {
                    Value::from(f as i64)
                } else {
                    Value::from(f as u64)
                };
            }
        }
        Value::Array(a) => a.iter_mut().for_each(normalize_integers),
        Value::Object(o) => o.values_mut().for_each(normalize_integers),
        _ => {}
    }
}

/// What a list of the file holds, for error messages.
pub(super) trait Kind {
    /// "accessor", "buffer view", ...
    const KIND: &'static str;
}

macro_rules! kinds {
    ($($t:ty => $name:literal),* $(,)?) => {
        $(impl Kind for $t { const KIND: &'static str = $name; })*
    };
}

kinds! {
    json::Accessor => "accessor",
    json::buffer::View => "buffer view",
    json::Buffer => "buffer",
    json::Mesh => "mesh",
    json::Node => "node",
    json::Material => "material",
    json::Texture => "texture",
    json::Image => "image",
    json::Camera => "camera",
    json::Scene => "scene",
    json::extensions::scene::khr_lights_punctual::Light => "light",
}

/// `list[index]`, or an error naming what refers to what: the loader's one way to follow an
/// index from the file.
pub(super) fn get<'a, T: Kind>(list: &'a [T], index: usize, what: &str) -> Result<&'a T, String> {
    list.get(index).ok_or_else(|| {
        format!(
            "{what} refers to {} {index}, but the file has {}",
            T::KIND,
            list.len()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_valued_floats_become_integers_and_others_stay() {
        let mut v: Value =
            serde_json::from_str(r#"{"a": 3.0, "b": [0.5, -2.0, 1e300], "c": {"d": 7}}"#).unwrap();
        normalize_integers(&mut v);
        assert_eq!(v["a"], Value::from(3u64));
        assert_eq!(v["b"][0], Value::from(0.5));
        assert_eq!(v["b"][1], Value::from(-2i64));
        assert!(v["b"][2].is_f64());
        assert_eq!(v["c"]["d"], Value::from(7u64));
    }

    #[test]
    fn get_names_the_missing_index() {
        let e = get::<json::Accessor>(&[], 4, "mesh 0 POSITION").unwrap_err();
        assert_eq!(
            e,
            "mesh 0 POSITION refers to accessor 4, but the file has 0"
        );
    }
}
