//! A minimal glTF 2.0 binary writer for the generated scenes.

use glam::Vec3;
use serde_json::{Value, json};

/// The rotation taking −Z to `dir` with +Y kept up (glTF cameras and lights look down −Z).
fn look_rotation(dir: Vec3) -> glam::Quat {
    let f = dir.normalize();
    let r = f.cross(Vec3::Y).normalize_or(Vec3::X);
    let u = r.cross(f);
    glam::Quat::from_mat3(&glam::Mat3::from_cols(r, u, -f)).normalize()
}

/// A minimal glTF 2.0 binary writer for generated scenes (the project's own scenes, tests):
/// one mesh per object with positions, normals, further float attributes and u32 indices,
/// metallic-roughness materials given as glTF JSON, PNG textures with their samplers,
/// perspective cameras and KHR_lights_punctual lights.
#[derive(Default)]
pub struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    cameras: Vec<Value>,
    lights: Vec<Value>,
    images: Vec<Value>,
    textures: Vec<Value>,
    samplers: Vec<Value>,
}

impl GlbBuilder {
    /// Add a material (a glTF material object); returns its index.
    pub fn material(&mut self, m: Value) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        self.views.len() - 1
    }

    fn vec3_accessor(&mut self, v: &[Vec3], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = v
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.push_view(&bytes, 34962);
        let mut acc =
            json!({"bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3"});
        if with_bounds {
            let min = v.iter().fold(Vec3::splat(f32::INFINITY), |a, b| a.min(*b));
            let max = v
                .iter()
                .fold(Vec3::splat(f32::NEG_INFINITY), |a, b| a.max(*b));
            acc["min"] = json!(min.to_array());
            acc["max"] = json!(max.to_array());
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// Add a triangle mesh (one primitive) under its own node.
    pub fn mesh(&mut self, name: &str, p: &[Vec3], n: &[Vec3], idx: &[u32], material: u32) {
        self.mesh_with(name, p, n, &[], idx, material);
    }

    /// [`GlbBuilder::mesh`] with further float attributes: (semantic, components per vertex
    /// — 2, 3 or 4 —, the values vertex by vertex), e.g. ("TEXCOORD_0", 2, uvs).
    pub fn mesh_with(
        &mut self,
        name: &str,
        p: &[Vec3],
        n: &[Vec3],
        extra: &[(&str, usize, &[f32])],
        idx: &[u32],
        material: u32,
    ) {
        let pos = self.vec3_accessor(p, true);
        let nrm = self.vec3_accessor(n, false);
        let mut attributes = json!({"POSITION": pos, "NORMAL": nrm});
        for &(semantic, width, values) in extra {
            let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            let view = self.push_view(&bytes, 34962);
            let kind = ["SCALAR", "VEC2", "VEC3", "VEC4"][width.clamp(1, 4) - 1];
            self.accessors
                .push(json!({"bufferView": view, "componentType": 5126,
                "count": values.len() / width.max(1), "type": kind}));
            attributes[semantic] = json!(self.accessors.len() - 1);
        }
        let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34963);
        self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}));
        let ind = self.accessors.len() - 1;
        self.meshes.push(json!({"name": name, "primitives": [{
            "attributes": attributes, "indices": ind, "material": material}]}));
        self.nodes
            .push(json!({"name": name, "mesh": self.meshes.len() - 1}));
    }

    /// Add a texture of the PNG file `png` (embedded in the buffer) read through `sampler`
    /// (a glTF sampler object; `None`: the default, repeat and bilinear); returns its index
    /// for a material's texture info.
    pub fn texture(&mut self, png: &[u8], sampler: Option<Value>) -> u32 {
        let view = self.push_view(png, 0);
        self.views[view]
            .as_object_mut()
            .expect("a view is an object")
            .remove("target");
        self.images
            .push(json!({"bufferView": view, "mimeType": "image/png"}));
        let mut t = json!({"source": self.images.len() - 1});
        if let Some(s) = sampler {
            self.samplers.push(s);
            t["sampler"] = json!(self.samplers.len() - 1);
        }
        self.textures.push(t);
        (self.textures.len() - 1) as u32
    }

    /// Add a perspective camera at `eye` looking at `target` (vertical field of view in radians).
    pub fn camera(&mut self, name: &str, eye: Vec3, target: Vec3, yfov: f32) {
        let q = look_rotation(target - eye);
        self.cameras
            .push(json!({"name": name, "type": "perspective",
            "perspective": {"yfov": yfov, "znear": 0.01, "aspectRatio": 1.0}}));
        self.nodes
            .push(json!({"name": name, "camera": self.cameras.len() - 1,
            "translation": eye.to_array(), "rotation": q.to_array()}));
    }

    /// Add a KHR_lights_punctual point light (intensity in W/sr).
    pub fn point_light(&mut self, name: &str, position: Vec3, color: Vec3, intensity: f32) {
        self.lights.push(json!({"name": name, "type": "point", "color": color.to_array(), "intensity": intensity}));
        self.nodes
            .push(json!({"name": name, "translation": position.to_array(),
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}}));
    }

    /// Add a KHR_lights_punctual spot light pointing along `direction`.
    pub fn spot_light(
        &mut self,
        name: &str,
        position: Vec3,
        direction: Vec3,
        color: Vec3,
        intensity: f32,
        cone: (f32, f32),
    ) {
        self.lights.push(
            json!({"name": name, "type": "spot", "color": color.to_array(), "intensity": intensity,
            "spot": {"innerConeAngle": cone.0, "outerConeAngle": cone.1}}),
        );
        self.nodes
            .push(json!({"name": name, "translation": position.to_array(),
            "rotation": look_rotation(direction).to_array(),
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}}));
    }

    /// The extensions its materials use, each once, in the order first met (the file's
    /// `extensionsUsed` must list them).
    fn material_extensions(&self) -> Vec<String> {
        let mut used: Vec<String> = Vec::new();
        for m in &self.materials {
            for name in m["extensions"]
                .as_object()
                .into_iter()
                .flat_map(|e| e.keys())
            {
                if !used.contains(name) {
                    used.push(name.clone());
                }
            }
        }
        used
    }

    /// The GLB file.
    pub fn to_glb(&self) -> Vec<u8> {
        let mut root = json!({
            "asset": {"version": "2.0", "generator": concat!("raysplat ", env!("CARGO_PKG_VERSION"))},
            "extensionsUsed": self.material_extensions(),
            "scene": 0,
            "scenes": [{"nodes": (0..self.nodes.len()).collect::<Vec<_>>()}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "cameras": self.cameras,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        for (key, list) in [
            ("images", &self.images),
            ("textures", &self.textures),
            ("samplers", &self.samplers),
        ] {
            if !list.is_empty() {
                root[key] = json!(list);
            }
        }
        if !self.lights.is_empty() {
            root["extensionsUsed"]
                .as_array_mut()
                .expect("set above")
                .push(json!("KHR_lights_punctual"));
            root["extensions"] = json!({"KHR_lights_punctual": {"lights": self.lights}});
        }
        let mut json_bytes =
            serde_json::to_vec(&root).expect("serialising a JSON value cannot fail");
        while !json_bytes.len().is_multiple_of(4) {
            json_bytes.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_bytes);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }
}
