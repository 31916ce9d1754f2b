//! Buffers and accessors, read with every bound checked before it is used: an accessor without a
//! buffer view is zeros, a sparse accessor has its substitutions applied (on a view or on the
//! zeros), every component type is read with its `normalized` flag (KHR_mesh_quantization), and
//! byte strides are honoured. A buffer that cannot be loaded is only an error when something
//! reads it.

use super::document::get;
use super::meshopt::{self, Compressed};
use gltf::json::{
    self,
    accessor::{ComponentType, Type},
    validation::Checked,
};
use serde_json::Value;
use std::cell::OnceCell;
use std::path::Path;

/// Most elements an accessor may have when the file holds no data for them (an accessor
/// without a buffer view is zeros of any count): 2²⁵, far above any real mesh, far below an
/// allocation that would abort the program.
const MAX_UNBACKED_ELEMENTS: usize = 1 << 25;

/// Most accessor elements one load reads in all, 2²⁸ (a 60-million-triangle scene reads about
/// a quarter of that): a small file cannot make the loader work for hours by having many
/// nodes instance one large mesh, or many primitives read one large accessor.
const MAX_ELEMENTS_READ: usize = 1 << 28;

/// Most bytes one load decodes from EXT_meshopt_compression's views in all (1 GiB).
const MAX_DECODED_BYTES: u64 = 1 << 30;

/// Why data could not be read.
#[derive(Clone, Debug)]
pub(super) enum DataError {
    /// The file is malformed (an index, range or type that cannot be): the load fails.
    Invalid(String),
    /// The data is not there (a buffer without a source, a file that cannot be read): what
    /// needs it is skipped, with a warning.
    Unavailable(String),
}

impl From<String> for DataError {
    fn from(message: String) -> Self {
        Self::Invalid(message)
    }
}

impl DataError {
    /// The one-line reason.
    pub(super) fn message(&self) -> &str {
        match self {
            Self::Invalid(m) | Self::Unavailable(m) => m,
        }
    }

    fn map(self, f: impl FnOnce(String) -> String) -> Self {
        match self {
            Self::Invalid(m) => Self::Invalid(f(m)),
            Self::Unavailable(m) => Self::Unavailable(f(m)),
        }
    }
}

/// A compressed view: its EXT_meshopt_compression (or why it is malformed) and its bytes,
/// decoded on first use (or why they cannot be had).
type CompressedView = (
    Result<Compressed, String>,
    OnceCell<Result<Vec<u8>, DataError>>,
);

/// The file's buffers, each loaded or the reason it could not be, and how many more accessor
/// elements this load may read.
pub(super) struct Buffers {
    data: Vec<Result<Vec<u8>, DataError>>,
    budget: std::cell::Cell<usize>,
    /// Each buffer view's compression, when it has one (views never used, such as animation
    /// data, are never decoded).
    compressed: Vec<Option<CompressedView>>,
    /// Bytes the load may still decode from compressed views, in all.
    decode_budget: std::cell::Cell<u64>,
}

impl Buffers {
    /// Load every buffer of `root` (`raw` its JSON): from a data URI, a file next to the glTF
    /// (`base`), or the GLB's BIN chunk (`blob`, buffer 0 without a uri).
    pub(super) fn load(
        root: &json::Root,
        raw: &Value,
        base: Option<&Path>,
        mut blob: Option<Vec<u8>>,
    ) -> Self {
        let buffers = root
            .buffers
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let data = match &b.uri {
                    Some(uri) => {
                        read_uri(uri, base).map_err(|e| e.map(|m| format!("buffer {i}: {m}")))
                    }
                    None if i == 0 => blob.take().ok_or_else(|| {
                        DataError::Unavailable(format!(
                            "buffer {i} has no uri and the file no BIN chunk"
                        ))
                    }),
                    None => Err(DataError::Unavailable(format!(
                        "buffer {i} has no uri (only buffer 0 may be the BIN chunk)"
                    ))),
                }?;
                let declared = b.byte_length.0;
                if (data.len() as u64) < declared {
                    return Err(DataError::Invalid(format!(
                        "buffer {i} holds {} bytes but declares {declared}",
                        data.len()
                    )));
                }
                Ok(data)
            })
            .collect();
        let compressed = (0..root.buffer_views.len())
            .map(|i| {
                let c = meshopt::compressed(&raw["bufferViews"][i], i).transpose()?;
                Some((c, OnceCell::new()))
            })
            .collect();
        Self {
            data: buffers,
            budget: std::cell::Cell::new(MAX_ELEMENTS_READ),
            compressed,
            decode_budget: std::cell::Cell::new(MAX_DECODED_BYTES),
        }
    }

    /// Buffer view `index`'s bytes decoded from its EXT_meshopt_compression (decoded once),
    /// or `None` when the view is not compressed.
    fn decoded(&self, index: usize) -> Option<Result<&[u8], DataError>> {
        let (compressed, decoded) = self.compressed.get(index)?.as_ref()?;
        let decoded = decoded.get_or_init(|| {
            let c = compressed.as_ref().map_err(|e| DataError::Invalid(e.clone()))?;
            let data = self.get(c.buffer, &format!("buffer view {index}'s compressed data"))?;
            let bytes = c
                .offset
                .checked_add(c.length)
                .and_then(|end| data.get(c.offset..end))
                .ok_or_else(|| {
                    format!(
                        "buffer view {index}'s compressed data (offset {}, length {}) runs past the end of buffer {} ({} bytes)",
                        c.offset,
                        c.length,
                        c.buffer,
                        data.len()
                    )
                })?;
            // The decoded size is charged before anything is allocated: views may share
            // one compressed payload, so each view's own cap does not bound the load.
            let size = c.decoded_size(index)?;
            let left = self.decode_budget.get().checked_sub(size).ok_or_else(|| {
                format!(
                    "buffer view {index}: the file's compressed views decode to more than raysplat reads ({MAX_DECODED_BYTES} bytes in all)"
                )
            })?;
            self.decode_budget.set(left);
            self.spend(c.count)?;
            c.decode(bytes, index)
        });
        Some(decoded.as_deref().map_err(DataError::clone))
    }

    /// The element stride of compressed view `index` (of attribute data; indices have none).
    fn decoded_stride(&self, index: usize) -> Option<usize> {
        match self.compressed.get(index)? {
            Some((Ok(c), _)) => c.attribute_stride(),
            _ => None,
        }
    }

    /// Takes `count` elements from the load's budget, or says the file asks for too many.
    pub(super) fn spend(&self, count: usize) -> Result<(), DataError> {
        let left = self.budget.get().checked_sub(count).ok_or_else(|| {
            format!(
                "the file asks the loader to read more than {MAX_ELEMENTS_READ} accessor elements in all (each instance of a mesh counts)"
            )
        })?;
        self.budget.set(left);
        Ok(())
    }

    fn get(&self, index: usize, what: &str) -> Result<&[u8], DataError> {
        match self.data.get(index) {
            Some(Ok(data)) => Ok(data),
            Some(Err(DataError::Invalid(e))) => Err(format!("{what} cannot be read: {e}").into()),
            Some(Err(DataError::Unavailable(e))) => Err(DataError::Unavailable(format!(
                "{what} cannot be read: {e}"
            ))),
            None => Err(DataError::Invalid(format!(
                "{what} refers to buffer {index}, but the file has {}",
                self.data.len()
            ))),
        }
    }
}

/// The bytes a uri names: a `data:` URI (decoded by the `gltf` crate), or a file relative to
/// `base` (percent-decoded). Other schemes, and files when loading from memory, are errors.
pub(super) fn read_uri(uri: &str, base: Option<&Path>) -> Result<Vec<u8>, DataError> {
    if uri.starts_with("data:") {
        gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
            .map(|d| d.0)
            .map_err(|e| DataError::Invalid(format!("its data uri cannot be decoded ({e})")))
    } else if uri.contains(':') {
        let scheme = uri.split(':').next().unwrap_or("");
        Err(DataError::Unavailable(format!(
            "its uri scheme {scheme:?} is not supported"
        )))
    } else {
        let name = urlencoding::decode(uri)
            .map_err(|_| format!("its uri {uri:?} is not valid percent-encoded UTF-8"))?;
        let Some(base) = base else {
            return Err(DataError::Unavailable(format!(
                "it refers to the file {name:?}, which cannot be read when loading from memory"
            )));
        };
        std::fs::read(base.join(&*name))
            .map_err(|e| DataError::Unavailable(format!("cannot read {name:?}: {e}")))
    }
}

/// Buffer view `index`'s bytes, and its byte stride.
pub(super) fn view_bytes<'a>(
    root: &json::Root,
    buffers: &'a Buffers,
    index: usize,
    what: &str,
) -> Result<(&'a [u8], Option<usize>), DataError> {
    let view = get(&root.buffer_views, index, what)?;
    if let Some(decoded) = buffers.decoded(index) {
        // The stride the elements were encoded with (the view may leave its own out).
        return Ok((decoded?, buffers.decoded_stride(index)));
    }
    let b = view.buffer.value();
    let data = buffers.get(b, &format!("buffer view {index}"))?;
    let offset = view.byte_offset.map_or(0, |o| o.0);
    let length = view.byte_length.0;
    match offset.checked_add(length) {
        Some(end) if end <= data.len() as u64 => {
            Ok((&data[offset as usize..end as usize], view.byte_stride.map(|s| s.0)))
        }
        _ => Err(format!(
            "buffer view {index} (offset {offset}, length {length}) runs past the end of buffer {b} ({} bytes)",
            data.len()
        )
        .into()),
    }
}

/// An accessor's component type and element width, checked.
fn layout(acc: &json::Accessor, index: usize) -> Result<(ComponentType, usize), String> {
    let Checked::Valid(json::accessor::GenericComponentType(ct)) = acc.component_type else {
        return Err(format!("accessor {index} has an unknown component type"));
    };
    let width = match acc.type_ {
        Checked::Valid(Type::Scalar) => 1,
        Checked::Valid(Type::Vec2) => 2,
        Checked::Valid(Type::Vec3) => 3,
        Checked::Valid(Type::Vec4) => 4,
        Checked::Valid(t) => {
            return Err(format!(
                "accessor {index} is a {t:?} matrix, where a scalar or vector is needed"
            ));
        }
        Checked::Invalid => return Err(format!("accessor {index} has an unknown type")),
    };
    Ok((ct, width))
}

/// One component at `at` (in bounds: callers check) as an f32, mapped to [0, 1] or [−1, 1] when
/// the accessor is normalized (glTF 2.0 §3.11).
fn float_reader(ct: ComponentType, normalized: bool) -> fn(&[u8], usize) -> f32 {
    use ComponentType::*;
    match (ct, normalized) {
        (F32, _) => |b, i| f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]),
        (I8, false) => |b, i| b[i] as i8 as f32,
        (U8, false) => |b, i| b[i] as f32,
        (I16, false) => |b, i| i16::from_le_bytes([b[i], b[i + 1]]) as f32,
        (U16, false) => |b, i| u16::from_le_bytes([b[i], b[i + 1]]) as f32,
        (U32, false) => |b, i| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]) as f32,
        (I8, true) => |b, i| normalized_value(I8, b[i] as i8 as f32),
        (U8, true) => |b, i| normalized_value(U8, b[i] as f32),
        (I16, true) => |b, i| normalized_value(I16, i16::from_le_bytes([b[i], b[i + 1]]) as f32),
        (U16, true) => |b, i| normalized_value(U16, u16::from_le_bytes([b[i], b[i + 1]]) as f32),
        (U32, true) => |b, i| {
            normalized_value(
                U32,
                u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]) as f32,
            )
        },
    }
}

/// The value of a `normalized` integer component `v` of type `ct` (glTF 2.0 §3.11: signed
/// types to [−1, 1], with the most negative integer clamped, unsigned to [0, 1]); floats as
/// they are.
pub(super) fn normalized_value(ct: ComponentType, v: f32) -> f32 {
    match ct {
        ComponentType::I8 => (v / 127.0).max(-1.0),
        ComponentType::U8 => v / 255.0,
        ComponentType::I16 => (v / 32767.0).max(-1.0),
        ComponentType::U16 => v / 65535.0,
        ComponentType::U32 => v / u32::MAX as f32,
        ComponentType::F32 => v,
    }
}

/// One unsigned integer component at `at`, or `None` for a type indices cannot have.
fn index_reader(ct: ComponentType) -> Option<fn(&[u8], usize) -> u32> {
    match ct {
        ComponentType::U8 => Some(|b, i| b[i] as u32),
        ComponentType::U16 => Some(|b, i| u16::from_le_bytes([b[i], b[i + 1]]) as u32),
        ComponentType::U32 => Some(|b, i| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])),
        _ => None,
    }
}

/// The first byte of the last of `count` elements of `elem` bytes, `stride` apart from
/// `offset`, plus `elem`: the bytes the elements need; `None` on overflow.
fn bytes_needed(offset: usize, count: usize, stride: usize, elem: usize) -> Option<usize> {
    if count == 0 {
        return Some(offset);
    }
    (count - 1)
        .checked_mul(stride)?
        .checked_add(elem)?
        .checked_add(offset)
}

/// Accessor `index`'s elements as `width` f32 components each: (values, width).
pub(super) fn read_floats(
    root: &json::Root,
    buffers: &Buffers,
    index: usize,
    what: &str,
) -> Result<(Vec<f32>, usize), DataError> {
    let acc = get(&root.accessors, index, what)?;
    let (ct, width) = layout(acc, index)?;
    let values = read(
        root,
        buffers,
        acc,
        index,
        width,
        ct.size(),
        float_reader(ct, acc.normalized),
    )?;
    Ok((values, width))
}

/// Accessor `index`'s components per element and `normalized` flag (how a decoder's values
/// are read when the accessor has no data of its own, KHR_draco_mesh_compression).
pub(super) fn accessor_shape(
    root: &json::Root,
    index: usize,
    what: &str,
) -> Result<(usize, bool), DataError> {
    let acc = get(&root.accessors, index, what)?;
    let (_, width) = layout(acc, index)?;
    Ok((width, acc.normalized))
}

/// Index accessor `index` (unsigned byte, short or int scalars).
pub(super) fn read_indices(
    root: &json::Root,
    buffers: &Buffers,
    index: usize,
    what: &str,
) -> Result<Vec<u32>, DataError> {
    let acc = get(&root.accessors, index, what)?;
    let (ct, width) = layout(acc, index)?;
    let reader = index_reader(ct)
        .filter(|_| width == 1)
        .ok_or_else(|| format!("accessor {index} cannot hold indices ({ct:?} × {width})"))?;
    read(root, buffers, acc, index, 1, ct.size(), reader)
}

/// The elements of `acc`: from its buffer view or zeros, then its sparse substitutions.
fn read<T: Copy + Default>(
    root: &json::Root,
    buffers: &Buffers,
    acc: &json::Accessor,
    index: usize,
    width: usize,
    size: usize,
    component: fn(&[u8], usize) -> T,
) -> Result<Vec<T>, DataError> {
    let count = usize::try_from(acc.count.0).unwrap_or(usize::MAX);
    let elem = width * size;
    let mut out: Vec<T>;
    if let Some(v) = acc.buffer_view {
        let (bytes, stride) = view_bytes(root, buffers, v.value(), &format!("accessor {index}"))?;
        let stride = stride.unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "buffer view {} has a byte stride of {stride}, less than accessor {index}'s {elem}-byte elements",
                v.value()
            ).into());
        }
        let offset = acc.byte_offset.map_or(0, |o| o.0) as usize;
        if bytes_needed(offset, count, stride, elem).is_none_or(|n| n > bytes.len()) {
            return Err(format!(
                "accessor {index} ({count} elements from offset {offset}) reads past the end of buffer view {}",
                v.value()
            ).into());
        }
        buffers.spend(count)?;
        out = Vec::with_capacity(count * width);
        for e in 0..count {
            let at = offset + e * stride;
            out.extend((0..width).map(|c| component(bytes, at + c * size)));
        }
    } else {
        if count > MAX_UNBACKED_ELEMENTS {
            return Err(format!(
                "accessor {index} has {count} elements and no buffer view: more than the loader's {MAX_UNBACKED_ELEMENTS}"
            )
            .into());
        }
        buffers.spend(count)?;
        out = vec![T::default(); count * width];
    }
    if let Some(sparse) = &acc.sparse {
        let n = usize::try_from(sparse.count.0).unwrap_or(usize::MAX);
        if n > count {
            return Err(
                format!("accessor {index} substitutes {n} sparse elements of its {count}").into(),
            );
        }
        let what = format!("accessor {index}'s sparse indices");
        let Checked::Valid(json::accessor::IndexComponentType(ict)) = sparse.indices.component_type
        else {
            return Err(format!("{what} have an unknown component type").into());
        };
        let index_of = index_reader(ict).ok_or_else(|| format!("{what} are not integers"))?;
        let (ibytes, _) = view_bytes(root, buffers, sparse.indices.buffer_view.value(), &what)?;
        let ioff = sparse.indices.byte_offset.0 as usize;
        if bytes_needed(ioff, n, ict.size(), ict.size()).is_none_or(|x| x > ibytes.len()) {
            return Err(format!("{what} read past the end of their buffer view").into());
        }
        let what = format!("accessor {index}'s sparse values");
        let (vbytes, _) = view_bytes(root, buffers, sparse.values.buffer_view.value(), &what)?;
        let voff = sparse.values.byte_offset.0 as usize;
        if bytes_needed(voff, n, elem, elem).is_none_or(|x| x > vbytes.len()) {
            return Err(format!("{what} read past the end of their buffer view").into());
        }
        for k in 0..n {
            let target = index_of(ibytes, ioff + k * ict.size()) as usize;
            if target >= count {
                return Err(format!(
                    "accessor {index}'s sparse index {target} is out of range ({count} elements)"
                )
                .into());
            }
            for c in 0..width {
                out[target * width + c] = component(vbytes, voff + k * elem + c * size);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalized_components_map_to_the_unit_range() {
        use ComponentType::*;
        let r = |ct, b: &[u8]| float_reader(ct, true)(b, 0);
        assert_eq!(r(I8, &[127]), 1.0);
        assert_eq!(r(I8, &[0x80]), -1.0);
        assert_eq!(r(I8, &[0x81]), -1.0);
        assert_eq!(r(U8, &[255]), 1.0);
        assert_eq!(r(I16, &i16::MIN.to_le_bytes()), -1.0);
        assert_eq!(r(U16, &u16::MAX.to_le_bytes()), 1.0);
        assert_eq!(
            float_reader(I16, false)(&(-300i16).to_le_bytes(), 0),
            -300.0
        );
    }

    #[test]
    fn one_load_reads_at_most_its_budget_of_elements() {
        let buffers = Buffers::load(&json::Root::default(), &Value::Null, None, None);
        assert!(buffers.spend(MAX_ELEMENTS_READ - 1).is_ok());
        assert!(buffers.spend(1).is_ok());
        let e = buffers.spend(1).unwrap_err();
        assert!(e.message().contains("more than"), "{}", e.message());
    }

    #[test]
    fn the_bytes_needed_account_for_stride_and_overflow() {
        assert_eq!(bytes_needed(4, 3, 16, 12), Some(4 + 32 + 12));
        assert_eq!(bytes_needed(4, 0, 16, 12), Some(4));
        assert_eq!(bytes_needed(0, usize::MAX, 16, 12), None);
    }
}
