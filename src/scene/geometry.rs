//! Hit records, per-triangle shading data, and spawn offsets that keep rays off their surface
//! at any scene scale (pbrt-v4 §6.8).

use glam::{Vec2, Vec3, Vec3A, Vec4};
use obvhs::triangle::Triangle;

/// Per-triangle shading data (vertex normals and texture coordinates).
#[derive(Clone, Copy, Debug)]
pub struct TriShading {
    /// Unit vertex normals (the face normal where the mesh has none).
    pub normals: [Vec3; 3],
    /// Vertex texture coordinates (TEXCOORD_0; zero where the mesh has none).
    pub uvs: [Vec2; 3],
    /// Index into [`Scene::materials`](super::Scene::materials).
    pub material: u32,
    /// Index into [`Scene::extras`](super::Scene::extras) when the triangle has vertex data
    /// beyond these (`NO_EXTRA` otherwise).
    pub extra: u32,
}

/// [`TriShading::extra`] of a triangle with no further vertex data.
pub const NO_EXTRA: u32 = u32::MAX;

/// Vertex data only some triangles have (kept apart so that the rest stay small):
/// TEXCOORD_1, COLOR_0 and tangents for normal mapping.
#[derive(Clone, Copy, Debug)]
pub struct TriExtra {
    /// TEXCOORD_1 (zero where the mesh has none).
    pub uv1: [Vec2; 3],
    /// COLOR_0 as linear RGBA (white where the mesh has none).
    pub color: [Vec4; 3],
    /// Tangents (xyz unit, w the bitangent's sign: glTF §3.7.2.1), the file's TANGENT or
    /// computed from the normal texture's coordinates; zero without a normal texture.
    pub tangent: [Vec4; 3],
}

/// A ray–surface intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter of the hit (distance, for a unit direction).
    pub t: f32,
    /// The hit point, recomputed on the triangle's plane from its barycentrics.
    pub position: Vec3,
    /// Geometric normal from the winding (unit, not flipped towards the ray).
    pub geo_normal: Vec3,
    /// Shading normal (interpolated, then perturbed by the material's normal texture), on
    /// the same side as `geo_normal`.
    pub normal: Vec3,
    /// Interpolated texture coordinates (TEXCOORD_0).
    pub uv: Vec2,
    /// Interpolated TEXCOORD_1 (zero where the mesh has none).
    pub uv1: Vec2,
    /// Interpolated COLOR_0 (linear RGBA; white where the mesh has none).
    pub color: Vec4,
    /// Index of the triangle hit.
    pub triangle: u32,
    /// Its material index.
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

pub(crate) fn tri(v0: Vec3, v1: Vec3, v2: Vec3) -> Triangle {
    Triangle {
        v0: Vec3A::from(v0),
        v1: Vec3A::from(v1),
        v2: Vec3A::from(v2),
    }
}
