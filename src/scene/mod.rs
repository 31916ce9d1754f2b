//! The scene: triangles with materials, lights, cameras and the BVH (obvhs) over them.
//!
//! Loading lives in `load` (glTF 2.0 / GLB), the project's own scenes in `builtin`, light
//! sampling in `light`, the environment and the sun in [`environment`], materials and textures
//! in `material`, the camera in `camera`, hit records and ray offsets in `geometry`, ray
//! queries in `trace`. Everything here is read-only once built and shared between threads.

mod builtin;
mod camera;
pub mod environment;
mod geometry;
mod light;
mod load;
mod material;
mod trace;

pub use builtin::{BuiltinScene, DEFAULT_SCENE_GLB, GlbBuilder, uv_sphere};
pub use camera::Camera;
use camera::framing_camera;
pub use environment::{Environment, EnvironmentKind, EnvironmentSettings, Sun};
pub(crate) use geometry::tri;
pub use geometry::{
    Hit, NO_EXTRA, SHADOW_EPSILON, TriExtra, TriShading, gamma, offset_ray_origin, surface_offset,
};
use light::Surfaces;
pub use light::{EmittedPhoton, Light, LightSample, Lights, NO_TEXTURE};
pub use material::{AlphaMode, Material, MaterialKind, Texture, TextureRef, Wrap};

use glam::Vec3;
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    triangle::Triangle,
};
use std::{path::Path, sync::Arc, time::Duration};

/// A scene that could not be loaded: which file, and why. The kinds are what a caller
/// branches on: the command line's exit status is the same for all three (the input is at
/// fault), but only [`SceneError::Unreadable`] is worth retrying (the file may appear, or its
/// permissions change), and [`SceneError::ReaderFailed`] names a fault in a dependency, not in
/// the user's file alone.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read (missing, a folder, no permission).
    #[error("{file}: cannot read the file: {reason}")]
    Unreadable {
        /// The file that failed.
        file: String,
        /// The operating system's reason.
        reason: String,
    },
    /// The file was read but holds no scene raysplat can render (not glTF, a broken buffer,
    /// a required extension that changes the geometry, no triangles, degenerate extent).
    #[error("{file}: {reason}")]
    Invalid {
        /// The file (or built-in scene) that failed.
        file: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The glTF reader (a dependency) panicked on the file; the panic was caught.
    #[error("{file}: the glTF reader failed on this file ({reason})")]
    ReaderFailed {
        /// The file that failed.
        file: String,
        /// The first line of the panic's message.
        reason: String,
    },
}

impl SceneError {
    /// The file (or built-in scene) the error is about.
    pub fn file(&self) -> &str {
        match self {
            Self::Unreadable { file, .. }
            | Self::Invalid { file, .. }
            | Self::ReaderFailed { file, .. } => file,
        }
    }
}

/// A loaded scene, ready to render: triangles with shading data and materials, lights,
/// cameras and the BVH. Cloning copies everything (the window clones a scene to light it
/// with another environment).
#[derive(Clone)]
pub struct Scene {
    /// Display name (the file's stem, or the built-in scene's title).
    pub name: String,
    /// Triangles in world space (the BVH's primitives).
    pub triangles: Vec<Triangle>,
    /// Shading data of each triangle.
    pub shading: Vec<TriShading>,
    /// Vertex data beyond [`TriShading`]'s, for the triangles that have it.
    pub extras: Vec<TriExtra>,
    /// Materials; the last is the default for primitives without one.
    pub materials: Vec<Material>,
    /// Decoded texture images, shared with the lights (emissive textures).
    pub textures: Arc<[Texture]>,
    /// The lights (emissive triangles, punctual lights, the environment and the sun).
    pub lights: Lights,
    /// The environment the lights hold, as chosen (never `Auto`: resolved).
    pub environment: EnvironmentSettings,
    /// One line for the user when the environment was chosen for them (a file without
    /// lights of its own, lit by the uniform environment); `None` otherwise.
    pub lighting_notice: Option<String>,
    /// The file's punctual lights (kept to rebuild the lights with another environment).
    punctual: Vec<Light>,
    /// What [`Scene::set_environment`] was last asked for (`Auto` after loading).
    requested: EnvironmentSettings,
    /// The scene's cameras; a framing camera when the file has none (never empty).
    pub cameras: Vec<Camera>,
    /// Lower corner of the triangles' bounding box.
    pub bounds_min: Vec3,
    /// Upper corner of the triangles' bounding box.
    pub bounds_max: Vec3,
    /// Things the loader skipped or repaired, for the user to read.
    pub warnings: Vec<String>,
    /// Some material is alpha-tested (MASK or BLEND): ray queries then read alpha.
    has_alpha: bool,
    bvh: CwBvh,
}

/// What the loaders hand to [`Scene::build`].
pub(crate) struct SceneParts {
    pub name: String,
    pub triangles: Vec<Triangle>,
    pub shading: Vec<TriShading>,
    pub extras: Vec<TriExtra>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub punctual: Vec<Light>,
    pub cameras: Vec<Camera>,
    pub warnings: Vec<String>,
}

impl Scene {
    /// Bytes held by the scene's triangles, shading data, textures (with the emissive
    /// textures' light tables) and BVH (the environment's map and tables are not counted).
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(&self.triangles[..])
            + size_of_val(&self.shading[..])
            + size_of_val(&self.extras[..])
            + self.texture_bytes()
            + size_of_val(&self.bvh.nodes[..])
            + size_of_val(&self.bvh.primitive_indices[..])
    }

    /// Bytes held by the decoded texture images and the emissive textures' light tables
    /// (part of [`Scene::memory_bytes`]).
    pub fn texture_bytes(&self) -> usize {
        self.textures
            .iter()
            .map(|t| std::mem::size_of_val(&t.texels[..]))
            .sum::<usize>()
            + self.lights.memory_bytes()
    }

    /// The embedded default scene (CORNELL BOX I).
    pub fn default_scene() -> Self {
        Self::from_glb_bytes(DEFAULT_SCENE_GLB, "CORNELL BOX I (embedded)")
            .expect("the embedded default scene is generated by this crate and always loads")
    }

    /// A project scene, generated in memory by `scene::builtin`.
    pub fn builtin(which: BuiltinScene) -> Self {
        Self::from_glb_bytes(&which.to_glb(), which.title()).expect("built-in scenes always load")
    }

    /// Load a .gltf or .glb file, lit by the `Auto` environment (a uniform white when the
    /// file has no light of its own, [`Scene::lighting_notice`] then says so). No input
    /// panics: a panic inside the glTF reader (the last line of defence behind the loader's
    /// own checks) becomes the one-line error.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let source = path.display().to_string();
        guarded(&source, || {
            load::load_path(path).and_then(|parts| Self::build(parts, &source))
        })
    }

    /// Load glTF (binary or JSON with embedded buffers) from memory; guarded as
    /// [`Scene::load`].
    pub fn from_glb_bytes(bytes: &[u8], name: &str) -> Result<Self, SceneError> {
        guarded(name, || {
            load::load_slice(bytes, name).and_then(|parts| Self::build(parts, name))
        })
    }

    pub(crate) fn build(parts: SceneParts, source: &str) -> Result<Self, SceneError> {
        let err = |reason: String| SceneError::Invalid {
            file: source.to_string(),
            reason,
        };
        if parts.triangles.is_empty() {
            return Err(err("the scene has no triangles to render".into()));
        }
        let mut bounds_min = Vec3::splat(f32::INFINITY);
        let mut bounds_max = Vec3::splat(f32::NEG_INFINITY);
        for t in &parts.triangles {
            for v in [t.v0, t.v1, t.v2] {
                bounds_min = bounds_min.min(v.into());
                bounds_max = bounds_max.max(v.into());
            }
        }
        let diag = (bounds_max - bounds_min).length();
        if !diag.is_finite() || diag <= 0.0 {
            return Err(err(
                "the scene's geometry is degenerate (zero or infinite extent)".into(),
            ));
        }
        let textures: Arc<[Texture]> = parts.textures.into();
        let lights = Lights::build(
            &Surfaces {
                triangles: &parts.triangles,
                shading: &parts.shading,
                extras: &parts.extras,
                materials: &parts.materials,
                textures: &textures,
            },
            None,
            parts.punctual.clone(),
            Environment::default(),
            bounds_min,
            bounds_max,
        );
        let bvh = build_cwbvh_from_tris(
            &parts.triangles,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let mut cameras = parts.cameras;
        if cameras.is_empty() {
            cameras.push(framing_camera(bounds_min, bounds_max));
        }
        let has_alpha = parts.materials.iter().any(Material::alpha_tested);
        let mut scene = Self {
            name: parts.name,
            has_alpha,
            triangles: parts.triangles,
            shading: parts.shading,
            extras: parts.extras,
            materials: parts.materials,
            textures,
            lights,
            environment: EnvironmentSettings {
                kind: EnvironmentKind::None,
                ..Default::default()
            },
            lighting_notice: None,
            punctual: parts.punctual,
            requested: EnvironmentSettings::default(),
            cameras,
            bounds_min,
            bounds_max,
            warnings: parts.warnings,
            bvh,
        };
        if !scene.has_own_lights() {
            scene
                .set_environment(&EnvironmentSettings::default())
                .map_err(err)?;
        }
        Ok(scene)
    }

    /// The file's own lights light it: punctual lights, or emissive triangles with power
    /// whose emission is not a texture's. Emissive textures (a lamp's bulb, a display, the
    /// trim of a model) emit, but a file lit by nothing else is a model made to be seen under
    /// an environment, as glTF viewers show it.
    pub fn has_own_lights(&self) -> bool {
        self.lights.lights.iter().any(|l| match l {
            Light::Environment { .. } | Light::Sun(_) => false,
            Light::Area { texture, .. } => *texture == NO_TEXTURE,
            _ => true,
        })
    }

    /// Light the scene with the environment `settings` ask for, rebuilding its lights. `Auto`
    /// resolves to `none` when the file has lights of its own and to `uniform` (at the
    /// settings' strength) when it has none; [`Scene::lighting_notice`] then says so. On an
    /// error (an unreadable map, or a scene left with no light at all) nothing changes.
    pub fn set_environment(&mut self, settings: &EnvironmentSettings) -> Result<(), String> {
        let own = self.has_own_lights();
        let mut resolved = settings.clone();
        let mut notice = None;
        if resolved.kind == EnvironmentKind::Auto {
            resolved.kind = if own {
                EnvironmentKind::None
            } else {
                let textured =
                    self.lights.lights.iter().any(
                        |l| matches!(l, Light::Area { texture, .. } if *texture != NO_TEXTURE),
                    );
                notice = Some(if textured {
                    format!(
                        "the file's only lights are emissive textures: lit by the uniform environment as well, at strength {}",
                        resolved.strength
                    )
                } else {
                    format!(
                        "the file has no light of its own: lit by the uniform environment at strength {}",
                        resolved.strength
                    )
                });
                EnvironmentKind::Uniform
            };
        }
        let environment = Environment::build(&resolved)?;
        let lights = Lights::build(
            &Surfaces {
                triangles: &self.triangles,
                shading: &self.shading,
                extras: &self.extras,
                materials: &self.materials,
                textures: &self.textures,
            },
            Some(self.lights.textured_emitters()),
            self.punctual.clone(),
            environment,
            self.bounds_min,
            self.bounds_max,
        );
        if lights.is_empty() {
            return Err(if own {
                "that environment gives no light".into()
            } else {
                "the scene has no light of its own and the environment gives none: choose the uniform or sky environment, or a map".into()
            });
        }
        self.lights = lights;
        self.environment = resolved;
        self.lighting_notice = notice;
        self.requested = settings.clone();
        Ok(())
    }

    /// The scene is lit as `Auto` with default strength, rotation and no sun decides (as
    /// it loaded).
    pub fn environment_is_auto(&self) -> bool {
        self.requested == EnvironmentSettings::default()
    }

    /// The environment the scene was last lit with, as asked (before `Auto` is resolved).
    pub fn requested_environment(&self) -> &EnvironmentSettings {
        &self.requested
    }

    /// Radiance arriving along a ray that leaves the scene in direction `d` (the
    /// environment's; black without one).
    #[inline]
    pub fn background(&self, d: Vec3) -> Vec3 {
        self.lights.environment.radiance(d)
    }

    /// Length of the bounding box's diagonal (scene units).
    pub fn diagonal(&self) -> f32 {
        (self.bounds_max - self.bounds_min).length()
    }

    /// Centre of the bounding box.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.bounds_min + self.bounds_max)
    }

    /// The camera named `name`, or the first camera when `name` is `None`.
    pub fn camera(&self, name: Option<&str>) -> Option<&Camera> {
        match name {
            None => self.cameras.first(),
            Some(n) => self.cameras.iter().find(|c| c.name == n),
        }
    }

    /// [`Scene::camera`], or an error listing the cameras there are.
    pub fn camera_or_error(&self, name: Option<&str>) -> Result<Camera, String> {
        self.camera(name).cloned().ok_or_else(|| {
            let names: Vec<&str> = self.cameras.iter().map(|c| c.name.as_str()).collect();
            format!(
                "no camera named {:?}; the scene has: {}",
                name.unwrap_or(""),
                names.join(", ")
            )
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
}

thread_local! {
    /// True while this thread runs a guarded load: its panics are turned into errors, so the
    /// panic hook stays quiet for them.
    static IN_GUARDED_LOAD: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Run `load`, turning a panic (inside a dependency) into a [`SceneError`] for `source`. A
/// process-wide panic hook, installed once, keeps such panics off stderr; every other panic
/// is reported by the hook that was there before.
fn guarded<T>(source: &str, load: impl FnOnce() -> Result<T, SceneError>) -> Result<T, SceneError> {
    static QUIET_HOOK: std::sync::Once = std::sync::Once::new();
    QUIET_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !IN_GUARDED_LOAD.with(|g| g.get()) {
                previous(info);
            }
        }));
    });
    let outer = IN_GUARDED_LOAD.with(|g| g.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(load));
    IN_GUARDED_LOAD.with(|g| g.set(outer));
    result.unwrap_or_else(|panic| {
        let why = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        Err(SceneError::ReaderFailed {
            file: source.to_string(),
            reason: why.lines().next().unwrap_or("").to_string(),
        })
    })
}
