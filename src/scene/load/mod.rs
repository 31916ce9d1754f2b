//! glTF 2.0 / GLB loading. The JSON is read leniently (`document`: integers written as `1.0`,
//! scenes without nodes) into the `gltf` crate's typed JSON, without the crate's validation,
//! which refuses valid files; instead every index is checked where the loader follows it, and
//! accessors are read by the loader's own bounds-checked reader (`data`: no buffer view, sparse
//! substitution, every component type with `normalized`, byte strides). Meshes become triangles
//! in `mesh`; materials, textures (KHR_texture_transform, extension-only images falling back to
//! the base colour factor) and lights are converted in `convert`. Bad input is an error of one
//! line, never a panic; `Scene::load` still catches a dependency's panic as the last line of
//! defence.

mod convert;
mod data;
mod document;
mod draco;
mod mesh;
mod meshopt;

use convert::{TextureLoader, convert_light, convert_material, unrendered};
use data::Buffers;
use document::get;
use mesh::{LoadStats, MeshInput, add_mesh};

use super::{Camera, Material, SceneError, SceneParts};
use glam::{Mat4, Quat, Vec3};
use gltf::json::{self, validation::Checked};
use std::path::Path;

/// Extensions the loader reads or may ignore without misreading the geometry (any other that a
/// file requires is a warning).
const SUPPORTED: [&str; 11] = [
    "KHR_mesh_quantization",
    meshopt::EXTENSION,
    draco::EXTENSION,
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_volume",
    "KHR_materials_unlit",
];

pub(crate) fn load_path(path: &Path) -> Result<SceneParts, SceneError> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SceneError::Unreadable {
        file: source.clone(),
        reason: e.to_string(),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_checked(&bytes, Some(base), &source)
}

pub(crate) fn load_slice(bytes: &[u8], name: &str) -> Result<SceneParts, SceneError> {
    load_checked(bytes, None, name)
}

/// Parse and convert (a panic inside a dependency is caught by `Scene::load`).
fn load_checked(bytes: &[u8], base: Option<&Path>, source: &str) -> Result<SceneParts, SceneError> {
    let err = |reason: String| SceneError::Invalid {
        file: source.to_string(),
        reason,
    };
    let name = Path::new(source)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| source.to_string());
    convert_file(bytes, base, name).map_err(err)
}

fn convert_file(bytes: &[u8], base: Option<&Path>, name: String) -> Result<SceneParts, String> {
    let document::Parsed { root, raw, blob } = document::parse(bytes)?;
    let mut warnings = Vec::new();
    for ext in &root.extensions_required {
        if !SUPPORTED.contains(&ext.as_str()) {
            warnings.push(format!(
                "the file requires {ext}, which raysplat does not support: it may look different"
            ));
        }
    }
    let buffers = Buffers::load(&root, &raw, base, blob);
    let mut textures = TextureLoader {
        root: &root,
        raw: &raw,
        buffers: &buffers,
        base,
        decoded: vec![None; root.images.len()],
        textures: Vec::new(),
        warnings,
    };
    let mut materials = Vec::with_capacity(root.materials.len() + 1);
    // What the materials use and raysplat does not render: one line per extension.
    let mut ignored: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, m) in root.materials.iter().enumerate() {
        materials.push(convert_material(i, m, &mut textures)?);
        for what in unrendered(m, &raw["materials"][i]) {
            match ignored.iter_mut().find(|(w, _)| *w == what) {
                Some((_, list)) => list.push(i),
                None => ignored.push((what, vec![i])),
            }
        }
    }
    for (what, list) in ignored {
        let names: Vec<String> = list
            .iter()
            .take(4)
            .map(|&i| {
                root.materials[i]
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("#{i}"))
            })
            .collect();
        let more = if list.len() > 4 {
            format!(" and {} more", list.len() - 4)
        } else {
            String::new()
        };
        textures.warn(format!(
            "{what} ignored: raysplat does not render it (material {}{more})",
            names.join(", ")
        ));
    }
    // The default material for primitives without one (glTF spec: white, metallic 1 — we use
    // a plain light-grey Lambertian, the usual choice of viewers).
    let default_material = materials.len() as u32;
    materials.push(Material::diffuse("default", Vec3::splat(0.8)));
    let TextureLoader {
        textures, warnings, ..
    } = textures;
    let mut parts = SceneParts {
        name,
        triangles: Vec::new(),
        shading: Vec::new(),
        extras: Vec::new(),
        materials,
        textures,
        punctual: Vec::new(),
        cameras: Vec::new(),
        warnings,
    };
    let input = MeshInput {
        root: &root,
        raw: &raw,
        buffers: &buffers,
        default_material,
    };
    let mut stats = LoadStats::default();
    traverse(&input, scene_roots(&root)?, &mut parts, &mut stats)?;
    if stats.degenerate > 0 {
        parts.warnings.push(format!(
            "{} degenerate (zero-area) triangles skipped",
            stats.degenerate
        ));
    }
    if stats.skipped_primitives > 0 {
        parts.warnings.push(format!(
            "{} point, line or unknown-mode primitives skipped",
            stats.skipped_primitives
        ));
    }
    if stats.without_positions > 0 {
        parts.warnings.push(format!(
            "{} primitives without POSITION skipped",
            stats.without_positions
        ));
    }
    // Primitives whose data is not there: without any other triangle the one line says why.
    if parts.triangles.is_empty()
        && let Some(first) = stats.unavailable.first()
    {
        return Err(format!(
            "the scene has no triangles to render: {} primitives have no data, {first}",
            stats.unavailable.len()
        ));
    }
    for u in stats.unavailable {
        parts.warnings.push(format!("{u}: skipped"));
    }
    Ok(parts)
}

/// The root nodes to show: the file's `scene`; without one its first scene; without scenes every
/// node that is no other node's child. (A scene that lists no nodes shows nothing, and is
/// refused as having no triangles.)
fn scene_roots(root: &json::Root) -> Result<Vec<usize>, String> {
    let scene = match root.scene {
        Some(s) => Some(get(&root.scenes, s.value(), "the file's default scene")?),
        None => root.scenes.first(),
    };
    Ok(match scene {
        Some(s) => s.nodes.iter().map(|n| n.value()).collect(),
        None => {
            let mut child = vec![false; root.nodes.len()];
            for n in &root.nodes {
                for c in n.children.iter().flatten() {
                    if let Some(flag) = child.get_mut(c.value()) {
                        *flag = true;
                    }
                }
            }
            (0..root.nodes.len()).filter(|&n| !child[n]).collect()
        }
    })
}

/// A node's local transform: its matrix, or translation × rotation (normalised) × scale.
fn local_transform(node: &json::Node) -> Mat4 {
    if let Some(m) = node.matrix {
        return Mat4::from_cols_array(&m);
    }
    let rotation = node.rotation.map_or(Quat::IDENTITY, |q| {
        let q = Quat::from_array(q.0);
        if q.is_finite() && q.length_squared() > 0.0 {
            q.normalize()
        } else {
            q
        }
    });
    Mat4::from_scale_rotation_translation(
        Vec3::from(node.scale.unwrap_or([1.0; 3])),
        rotation,
        Vec3::from(node.translation.unwrap_or([0.0; 3])),
    )
}

/// Walk the node tree from `roots`, adding meshes, cameras and lights to `parts`. Every node is
/// visited once: one reached twice (a cycle, or a child with two parents) is an error.
fn traverse(
    input: &MeshInput,
    roots: Vec<usize>,
    parts: &mut SceneParts,
    stats: &mut LoadStats,
) -> Result<(), String> {
    let root = input.root;
    let no_lights = Vec::new();
    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map_or(&no_lights, |l| &l.lights);
    let mut visited = vec![false; root.nodes.len()];
    // Each camera's (glTF camera index, node index): cameras are listed in the file's order,
    // whatever order the node traversal meets them in.
    let mut keyed: Vec<((usize, usize), Camera)> = Vec::new();
    let mut stack: Vec<(usize, Mat4, String)> = roots
        .into_iter()
        .map(|n| (n, Mat4::IDENTITY, "the scene".to_string()))
        .collect();
    // Popped from the end: the order the loader has always met nodes in (triangle order, and
    // so images, stay as they were).
    while let Some((n, parent, referrer)) = stack.pop() {
        let node = get(&root.nodes, n, &referrer)?;
        if std::mem::replace(&mut visited[n], true) {
            return Err(format!(
                "node {n} is reached twice (the node hierarchy has a cycle or a shared child)"
            ));
        }
        let world = parent * local_transform(node);
        if !world.is_finite() {
            return Err(format!("node {n} has a non-finite transform"));
        }
        if let Some(m) = node.mesh {
            let mesh = get(&root.meshes, m.value(), &format!("node {n}"))?;
            add_mesh(input, m.value(), world, parts, stats).map_err(|e| {
                format!(
                    "mesh {} ({}): {e}",
                    m.value(),
                    mesh.name.as_deref().unwrap_or("unnamed")
                )
            })?;
        }
        if let Some(c) = node.camera {
            let cam = get(&root.cameras, c.value(), &format!("node {n}"))?;
            match (&cam.type_, &cam.perspective) {
                (Checked::Valid(json::camera::Type::Perspective), Some(p)) => {
                    let (_, rot, pos) = world.to_scale_rotation_translation();
                    let yfov = p.yfov;
                    if yfov.is_finite() && yfov > 1e-4 && yfov < std::f32::consts::PI - 1e-3 {
                        let name = node
                            .name
                            .clone()
                            .or(cam.name.clone())
                            .unwrap_or_else(|| format!("camera{}", keyed.len()));
                        let camera = Camera {
                            name,
                            position: pos,
                            forward: (rot * -Vec3::Z).normalize(),
                            up: (rot * Vec3::Y).normalize(),
                            yfov,
                        };
                        keyed.push(((c.value(), n), camera));
                    } else {
                        parts.warnings.push(format!(
                            "camera on node {n} skipped: field of view {yfov} rad is unusable"
                        ));
                    }
                }
                _ => parts.warnings.push(format!(
                    "camera on node {n} skipped (only perspective cameras are supported)"
                )),
            }
        }
        let light = node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref());
        if let Some(l) = light {
            let light = get(lights, l.light.value(), &format!("node {n}"))?;
            match convert_light(light, world) {
                Some(l) => parts.punctual.push(l),
                None => parts.warnings.push(format!(
                    "light {} skipped: unknown type, or non-positive or non-finite intensity or cone",
                    l.light.value()
                )),
            }
        }
        for c in node.children.iter().flatten() {
            stack.push((c.value(), world, format!("node {n}'s child")));
        }
    }
    keyed.sort_by_key(|(k, _)| *k);
    parts.cameras = keyed.into_iter().map(|(_, c)| c).collect();
    Ok(())
}
