//! The splat pass (§7.2): every prepared photon ray into every subtree it reaches, 8 lanes at a
//! time, with AVX2 chosen once per subtree.

use super::{RayDirection, SplatBatch, SplatCounters, SplatRay, test_sample};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::radiance_map::{AccView, AccumChunk, Accumulators, Channel, NO_RECORD};
use crate::pipeline::splat_tree::{
    DomainChunk, LANES, PROBES, PointChunk, SplatTree, Subtree, cell_index, free_distance,
    share_from_row, share_position, sphere_in_cone,
};
use crate::sampling::onb;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Splat `batch` into `acc` (slot order). With `scene`, and a tree that knows its targets'
/// visible domains ([`SplatTree::probe_domains`]), each kernel is kept to the part of its
/// footprint its target sees and renormalised over it ([`visible_domain`]). Parallel over the
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
    splat_marking(tree, batch, acc, scene, &[])
}

/// [`splat`], setting `reached[i]` for each ray i of the batch that splatted onto at least
/// one target (an empty `reached` marks nothing): the emission guide's feedback
/// (docs/deviations.md §44). The flags do not depend on the number of threads.
pub(super) fn splat_marking(
    tree: &SplatTree,
    batch: &SplatBatch,
    acc: &mut Accumulators,
    scene: Option<&Scene>,
    reached: &[AtomicBool],
) -> SplatCounters {
    let reached = if reached.len() == batch.rays.len() {
        reached
    } else {
        &[]
    };
    let scene = scene.filter(|_| tree.has_domains());
    assert_eq!(acc.len(), tree.slots());
    // Without directions (diffuse mode, or rays prepared without them) nothing directional is
    // deposited.
    let mode = if batch.directions.len() == batch.rays.len() {
        acc.mode
    } else {
        DirectionalMode::Diffuse
    };
    let (rays, dirs) = (&batch.rays[..], &batch.directions[..]);
    let job = |rays, dirs, reached| Job {
        tree,
        rays,
        dirs,
        mode,
        scene,
        reached,
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
                let r = if reached.is_empty() {
                    reached
                } else {
                    &reached[k * chunk..k * chunk + part.len()]
                };
                let c = splat_into(&job(part, d, r), &mut local, false);
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
    splat_into(&job(rays, dirs, reached), acc, true)
}

/// What every subtree of one splat pass shares: the tree, the rays (with their directions when
/// the radiance map keeps them), the directional mode and the scene for the visibility test.
struct Job<'a> {
    tree: &'a SplatTree,
    rays: &'a [SplatRay],
    dirs: &'a [RayDirection],
    mode: DirectionalMode,
    scene: Option<&'a Scene>,
    /// One flag per ray, set where it splatted onto a target (empty: none kept).
    reached: &'a [AtomicBool],
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
        reached,
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
        let mut any = false;
        for &(first, count) in &leaves {
            let (first, end) = (first as usize, (first + count) as usize);
            let mut slot = first;
            while slot < end {
                // Skip whole chunks outside the cone before testing their lanes.
                let k = slot / LANES;
                let chunk = &tree.chunks[k];
                if sphere_in_cone(&ray.cone, chunk.center, chunk.radius) {
                    c.tested += (end - slot).min(LANES) as u64;
                    let vis = if VIS && scene.is_some() {
                        Some(&tree.domains[k])
                    } else {
                        None
                    };
                    let lanes =
                        splat_lanes(ray, &tree.points.chunks[k], vis, &mut acc.chunks[k - base]);
                    c.accepted += lanes.accepted as u64;
                    c.domain_tests += lanes.domain_tests as u64;
                    c.occluded += lanes.occluded as u64;
                    any |= lanes.accepted > 0;
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
        if any && let Some(flag) = reached.get(ri) {
            flag.store(true, Ordering::Relaxed);
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
    /// Feasible pairs near a wall ([`near_walls`]), tested against their target's visible
    /// domain cell by cell.
    domain_tests: u32,
    /// Of those, the ones outside it (splatting nothing).
    occluded: u32,
}

/// Test and accumulate one chunk of 8 slots, kept to the targets' visible domains when `vis`
/// gives the chunk's.
#[inline(always)]
fn splat_lanes(
    ray: &SplatRay,
    pts: &PointChunk,
    vis: Option<&DomainChunk>,
    acc: &mut AccumChunk,
) -> LaneSplat {
    let mut w = [0.0f32; LANES];
    let mut wr = [0.0f32; LANES];
    let mut wd = [0.0f32; LANES];
    let mut hit = [0.0f32; LANES];
    let mut radius = [0.0f32; LANES];
    for l in 0..LANES {
        let r = test_sample(
            ray,
            Vec3::new(pts.px[l], pts.py[l], pts.pz[l]),
            Vec3::new(pts.nx[l], pts.ny[l], pts.nz[l]),
        );
        w[l] = r.weight;
        wr[l] = r.weight * r.radius;
        radius[l] = r.radius;
        wd[l] = r.weight * r.inv_dist;
        hit[l] = if r.feasible { 1.0 } else { 0.0 };
    }
    let splatted = hit.iter().sum::<f32>() as u32;
    let domain = match vis {
        // A chunk without a splatted lane has nothing to test.
        Some(dom) if splatted > 0 => {
            let near = near_walls(ray, pts, dom, &w, &radius);
            let flagged = near.count_ones();
            let outside = if near != 0 {
                visible_domain(
                    ray,
                    pts,
                    dom,
                    near,
                    &radius,
                    [&mut w, &mut wr, &mut wd, &mut hit],
                )
            } else {
                0
            };
            (flagged, outside)
        }
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
        // Those the visible domains kept.
        accepted: splatted - domain.1,
        domain_tests: domain.0,
        occluded: domain.1,
    }
}

/// The first, branch-free half of the visible-domain test (it vectorises): a bit per
/// splatted lane whose pair needs [`visible_domain`], because the foot of its target on the
/// ray's line lies behind the target's tangent plane or the splat radius reaches past the
/// nearest surface its probes met. Everything else is an open-plane pair, kept as it is.
#[inline(always)]
fn near_walls(
    ray: &SplatRay,
    pts: &PointChunk,
    dom: &DomainChunk,
    w: &[f32; LANES],
    radius: &[f32; LANES],
) -> u32 {
    let c = &ray.cone;
    let (o, d) = (c.origin, c.dir);
    let mut near = 0u32;
    for l in 0..LANES {
        let r = radius[l];
        let (vx, vy, vz) = (pts.px[l] - o.x, pts.py[l] - o.y, pts.pz[l] - o.z);
        let t = vx * d.x + vy * d.y + vz * d.z;
        // foot − x = d·t − (x − o), against the normal.
        let s = (d.x * t - vx) * dom.normal[0][l]
            + (d.y * t - vy) * dom.normal[1][l]
            + (d.z * t - vz) * dom.normal[2][l];
        // Past the end of a ray that landed on another surface than the target's.
        let plane =
            vx * ray.end_normal.x + vy * ray.end_normal.y + vz * ray.end_normal.z - ray.end_plane;
        let facing = ray.end_normal.x * dom.normal[0][l]
            + ray.end_normal.y * dom.normal[1][l]
            + ray.end_normal.z * dom.normal[2][l];
        let beyond = t > c.length;
        let on_landing = on_landing_surface(plane, facing, c.h_end);
        let past = beyond & !on_landing;
        // On the landing surface beyond the hit, the hemisphere of Fig. 4 already keeps the
        // pair within r of the hit, where the line crosses the target's plane (the planar
        // model): its foot lying behind the plane needs no test there.
        let crossing = (s < -1e-4 * r) & !(beyond & on_landing);
        let flag = (w[l] > 0.0) & (crossing | (r > dom.free_min[l]) | past);
        near |= (flag as u32) << l;
    }
    near
}

/// Keep one chunk's splatted lanes to their targets' visible domains
/// ([`crate::pipeline::splat_tree::DomainChunk`], docs/deviations.md §40): each pair's point v
/// (the foot of the target on the ray's line, or where the line crosses the target's tangent
/// plane when the foot lies behind it) must lie within the splat radius and the free distance
/// of its cell, or the pair splats nothing; a kept pair is divided by N(x, r), the share of
/// the kernel its target sees, wherever a cell's free distance is shorter than the radius.
/// Only the lanes flagged in `near` ([`near_walls`]) change. `sums` are the lanes' weight,
/// weight·radius, weight/distance and hit. Returns the pairs found outside.
///
/// Branch-free over the 8 lanes (every lane computes every case and selects; the cell's free
/// distance and the share table are per-lane gathers), so that it vectorises: the scalar,
/// branching version took 14 ns per pair and T_S on CORNELL BOX I 4.3× (docs/benchmarks.md).
#[inline(always)]
fn visible_domain(
    ray: &SplatRay,
    pts: &PointChunk,
    dom: &DomainChunk,
    near: u32,
    radius: &[f32; LANES],
    sums: [&mut [f32; LANES]; 4],
) -> u32 {
    let c = &ray.cone;
    let (o, d, en) = (c.origin, c.dir, ray.end_normal);
    // Three passes: the lanes' geometry (vectorised), the per-lane reads of their cells' free
    // distances and share tables (8 scalar gathers), the lanes' verdicts (vectorised).
    let mut keep = [false; LANES];
    let mut cut = [false; LANES];
    let mut len2 = [0.0f32; LANES];
    let mut cell = [0u32; LANES];
    // For a ray that stopped on another surface: its planar v (where it would have landed
    // on an open plane, the point N's model counts it at) must lie in view as well.
    let mut stopped = [false; LANES];
    let mut planar = [Vec3::ZERO; LANES];
    let mut share_x = [0.0f32; LANES];
    for l in 0..LANES {
        let r = radius[l];
        let (nx, ny, nz) = (dom.normal[0][l], dom.normal[1][l], dom.normal[2][l]);
        // x − o.
        let (vx, vy, vz) = (pts.px[l] - o.x, pts.py[l] - o.y, pts.pz[l] - o.z);
        // The foot of x on the ray's line, past its end too (the hemisphere of Fig. 4) when
        // x lies on the surface the ray landed on; a ray that landed elsewhere stops there.
        let t_foot = vx * d.x + vy * d.y + vz * d.z;
        let plane = vx * en.x + vy * en.y + vz * en.z - ray.end_plane;
        let facing = nx * en.x + ny * en.y + nz * en.z;
        let stops = (t_foot > c.length) & !on_landing_surface(plane, facing, c.h_end);
        let tf = if stops { c.length } else { t_foot };
        // v = foot − x.
        let (fx, fy, fz) = (d.x * tf - vx, d.y * tf - vy, d.z * tf - vz);
        let behind = fx * nx + fy * ny + fz * nz;
        // Behind the tangent plane: the ray stands for the one landing where its line crosses
        // the plane, if it reaches it from the front within r.
        let crosses = behind < -1e-4 * r;
        let dn = d.x * nx + d.y * ny + d.z * nz;
        let tc = (vx * nx + vy * ny + vz * nz) / dn;
        let (cx, cy, cz) = (d.x * tc - vx, d.y * tc - vy, d.z * tc - vz);
        let crossing_kept = (dn < 0.0) & (tc >= 0.0) & (cx * cx + cy * cy + cz * cz <= r * r);
        // The planar v of a ray that stopped: its unclamped foot, or the crossing when that
        // lies behind the plane (and is reached within r, as for any crossing pair).
        let (px, py, pz) = (d.x * t_foot - vx, d.y * t_foot - vy, d.z * t_foot - vz);
        let planar_crosses = px * nx + py * ny + pz * nz < -1e-4 * r;
        // A ray that stopped behind the target's plane before reaching it splats nothing.
        // A ray that stopped on a face turned away from the target (the target lies behind
        // the lit side's plane: the outside of a thin wall, the top of a ledge the target
        // sits below) lit that face, not the target's side of it: it splats nothing, however
        // coarse the cells around the corner are (docs/deviations.md §40, "Rays that lit a
        // face turned away").
        let lit_face_away = stops & (plane < -BEHIND_LANDING * r);
        keep[l] = !(stops & (behind < 0.0))
            & !lit_face_away
            & (!crosses | crossing_kept)
            & (!(stops & planar_crosses) | crossing_kept);
        let (ux, uy, uz) = if crosses { (cx, cy, cz) } else { (fx, fy, fz) };
        len2[l] = ux * ux + uy * uy + uz * uz;
        // Where the radius reaches past the nearest surface a probe met, v's cell decides.
        cut[l] = r > dom.free_min[l];
        // The cells' frame, as the probes': onb of the normal (branch-free, it vectorises).
        let n = Vec3::new(nx, ny, nz);
        let (t, b) = onb(n);
        let u = Vec3::new(ux, uy, uz);
        cell[l] = cell_index(u.dot(t), u.dot(b), u.dot(n));
        stopped[l] = stops;
        planar[l] = if planar_crosses {
            Vec3::new(cx, cy, cz)
        } else {
            Vec3::new(px, py, pz)
        };
        share_x[l] = share_position(r, dom.free_min[l]);
    }
    // The cells' free distances and N(x, r) read from each lane's table.
    let mut free = [0.0f32; LANES];
    let mut share = [1.0f32; LANES];
    for l in 0..LANES {
        free[l] = free_distance(dom.free[l][cell[l] as usize % PROBES], dom.free_min[l]);
        share[l] = share_from_row(&dom.share[l], share_x[l]);
    }
    // A ray that stopped on another surface is kept where N counts it: its planar v in view
    // too (a ray landing on the far wall of a concave corner would otherwise add to the
    // renormalised near wall's light what N's open plane has it land beyond the corner, where
    // the cell cuts it). Rare outside corners and thin walls: only then are the cells read.
    let mut planar_in_view = [true; LANES];
    if stopped.iter().any(|&s| s) {
        for l in 0..LANES {
            let n = Vec3::new(dom.normal[0][l], dom.normal[1][l], dom.normal[2][l]);
            let (t, b) = onb(n);
            let p = planar[l];
            let c = cell_index(p.dot(t), p.dot(b), p.dot(n));
            let f = free_distance(dom.free[l][c as usize % PROBES], dom.free_min[l]) * NEARER;
            planar_in_view[l] = !stopped[l] | (p.length_squared() < f * f);
        }
    }
    let flagged: [bool; LANES] = std::array::from_fn(|l| near & (1 << l) != 0);
    let mut scale = [1.0f32; LANES];
    for l in 0..LANES {
        // Strictly nearer than the surface the probe met: a ray that ended on it lies on it,
        // and stands for rays the planar model lets pass on. N(x, r) renormalises.
        let f = free[l] * NEARER;
        let kept = keep[l] & (!cut[l] | ((len2[l] < f * f) & planar_in_view[l]));
        let n = if cut[l] { share[l] } else { 1.0 };
        let s = 1.0 / n.max(1.0 / 16.0);
        scale[l] = if !flagged[l] {
            1.0
        } else if kept {
            s
        } else {
            0.0
        };
    }
    let outside = (0..LANES)
        .filter(|&l| flagged[l] & (scale[l] == 0.0))
        .count() as u32;
    let [w, wr, wd, hit] = sums;
    for l in 0..LANES {
        w[l] *= scale[l];
        wr[l] *= scale[l];
        wd[l] *= scale[l];
        hit[l] = if scale[l] == 0.0 { 0.0 } else { hit[l] };
    }
    outside
}

/// A target lies behind the lit face a ray stopped on ([`visible_domain`]) when it is
/// farther behind that face's plane than this share of the splat radius: nearer, it may sit on
/// a gently curved or bumpy surface whose tangent plane passes just in front of it.
const BEHIND_LANDING: f32 = 0.05;

/// A point of the footprint is in view when strictly nearer than the surface its cell's probe
/// met, by this factor: a ray that ended on that surface lies on it ([`visible_domain`]).
const NEARER: f32 = 1.0 - 1e-3;

/// A target lies on the surface a ray landed on: within half the ray's end radius of the hit
/// plane (signed distance `plane`) and facing the same way (`facing`, the cosine between the
/// normals): the other face of a thin wall is near the plane too. Past the end of its ray,
/// only such a target sees the ray go on (the hemisphere of Fig. 4); [`near_walls`] and
/// [`visible_domain`] must agree on it.
#[inline(always)]
fn on_landing_surface(plane: f32, facing: f32, h_end: f32) -> bool {
    (plane.abs() < 0.5 * h_end) & (facing >= 0.5)
}
