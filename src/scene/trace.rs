//! Ray queries against the scene's BVH: closest hits, occlusion, shadow rays and spawning.

use super::{Hit, LightSample, SHADOW_EPSILON, Scene, offset_ray_origin, surface_offset};
use glam::Vec3;
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

    /// Whether the open segment `origin + t·dir`, t ∈ (0, tmax), meets triangle `tri` (by the
    /// test the BVH traversal uses); false for an index out of range.
    #[inline]
    pub fn segment_meets(&self, origin: Vec3, dir: Vec3, tmax: f32, tri: u32) -> bool {
        let ray = Ray::new(origin.into(), dir.into(), 0.0, tmax);
        self.triangles
            .get(tri as usize)
            .is_some_and(|t| t.intersect(&ray) < tmax)
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
