//! EXT_meshopt_compression: buffer views whose bytes are stored compressed in another buffer
//! view's place, decoded once on load by meshoptimizer's own decoder (the `meshopt` crate)
//! before any accessor reads them. The extension's specification
//! (KhronosGroup/glTF, `extensions/2.0/Vendor/EXT_meshopt_compression`): each compressed view
//! names the `buffer`, `byteOffset` and `byteLength` of its compressed bytes, the `count` and
//! `byteStride` of its elements, a `mode` (ATTRIBUTES: the vertex codec; TRIANGLES: the index
//! codec; INDICES: the index-sequence codec) and a `filter` applied after decoding
//! (OCTAHEDRAL, QUATERNION, EXPONENTIAL, or NONE). The view's own buffer is then often a
//! fallback without data, which nothing reads.

use super::data::DataError;
use serde_json::Value;

/// The extension's name, as files require it.
pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

/// Most bytes one decoded view may hold (256 MiB): a small file that declares a huge count
/// cannot make the loader allocate until the program aborts (the load's total is bounded by
/// `data::Buffers`).
const MAX_DECODED_BYTES: u64 = 1 << 28;

/// What a compressed view declares.
pub(super) struct Compressed {
    pub(super) buffer: usize,
    pub(super) offset: usize,
    pub(super) length: usize,
    stride: usize,
    pub(super) count: usize,
    mode: Mode,
    filter: Filter,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
}

/// Buffer view `index`'s compression (`raw` its JSON), when it has the extension; an error
/// when the extension's fields are missing or out of the specification's ranges.
pub(super) fn compressed(raw: &Value, index: usize) -> Result<Option<Compressed>, String> {
    let Some(ext) = raw.get("extensions").and_then(|e| e.get(EXTENSION)) else {
        return Ok(None);
    };
    let what = format!("buffer view {index}'s {EXTENSION}");
    let number = |key: &str, default: Option<u64>| -> Result<usize, String> {
        match ext.get(key) {
            Some(v) => v
                .as_u64()
                .and_then(|n| usize::try_from(n).ok())
                .ok_or_else(|| format!("{what} has a {key} that is not a count")),
            None => default
                .map(|d| d as usize)
                .ok_or_else(|| format!("{what} has no {key}")),
        }
    };
    let name = |key: &str, default: &'static str| -> Result<String, String> {
        match ext.get(key) {
            Some(v) => v
                .as_str()
                .map(str::to_string)
                .ok_or_else(|| format!("{what} has a {key} that is not a name")),
            None => Ok(default.to_string()),
        }
    };
    if ext.get("mode").is_none() {
        return Err(format!("{what} has no mode"));
    }
    let mode = match name("mode", "")?.as_str() {
        "ATTRIBUTES" => Mode::Attributes,
        "TRIANGLES" => Mode::Triangles,
        "INDICES" => Mode::Indices,
        other => return Err(format!("{what} has the unknown mode {other:?}")),
    };
    let filter = match name("filter", "NONE")?.as_str() {
        "NONE" => Filter::None,
        "OCTAHEDRAL" => Filter::Octahedral,
        "QUATERNION" => Filter::Quaternion,
        "EXPONENTIAL" => Filter::Exponential,
        other => return Err(format!("{what} has the unknown filter {other:?}")),
    };
    let c = Compressed {
        buffer: number("buffer", None)?,
        offset: number("byteOffset", Some(0))?,
        length: number("byteLength", None)?,
        stride: number("byteStride", None)?,
        count: number("count", None)?,
        mode,
        filter,
    };
    // The specification's constraints on stride, mode and filter.
    let stride_ok = match (c.mode, c.filter) {
        (Mode::Attributes, Filter::None | Filter::Exponential) => {
            c.stride.is_multiple_of(4) && (4..=256).contains(&c.stride)
        }
        (Mode::Attributes, Filter::Octahedral) => c.stride == 4 || c.stride == 8,
        (Mode::Attributes, Filter::Quaternion) => c.stride == 8,
        (Mode::Triangles | Mode::Indices, Filter::None) => c.stride == 2 || c.stride == 4,
        (Mode::Triangles | Mode::Indices, _) => false,
    };
    if !stride_ok {
        return Err(format!(
            "{what}: byteStride {} is not allowed with mode {:?} and filter {:?}",
            c.stride, c.mode, c.filter
        ));
    }
    if c.mode == Mode::Triangles && !c.count.is_multiple_of(3) {
        return Err(format!("{what}: TRIANGLES with a count of {}", c.count));
    }
    Ok(Some(c))
}

impl Compressed {
    /// The decoded size, `count · byteStride` bytes, or why view `view` may not decode it.
    pub(super) fn decoded_size(&self, view: usize) -> Result<u64, DataError> {
        (self.count as u64)
            .checked_mul(self.stride as u64)
            .filter(|&size| size <= MAX_DECODED_BYTES)
            .ok_or_else(|| {
                format!(
                    "buffer view {view} would decode {} elements of {} bytes, more than raysplat reads ({MAX_DECODED_BYTES} bytes)",
                    self.count, self.stride
                )
                .into()
            })
    }

    /// The stride of the decoded elements when they are vertex attributes (indices are read
    /// by their accessor's type).
    pub(super) fn attribute_stride(&self) -> Option<usize> {
        (self.mode == Mode::Attributes).then_some(self.stride)
    }

    /// The decoded bytes (`count · byteStride` of them) from the compressed `bytes`.
    pub(super) fn decode(&self, bytes: &[u8], view: usize) -> Result<Vec<u8>, DataError> {
        self.decoded_size(view)?;
        let failed = |e: meshopt::Error| {
            DataError::Invalid(format!(
                "buffer view {view}'s {EXTENSION} data cannot be decoded ({e})"
            ))
        };
        let mut out = match (self.mode, self.stride) {
            (Mode::Attributes, _) => vertices(bytes, self.count, self.stride).map_err(failed)?,
            (Mode::Triangles, 2) => {
                le_bytes(meshopt::decode_index_buffer::<u16>(bytes, self.count)).map_err(failed)?
            }
            (Mode::Triangles, _) => {
                le_bytes(meshopt::decode_index_buffer::<u32>(bytes, self.count)).map_err(failed)?
            }
            (Mode::Indices, 2) => {
                le_bytes(meshopt::decode_index_sequence::<u16>(bytes, self.count))
                    .map_err(failed)?
            }
            (Mode::Indices, _) => {
                le_bytes(meshopt::decode_index_sequence::<u32>(bytes, self.count))
                    .map_err(failed)?
            }
        };
        self.unfilter(&mut out);
        Ok(out)
    }

    /// The filter's inverse, in place on the decoded little-endian bytes.
    fn unfilter(&self, data: &mut [u8]) {
        match (self.filter, self.stride) {
            (Filter::None, _) => {}
            (Filter::Octahedral, 4) => {
                let mut v: Vec<[i8; 4]> = data
                    .chunks_exact(4)
                    .map(|c| [c[0] as i8, c[1] as i8, c[2] as i8, c[3] as i8])
                    .collect();
                meshopt::decode_filter_oct(&mut v);
                for (c, x) in data.chunks_exact_mut(4).zip(v) {
                    c.copy_from_slice(&x.map(|b| b as u8));
                }
            }
            (Filter::Octahedral, _) => {
                let mut v = i16_quads(data);
                meshopt::decode_filter_oct(&mut v);
                put_i16_quads(data, &v);
            }
            (Filter::Quaternion, _) => {
                let mut v = i16_quads(data);
                meshopt::decode_filter_quat(&mut v);
                put_i16_quads(data, &v);
            }
            (Filter::Exponential, _) => {
                // Each 32-bit component is decoded on its own.
                let mut v: Vec<[u32; 1]> = data
                    .chunks_exact(4)
                    .map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])])
                    .collect();
                meshopt::decode_filter_exp(&mut v);
                for (c, x) in data.chunks_exact_mut(4).zip(v) {
                    c.copy_from_slice(&x[0].to_le_bytes());
                }
            }
        }
    }
}

/// The vertex codec's output for elements of `stride` bytes (a multiple of 4, at most 256):
/// the crate decodes into elements of the stride's size.
fn vertices(bytes: &[u8], count: usize, stride: usize) -> meshopt::Result<Vec<u8>> {
    fn decode<const N: usize>(bytes: &[u8], count: usize) -> meshopt::Result<Vec<u8>> {
        let v = meshopt::decode_vertex_buffer::<Element<N>>(bytes, count)?;
        Ok(v.iter().flat_map(|e| e.0).collect())
    }
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => decode::<$n>(bytes, count),)*
                // (`compressed` admits no other stride.)
                _ => Err(meshopt::Error::Parse(format!("byte stride {stride}"))),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104
        108 112 116 120 124 128 132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
        196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256)
}

/// One vertex of `N` bytes (arrays past 32 elements have no `Default`).
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Self([0; N])
    }
}

/// Decoded indices as the little-endian bytes an accessor reads.
fn le_bytes<T: Copy + Into<u32>>(v: meshopt::Result<Vec<T>>) -> meshopt::Result<Vec<u8>> {
    let v = v?;
    let width = std::mem::size_of::<T>();
    Ok(v.iter()
        .flat_map(|&i| {
            let b = i.into().to_le_bytes();
            b.into_iter().take(width)
        })
        .collect())
}

fn i16_quads(data: &[u8]) -> Vec<[i16; 4]> {
    data.chunks_exact(8)
        .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
        .collect()
}

fn put_i16_quads(data: &mut [u8], v: &[[i16; 4]]) {
    for (c, q) in data.chunks_exact_mut(8).zip(v) {
        for (k, x) in q.iter().enumerate() {
            c[2 * k..2 * k + 2].copy_from_slice(&x.to_le_bytes());
        }
    }
}
