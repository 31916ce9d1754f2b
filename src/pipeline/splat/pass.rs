//! The splat pass (§7.2): every prepared photon ray into every subtree it reaches, 8 lanes at a
//! time, with AVX2 chosen once per subtree.

use super::{RayDirection, SplatBatch, SplatCounters, SplatRay, test_sample};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::radiance_map::{AccView, AccumChunk, Accumulators, Channel, NO_RECORD};
use crate::pipeline::splat_tree::{LANES, PointChunk, SplatTree, Subtree, sphere_in_cone};
use glam::Vec3;
use rayon::prelude::*;

/// Splat `batch` into `acc` (slot order). Parallel over the tree's subtrees, each owning a
/// disjoint range of slots; a tree with too few subtrees to keep the threads busy (a radiance
/// cache pass splats onto a few hundred records) is splatted in parallel over fixed chunks of
/// rays instead, each into its own accumulators, summed in chunk order. Either way the result
/// does not depend on the number of threads.
pub fn splat(tree: &SplatTree, batch: &SplatBatch, acc: &mut Accumulators) -> SplatCounters {
    assert_eq!(acc.len(), tree.slots());
    // Without directions (diffuse mode, or rays prepared without them) nothing directional is
    // deposited.
    let mode = if batch.directions.len() == batch.rays.len() {
        acc.mode
    } else {
        DirectionalMode::Diffuse
    };
    let (rays, dirs) = (&batch.rays[..], &batch.directions[..]);
    // At most 8 parts, each with its own zeroed accumulators: the part size follows the ray
    // count only, never the thread count, so the sums do not depend on the threads.
    const MIN_CHUNK: usize = 4096;
    if tree.subtrees.len() < 4 && rays.len() > 2 * MIN_CHUNK && acc.len() <= 1 << 16 {
        let chunk = rays.len().div_ceil(8).max(MIN_CHUNK);
        let parts: Vec<(Accumulators, SplatCounters)> = rays
            .par_chunks(chunk)
            .enumerate()
            .map(|(k, part)| {
                let chunk_len = chunk;
                let mut local = acc.zeroed();
                let d = if mode == DirectionalMode::Diffuse {
                    &dirs[..0]
                } else {
                    &dirs[k * chunk_len..k * chunk_len + part.len()]
                };
                let c = splat_into(tree, part, d, &mut local, mode, false);
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
    splat_into(tree, rays, dirs, acc, mode, true)
}

fn splat_into(
    tree: &SplatTree,
    rays: &[SplatRay],
    dirs: &[RayDirection],
    acc: &mut Accumulators,
    mode: DirectionalMode,
    parallel: bool,
) -> SplatCounters {
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
            .map(|(st, view)| splat_subtree(tree, st, rays, dirs, view, mode))
            .reduce(SplatCounters::default, sum)
    } else {
        tree.subtrees
            .iter()
            .zip(views)
            .map(|(st, view)| splat_subtree(tree, st, rays, dirs, view, mode))
            .fold(SplatCounters::default(), sum)
    }
}

fn splat_subtree(
    tree: &SplatTree,
    st: &Subtree,
    rays: &[SplatRay],
    dirs: &[RayDirection],
    acc: AccView,
    mode: DirectionalMode,
) -> SplatCounters {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { splat_subtree_avx2(tree, st, rays, dirs, acc, mode) };
        }
    }
    splat_subtree_impl(tree, st, rays, dirs, acc, mode)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn splat_subtree_avx2(
    tree: &SplatTree,
    st: &Subtree,
    rays: &[SplatRay],
    dirs: &[RayDirection],
    acc: AccView,
    mode: DirectionalMode,
) -> SplatCounters {
    splat_subtree_impl(tree, st, rays, dirs, acc, mode)
}

#[inline(always)]
fn splat_subtree_impl(
    tree: &SplatTree,
    st: &Subtree,
    rays: &[SplatRay],
    dirs: &[RayDirection],
    acc: AccView,
    mode: DirectionalMode,
) -> SplatCounters {
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
                    let (w, accepted) =
                        splat_lanes(ray, &tree.points.chunks[k], &mut acc.chunks[k - base]);
                    c.accepted += accepted as u64;
                    if accepted > 0
                        && mode != DirectionalMode::Diffuse
                        && acc.chunk_has_record[k - base]
                    {
                        let lane0 = (k - base) * LANES;
                        deposit_directional(
                            ray.power,
                            &dirs[ri],
                            &w,
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

/// Test and accumulate one chunk of 8 slots; returns the lanes' splat weights K·cos θ
/// (zero where infeasible) and the number of feasible samples.
#[inline(always)]
fn splat_lanes(ray: &SplatRay, pts: &PointChunk, acc: &mut AccumChunk) -> ([f32; LANES], u32) {
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
    (w, hit.iter().sum::<f32>() as u32)
}
