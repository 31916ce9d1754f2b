//! glTF mesh primitives turned into triangles: attributes read through `data` (bounds-checked,
//! any component type), indices checked against the vertex count, positions for NaN/Inf.

use super::data::{Buffers, DataError, accessor_shape, read_floats, read_indices, view_bytes};
use super::document::get;
use super::draco;
use crate::scene::{NO_EXTRA, SceneParts, TriExtra, TriShading, tri};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::json::{
    self,
    mesh::{Mode, Semantic},
    validation::Checked,
};

/// Most triangles a scene may have: 2²⁵ (about 4 GB with their shading data and BVH), so that
/// instancing cannot grow the scene until an allocation aborts the program.
pub(super) const MAX_TRIANGLES: usize = 1 << 25;

#[derive(Default)]
pub(super) struct LoadStats {
    pub(super) degenerate: usize,
    pub(super) skipped_primitives: usize,
    pub(super) without_positions: usize,
    /// Primitives skipped because their data is not there, and why.
    pub(super) unavailable: Vec<String>,
}

/// What every mesh reads: the file (typed, and raw for extension data), its buffers and the
/// default material's index.
pub(super) struct MeshInput<'a> {
    pub(super) root: &'a json::Root,
    pub(super) raw: &'a serde_json::Value,
    pub(super) buffers: &'a Buffers,
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
        let raw = &input.raw["meshes"][index]["primitives"][p];
        match add_primitive(input, p, (prim, raw), &placement, parts, stats) {
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
    (prim, raw): (&json::mesh::Primitive, &serde_json::Value),
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
    let mut mode = match prim.mode {
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
    // A Draco stream holds the primitive's attributes and its faces (as triangles); it is
    // decoded for each instance, so each is charged to the load's budget.
    let decoded = match draco::compressed(raw, &format!("primitive {p}"))? {
        Some(c) => {
            let (bytes, _) = view_bytes(root, input.buffers, c.view, &what(draco::EXTENSION))?;
            mode = Mode::Triangles;
            let decoded = c.decode(bytes, &format!("primitive {p}"))?;
            input.buffers.spend(decoded.elements())?;
            Some(decoded)
        }
        None => None,
    };
    // An attribute's values: from the Draco stream when it carries them, else its accessor.
    let floats = |a: usize, name: &str| -> Result<(Vec<f32>, usize), DataError> {
        if let Some(d) = &decoded {
            let (width, normalized) = accessor_shape(root, a, &what(name))?;
            if let Some(values) = d.floats(name, width, normalized) {
                return Ok((values?, width));
            }
        }
        read_floats(root, input.buffers, a, &what(name))
    };
    let (values, width) = floats(position, "POSITION")?;
    if width != 3 {
        return Err(format!(
            "primitive {p} POSITION accessor {position} has {width} components, not 3"
        )
        .into());
    }
    let positions: Vec<Vec3> = values
        .chunks_exact(3)
        .map(|c| world.transform_point3(Vec3::from_slice(c)))
        .collect();
    if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("primitive {p} vertex {bad} has a NaN or infinite position").into());
    }
    let normals: Option<Vec<Vec3>> = match attribute(Semantic::Normals) {
        None => None,
        Some(a) => {
            let (raw, width) = floats(a, "NORMAL")?;
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
    // Further attributes: `width` components each, one per position.
    let read = |s: Semantic,
                name: &str,
                widths: &[usize]|
     -> Result<Option<(Vec<f32>, usize)>, DataError> {
        let Some(a) = attribute(s) else {
            return Ok(None);
        };
        let (raw, width) = floats(a, name)?;
        if !widths.contains(&width) || raw.len() != width * positions.len() {
            return Err(format!(
                "primitive {p} {name} accessor {a} has {} elements of {width} components for {} positions",
                raw.len() / width.max(1),
                positions.len()
            )
            .into());
        }
        Ok(Some((raw, width)))
    };
    let texcoords = |set: u32| -> Result<Option<Vec<Vec2>>, DataError> {
        Ok(
            read(Semantic::TexCoords(set), &format!("TEXCOORD_{set}"), &[2])?
                .map(|(raw, _)| raw.chunks_exact(2).map(Vec2::from_slice).collect()),
        )
    };
    let m = &parts.materials[material as usize];
    let uvs = texcoords(0)?;
    let uvs1 = if m.needs_extra() { texcoords(1)? } else { None };
    let colors: Option<Vec<Vec4>> =
        read(Semantic::Colors(0), "COLOR_0", &[3, 4])?.map(|(raw, w)| {
            raw.chunks_exact(w)
                .map(|c| {
                    if w == 3 {
                        Vec3::from_slice(c).extend(1.0)
                    } else {
                        Vec4::from_slice(c)
                    }
                })
                .collect()
        });
    let normal_set = m.normal_texture.as_ref().map(|(t, _)| t.set);
    let file_tangents: Option<Vec<Vec4>> = match normal_set {
        None => None,
        Some(_) => read(Semantic::Tangents, "TANGENT", &[4])?.map(|(raw, _)| {
            let world3 = Mat3::from_mat4(world);
            raw.chunks_exact(4)
                .map(|t| {
                    let xyz = (world3 * Vec3::from_slice(t)).normalize_or_zero();
                    // A mirroring placement turns the bitangent (n × t) around.
                    xyz.extend(if (t[3] < 0.0) != flip { -1.0 } else { 1.0 })
                })
                .collect()
        }),
    };
    let indices: Vec<u32> = match (decoded, prim.indices) {
        (Some(d), _) => d.indices,
        (None, Some(a)) => read_indices(root, input.buffers, a.value(), &what("indices"))?,
        (None, None) => (0..positions.len() as u32).collect(),
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
    // Without the file's tangents, each vertex sums its triangles' texture-space directions
    // (area-weighted, Lengyel's construction; MikkTSpace starts from the same frame).
    let vertex_tangents: Option<Vec<[Vec3; 2]>> = match (normal_set, &file_tangents) {
        (Some(set), None) => {
            let tuv = if set == 1 { &uvs1 } else { &uvs };
            let mut acc = vec![[Vec3::ZERO; 2]; positions.len()];
            for &[a, b, c] in &tri_indices {
                let (a, b, c) = if flip { (a, c, b) } else { (a, b, c) };
                let p = [a, b, c].map(|i| positions[i as usize]);
                let uv = [a, b, c].map(|i| {
                    tuv.as_ref()
                        .and_then(|u| u.get(i as usize).copied())
                        .filter(|u| u.is_finite())
                        .unwrap_or(Vec2::ZERO)
                });
                if let Some(tb) = texture_directions(p, uv) {
                    for i in [a, b, c] {
                        acc[i as usize][0] += tb[0];
                        acc[i as usize][1] += tb[1];
                    }
                }
            }
            Some(acc)
        }
        _ => None,
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
        let at = |v: &Option<Vec<Vec2>>, i: u32| -> Vec2 {
            v.as_ref()
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
        let corners = [a, b, c];
        let normals3 = [pick(a), pick(b), pick(c)];
        let extra = if colors.is_some() || uvs1.is_some() || normal_set.is_some() {
            let color = |i: u32| {
                colors
                    .as_ref()
                    .map(|c| c[i as usize])
                    .filter(|c| c.is_finite())
                    .map_or(Vec4::ONE, |c| c.clamp(Vec4::ZERO, Vec4::ONE))
            };
            let tangent = match (&file_tangents, &vertex_tangents) {
                (Some(t), _) => corners.map(|i| t[i as usize]),
                (None, Some(tb)) => {
                    let mut k = 0;
                    corners.map(|i| {
                        k += 1;
                        tangent_at(tb[i as usize], normals3[k - 1])
                    })
                }
                (None, None) => [Vec4::ZERO; 3],
            };
            parts.extras.push(TriExtra {
                uv1: corners.map(|i| at(&uvs1, i)),
                color: corners.map(color),
                tangent,
            });
            (parts.extras.len() - 1) as u32
        } else {
            NO_EXTRA
        };
        parts.triangles.push(tri(pa, pb, pc));
        parts.shading.push(TriShading {
            normals: normals3,
            uvs: corners.map(|i| at(&uvs, i)),
            material,
            extra,
        });
    }
    Ok(())
}

/// The directions in which u and v grow on a triangle with corners `p` and texture
/// coordinates `uv`, scaled by its area in texture space's units (Lengyel's construction,
/// the frame MikkTSpace also starts from); `None` where the coordinates are degenerate.
fn texture_directions(p: [Vec3; 3], uv: [Vec2; 3]) -> Option<[Vec3; 2]> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let det = d1.x * d2.y - d2.x * d1.y;
    if !det.is_finite() || det.abs() <= f32::MIN_POSITIVE {
        return None;
    }
    let s = det.signum();
    let t = (e1 * d2.y - e2 * d1.y) * s;
    let b = (e2 * d1.x - e1 * d2.x) * s;
    (t.is_finite() && b.is_finite()).then_some([t, b])
}

/// A vertex tangent from its summed texture directions `tb`: u's direction made orthogonal
/// to the normal `n`, w the sign that makes the bitangent n × t·w point where v falls, up the
/// image (glTF §3.9.3: a normal texture's +Y is up; v = 0 is the image's top row). Blender's
/// MikkTSpace tangents, computed with v flipped, point the same way. Zero where the
/// directions vanish: the normal texture is then not applied there.
fn tangent_at(tb: [Vec3; 2], n: Vec3) -> Vec4 {
    let t = (tb[0] - n * n.dot(tb[0])).normalize_or_zero();
    let w = if n.cross(t).dot(tb[1]) > 0.0 {
        -1.0
    } else {
        1.0
    };
    t.extend(w)
}
