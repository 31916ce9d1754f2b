//! The scene: triangles with materials, lights, cameras and the BVH (obvhs) over them.
//!
//! Loading lives in `load` (glTF 2.0 / GLB), the project's own scenes in `builtin`, light
//! sampling in `light`. Everything here is read-only once built and shared between threads.

mod builtin;
mod light;
mod load;

pub use builtin::{BuiltinScene, DEFAULT_SCENE_GLB, GlbBuilder, uv_sphere};
pub use light::{EmittedPhoton, Light, LightSample, Lights};

use crate::bsdf::Bsdf;
use glam::{Affine2, Vec2, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::{Ray, RayHit},
    triangle::Triangle,
};
use std::{fmt, path::Path, time::Duration};

/// A scene that could not be loaded: which file, and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub source: String,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source, self.message)
    }
}

impl std::error::Error for SceneError {}

/// How a material scatters; glTF's metallic/roughness model mapped onto the models we render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    Diffuse,
    /// Moderately glossy (0.05 ≤ roughness < 0.9 or metallic but rough): [`Bsdf::Glossy`],
    /// rendered through the directional radiance map (§8.1).
    Glossy {
        roughness: f32,
        metallic: f32,
    },
    Mirror,
    Dielectric {
        ior: f32,
    },
}

#[derive(Clone, Debug)]
pub struct TextureRef {
    pub image: usize,
    pub transform: Affine2,
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Linear RGB base colour (glTF baseColorFactor).
    pub base_color: Vec3,
    pub base_texture: Option<TextureRef>,
    pub kind: MaterialKind,
    /// Emitted radiance, emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    pub double_sided: bool,
}

impl Material {
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Self {
            name: name.to_string(),
            base_color: color,
            base_texture: None,
            kind: MaterialKind::Diffuse,
            emission: Vec3::ZERO,
            double_sided: false,
        }
    }

    pub fn is_specular(&self) -> bool {
        matches!(
            self.kind,
            MaterialKind::Mirror | MaterialKind::Dielectric { .. }
        )
    }
}

/// A decoded base-colour texture, stored as linear RGB.
#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// Nearest-texel lookup with repeat wrapping.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let u = uv.x - uv.x.floor();
        let v = uv.y - uv.y.floor();
        let x = ((u * self.width as f32) as u32).min(self.width - 1);
        let y = ((v * self.height as f32) as u32).min(self.height - 1);
        self.texels[(y * self.width + x) as usize]
    }
}

/// A pinhole camera (glTF perspective camera: looks down its local −Z, +Y up).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    pub forward: Vec3,
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl Camera {
    pub fn look_at(name: &str, position: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - position).normalize();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        Self {
            name: name.to_string(),
            position,
            forward,
            up: right.cross(forward),
            yfov,
        }
    }

    pub fn right(&self) -> Vec3 {
        self.forward.cross(self.up).normalize()
    }

    /// Direction through film point (`sx`, `sy`) ∈ [0,1]², y down, for an image of `aspect` = w/h.
    #[inline]
    pub fn direction(&self, sx: f32, sy: f32, aspect: f32) -> Vec3 {
        let th = (0.5 * self.yfov).tan();
        let x = (2.0 * sx - 1.0) * th * aspect;
        let y = (1.0 - 2.0 * sy) * th;
        (self.forward + x * self.right() + y * self.up).normalize()
    }
}

/// Per-triangle shading data (vertex normals and texture coordinates).
#[derive(Clone, Copy, Debug)]
pub struct TriShading {
    pub normals: [Vec3; 3],
    pub uvs: [Vec2; 3],
    pub material: u32,
}

/// A ray–surface intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub position: Vec3,
    /// Geometric normal from the winding (unit, not flipped towards the ray).
    pub geo_normal: Vec3,
    /// Interpolated shading normal, on the same side as `geo_normal`.
    pub normal: Vec3,
    pub uv: Vec2,
    pub triangle: u32,
    pub material: u32,
    /// How far `position` may lie from the true surface along `geo_normal`: the floating-point
    /// error bound of the barycentric interpolation that computed it (pbrt-v4 §6.8), a few
    /// ulps of the triangle's own coordinates. Spawned rays start this far off the surface.
    pub offset: f32,
}

/// γ(n) = n·u/(1 − n·u), u = 2⁻²⁴: the bound on the relative error of n floating-point
/// operations (Higham; pbrt-v4 §6.8.1).
pub const fn gamma(n: u32) -> f32 {
    let u = f32::EPSILON * 0.5;
    n as f32 * u / (1.0 - n as f32 * u)
}

/// Spawn offsets are this many times the error bound: the ray–triangle test's own rounding
/// (obvhs's Möller–Trumbore, not watertight) must not bring a ray back onto its surface.
const OFFSET_SAFETY: f32 = 4.0;

/// How far a spawned ray must start off a surface whose triangle has coordinates of absolute
/// value up to `coord_max`. pbrt-v4 bounds only the hit point's own error (§6.8), which is
/// exactly zero on a plane through the origin such as a floor at y = 0; but obvhs's
/// Möller–Trumbore test computes t from v0 − origin and accepts t = 0, so an origin exactly on
/// the plane hits its own triangle. The bound here covers both: a few ulps of the largest
/// coordinate of the triangle or the point (Higham's γ(7), pbrt-v4 §6.8.1). It depends on the
/// hit triangle alone, never on the scene's size.
#[inline]
pub fn surface_offset(coord_max: f32) -> f32 {
    OFFSET_SAFETY * gamma(7) * coord_max.max(f32::MIN_POSITIVE)
}

/// A ray origin just off the surface through `p` (normal `n`, error bound `offset` along it),
/// on the side of `dir`: pbrt-v4's OffsetRayOrigin. Each coordinate is rounded away from `p`
/// so that the addition's own rounding cannot bring it back. The offset depends only on the
/// hit triangle's coordinates, never on the scene's size.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, offset: f32, dir: Vec3) -> Vec3 {
    let off = if dir.dot(n) < 0.0 {
        -n * offset
    } else {
        n * offset
    };
    let po = p + off;
    let away = |v: f32, d: f32| {
        if d > 0.0 {
            v.next_up()
        } else if d < 0.0 {
            v.next_down()
        } else {
            v
        }
    };
    Vec3::new(away(po.x, off.x), away(po.y, off.y), away(po.z, off.z))
}

/// Shadow rays stop this fraction of their length short of the light sample (pbrt-v4's
/// ShadowEpsilon): relative, so the same at every scale.
pub const SHADOW_EPSILON: f32 = 1e-4;

pub struct Scene {
    pub name: String,
    pub triangles: Vec<Triangle>,
    pub shading: Vec<TriShading>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Lights,
    pub cameras: Vec<Camera>,
    pub bounds_min: Vec3,
    pub bounds_max: Vec3,
    /// Things the loader skipped or repaired, for the user to read.
    pub warnings: Vec<String>,
    bvh: CwBvh,
}

/// What the loaders hand to [`Scene::build`].
pub(crate) struct SceneParts {
    pub name: String,
    pub triangles: Vec<Triangle>,
    pub shading: Vec<TriShading>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub punctual: Vec<Light>,
    pub cameras: Vec<Camera>,
    pub warnings: Vec<String>,
}

impl Scene {
    /// The embedded default scene (CORNELL BOX I).
    pub fn default_scene() -> Self {
        Self::from_glb_bytes(DEFAULT_SCENE_GLB, "CORNELL BOX I (embedded)")
            .expect("the embedded default scene is generated by this crate and always loads")
    }

    /// A project scene, generated in memory by `scene::builtin`.
    pub fn builtin(which: BuiltinScene) -> Self {
        Self::from_glb_bytes(&which.to_glb(), which.title()).expect("built-in scenes always load")
    }

    /// Load a .gltf or .glb file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        load::load_path(path).and_then(|parts| Self::build(parts, &path.display().to_string()))
    }

    /// Load glTF (binary or JSON with embedded buffers) from memory.
    pub fn from_glb_bytes(bytes: &[u8], name: &str) -> Result<Self, SceneError> {
        load::load_slice(bytes, name).and_then(|parts| Self::build(parts, name))
    }

    pub(crate) fn build(parts: SceneParts, source: &str) -> Result<Self, SceneError> {
        let err = |message: String| SceneError {
            source: source.to_string(),
            message,
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
        let lights = Lights::build(
            &parts.triangles,
            &parts.shading,
            &parts.materials,
            parts.punctual,
            bounds_min,
            bounds_max,
        );
        if lights.is_empty() {
            return Err(err(
                "the scene has no light: add an emissive material (emissiveFactor > 0) or a KHR_lights_punctual light".into(),
            ));
        }
        let bvh = build_cwbvh_from_tris(
            &parts.triangles,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let mut cameras = parts.cameras;
        if cameras.is_empty() {
            cameras.push(framing_camera(bounds_min, bounds_max));
        }
        Ok(Self {
            name: parts.name,
            triangles: parts.triangles,
            shading: parts.shading,
            materials: parts.materials,
            textures: parts.textures,
            lights,
            cameras,
            bounds_min,
            bounds_max,
            warnings: parts.warnings,
            bvh,
        })
    }

    pub fn diagonal(&self) -> f32 {
        (self.bounds_max - self.bounds_min).length()
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.bounds_min + self.bounds_max)
    }

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

    /// Closest hit along `origin + t·dir`, t ∈ (0, tmax).
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.intersect_except(origin, dir, tmax, u32::MAX)
    }

    /// [`Scene::intersect`] ignoring the triangle `skip`: a ray leaving a flat triangle can
    /// never meet it again, so spawned rays skip the one they leave, whatever the rounding of
    /// the ray–triangle test on a thin triangle (the offset alone bounds it for well-shaped
    /// ones only).
    #[inline]
    pub fn intersect_except(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32) -> Option<Hit> {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, tmax);
        let mut hit = RayHit::none();
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        if !self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            let t = idx[id];
            if t == skip {
                f32::INFINITY
            } else {
                tris[t as usize].intersect(r)
            }
        }) {
            return None;
        }
        let tri_id = idx[hit.primitive_id as usize];
        Some(self.hit_record(tri_id, origin + hit.t * dir, hit.t))
    }

    /// True when something blocks the open segment `origin + t·dir`, t ∈ (0, tmax).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        self.occluded_except(origin, dir, tmax, u32::MAX)
    }

    /// Whether the ray from `origin` along `dir` meets any of the triangles `tris` (by the same
    /// test the BVH traversal uses).
    pub fn meets_any(&self, origin: Vec3, dir: Vec3, tris: &[u32]) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, f32::INFINITY);
        tris.iter()
            .any(|&t| self.triangles[t as usize].intersect(&ray).is_finite())
    }

    /// [`Scene::occluded`], never counting the triangle `skip` as an occluder.
    #[inline]
    pub fn occluded_except(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, tmax);
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        !self.bvh.ray_traverse_miss(ray, |r, id| {
            let t = idx[id];
            if t == skip {
                f32::INFINITY
            } else {
                tris[t as usize].intersect(r)
            }
        })
    }

    /// True when the light sample `ls` is visible from `origin` (already offset off its
    /// surface): the shadow ray stops [`SHADOW_EPSILON`] of its length short of the sample and
    /// never counts the sampled emitter triangle itself as the occluder, so a light panel just
    /// below a ceiling lights the ceiling at any scene scale.
    #[inline]
    pub fn light_visible(&self, origin: Vec3, ls: &LightSample) -> bool {
        let tmax = ls.distance * (1.0 - SHADOW_EPSILON);
        tmax > 0.0 && !self.occluded_except(origin, ls.wi, tmax, ls.triangle)
    }

    fn hit_record(&self, tri_id: u32, p: Vec3, t: f32) -> Hit {
        let tri = &self.triangles[tri_id as usize];
        let (v0, v1, v2): (Vec3, Vec3, Vec3) = (tri.v0.into(), tri.v1.into(), tri.v2.into());
        let e1 = v1 - v0;
        let e2 = v2 - v0;
        let cross = e1.cross(e2);
        let geo_normal = cross.normalize_or(Vec3::Y);
        // Barycentrics from sub-triangle areas.
        let vp = p - v0;
        let inv = 1.0 / cross.length_squared().max(f32::MIN_POSITIVE);
        let b1 = (vp.cross(e2)).dot(cross) * inv;
        let b2 = (e1.cross(vp)).dot(cross) * inv;
        let b0 = 1.0 - b1 - b2;
        // The point on the triangle's plane from its barycentrics, with the error bound of
        // that interpolation (pbrt-v4 §6.8.5): the hit point is no more wrong than a few ulps
        // of the triangle's own coordinates.
        let p_on = v0 * b0 + v1 * b1 + v2 * b2;
        let p = if p_on.is_finite() { p_on } else { p };
        let coord_max = v0
            .abs()
            .max(v1.abs())
            .max(v2.abs())
            .max(p.abs())
            .max_element();
        let offset = surface_offset(coord_max);
        let sh = &self.shading[tri_id as usize];
        let mut normal =
            (sh.normals[0] * b0 + sh.normals[1] * b1 + sh.normals[2] * b2).normalize_or(geo_normal);
        if normal.dot(geo_normal) < 0.0 {
            normal = -normal;
        }
        let uv = sh.uvs[0] * b0 + sh.uvs[1] * b1 + sh.uvs[2] * b2;
        Hit {
            t,
            position: p,
            geo_normal,
            normal,
            uv,
            triangle: tri_id,
            material: sh.material,
            offset,
        }
    }

    /// Phong exponent of a glossy material (1 for any other).
    #[inline]
    pub fn glossy_exponent(&self, material: u32) -> f32 {
        match self.materials[material as usize].kind {
            MaterialKind::Glossy { roughness, .. } => crate::bsdf::phong_exponent(roughness),
            _ => 1.0,
        }
    }

    /// Diffuse albedo at a hit (base colour × texture).
    #[inline]
    pub fn albedo(&self, hit: &Hit) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        match &m.base_texture {
            Some(t) => {
                let uv = t.transform.transform_point2(hit.uv);
                m.base_color * self.textures[t.image].sample(uv)
            }
            None => m.base_color,
        }
    }

    /// The scattering model at a hit.
    #[inline]
    pub fn bsdf(&self, hit: &Hit) -> Bsdf {
        let m = &self.materials[hit.material as usize];
        match m.kind {
            MaterialKind::Diffuse => Bsdf::Lambert {
                albedo: self.albedo(hit),
            },
            MaterialKind::Glossy {
                roughness,
                metallic,
            } => crate::bsdf::glossy_from_pbr(self.albedo(hit), roughness, metallic),
            MaterialKind::Mirror => Bsdf::Mirror {
                color: self.albedo(hit),
            },
            MaterialKind::Dielectric { ior } => Bsdf::Dielectric {
                ior,
                tint: self.albedo(hit),
            },
        }
    }

    /// Radiance emitted from a hit towards `wo` (one-sided along the winding unless double-sided).
    #[inline]
    pub fn emitted(&self, hit: &Hit, wo: Vec3) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        if m.emission == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if m.double_sided || hit.geo_normal.dot(wo) > 0.0 {
            m.emission
        } else {
            Vec3::ZERO
        }
    }

    /// A spawn point just off the surface on the side of `dir` ([`offset_ray_origin`]).
    #[inline]
    pub fn offset(&self, hit: &Hit, dir: Vec3) -> Vec3 {
        offset_ray_origin(hit.position, hit.geo_normal, hit.offset, dir)
    }

    /// The next hit of a ray leaving `hit` along `dir`: offset off the surface and never
    /// meeting the triangle it leaves.
    #[inline]
    pub fn intersect_from(&self, hit: &Hit, dir: Vec3) -> Option<Hit> {
        self.intersect_except(self.offset(hit, dir), dir, f32::INFINITY, hit.triangle)
    }

    /// Does `dir` leave the surface of `hit` on the side it should? Reflection (`transmit`
    /// false) must stay on the side of `wo` and transmission cross to the other, judged by the
    /// geometric normal: an interpolated shading normal can send a sample through the surface,
    /// and photons, the path tracer and the eye pass all drop such samples alike.
    #[inline]
    pub fn leaves_correctly(hit: &Hit, wo: Vec3, dir: Vec3, transmit: bool) -> bool {
        let s = wo.dot(hit.geo_normal) * dir.dot(hit.geo_normal);
        if transmit { s < 0.0 } else { s > 0.0 }
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
}

/// A camera looking at the bounding box from +Z, for scenes without one.
fn framing_camera(min: Vec3, max: Vec3) -> Camera {
    let center = 0.5 * (min + max);
    let radius = 0.5 * (max - min).length();
    let yfov = 45f32.to_radians();
    let dist = radius / (0.5 * yfov).sin();
    Camera::look_at("framing", center + Vec3::new(0.0, 0.0, dist), center, yfov)
}

pub(crate) fn tri(v0: Vec3, v1: Vec3, v2: Vec3) -> Triangle {
    Triangle {
        v0: Vec3A::from(v0),
        v1: Vec3A::from(v1),
        v2: Vec3A::from(v2),
    }
}
