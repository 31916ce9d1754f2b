//! Buffer and accessor bounds checks, and glTF mesh primitives turned into triangles.

use crate::scene::{SceneParts, TriShading, tri};
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::{Document, buffer};

#[derive(Default)]
pub(super) struct LoadStats {
    pub(super) degenerate: usize,
    pub(super) skipped_primitives: usize,
}

/// Every buffer view inside its buffer, every accessor inside its view.
pub(super) fn check_buffers(document: &Document, buffers: &[buffer::Data]) -> Result<(), String> {
    for view in document.views() {
        let b = view.buffer().index();
        let len = buffers
            .get(b)
            .map(|d| d.0.len())
            .ok_or_else(|| format!("buffer view {} refers to missing buffer {b}", view.index()))?;
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|e| e > len) {
            return Err(format!(
                "buffer view {} (offset {}, length {}) runs past the end of buffer {b} ({len} bytes)",
                view.index(),
                view.offset(),
                view.length()
            ));
        }
    }
    for acc in document.accessors() {
        if acc.sparse().is_some() {
            return Err(format!(
                "accessor {} is sparse; sparse accessors are not supported",
                acc.index()
            ));
        }
        let Some(view) = acc.view() else { continue };
        let elem = acc.size();
        let stride = view.stride().unwrap_or(elem);
        let count = acc.count();
        if count == 0 {
            continue;
        }
        let need = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(acc.offset()));
        if need.is_none_or(|n| n > view.length()) {
            return Err(format!(
                "accessor {} ({} elements) reads past the end of buffer view {}",
                acc.index(),
                count,
                view.index()
            ));
        }
    }
    Ok(())
}

pub(super) fn add_mesh(
    mesh: &gltf::Mesh,
    world: Mat4,
    buffers: &[buffer::Data],
    default_material: u32,
    parts: &mut SceneParts,
    stats: &mut LoadStats,
) -> Result<(), String> {
    let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
    let flip = world.determinant() < 0.0;
    for prim in mesh.primitives() {
        use gltf::mesh::Mode;
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            stats.skipped_primitives += 1;
            continue;
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<Vec3> = match reader.read_positions() {
            Some(it) => it.map(|p| world.transform_point3(Vec3::from(p))).collect(),
            None => return Err(format!("primitive {} has no POSITION data", prim.index())),
        };
        if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "primitive {} vertex {bad} has a NaN or infinite position",
                prim.index()
            ));
        }
        let normals: Option<Vec<Vec3>> = reader.read_normals().map(|it| {
            it.map(|n| (normal_matrix * Vec3::from(n)).normalize_or_zero())
                .collect()
        });
        if let Some(n) = &normals
            && n.len() != positions.len()
        {
            return Err(format!(
                "primitive {} has {} normals for {} positions",
                prim.index(),
                n.len(),
                positions.len()
            ));
        }
        let uvs: Option<Vec<Vec2>> = reader
            .read_tex_coords(0)
            .map(|t| t.into_f32().map(Vec2::from).collect());
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(format!(
                "primitive {} index {bad} is out of range ({} vertices)",
                prim.index(),
                positions.len()
            ));
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
        let material = prim
            .material()
            .index()
            .map(|i| i as u32)
            .unwrap_or(default_material);
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
            parts.triangles.push(tri(pa, pb, pc));
            parts.shading.push(TriShading {
                normals: [pick(a), pick(b), pick(c)],
                uvs: [uv(a), uv(b), uv(c)],
                material,
            });
        }
    }
    Ok(())
}
