//! Ray queries against the scene's BVH: closest hits, occlusion, shadow rays and spawning.

use super::{
    AlphaMode, Hit, LightSample, NO_EXTRA, SHADOW_EPSILON, Scene, offset_ray_origin, surface_offset,
};
use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};
use obvhs::ray::{Ray, RayHit};

impl Scene {
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
        let (t, tri_id) = self.nearest(origin, dir, tmax, skip, true)?;
        Some(self.hit_record(tri_id, origin + t * dir, t))
    }

    /// [`Scene::intersect_except`] meeting alpha-`BLEND` surfaces whole instead of drawing
    /// their coverage: for the eye chain, which splits at them into the surface's share α and
    /// the share 1 − α passing on ([`Scene::coverage`], docs/deviations.md §61).
    #[inline]
    pub fn intersect_layers(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32) -> Option<Hit> {
        let (t, tri_id) = self.nearest(origin, dir, tmax, skip, false)?;
        Some(self.hit_record(tri_id, origin + t * dir, t))
    }

    /// The closest hit's distance and triangle, never `skip` (the BVH traversal with the
    /// alpha test, BLEND's coverage drawn when `draw_blend`; [`Scene::intersect_except`] and
    /// [`Scene::intersect_geometry`] build on it).
    #[inline]
    fn nearest(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmax: f32,
        skip: u32,
        draw_blend: bool,
    ) -> Option<(f32, u32)> {
        let ray = query(origin, dir, tmax);
        let mut hit = RayHit::none();
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        if !self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            let t = idx[id];
            if t == skip {
                f32::INFINITY
            } else {
                self.cut_out(r, t, tris[t as usize].intersect(r), draw_blend)
            }
        }) {
            return None;
        }
        Some((hit.t, idx[hit.primitive_id as usize]))
    }

    /// The first hit's distance and unit geometric normal, without the shading
    /// record [`Scene::intersect`] builds (texture reads, normal maps): for rays that only ask
    /// how far the nearest surface is and which way it faces (the visible domains' probes).
    #[inline]
    pub fn intersect_geometry(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<(f32, Vec3)> {
        let (t, tri_id) = self.nearest(origin, dir, tmax, u32::MAX, true)?;
        let tri = &self.triangles[tri_id as usize];
        let (v0, v1, v2): (Vec3, Vec3, Vec3) = (tri.v0.into(), tri.v1.into(), tri.v2.into());
        Some((t, (v1 - v0).cross(v2 - v0).normalize_or(Vec3::Y)))
    }

    /// True when something blocks the open segment `origin + t·dir`, t ∈ (0, tmax).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        self.occluded_except(origin, dir, tmax, u32::MAX)
    }

    /// Whether the open segment `origin + t·dir`, t ∈ (0, tmax), meets triangle `tri` (by the
    /// test the BVH traversal uses); false for an index out of range.
    #[inline]
    pub fn segment_meets(&self, origin: Vec3, dir: Vec3, tmax: f32, tri: u32) -> bool {
        let ray = query(origin, dir, tmax);
        self.triangles
            .get(tri as usize)
            .is_some_and(|t| self.cut_out(&ray, tri, t.intersect(&ray), true) < tmax)
    }

    /// Whether the ray from `origin` along `dir` meets any of the triangles `tris` (by the same
    /// test the BVH traversal uses).
    pub fn meets_any(&self, origin: Vec3, dir: Vec3, tris: &[u32]) -> bool {
        let ray = query(origin, dir, f32::INFINITY);
        tris.iter().any(|&t| {
            self.cut_out(&ray, t, self.triangles[t as usize].intersect(&ray), true)
                .is_finite()
        })
    }

    /// [`Scene::occluded`], never counting the triangle `skip` as an occluder.
    #[inline]
    pub fn occluded_except(&self, origin: Vec3, dir: Vec3, tmax: f32, skip: u32) -> bool {
        let ray = query(origin, dir, tmax);
        let tris = &self.triangles;
        let idx = &self.bvh.primitive_indices;
        !self.bvh.ray_traverse_miss(ray, |r, id| {
            let t = idx[id];
            if t == skip {
                f32::INFINITY
            } else {
                self.cut_out(r, t, tris[t as usize].intersect(r), true)
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
        let uv = sh.uvs[0] * b0 + sh.uvs[1] * b1 + sh.uvs[2] * b2;
        let (uv1, color, tangent) = self.extra_at(sh.extra, b0, b1, b2);
        let mut normal =
            (sh.normals[0] * b0 + sh.normals[1] * b1 + sh.normals[2] * b2).normalize_or(geo_normal);
        if let Some((tex, scale)) = &self.materials[sh.material as usize].normal_texture {
            let uv = tex
                .transform
                .transform_point2(if tex.set == 1 { uv1 } else { uv });
            let s = self.textures[tex.image].lookup(uv, tex, false).xyz() * 2.0 - 1.0;
            normal = perturbed(
                normal,
                geo_normal,
                tangent,
                s * Vec3::new(*scale, *scale, 1.0),
            );
        }
        if normal.dot(geo_normal) < 0.0 {
            normal = -normal;
        }
        Hit {
            t,
            position: p,
            geo_normal,
            normal,
            uv,
            uv1,
            color,
            triangle: tri_id,
            material: sh.material,
            offset,
        }
    }

    /// TEXCOORD_1, COLOR_0 and the tangent at barycentrics (b0, b1, b2) of a triangle whose
    /// extra vertex data is `extra` (zero, white and zero without).
    #[inline]
    fn extra_at(&self, extra: u32, b0: f32, b1: f32, b2: f32) -> (Vec2, Vec4, Vec4) {
        if extra == NO_EXTRA {
            return (Vec2::ZERO, Vec4::ONE, Vec4::ZERO);
        }
        let e = &self.extras[extra as usize];
        let tangent = (e.tangent[0] * b0 + e.tangent[1] * b1 + e.tangent[2] * b2)
            .xyz()
            .extend(e.tangent[0].w);
        (
            e.uv1[0] * b0 + e.uv1[1] * b1 + e.uv1[2] * b2,
            e.color[0] * b0 + e.color[1] * b1 + e.color[2] * b2,
            tangent,
        )
    }

    /// `t`, the distance at which ray `r` meets triangle `tri`, or infinity where the
    /// triangle's material is cut out there (glTF §3.9.4): alpha below the cutoff (`MASK`),
    /// or, for `BLEND`, a hash of the ray and the triangle at or above its alpha (stochastic
    /// coverage: a share α of rays is stopped, the rest pass; without `draw_blend` BLEND is
    /// met whole wherever its alpha is above 0).
    #[inline]
    fn cut_out(&self, r: &Ray, tri: u32, t: f32, draw_blend: bool) -> f32 {
        if !t.is_finite() || !self.has_alpha {
            return t;
        }
        let sh = &self.shading[tri as usize];
        let m = &self.materials[sh.material as usize];
        let cutoff = match m.alpha {
            AlphaMode::Opaque => return t,
            AlphaMode::Mask(cutoff) => Some(cutoff),
            AlphaMode::Blend if draw_blend => None,
            // Met whole, but never where it is wholly transparent (alpha 0: nothing to meet).
            AlphaMode::Blend => Some(f32::MIN_POSITIVE),
        };
        let tr = &self.triangles[tri as usize];
        let v0: Vec3 = tr.v0.into();
        let p = Vec3::from(r.origin) + t * Vec3::from(r.direction) - v0;
        let (b1, b2) =
            super::light::barycentrics(p, Vec3::from(tr.v1) - v0, Vec3::from(tr.v2) - v0);
        let b0 = 1.0 - b1 - b2;
        let cover = cutoff.unwrap_or_else(|| coverage_hash(r, tri, b1, b2));
        let (uv1, color, _) = self.extra_at(sh.extra, b0, b1, b2);
        let mut alpha = m.base_alpha * color.w;
        if let Some(tex) = &m.base_texture {
            let uv = sh.uvs[0] * b0 + sh.uvs[1] * b1 + sh.uvs[2] * b2;
            let uv = tex
                .transform
                .transform_point2(if tex.set == 1 { uv1 } else { uv });
            alpha *= self.textures[tex.image].lookup(uv, tex, false).w;
        }
        if alpha < cover { f32::INFINITY } else { t }
    }

    /// A spawn point just off the surface on the side of `dir` ([`offset_ray_origin`]).
    #[inline]
    pub fn offset(&self, hit: &Hit, dir: Vec3) -> Vec3 {
        offset_ray_origin(hit.position, hit.geo_normal, hit.offset, dir)
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
}

/// The shading normal `n` bent by a tangent-space normal `s` (already scaled: glTF §3.9.3,
/// normalTexture), in the frame of the interpolated `tangent` (w the bitangent's sign)
/// made orthogonal to `n`. `n` is kept where the tangent is missing or degenerate, and where
/// the bent normal would face the other side of the surface (`geo` the geometric normal).
#[inline]
pub(crate) fn perturbed(n: Vec3, geo: Vec3, tangent: Vec4, s: Vec3) -> Vec3 {
    let t = (tangent.xyz() - n * n.dot(tangent.xyz())).normalize_or_zero();
    if t == Vec3::ZERO || !s.is_finite() {
        return n;
    }
    let b = n.cross(t) * if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let bent = (t * s.x + b * s.y + n * s.z).normalize_or_zero();
    if bent.dot(geo) * n.dot(geo) > 0.0 {
        bent
    } else {
        n
    }
}

/// A uniform number in [0, 1) from where and along which direction a ray meets a triangle
/// (its barycentrics `b1`, `b2` and the ray's direction, each quantised): the same ray
/// always meets the same coverage, different rays sample it independently, and the draw does
/// not depend on the unit of length (the ray's origin, which it hashed before, changes its
/// bits when a scene is scaled; `tests/invariance.rs`).
#[inline]
fn coverage_hash(r: &Ray, tri: u32, b1: f32, b2: f32) -> f32 {
    let d = Vec3::from(r.direction);
    unit_hash(
        tri,
        [
            quantised(b1, BARYCENTRIC_CELL),
            quantised(b2, BARYCENTRIC_CELL),
            quantised(d.x, DIRECTION_CELL),
            quantised(d.y, DIRECTION_CELL),
            quantised(d.z, DIRECTION_CELL),
            0.0,
        ],
    )
}

/// Cells of the per-hit draws that must not depend on the unit of length (BLEND's coverage
/// here, partial transmission's glass in `Scene::bsdf`), as powers of two: a barycentric
/// coordinate to 2⁻¹⁰ of its triangle (a hit point's rounding moves it by some 10⁻⁶ on a
/// small triangle far from the origin, which a scaled scene rounds otherwise: 2⁻¹⁴ cells
/// changed a partly transmissive sphere's image by relMSE 0.017, `tests/invariance.rs`), a
/// unit direction's component to 2⁻¹⁴ (0.003°, far below the spread of a pixel's rays).
pub(crate) const BARYCENTRIC_CELL: u32 = 10;
pub(crate) const DIRECTION_CELL: u32 = 14;

/// `x` in [−2, 2) rounded down to a cell of 2^−`bits`, as a word for [`unit_hash`].
#[inline]
pub(crate) fn quantised(x: f32, bits: u32) -> f32 {
    f32::from_bits((((x + 2.0) * (1u32 << bits) as f32) as u32) | 1 << 30)
}

/// A uniform number in [0, 1) from a key and six floats (SplitMix64 over their bits).
#[inline]
pub(crate) fn unit_hash(key: u32, words: [f32; 6]) -> f32 {
    let mut h = (key as u64) ^ 0x9E37_79B9_7F4A_7C15;
    for x in words {
        h = (h ^ x.to_bits() as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
    }
    h = (h ^ (h >> 30)).wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// The BVH's ray for `origin + t·dir`, t ∈ (0, tmax), with every −0 component of `dir` made
/// +0: obvhs's traversal misses everything along a direction such as (−0, −1, −0), which
/// `-Vec3::Y` is (adding +0 turns −0 into +0 and leaves every other value alone).
#[inline]
fn query(origin: Vec3, dir: Vec3, tmax: f32) -> Ray {
    Ray::new(origin.into(), (dir + Vec3::ZERO).into(), 0.0, tmax)
}
