//! glTF mesh primitives turned into triangles: attributes read through `data` (bounds-checked,
//! any component type), indices checked against the vertex count, positions for NaN/Inf.

use super::data::{Buffers, DataError, read_floats, read_indices};
use super::document::get;
use crate::scene::{SceneParts, TriShading, tri};
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::json::{
    self,
    mesh::{Mode, Semantic},
    validation::Checked,
};

/// Most triangles a scene may have: 2²⁵ (about 4 GB with their shading data and BVH), so that
/// instancing cannot grow the scene until an allocation aborts the program.
const MAX_TRIANGLES: usize = 1 << 25;

#[derive(Default)]
pub(super) struct LoadStats {
    pub(super) degenerate: usize,
    pub(super) skipped_primitives: usize,
    pub(super) without_positions: usize,
    /// Primitives skipped because their data is not there, and why.
    pub(super) unavailable: Vec<String>,
}

/// What every mesh reads: the file, its buffers, the materials' TEXCOORD sets and the default
/// material's index.
pub(super) struct MeshInput<'a> {
    pub(super) root: &'a json::Root,
    pub(super) buffers: &'a Buffers,
    pub(super) tex_coords: &'a [u32],
    pub(super) default_material: u32,
}

/// Mesh `index`'s triangle primitives, placed by `world`, appended to `parts`. A primitive
/// whose data is not there (a buffer without a source, a missing file) is skipped with a
/// warning; a malformed one is an error.
pub(super) fn add_mesh(
    input: &MeshInput,
    index: usize,
    world: Mat4,
    parts: &mut SceneParts,
    stats: &mut LoadStats,
) -> Result<(), String> {
    let placement = Placement {
        world,
        normal_matrix: Mat3::from_mat4(world).inverse().transpose(),
        flip: world.determinant() < 0.0,
    };
    for (p, prim) in input.root.meshes[index].primitives.iter().enumerate() {
        match add_primitive(input, p, prim, &placement, parts, stats) {
            Ok(()) => {}
            Err(DataError::Unavailable(why)) => stats
                .unavailable
                .push(format!("mesh {index} primitive {p}: {why}")),
            Err(DataError::Invalid(why)) => return Err(why),
        }
    }
    Ok(())
}

struct Placement {
    world: Mat4,
    normal_matrix: Mat3,
    flip: bool,
}

fn add_primitive(
    input: &MeshInput,
    p: usize,
    prim: &json::mesh::Primitive,
    placement: &Placement,
    parts: &mut SceneParts,
    stats: &mut LoadStats,
) -> Result<(), DataError> {
    let root = input.root;
    let Placement {
        world,
        normal_matrix,
        flip,
    } = *placement;
    let what = |attr: &str| format!("primitive {p} {attr}");
    let mode = match prim.mode {
        Checked::Valid(m @ (Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)) => m,
        _ => {
            stats.skipped_primitives += 1;
            return Ok(());
        }
    };
    let material = match prim.material {
        Some(m) => {
            get(&root.materials, m.value(), &what("material"))?;
            m.value() as u32
        }
        None => input.default_material,
    };
    let attribute = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
    // Without positions the specification asks to skip the primitive.
    let Some(position) = attribute(Semantic::Positions) else {
        stats.without_positions += 1;
        return Ok(());
    };
    let (raw, width) = read_floats(root, input.buffers, position, &what("POSITION"))?;
    if width != 3 {
        return Err(format!(
            "primitive {p} POSITION accessor {position} has {width} components, not 3"
        )
        .into());
    }
    let positions: Vec<Vec3> = raw
        .chunks_exact(3)
        .map(|c| world.transform_point3(Vec3::from_slice(c)))
        .collect();
    if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("primitive {p} vertex {bad} has a NaN or infinite position").into());
    }
    let normals: Option<Vec<Vec3>> = match attribute(Semantic::Normals) {
        None => None,
        Some(a) => {
            let (raw, width) = read_floats(root, input.buffers, a, &what("NORMAL"))?;
            if width != 3 || raw.len() != 3 * positions.len() {
                return Err(format!(
                    "primitive {p} has {} normals of {width} components for {} positions",
                    raw.len() / width,
                    positions.len()
                )
                .into());
            }
            Some(
                raw.chunks_exact(3)
                    .map(|n| (normal_matrix * Vec3::from_slice(n)).normalize_or_zero())
                    .collect(),
            )
        }
    };
    let set = input
        .tex_coords
        .get(material as usize)
        .copied()
        .unwrap_or(0);
    let uvs: Option<Vec<Vec2>> = match attribute(Semantic::TexCoords(set)) {
        None => None,
        Some(a) => {
            let (raw, width) =
                read_floats(root, input.buffers, a, &what(&format!("TEXCOORD_{set}")))?;
            if width != 2 {
                return Err(format!(
                    "primitive {p} TEXCOORD_{set} accessor {a} has {width} components, not 2"
                )
                .into());
            }
            Some(raw.chunks_exact(2).map(Vec2::from_slice).collect())
        }
    };
    let indices: Vec<u32> = match prim.indices {
        Some(a) => read_indices(root, input.buffers, a.value(), &what("indices"))?,
        None => (0..positions.len() as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(format!(
            "primitive {p} index {bad} is out of range ({} vertices)",
            positions.len()
        )
        .into());
    }
    let tri_indices: Vec<[u32; 3]> = match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        Mode::TriangleStrip => (2..indices.len())
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i - 2], indices[i - 1], indices[i]]
                } else {
                    [indices[i - 1], indices[i - 2], indices[i]]
                }
            })
            .collect(),
        _ => (2..indices.len())
            .map(|i| [indices[0], indices[i - 1], indices[i]])
            .collect(),
    };
    for [a, b, c] in tri_indices {
        let (a, b, c) = if flip { (a, c, b) } else { (a, b, c) };
        let (pa, pb, pc) = (
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        );
        // Edges scaled to unit size first, so that huge coordinates cannot overflow the
        // cross product into an infinite (and then NaN) normal.
        let (e1, e2) = (pb - pa, pc - pa);
        let scale = e1.abs().max_element().max(e2.abs().max_element());
        let cross = (e1 / scale).cross(e2 / scale);
        if !(scale.is_finite() && cross.length_squared() > 0.0) {
            stats.degenerate += 1;
            continue;
        }
        let ng = cross.normalize();
        let pick = |i: u32| -> Vec3 {
            normals
                .as_ref()
                .map(|n| n[i as usize])
                .filter(|n| n.is_finite() && n.length_squared() > 0.5)
                .unwrap_or(ng)
        };
        let uv = |i: u32| -> Vec2 {
            uvs.as_ref()
                .and_then(|u| u.get(i as usize).copied())
                .filter(|u| u.is_finite())
                .unwrap_or(Vec2::ZERO)
        };
        if parts.triangles.len() >= MAX_TRIANGLES {
            return Err(format!(
                "the scene has more than {MAX_TRIANGLES} triangles (each instance of a mesh counts), more than raysplat can hold"
            )
            .into());
        }
        parts.triangles.push(tri(pa, pb, pc));
        parts.shading.push(TriShading {
            normals: [pick(a), pick(b), pick(c)],
            uvs: [uv(a), uv(b), uv(c)],
            material,
        });
    }
    Ok(())
}
