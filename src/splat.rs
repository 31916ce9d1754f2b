//! Photon ray splatting (§4, §5, §7.2): each photon ray deposits its power, through a 2D
//! Epanechnikov kernel perpendicular to the ray, onto the feasible eye samples in its conical
//! frustum, weighted by cos θ at the sample.

use crate::photon::{Bandwidth, PhotonRay};
use crate::radiance_map::SplatAccum;
use crate::splat_tree::{Cone, SplatTree};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use std::f32::consts::PI;

/// 2D Epanechnikov kernel normalised over the disc of radius h (§6):
/// K_h(d) = 2/(πh²)·(1 − d²/h²) for d < h. Takes d² and h².
#[inline(always)]
pub fn epanechnikov(d2: f32, h2: f32) -> f32 {
    if d2 >= h2 {
        0.0
    } else {
        2.0 / (PI * h2) * (1.0 - d2 / h2)
    }
}

/// A photon ray ready to splat: its cone from the current bandwidth (§6) and its power.
#[derive(Clone, Copy, Debug)]
pub struct SplatRay {
    pub cone: Cone,
    pub power: Vec3A,
    pub origin_normal: Vec3A,
    pub bounds_min: Vec3A,
    pub bounds_max: Vec3A,
}

impl SplatRay {
    pub fn new(ray: &PhotonRay, bw: &Bandwidth) -> Self {
        let (h0, dh) = bw.cone(ray);
        let cone = Cone {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
            length: ray.length,
            h0,
            dh,
            h_end: h0 + dh * ray.length,
        };
        let (bounds_min, bounds_max) = cone.bounds();
        Self {
            cone,
            power: ray.power.into(),
            origin_normal: ray.origin_normal.into(),
            bounds_min,
            bounds_max,
        }
    }
}

/// Prepare rays of the classes selected by `splat_class` with per-class bandwidths.
pub fn prepare(
    rays: &[PhotonRay],
    bandwidths: &[Bandwidth; 3],
    splat_class: [bool; 3],
) -> Vec<SplatRay> {
    rays.par_iter()
        .filter(|r| splat_class[r.class as usize])
        .map(|r| SplatRay::new(r, &bandwidths[r.class as usize]))
        .collect()
}

/// Counters of one splat pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SplatCounters {
    /// Eye samples tested for feasibility (in visited leaves).
    pub tested: u64,
    /// Eye samples that received energy.
    pub accepted: u64,
}

impl std::ops::AddAssign for SplatCounters {
    fn add_assign(&mut self, o: Self) {
        self.tested += o.tested;
        self.accepted += o.accepted;
    }
}

/// Splat `rays` into `acc` (one accumulator per eye sample, tree order). Parallel over the
/// tree's subtrees, each owning a disjoint slice of `acc`.
pub fn splat(tree: &SplatTree, rays: &[SplatRay], acc: &mut [SplatAccum]) -> SplatCounters {
    assert_eq!(acc.len(), tree.points.len());
    // Cut `acc` into the subtrees' disjoint ranges (subtrees are in sample order).
    let mut slices = Vec::with_capacity(tree.subtrees.len());
    let mut rest = acc;
    let mut at = 0usize;
    for st in &tree.subtrees {
        let (_, tail) = rest.split_at_mut(st.first as usize - at);
        let (mine, tail) = tail.split_at_mut(st.count as usize);
        slices.push((st, mine));
        rest = tail;
        at = (st.first + st.count) as usize;
    }
    slices
        .into_par_iter()
        .map(|(st, acc)| {
            let mut c = SplatCounters::default();
            let first = st.first as usize;
            for ray in rays {
                if ray.bounds_max.cmplt(st.min).any() || ray.bounds_min.cmpgt(st.max).any() {
                    continue;
                }
                tree.traverse(st, &ray.cone, |lo, n| {
                    c.tested += n as u64;
                    for i in lo..lo + n {
                        let p = &tree.points[i];
                        if let Some((w, h, dist)) = feasible_weight(ray, p.position, p.normal) {
                            let a = &mut acc[i - first];
                            a.flux += Vec3::from(ray.power) * w;
                            a.weight += w;
                            a.weighted_h += w * h;
                            a.weighted_inv_dist += w / dist.max(1e-6);
                            a.count += 1;
                            c.accepted += 1;
                        }
                    }
                });
            }
            c
        })
        .reduce(SplatCounters::default, |mut a, b| {
            a += b;
            a
        })
}

/// Feasibility (§7.2) and kernel weight of one eye sample for one photon ray.
/// Returns (K·cos θ, splat radius, distance to the ray origin).
#[inline(always)]
pub fn feasible_weight(ray: &SplatRay, p: Vec3A, n: Vec3A) -> Option<(f32, f32, f32)> {
    let cone = &ray.cone;
    let v = p - cone.origin;
    let t = v.dot(cone.dir);
    if t < 0.0 || t > cone.length + cone.h_end {
        return None;
    }
    let r = cone.radius(t);
    let vv = v.length_squared();
    let d2 = vv - t * t; // squared distance to the ray line
    let r2 = r * r;
    if d2 >= r2 {
        return None;
    }
    // Beyond the photon's hit point the footprint is a hemisphere around it (Fig. 4).
    if t > cone.length {
        let e = v - cone.dir * cone.length;
        if e.length_squared() >= r2 {
            return None;
        }
    }
    // The eye sample's normal must face the ray ...
    let cos = -n.dot(cone.dir);
    if cos <= 0.0 {
        return None;
    }
    // ... and the sample must lie in front of the surface the ray leaves.
    if v.dot(ray.origin_normal) < 0.0 {
        return None;
    }
    // §5: 2D kernel perpendicular to the ray times cos θ at the eye sample (eq. 5).
    let w = epanechnikov(d2.max(0.0), r2) * cos;
    Some((w, r, vv.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epanechnikov_integrates_to_one_over_the_disc() {
        // ∫_0^h K(r) 2πr dr by the midpoint rule.
        for h in [0.01f32, 0.5, 3.0] {
            let n = 100_000;
            let dr = h / n as f32;
            let mut sum = 0.0f64;
            for i in 0..n {
                let r = (i as f32 + 0.5) * dr;
                sum += (epanechnikov(r * r, h * h) * 2.0 * PI * r * dr) as f64;
            }
            assert!((sum - 1.0).abs() < 1e-4, "h = {h}: {sum}");
        }
    }

    #[test]
    fn kernel_is_zero_outside() {
        assert_eq!(epanechnikov(1.0, 1.0), 0.0);
        assert_eq!(epanechnikov(2.0, 1.0), 0.0);
        assert!(epanechnikov(0.0, 1.0) > 0.0);
    }
}
