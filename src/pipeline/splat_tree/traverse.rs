//! The conical-frustum traversal of the splat tree (§7.2, Alg. 1) and its geometric tests.

use super::node::{KIND_CULL, KIND_INTERIOR, KIND_LEAF};
use super::{Cone, STACK, SplatTree, Subtree};
use glam::Vec3A;

impl SplatTree {
    /// Collect every leaf of `subtree` the cone may reach into `out` as (first slot, count)
    /// (Alg. 1, iterative, near child first). `out` is cleared first; reuse it across rays.
    #[inline(always)]
    pub fn traverse(&self, subtree: &Subtree, cone: &Cone, out: &mut Vec<(u32, u32)>) {
        out.clear();
        // Clip the ray against the subtree's bounds grown by the largest splat radius (§7.2).
        let grow = Vec3A::splat(cone.h_end);
        let Some((t0, t1)) = clip(
            cone.origin,
            cone.dir,
            subtree.min - grow,
            subtree.max + grow,
            0.0,
            cone.length + cone.h_end,
        ) else {
            return;
        };
        let inv_dir = Vec3A::ONE / cone.dir;
        let mut stack = [(0u32, 0f32, 0f32); STACK];
        let mut sp = 0;
        let (mut idx, mut t0, mut t1) = (subtree.root as usize, t0, t1);
        loop {
            let node = self.nodes[idx];
            let mut descend = false;
            match node.kind() {
                KIND_INTERIOR => {
                    let a = node.axis();
                    // Splat radius at t1, the largest on [t0, t1] (Alg. 1: R1).
                    let r1 = (cone.h0 + cone.dh * t1).min(cone.h_end);
                    let (o, inv) = (cone.origin[a], inv_dir[a]);
                    let split = node.split();
                    let (left, right) = (idx + 1, node.right());
                    if inv.is_finite() && inv.abs() < 1e9 {
                        // Distances to the virtual planes split ± r1 (Alg. 1: tα, tβ).
                        let t = (split - o) * inv;
                        let dt = r1 * inv.abs();
                        let (near, far) = if inv > 0.0 {
                            (left, right)
                        } else {
                            (right, left)
                        };
                        let near_end = t1.min(t + dt);
                        let far_start = t0.max(t - dt);
                        if far_start <= t1 {
                            stack[sp] = (far as u32, far_start, t1);
                            sp += 1;
                        }
                        if t0 <= near_end {
                            idx = near;
                            t1 = near_end;
                            descend = true;
                        }
                    } else {
                        // The ray runs parallel to the plane.
                        let go_left = o - r1 <= split;
                        let go_right = o + r1 >= split;
                        if go_left && go_right {
                            stack[sp] = (right as u32, t0, t1);
                            sp += 1;
                        }
                        if go_left || go_right {
                            idx = if go_left { left } else { right };
                            descend = true;
                        }
                    }
                }
                KIND_LEAF => {
                    let lf = &self.leaves[node.leaf_index()];
                    // Bounding-sphere test: skip leaves the cone cannot reach.
                    if sphere_in_cone(cone, lf.center, lf.radius) {
                        out.push((lf.first, node.count() as u32));
                    }
                }
                // Cull node: every sample below faces away from rays with dir·n > C_max (§7.1).
                KIND_CULL if cone.dir.dot(node.normal()) <= node.cmax() => {
                    idx += 1;
                    descend = true;
                }
                _ => {}
            }
            if !descend {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (i, a, b) = stack[sp];
                (idx, t0, t1) = (i as usize, a, b);
            }
        }
    }
}

/// Could the cone reach a point within `radius` of `center`? (Conservative: the radius is
/// taken at the sphere's far end along the ray.)
#[inline(always)]
pub fn sphere_in_cone(cone: &Cone, center: Vec3A, radius: f32) -> bool {
    let v = center - cone.origin;
    let t = v.dot(cone.dir);
    let dist2 = (v.length_squared() - t * t).max(0.0);
    let reach = (cone.h0 + cone.dh * (t + radius)).min(cone.h_end) + radius;
    t + radius >= 0.0 && t - radius <= cone.length + cone.h_end && dist2 < reach * reach
}

/// Ray/box clipping (slab test) restricted to [tmin, tmax].
#[inline]
pub fn clip(
    o: Vec3A,
    d: Vec3A,
    min: Vec3A,
    max: Vec3A,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (tmin, tmax);
    for a in 0..3 {
        if d[a].abs() < 1e-12 {
            if o[a] < min[a] || o[a] > max[a] {
                return None;
            }
        } else {
            let inv = 1.0 / d[a];
            let (mut ta, mut tb) = ((min[a] - o[a]) * inv, (max[a] - o[a]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((t0, t1))
}
