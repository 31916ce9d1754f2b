//! KHR_draco_mesh_compression: a primitive whose attributes and indices are one Draco stream in
//! a buffer view, decoded by the pure-Rust `draco-core` decoder. The extension's specification
//! (KhronosGroup/glTF, `extensions/2.0/Khronos/KHR_draco_mesh_compression`): the primitive's
//! extension names the `bufferView` of the stream and maps each glTF attribute name to the
//! Draco attribute's unique id; the primitive's accessors keep their type, component type and
//! `normalized` flag (how the decoded values are read) but have no data of their own, and the
//! decoded faces are the primitive's triangle indices.

use super::data::DataError;
use draco_core::{DataType, DecodeLimits, DecoderBuffer, Mesh, MeshDecoder};
use serde_json::Value;

/// The extension's name, as files require it.
pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// Most points and faces one primitive may decode to: 2²⁵ each, the scene's own cap on
/// triangles (`mesh::MAX_TRIANGLES`), and 1 GiB of decoded attributes, so that a small stream
/// that claims a huge mesh is refused before it is allocated.
const MAX_ELEMENTS: u64 = 1 << 25;
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

/// A decoded primitive: its vertex count, triangle indices and the attributes it names.
pub(super) struct Decoded {
    mesh: Mesh,
    attributes: Vec<(String, u32)>,
    pub(super) indices: Vec<u32>,
}

impl Compressed {
    /// Decodes the stream `bytes`.
    pub(super) fn decode(&self, bytes: &[u8], what: &str) -> Result<Decoded, DataError> {
        let limits = DecodeLimits::default()
            .with_max_points(MAX_ELEMENTS)
            .with_max_faces(MAX_ELEMENTS)
            .with_max_decoded_bytes(MAX_DECODED_BYTES);
        let mut buffer = DecoderBuffer::new(bytes).with_limits(limits);
        let mut mesh = Mesh::new();
        MeshDecoder::new()
            .decode(&mut buffer, &mut mesh)
            .map_err(|e| format!("{what}'s {EXTENSION} stream cannot be decoded ({e})"))?;
        let points = mesh.num_points() as u32;
        let indices: Vec<u32> = mesh.faces().iter().flat_map(|f| f.map(|p| p.0)).collect();
        if let Some(bad) = indices.iter().find(|&&i| i >= points) {
            return Err(format!("{what}'s {EXTENSION} face index {bad} is out of range").into());
        }
        Ok(Decoded {
            mesh,
            attributes: self.attributes.clone(),
            indices,
        })
    }
}

impl Decoded {
    /// The decoded values of the glTF attribute `name` with `width` components, read as its
    /// accessor says (`normalized` integers to [0, 1] or [−1, 1], glTF 2.0 §3.11), or `None`
    /// when the stream does not carry it.
    pub(super) fn floats(
        &self,
        name: &str,
        width: usize,
        normalized: bool,
    ) -> Option<Result<Vec<f32>, DataError>> {
        let &(_, id) = self.attributes.iter().find(|(n, _)| n == name)?;
        let Some(attribute) = self.mesh.attribute_by_unique_id(id) else {
            return Some(Err(format!(
                "{EXTENSION}: attribute {name} names Draco attribute {id}, which the stream lacks"
            )
            .into()));
        };
        let mut values = attribute.read_f32s(self.mesh.num_points(), width);
        let scale = match attribute.data_type() {
            _ if !normalized => 1.0,
            DataType::Int8 => 1.0 / 127.0,
            DataType::Uint8 => 1.0 / 255.0,
            DataType::Int16 => 1.0 / 32767.0,
            DataType::Uint16 => 1.0 / 65535.0,
            _ => 1.0,
        };
        if scale != 1.0 {
            for v in &mut values {
                *v = (*v * scale).max(-1.0);
            }
        }
        Some(Ok(values))
    }
}
