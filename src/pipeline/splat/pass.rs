//! The splat pass (§7.2): every prepared photon ray into every subtree it reaches, 8 lanes at a
//! time, with AVX2 chosen once per subtree.

use super::{RayDirection, SplatBatch, SplatCounters, SplatRay, test_sample};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::radiance_map::{AccView, AccumChunk, Accumulators, Channel, NO_RECORD};
use crate::pipeline::splat_tree::{
    BLOCKERS, BlockerChunk, LANES, PointChunk, SplatTree, Subtree, sphere_in_cone,
};
use crate::scene::{SHADOW_EPSILON, Scene, offset_ray_origin, surface_offset};
use glam::Vec3;
use rayon::prelude::*;

/// Splat `batch` into `acc` (slot order). With `scene`, and a tree that knows its targets'
/// blocker planes ([`SplatTree::find_blockers`]), a pair whose nearest ray point lies behind
/// one of them is splatted only if a shadow ray finds that point visible. Parallel over the
/// tree's subtrees, each owning a disjoint range of slots; a tree with too few subtrees to keep the threads busy (a radiance
/// cache pass splats onto a few hundred records) is splatted in parallel over fixed chunks of
/// rays instead, each into its own accumulators, summed in chunk order. Either way the result
/// does not depend on the number of threads.
pub fn splat(
    tree: &SplatTree,
    batch: &SplatBatch,
    acc: &mut Accumulators,
    scene: Option<&Scene>,
) -> SplatCounters {
    let scene = scene.filter(|_| tree.has_blockers());
    assert_eq!(acc.len(), tree.slots());
    // Without directions (diffuse mode, or rays prepared without them) nothing directional is
    // deposited.
    let mode = if batch.directions.len() == batch.rays.len() {
        acc.mode
    } else {
        DirectionalMode::Diffuse
    };
    let (rays, dirs) = (&batch.rays[..], &batch.directions[..]);
    let job = |rays, dirs| Job {
        tree,
        rays,
        dirs,
        mode,
        scene,
    };
    // At most 8 parts, each with its own zeroed accumulators: the part size follows the ray
    // count only, never the thread count, so the sums do not depend on the threads.
    const MIN_CHUNK: usize = 4096;
    if tree.subtrees.len() < 4 && rays.len() > 2 * MIN_CHUNK && acc.len() <= 1 << 16 {
        let chunk = rays.len().div_ceil(8).max(MIN_CHUNK);
        let parts: Vec<(Accumulators, SplatCounters)> = rays
            .par_chunks(chunk)
            .enumerate()
            .map(|(k, part)| {
                let mut local = acc.zeroed();
                let d = if mode == DirectionalMode::Diffuse {
                    &dirs[..0]
                } else {
                    &dirs[k * chunk..k * chunk + part.len()]
                };
                let c = splat_into(&job(part, d), &mut local, false);
                (local, c)
            })
            .collect();
        let mut counters = SplatCounters::default();
        for (part, c) in parts {
            acc.add(&part);
            counters += c;
        }
        return counters;
    }
    splat_into(&job(rays, dirs), acc, true)
}

/// What every subtree of one splat pass shares: the tree, the rays (with their directions when
/// the radiance map keeps them), the directional mode and the scene for the visibility test.
struct Job<'a> {
    tree: &'a SplatTree,
    rays: &'a [SplatRay],
    dirs: &'a [RayDirection],
    mode: DirectionalMode,
    scene: Option<&'a Scene>,
}

fn splat_into(job: &Job, acc: &mut Accumulators, parallel: bool) -> SplatCounters {
    let tree = job.tree;
    let views = acc.split(
        tree.subtrees
            .iter()
            .map(|s| (s.first as usize, s.len as usize)),
    );
    let sum = |a: SplatCounters, b: SplatCounters| {
        let mut a = a;
        a += b;
        a
    };
    if parallel {
        tree.subtrees
            .par_iter()
            .zip(views)
            .map(|(st, view)| splat_subtree(job, st, view))
            .reduce(SplatCounters::default, sum)
    } else {
        tree.subtrees
            .iter()
            .zip(views)
            .map(|(st, view)| splat_subtree(job, st, view))
            .fold(SplatCounters::default(), sum)
    }
}

fn splat_subtree(job: &Job, st: &Subtree, acc: AccView) -> SplatCounters {
    // The visibility test is a separate instance of the loop: without it the loop is the one
    // before §40 (sharing one instance with a runtime test cost 12% of T_S).
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe {
                match job.scene {
                    Some(_) => splat_subtree_avx2::<true>(job, st, acc),
                    None => splat_subtree_avx2::<false>(job, st, acc),
                }
            };
        }
    }
    match job.scene {
        Some(_) => splat_subtree_impl::<true>(job, st, acc),
        None => splat_subtree_impl::<false>(job, st, acc),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn splat_subtree_avx2<const VIS: bool>(job: &Job, st: &Subtree, acc: AccView) -> SplatCounters {
    splat_subtree_impl::<VIS>(job, st, acc)
}

#[inline(always)]
fn splat_subtree_impl<const VIS: bool>(job: &Job, st: &Subtree, acc: AccView) -> SplatCounters {
    let Job {
        tree,
        rays,
        dirs,
        mode,
        scene,
    } = *job;
    let mut c = SplatCounters::default();
    let base = st.first as usize / LANES;
    // Reused for every ray of this subtree: no allocation per photon.
    let mut leaves = Vec::with_capacity(4096);
    for (ri, ray) in rays.iter().enumerate() {
        if ray.bounds_max.cmplt(st.min).any() || ray.bounds_min.cmpgt(st.max).any() {
            continue;
        }
        tree.traverse(st, &ray.cone, &mut leaves);
        for &(first, count) in &leaves {
            let (first, end) = (first as usize, (first + count) as usize);
            let mut slot = first;
            while slot < end {
                // Skip whole chunks outside the cone before testing their lanes.
                let k = slot / LANES;
                let chunk = &tree.chunks[k];
                if sphere_in_cone(&ray.cone, chunk.center, chunk.radius) {
                    c.tested += (end - slot).min(LANES) as u64;
                    let vis = if VIS {
                        scene.map(|s| (&tree.blockers[k], s))
                    } else {
                        None
                    };
                    let lanes =
                        splat_lanes(ray, &tree.points.chunks[k], vis, &mut acc.chunks[k - base]);
                    c.accepted += lanes.accepted as u64;
                    c.shadow_tests += lanes.shadow_tests as u64;
                    c.occluded += lanes.occluded as u64;
                    if lanes.accepted > 0
                        && mode != DirectionalMode::Diffuse
                        && acc.chunk_has_record[k - base]
                    {
                        let lane0 = (k - base) * LANES;
                        deposit_directional(
                            ray.power,
                            &dirs[ri],
                            &lanes.weights,
                            &acc.slot_record[lane0..lane0 + LANES],
                            acc.first_record,
                            acc.records,
                            mode,
                        );
                    }
                }
                slot += LANES;
            }
        }
    }
    c
}

/// Add a splat's weighted power to the directional records of the glossy lanes of a chunk
/// (§8.1): in SH mode projected onto the basis, in histogram mode into the filter's strata.
#[inline(always)]
fn deposit_directional(
    power: Vec3,
    dir: &RayDirection,
    w: &[f32; LANES],
    lane_record: &[u32],
    first_record: u32,
    records: &mut [f32],
    mode: DirectionalMode,
) {
    let f = mode.record_floats();
    for l in 0..LANES {
        let r = lane_record[l];
        if r == NO_RECORD || w[l] <= 0.0 {
            continue;
        }
        let at = (r - first_record) as usize * f;
        dir.deposit(&mut records[at..at + f], power * w[l], mode);
    }
}

/// What splatting one ray onto one chunk of 8 slots gave.
struct LaneSplat {
    /// The lanes' splat weights K·cos θ (zero where infeasible).
    weights: [f32; LANES],
    /// Feasible lanes.
    accepted: u32,
    /// Shadow rays traced (with the visibility test).
    shadow_tests: u32,
    /// Of those, the ones found blocked.
    occluded: u32,
}

/// Test and accumulate one chunk of 8 slots, with the shadow rays of the visibility test when
/// `vis` gives the chunk's blocker planes.
#[inline(always)]
fn splat_lanes(
    ray: &SplatRay,
    pts: &PointChunk,
    vis: Option<(&BlockerChunk, &Scene)>,
    acc: &mut AccumChunk,
) -> LaneSplat {
    let mut w = [0.0f32; LANES];
    let mut wr = [0.0f32; LANES];
    let mut wd = [0.0f32; LANES];
    let mut hit = [0.0f32; LANES];
    for l in 0..LANES {
        let r = test_sample(
            ray,
            Vec3::new(pts.px[l], pts.py[l], pts.pz[l]),
            Vec3::new(pts.nx[l], pts.ny[l], pts.nz[l]),
        );
        w[l] = r.weight;
        wr[l] = r.weight * r.radius;
        wd[l] = r.weight * r.inv_dist;
        hit[l] = if r.feasible { 1.0 } else { 0.0 };
    }
    let shadow = match vis {
        Some((blockers, scene)) if hit.iter().any(|&h| h > 0.0) => occlude(
            ray,
            pts,
            blockers,
            scene,
            [&mut w, &mut wr, &mut wd, &mut hit],
        ),
        _ => (0, 0),
    };
    let p = ray.power;
    let ch = &mut acc.ch;
    for l in 0..LANES {
        ch[Channel::R as usize][l] += w[l] * p.x;
        ch[Channel::G as usize][l] += w[l] * p.y;
        ch[Channel::B as usize][l] += w[l] * p.z;
        ch[Channel::Weight as usize][l] += w[l];
        ch[Channel::WeightedH as usize][l] += wr[l];
        ch[Channel::WeightedInvDist as usize][l] += wd[l];
        ch[Channel::Count as usize][l] += hit[l];
    }
    LaneSplat {
        weights: w,
        accepted: hit.iter().sum::<f32>() as u32,
        shadow_tests: shadow.0,
        occluded: shadow.1,
    }
}

/// Shadow rays run parallel to the segment from the target to the photon ray's nearest point,
/// this fraction of its length above the target's surface.
const SHADOW_LIFT: f32 = 0.01;

/// Partial visibility (docs/deviations.md §40): the point of the ray segment nearest to each
/// splatted lane's target is tested against the target's blocker planes; where it lies behind
/// one (by more than 0.1% of the splat radius), a shadow ray from the target to it decides, and
/// a blocked pair splats nothing: its lanes of `sums` (weight, weight·radius, weight/distance,
/// hit) are zeroed. Returns the shadow rays traced and those found blocked. Kept out of line:
/// inlined, it slowed the splat loop without visibility by 12% (T_S 2.05 → 2.31 s on
/// `builtin:glossy-sharp`).
#[inline(never)]
fn occlude(
    ray: &SplatRay,
    pts: &PointChunk,
    b: &BlockerChunk,
    scene: &Scene,
    mut sums: [&mut [f32; LANES]; 4],
) -> (u32, u32) {
    let c = &ray.cone;
    let (o, d) = (c.origin, c.dir);
    // Which plane each lane lies behind, or BLOCKERS for none.
    let mut behind = [BLOCKERS; LANES];
    // The ray's point nearest to each lane's target.
    let mut q = [Vec3::ZERO; LANES];
    for l in 0..LANES {
        let (vx, vy, vz) = (pts.px[l] - o.x, pts.py[l] - o.y, pts.pz[l] - o.z);
        let t = (vx * d.x + vy * d.y + vz * d.z).clamp(0.0, c.length);
        let (qx, qy, qz) = (o.x + d.x * t, o.y + d.y * t, o.z + d.z * t);
        q[l] = Vec3::new(qx, qy, qz);
        // The splat radius, from weight·radius where the lane splats (others are skipped).
        let w = sums[0][l];
        let tol = -1e-3 * sums[1][l] / w.max(f32::MIN_POSITIVE);
        for (j, pl) in b.plane.iter().enumerate().rev() {
            let s = pl[0][l] * qx + pl[1][l] * qy + pl[2][l] * qz - pl[3][l];
            if (w > 0.0) & (s < tol) {
                behind[l] = j;
            }
        }
    }
    if behind.iter().all(|&j| j == BLOCKERS) {
        return (0, 0);
    }
    let (mut traced, mut blocked) = (0, 0);
    for l in (0..LANES).filter(|&l| behind[l] < BLOCKERS) {
        let p = Vec3::new(pts.px[l], pts.py[l], pts.pz[l]);
        let n = Vec3::new(b.own[0][l], b.own[1][l], b.own[2][l]);
        let v = q[l] - p;
        let dist = v.length();
        if dist.is_nan() || dist <= 0.0 {
            continue;
        }
        // Both ends lifted off the target's surface by 1% of their distance: a wall standing
        // on the target's floor meets that floor exactly at its edge, where a ray along the
        // floor could slip under it.
        let lift = n * (SHADOW_LIFT * dist);
        let dir = v / dist;
        let origin = offset_ray_origin(p + lift, n, surface_offset(p.abs().max_element()), dir);
        traced += 1;
        let tmax = dist * (1.0 - SHADOW_EPSILON);
        // The blocker's own triangle first: it settles a quarter of the blocked pairs on the
        // apartment without the BVH.
        let tri = b.triangle[behind[l]][l];
        if scene.segment_meets(origin, dir, tmax, tri) || scene.occluded(origin, dir, tmax) {
            blocked += 1;
            for x in sums.iter_mut() {
                x[l] = 0.0;
            }
        }
    }
    (traced, blocked)
}
