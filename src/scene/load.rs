//! glTF 2.0 / GLB loading through the `gltf` crate, with the bounds checks the crate leaves to
//! us: buffer views and accessors are checked against the loaded buffers before any is read,
//! indices against vertex counts, positions for NaN/Inf. Bad input is an error, never a panic.

use super::{
    Camera, Light, Material, MaterialKind, SceneError, SceneParts, Texture, TextureRef, TriShading,
    tri,
};
use glam::{Affine2, Mat3, Mat4, Quat, Vec2, Vec3};
use gltf::{Document, buffer, image};
use std::path::Path;

pub(crate) fn load_path(path: &Path) -> Result<SceneParts, SceneError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SceneError {
        source: source.clone(),
        message: format!("cannot read the file: {e}"),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_impl(&bytes, Some(base), &source)
}

pub(crate) fn load_slice(bytes: &[u8], name: &str) -> Result<SceneParts, SceneError> {
    load_impl(bytes, None, name)
}

fn load_impl(bytes: &[u8], base: Option<&Path>, source: &str) -> Result<SceneParts, SceneError> {
    let err = |message: String| SceneError {
        source: source.to_string(),
        message,
    };
    // The gltf crate indexes with unchecked slices in a few places; our checks below should
    // catch every such case first, and this keeps a missed one from taking the program down.
    let result = std::panic::catch_unwind(|| load_checked(bytes, base, source));
    match result {
        Ok(r) => r,
        Err(_) => Err(err(
            "the file is malformed (the glTF reader failed on it)".into()
        )),
    }
}

fn load_checked(bytes: &[u8], base: Option<&Path>, source: &str) -> Result<SceneParts, SceneError> {
    let err = |message: String| SceneError {
        source: source.to_string(),
        message,
    };
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(bytes).map_err(|e| {
        if bytes.starts_with(b"glTF") {
            err(format!("the GLB file is truncated or corrupt ({e})"))
        } else {
            err(format!("not valid glTF ({e})"))
        }
    })?;
    let buffers = gltf::import_buffers(&document, base, blob)
        .map_err(|e| err(format!("cannot load buffers: {e}")))?;
    check_buffers(&document, &buffers).map_err(err)?;

    let mut warnings = Vec::new();
    let images = match gltf::import_images(&document, base, &buffers) {
        Ok(images) => images,
        Err(e) => {
            if document.images().len() > 0 {
                warnings.push(format!(
                    "textures ignored, base colour factors used instead: {e}"
                ));
            }
            Vec::new()
        }
    };
    let textures: Vec<Texture> = images.iter().map(decode_texture).collect();

    let mut parts = SceneParts {
        name: Path::new(source)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| source.to_string()),
        triangles: Vec::new(),
        shading: Vec::new(),
        materials: document
            .materials()
            .map(|m| convert_material(&m, &textures))
            .collect(),
        textures,
        punctual: Vec::new(),
        cameras: Vec::new(),
        warnings,
    };
    for m in document.materials() {
        if let Some(s) = m.emissive_strength()
            && !(s.is_finite() && s >= 0.0)
        {
            parts.warnings.push(format!(
                "material {} ({}): emissive strength {s} ignored, it does not emit",
                m.index().map_or("default".into(), |i| i.to_string()),
                m.name().unwrap_or("unnamed")
            ));
        }
    }
    // The default material for primitives without one (glTF spec: white, metallic 1 — we use
    // a plain light-grey Lambertian, the usual choice of viewers).
    let default_material = parts.materials.len() as u32;
    parts
        .materials
        .push(Material::diffuse("default", Vec3::splat(0.8)));

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let roots: Vec<gltf::Node> = match &scene {
        Some(s) => s.nodes().collect(),
        None => document.nodes().collect(),
    };
    let mut stats = LoadStats::default();
    let mut stack: Vec<(gltf::Node, Mat4, usize)> =
        roots.into_iter().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(err(
                "the node hierarchy is deeper than 256 levels (a cycle?)".into(),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(err(format!(
                "node {} has a non-finite transform",
                node.index()
            )));
        }
        if let Some(mesh) = node.mesh() {
            add_mesh(
                &mesh,
                world,
                &buffers,
                default_material,
                &mut parts,
                &mut stats,
            )
            .map_err(|m| {
                err(format!(
                    "mesh {} ({}): {m}",
                    mesh.index(),
                    mesh.name().unwrap_or("unnamed")
                ))
            })?;
        }
        if let Some(cam) = node.camera() {
            match cam.projection() {
                gltf::camera::Projection::Perspective(p) => {
                    let (_, rot, pos) = world.to_scale_rotation_translation();
                    let yfov = p.yfov();
                    if yfov.is_finite() && yfov > 1e-4 && yfov < std::f32::consts::PI - 1e-3 {
                        let name = node
                            .name()
                            .or(cam.name())
                            .map(str::to_string)
                            .unwrap_or_else(|| format!("camera{}", parts.cameras.len()));
                        parts.cameras.push(Camera {
                            name,
                            position: pos,
                            forward: (rot * -Vec3::Z).normalize(),
                            up: (rot * Vec3::Y).normalize(),
                            yfov,
                        });
                    } else {
                        parts.warnings.push(format!(
                            "camera on node {} skipped: field of view {yfov} rad is unusable",
                            node.index()
                        ));
                    }
                }
                gltf::camera::Projection::Orthographic(_) => parts.warnings.push(format!(
                    "orthographic camera on node {} skipped (only perspective cameras are supported)",
                    node.index()
                )),
            }
        }
        if let Some(light) = node.light() {
            if let Some(l) = convert_light(&light, world) {
                parts.punctual.push(l);
            } else {
                parts.warnings.push(format!(
                    "light {} skipped: non-positive or non-finite intensity or cone",
                    light.index()
                ));
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    if stats.degenerate > 0 {
        parts.warnings.push(format!(
            "{} degenerate (zero-area) triangles skipped",
            stats.degenerate
        ));
    }
    if stats.skipped_primitives > 0 {
        parts.warnings.push(format!(
            "{} point or line primitives skipped",
            stats.skipped_primitives
        ));
    }
    Ok(parts)
}

#[derive(Default)]
struct LoadStats {
    degenerate: usize,
    skipped_primitives: usize,
}

/// Every buffer view inside its buffer, every accessor inside its view.
fn check_buffers(document: &Document, buffers: &[buffer::Data]) -> Result<(), String> {
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

fn add_mesh(
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

fn finite_or(x: f32, d: f32) -> f32 {
    if x.is_finite() { x } else { d }
}

fn convert_material(m: &gltf::Material, textures: &[Texture]) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let bc = pbr.base_color_factor();
    let base_color = Vec3::new(
        finite_or(bc[0], 0.8),
        finite_or(bc[1], 0.8),
        finite_or(bc[2], 0.8),
    )
    .clamp(Vec3::ZERO, Vec3::ONE);
    let metallic = finite_or(pbr.metallic_factor(), 1.0).clamp(0.0, 1.0);
    let roughness = finite_or(pbr.roughness_factor(), 1.0).clamp(0.0, 1.0);
    let transmission = m
        .transmission()
        .map(|t| finite_or(t.transmission_factor(), 0.0))
        .unwrap_or(0.0);
    let ior = m
        .ior()
        .filter(|i| i.is_finite() && *i >= 1.0)
        .unwrap_or(1.5);
    let specular_off = m.specular().is_some_and(|s| s.specular_factor() == 0.0);
    let kind = if transmission > 0.5 {
        MaterialKind::Dielectric { ior }
    } else if metallic > 0.5 && roughness < 0.05 {
        MaterialKind::Mirror
    } else if specular_off || (roughness >= 0.9 && metallic < 0.5) {
        MaterialKind::Diffuse
    } else {
        MaterialKind::Glossy {
            roughness,
            metallic,
        }
    };
    // A negative or non-finite strength is not light: the material does not emit (and the
    // loader says so).
    let strength = m
        .emissive_strength()
        .map(|s| if s.is_finite() && s >= 0.0 { s } else { 0.0 })
        .unwrap_or(1.0);
    let ef = m.emissive_factor();
    let emission = Vec3::new(ef[0], ef[1], ef[2]) * strength;
    let emission = if emission.is_finite() {
        emission.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    };
    let base_texture = pbr.base_color_texture().and_then(|info| {
        let image = info.texture().source().index();
        if image >= textures.len() {
            return None;
        }
        let transform = info
            .texture_transform()
            .map(|t| {
                let [ox, oy] = t.offset();
                let [sx, sy] = t.scale();
                Affine2::from_scale_angle_translation(
                    Vec2::new(sx, sy),
                    -t.rotation(),
                    Vec2::new(ox, oy),
                )
            })
            .filter(|a| a.is_finite())
            .unwrap_or(Affine2::IDENTITY);
        Some(TextureRef { image, transform })
    });
    Material {
        name: m.name().unwrap_or("unnamed").to_string(),
        base_color,
        base_texture,
        kind,
        emission,
        double_sided: m.double_sided(),
    }
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn decode_texture(img: &image::Data) -> Texture {
    use image::Format;
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    let channels = match img.format {
        Format::R8 => 1,
        Format::R8G8 => 2,
        Format::R8G8B8 => 3,
        Format::R8G8B8A8 => 4,
        // 16-bit and float textures: read the high byte of the first channels.
        Format::R16 => 2,
        Format::R16G16 => 4,
        Format::R16G16B16 => 6,
        Format::R16G16B16A16 => 8,
        Format::R32G32B32FLOAT => 12,
        Format::R32G32B32A32FLOAT => 16,
    };
    let wide = matches!(
        img.format,
        Format::R16 | Format::R16G16 | Format::R16G16B16 | Format::R16G16B16A16
    );
    let float = matches!(
        img.format,
        Format::R32G32B32FLOAT | Format::R32G32B32A32FLOAT
    );
    let n = (img.width * img.height) as usize;
    let mut texels = Vec::with_capacity(n);
    for i in 0..n {
        let px = &img.pixels[i * channels..(i + 1) * channels];
        let c = if float {
            let f = |k: usize| {
                f32::from_le_bytes([px[4 * k], px[4 * k + 1], px[4 * k + 2], px[4 * k + 3]])
            };
            Vec3::new(f(0), f(1), f(2))
        } else if wide {
            let k = channels / 2;
            let g = |j: usize| lut[px[2 * j.min(k - 1) + 1] as usize];
            Vec3::new(g(0), g(1), g(2))
        } else {
            let g = |j: usize| lut[px[j.min(channels - 1).min(2)] as usize];
            if channels <= 2 {
                Vec3::splat(g(0))
            } else {
                Vec3::new(g(0), g(1), g(2))
            }
        };
        texels.push(if c.is_finite() { c } else { Vec3::ONE });
    }
    if texels.is_empty() {
        texels.push(Vec3::ONE);
    }
    Texture {
        width: img.width.max(1),
        height: img.height.max(1),
        texels,
    }
}

fn convert_light(light: &gltf::khr_lights_punctual::Light, world: Mat4) -> Option<Light> {
    use gltf::khr_lights_punctual::Kind;
    let (_, rot, pos): (Vec3, Quat, Vec3) = world.to_scale_rotation_translation();
    let color = Vec3::from(light.color()) * light.intensity();
    if !color.is_finite() || color.max_element() <= 0.0 {
        return None;
    }
    let dir = (rot * -Vec3::Z).normalize();
    match light.kind() {
        Kind::Point => Some(Light::Point {
            position: pos,
            intensity: color,
        }),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let outer = outer_cone_angle.clamp(1e-3, std::f32::consts::FRAC_PI_2);
            let inner = inner_cone_angle.clamp(0.0, outer);
            Some(Light::Spot {
                position: pos,
                direction: dir,
                intensity: color,
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            })
        }
        Kind::Directional => Some(Light::Directional {
            direction: dir,
            irradiance: color,
        }),
    }
}
