//! KHR_draco_mesh_compression: a primitive whose attributes and indices are one Draco stream in
//! a buffer view, decoded by the pure-Rust `draco-core` decoder. The extension's specification
//! (KhronosGroup/glTF, `extensions/2.0/Khronos/KHR_draco_mesh_compression`): the primitive's
//! extension names the `bufferView` of the stream and maps each glTF attribute name to the
//! Draco attribute's unique id; the primitive's accessors keep their type, component type and
//! `normalized` flag (how the decoded values are read) but have no data of their own, and the
//! decoded faces are the primitive's triangle indices.

use super::data::{DataError, normalized_value};
use super::mesh::MAX_TRIANGLES;
use draco_core::{DataType, DecodeLimits, DecoderBuffer, Mesh, MeshDecoder, PointIndex};
use gltf::json::accessor::ComponentType;
use serde_json::Value;

/// The extension's name, as files require it.
pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// Most bytes of attributes one primitive may decode to (1 GiB); its points and faces are
/// capped at the scene's cap on triangles, so that a small stream that claims a huge mesh is
/// refused before it is allocated.
const MAX_DECODED_BYTES: u64 = 1 << 30;

/// What a compressed primitive declares: the view holding its stream and the Draco id of each
/// of its attributes.
pub(super) struct Compressed {
    pub(super) view: usize,
    attributes: Vec<(String, u32)>,
}

/// The primitive's compression (`raw` its JSON), when it has the extension.
pub(super) fn compressed(raw: &Value, what: &str) -> Result<Option<Compressed>, String> {
    let Some(ext) = raw.get("extensions").and_then(|e| e.get(EXTENSION)) else {
        return Ok(None);
    };
    let view = ext
        .get("bufferView")
        .and_then(Value::as_u64)
        .and_then(|v| usize::try_from(v).ok())
        .ok_or_else(|| format!("{what}'s {EXTENSION} has no bufferView"))?;
    let attributes = ext
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| format!("{what}'s {EXTENSION} has no attributes"))?
        .iter()
        .map(|(name, id)| {
            id.as_u64()
                .and_then(|i| u32::try_from(i).ok())
                .map(|i| (name.clone(), i))
                .ok_or_else(|| format!("{what}'s {EXTENSION} attribute {name} has no id"))
        })
        .collect::<Result<_, _>>()?;
    Ok(Some(Compressed { view, attributes }))
}

/// A decoded primitive: its mesh (points and their attributes), the glTF attribute names
/// with their Draco ids, and its triangle indices.
pub(super) struct Decoded {
    mesh: Mesh,
    attributes: Vec<(String, u32)>,
    pub(super) indices: Vec<u32>,
}

impl Compressed {
    /// Decodes the stream `bytes` (the faces' indices are checked where every primitive's
    /// are, in `mesh`).
    pub(super) fn decode(self, bytes: &[u8], what: &str) -> Result<Decoded, DataError> {
        let limits = DecodeLimits::default()
            .with_max_points(MAX_TRIANGLES as u64)
            .with_max_faces(MAX_TRIANGLES as u64)
            .with_max_decoded_bytes(MAX_DECODED_BYTES);
        let mut buffer = DecoderBuffer::new(bytes).with_limits(limits);
        let mut mesh = Mesh::new();
        MeshDecoder::new()
            .decode(&mut buffer, &mut mesh)
            .map_err(|e| format!("{what}'s {EXTENSION} stream cannot be decoded ({e})"))?;
        let indices: Vec<u32> = mesh.faces().iter().flat_map(|f| f.map(|p| p.0)).collect();
        Ok(Decoded {
            mesh,
            attributes: self.attributes,
            indices,
        })
    }
}

impl Decoded {
    /// The decoded values of the glTF attribute `name` with `width` components, read as its
    /// accessor says (`normalized` integers as `data::normalized_value` reads them, glTF 2.0
    /// §3.11), or `None` when the stream does not carry it.
    pub(super) fn floats(
        &self,
        name: &str,
        width: usize,
        is_normalized: bool,
    ) -> Option<Result<Vec<f32>, DataError>> {
        let &(_, id) = self.attributes.iter().find(|(n, _)| n == name)?;
        let lacks = |why: String| -> Option<Result<Vec<f32>, DataError>> {
            Some(Err(format!(
                "{EXTENSION}: attribute {name} (Draco attribute {id}) {why}"
            )
            .into()))
        };
        let Some(attribute) = self.mesh.attribute_by_unique_id(id) else {
            return lacks("is not in the stream".into());
        };
        // Every point must have a value (the decoder reads a missing one as zeros).
        let points = self.mesh.num_points();
        let values = attribute.size();
        if (0..points).any(|p| attribute.mapped_index(PointIndex(p as u32)).0 as usize >= values) {
            return lacks(format!("has {values} values for {points} points"));
        }
        let mut values = attribute.read_f32s(points, width);
        let ct = match attribute.data_type() {
            DataType::Int8 => ComponentType::I8,
            DataType::Uint8 => ComponentType::U8,
            DataType::Int16 => ComponentType::I16,
            DataType::Uint16 => ComponentType::U16,
            DataType::Uint32 => ComponentType::U32,
            _ => ComponentType::F32,
        };
        if is_normalized {
            values
                .iter_mut()
                .for_each(|v| *v = normalized_value(ct, *v));
        }
        Some(Ok(values))
    }

    /// The elements this primitive reads, for the load's budget: its points' values of every
    /// attribute the file names, and its indices.
    pub(super) fn elements(&self) -> usize {
        self.mesh.num_points() * self.attributes.len() + self.indices.len()
    }
}
