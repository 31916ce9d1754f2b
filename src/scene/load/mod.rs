//! glTF 2.0 / GLB loading through the `gltf` crate, with the bounds checks the crate leaves to
//! us: buffer views and accessors are checked against the loaded buffers before any is read,
//! indices against vertex counts, positions for NaN/Inf. Bad input is an error, never a panic.
//!
//! The buffer checks and the triangle conversion are in `mesh`; materials, textures and lights
//! are converted in `convert`.

mod convert;
mod mesh;

use convert::{convert_light, convert_material, decode_texture};
use mesh::{LoadStats, add_mesh, check_buffers};

use super::{Camera, Material, SceneError, SceneParts, Texture};
use glam::{Mat4, Vec3};
use std::path::Path;

pub(crate) fn load_path(path: &Path) -> Result<SceneParts, SceneError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SceneError {
        source: source.clone(),
        message: format!("cannot read the file: {e}"),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_checked(&bytes, Some(base), &source)
}

pub(crate) fn load_slice(bytes: &[u8], name: &str) -> Result<SceneParts, SceneError> {
    load_checked(bytes, None, name)
}

/// Parse and convert (a panic inside the `gltf` crate is caught by `Scene::load`).
fn load_checked(bytes: &[u8], base: Option<&Path>, source: &str) -> Result<SceneParts, SceneError> {
    let err = |message: String| SceneError {
        source: source.to_string(),
        message,
    };
    let images_usable = precheck(bytes).map_err(err)?;
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
    let images = match images_usable {
        Err(why) => {
            warnings.push(format!(
                "textures ignored, base colour factors used instead: {why}"
            ));
            Vec::new()
        }
        Ok(()) => gltf::import_images(&document, base, &buffers).unwrap_or_else(|e| {
            if document.images().len() > 0 {
                warnings.push(format!(
                    "textures ignored, base colour factors used instead: {e}"
                ));
            }
            Vec::new()
        }),
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
    // Each camera's (glTF camera index, node index): cameras are listed in the file's order,
    // whatever order the node traversal meets them in.
    let mut camera_keys: Vec<(usize, usize)> = Vec::new();
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
                        camera_keys.push((cam.index(), node.index()));
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
    let mut keyed: Vec<((usize, usize), Camera)> = camera_keys
        .into_iter()
        .zip(parts.cameras.drain(..))
        .collect();
    keyed.sort_by_key(|(k, _)| *k);
    parts.cameras = keyed.into_iter().map(|(_, c)| c).collect();
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

/// What the `gltf` crate would index before checking (it panics there): every primitive's
/// attributes and indices must name existing accessors, an error otherwise; every image must
/// have a uri or a buffer view, or else textures are ignored (`Ok(Err(why))`). Files whose
/// JSON cannot be read are left to the crate, which reports them.
fn precheck(bytes: &[u8]) -> Result<Result<(), String>, String> {
    let json: std::borrow::Cow<[u8]> = if bytes.starts_with(b"glTF") {
        match gltf::Glb::from_slice(bytes) {
            Ok(glb) => glb.json,
            Err(_) => return Ok(Ok(())),
        }
    } else {
        bytes.into()
    };
    let Ok(root) = gltf::json::Root::from_slice(&json) else {
        return Ok(Ok(()));
    };
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let named = prim
                .attributes
                .values()
                .chain(prim.indices.as_ref())
                .map(|i| i.value());
            for a in named {
                if a >= accessors {
                    return Err(format!(
                        "mesh {m} primitive {p} reads accessor {a}, but the file has {accessors}"
                    ));
                }
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        if image.uri.is_none() && image.buffer_view.is_none() {
            return Ok(Err(format!(
                "image {i} has neither a uri nor a buffer view"
            )));
        }
    }
    Ok(Ok(()))
}
