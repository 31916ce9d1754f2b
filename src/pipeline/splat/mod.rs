//! Photon ray splatting (§4, §5, §7.2): each photon ray deposits its power, through a 2D
//! Epanechnikov kernel perpendicular to the ray, onto the feasible eye samples in its conical
//! frustum, weighted by cos θ at the sample.
//!
//! The leaf test runs 8 lanes at a time over the padded structure-of-arrays slots
//! ([`crate::pipeline::splat_tree::LANES`]); on x86-64 with AVX2 the whole subtree loop is compiled for
//! AVX2 (chosen once per subtree, never per photon). Both paths compute the same IEEE
//! operations, so they give identical results.
//!
//! The kernel and the per-sample test are in `kernel`, the parallel pass over the splat tree in
//! `pass`; both are re-exported here.

mod kernel;
mod pass;

pub use kernel::{LaneResult, epanechnikov, kept_fraction, test_sample};
pub use pass::splat;

use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::directional::{FILTER_TAPS, SH_COEFFS, filter_taps, sh_basis};
use crate::pipeline::photon::{Bandwidth, PhotonRay, phi_at};
use crate::pipeline::radiance_map::Accumulators;
use crate::pipeline::splat_tree::{Cone, SplatTree, clip};
use crate::scene::Scene;
use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// A photon ray ready to splat: its cone from the current bandwidth (§6) and its power.
#[derive(Clone, Copy, Debug)]
pub struct SplatRay {
    /// The splat volume: the conical frustum and the hemisphere beyond the hit (Fig. 4).
    pub cone: Cone,
    /// ΔΦ: the photon ray's power (already divided by its class's photon count).
    pub power: Vec3,
    /// Normal of the surface the ray leaves, on the side it leaves (zero for point lights):
    /// samples behind it are not splatted.
    pub origin_normal: Vec3A,
    /// Normal of the surface hit, facing the ray (zero when the ray escapes).
    pub end_normal: Vec3A,
    /// 1 / [`kept_fraction`] at the hit: restores, on the hit surface, the kernel mass the
    /// hemisphere rule and the narrower cone before the hit cut off (docs/deviations.md §23).
    pub end_gain: f32,
    /// length · (dir · end_normal): the hit plane is {p : (p − origin) · end_normal = this}.
    pub end_plane: f32,
    /// 1 when the footprint extends beyond the hit point as the hemisphere of Fig. 4; 0 when
    /// the ray ends on a mirror or glass (the photon goes on from there, so the next segment
    /// carries that light) or escapes: then nothing past the end receives anything.
    pub beyond: f32,
    /// Lower corner of the splat volume's bounding box ([`Cone::bounds`]).
    pub bounds_min: Vec3A,
    /// Upper corner of the splat volume's bounding box.
    pub bounds_max: Vec3A,
}

/// A ray's incident direction (−dir) in the radiance map's basis (§8.1), computed once per
/// ray: Y_k(−dir) in SH mode; the filter taps (weights in `basis[..8]`, strata in `taps`) in
/// histogram mode. Kept apart from [`SplatRay`], which every subtree streams through, since
/// only splats onto glossy targets read it.
#[derive(Clone, Copy, Debug)]
pub struct RayDirection {
    /// SH mode: Y_k(−dir) for the 16 coefficients; histogram mode: the taps' weights in the
    /// first [`FILTER_TAPS`] entries; diffuse mode: zero.
    pub basis: [f32; SH_COEFFS],
    /// Histogram mode: the strata the taps deposit into.
    pub taps: [u8; FILTER_TAPS],
    /// Non-zero taps (histogram mode).
    pub tap_count: u8,
}

impl RayDirection {
    /// The basis values of the incident direction −`dir` for `mode`.
    pub fn new(dir: Vec3, mode: DirectionalMode) -> Self {
        let mut basis = [0.0; SH_COEFFS];
        let mut taps = [0u8; FILTER_TAPS];
        let mut tap_count = 0;
        match mode {
            DirectionalMode::Diffuse => {}
            DirectionalMode::Sh => basis = sh_basis(-dir),
            DirectionalMode::Histogram => {
                let t = filter_taps(-dir);
                taps = t.stratum;
                basis[..FILTER_TAPS].copy_from_slice(&t.weight);
                tap_count = t.weight.iter().filter(|&&w| w > 0.0).count() as u8;
            }
        }
        Self {
            basis,
            taps,
            tap_count,
        }
    }
}

impl RayDirection {
    /// Add `power` arriving along this direction to a directional record (§8.1): projected
    /// onto the SH basis, or spread over the filter's strata.
    #[inline(always)]
    pub fn deposit(&self, rec: &mut [f32], power: Vec3, mode: DirectionalMode) {
        match mode {
            DirectionalMode::Diffuse => {}
            DirectionalMode::Sh => {
                for (c, pc) in [power.x, power.y, power.z].into_iter().enumerate() {
                    let dst = &mut rec[c * SH_COEFFS..(c + 1) * SH_COEFFS];
                    for (d, b) in dst.iter_mut().zip(&self.basis) {
                        *d += pc * b;
                    }
                }
            }
            DirectionalMode::Histogram => {
                for t in 0..self.tap_count as usize {
                    let (wt, s) = (self.basis[t], self.taps[t] as usize * 3);
                    rec[s] += wt * power.x;
                    rec[s + 1] += wt * power.y;
                    rec[s + 2] += wt * power.z;
                }
            }
        }
    }
}

/// Rays ready to splat, with their directions when the radiance map keeps them.
#[derive(Clone, Debug, Default)]
pub struct SplatBatch {
    /// The rays, in the order of the photon rays they came from.
    pub rays: Vec<SplatRay>,
    /// One per ray in SH and histogram modes; empty in diffuse mode.
    pub directions: Vec<RayDirection>,
}

impl SplatRay {
    /// The ray with its cone (h0, dh) from eq. 8's bandwidth `bw` (§6) and the floor of its
    /// φ `phi` ([`crate::pipeline::photon::HitDensity::phi`]; 0: none), in a scene whose eye
    /// samples lie within `bounds` (min, max).
    ///
    /// A ray that escapes is stored up to where it leaves the bounds; its footprint still
    /// reaches samples within its radius of that point, beyond it along the ray (a lit
    /// floor's open edge, the classic box's ceiling at its open front). It is kept up to
    /// where it leaves the bounds grown by its radius, so that every sample its footprint
    /// reaches projects inside the segment (docs/deviations.md §42).
    pub fn new(ray: &PhotonRay, bw: &Bandwidth, phi: f32, bounds: (Vec3, Vec3)) -> Self {
        let (h0, dh) = bw.cone(ray, phi);
        let reach = if ray.escapes() {
            let r = Vec3A::splat(h0 + dh * ray.length);
            let (min, max) = (Vec3A::from(bounds.0) - r, Vec3A::from(bounds.1) + r);
            clip(
                ray.origin.into(),
                ray.dir.into(),
                min,
                max,
                0.0,
                f32::INFINITY,
            )
            .map_or(ray.length, |(_, t1)| t1.max(ray.length))
        } else {
            ray.length
        };
        Self::with_cone_reach(ray, h0, dh, reach)
    }

    /// The ray with a given cone: radius h0 at its origin, growing by dh per unit length (§6).
    pub fn with_cone(ray: &PhotonRay, h0: f32, dh: f32) -> Self {
        Self::with_cone_reach(ray, h0, dh, ray.length)
    }

    /// [`Self::with_cone`], the splat volume running to `reach` ≥ the ray's length (an
    /// escaping ray's radius stays h_end past its stored end).
    fn with_cone_reach(ray: &PhotonRay, h0: f32, dh: f32, reach: f32) -> Self {
        let cone = Cone {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
            length: reach,
            h0,
            dh,
            h_end: h0 + dh * ray.length,
        };
        let (bounds_min, bounds_max) = cone.bounds();
        let end_normal = ray.end_normal.get();
        let cos_hit = -ray.dir.dot(end_normal);
        // Only a ray that lands on a surface that holds eye samples gets the hemisphere and
        // the end gain; a specular end has no samples on it to correct for.
        let end_gain = if !ray.lands() {
            1.0
        } else {
            // Never more than 4×: at grazing incidence on a steep cone the kept mass tends to 0.
            1.0 / kept_fraction(cos_hit, dh).max(0.25)
        };
        Self {
            cone,
            power: ray.power,
            origin_normal: ray.origin_normal.get().into(),
            end_normal: end_normal.into(),
            end_gain,
            end_plane: ray.length * ray.dir.dot(end_normal),
            beyond: if ray.lands() { 1.0 } else { 0.0 },
            bounds_min,
            bounds_max,
        }
    }
}

/// Photon rays prepared and splatted per chunk of this many by [`prepare_and_splat`]: a
/// prepared ray with its SH direction takes about 240 bytes, three times a stored one, so
/// preparing a whole batch at once was the render's peak (500,000 rays: +130 MB). 2¹⁴ and
/// 2¹⁶ splat equally fast (T_S 6.85 s on CORNELL BOX I at M = 500,000); the smaller holds
/// 4 MB.
pub const SPLAT_CHUNK: usize = 1 << 14;

/// Prepare and splat `rays` of the classes selected by `classes` (per-class bandwidths, the
/// floors of the rays' φ `phis`: one per ray, or empty for none; directions in the basis of
/// `mode`) onto `tree`'s accumulators `acc`, [`SPLAT_CHUNK`] rays
/// at a time into one reused buffer. Each target receives the rays in the same order as from
/// one [`prepare`] and [`splat`] of the whole slice. Counts the rays offered and those that
/// splatted onto at least one target; with `reach`, adds each of those to its photon's
/// emission cell (`reach[ray.cell()]`, docs/deviations.md §44).
#[allow(clippy::too_many_arguments)]
pub fn prepare_and_splat(
    tree: &SplatTree,
    rays: &[PhotonRay],
    phis: &[f32],
    bandwidths: &[Bandwidth; 3],
    classes: [bool; 3],
    mode: DirectionalMode,
    scene: &Scene,
    acc: &mut Accumulators,
    visibility: Option<&Scene>,
    mut reach: Option<&mut [u32]>,
) -> SplatCounters {
    let mut counters = SplatCounters::default();
    let mut batch = SplatBatch::default();
    let mut reached: Vec<AtomicBool> = Vec::new();
    for (i, chunk) in rays.chunks(SPLAT_CHUNK).enumerate() {
        let phis = phis.get(i * SPLAT_CHUNK..).unwrap_or(&[]);
        let phis = &phis[..phis.len().min(chunk.len())];
        prepare_into(chunk, phis, bandwidths, classes, mode, scene, &mut batch);
        if batch.rays.is_empty() {
            continue;
        }
        reached.clear();
        reached.resize_with(batch.rays.len(), || AtomicBool::new(false));
        counters += pass::splat_marking(tree, &batch, acc, visibility, &reached);
        counters.rays += batch.rays.len() as u64;
        // The prepared rays are the chunk's rays of the classes splatted, in order.
        let selected = chunk.iter().filter(|r| classes[r.class() as usize]);
        for (ray, flag) in selected.zip(&reached) {
            if flag.load(Ordering::Relaxed) {
                counters.rays_reaching += 1;
                if let Some(cells) = reach.as_deref_mut()
                    && let Some(n) = cells.get_mut(ray.cell() as usize)
                {
                    *n += 1;
                }
            }
        }
    }
    counters
}

/// Prepare rays of the classes selected by `classes` with per-class bandwidths and the
/// floors of their φ `phis` (one per ray, or empty for none), their directions expressed in
/// the basis of `mode`.
pub fn prepare(
    rays: &[PhotonRay],
    phis: &[f32],
    bandwidths: &[Bandwidth; 3],
    classes: [bool; 3],
    mode: DirectionalMode,
    scene: &Scene,
) -> SplatBatch {
    let mut batch = SplatBatch::default();
    prepare_into(rays, phis, bandwidths, classes, mode, scene, &mut batch);
    batch
}

/// [`prepare`] into `batch`, reusing its buffers.
fn prepare_into(
    rays: &[PhotonRay],
    phis: &[f32],
    bandwidths: &[Bandwidth; 3],
    classes: [bool; 3],
    mode: DirectionalMode,
    scene: &Scene,
    batch: &mut SplatBatch,
) {
    let selected = || rays.par_iter().filter(|r| classes[r.class() as usize]);
    let bounds = (scene.bounds_min, scene.bounds_max);
    batch.rays.clear();
    debug_assert!(phis.is_empty() || phis.len() == rays.len());
    batch.rays.par_extend(
        rays.par_iter()
            .enumerate()
            .filter(|(_, r)| classes[r.class() as usize])
            .map(|(i, r)| {
                SplatRay::new(r, &bandwidths[r.class() as usize], phi_at(phis, i), bounds)
            }),
    );
    batch.directions.clear();
    if mode != DirectionalMode::Diffuse {
        batch
            .directions
            .par_extend(selected().map(|r| RayDirection::new(r.dir, mode)));
    }
}

/// Counters of one splat pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SplatCounters {
    /// Eye samples tested for feasibility (real samples in visited leaves).
    pub tested: u64,
    /// Eye samples that received energy.
    pub accepted: u64,
    /// Splatted pairs near a wall, tested cell by cell against their target's visible domain
    /// (docs/deviations.md §40); the others lie on an open plane.
    pub domain_tests: u64,
    /// Of those, the pairs outside it (which splatted nothing).
    pub occluded: u64,
    /// Photon rays offered to the eye side's splat targets ([`prepare_and_splat`]).
    pub rays: u64,
    /// Of those, the rays that splatted onto at least one target.
    pub rays_reaching: u64,
}

impl std::ops::AddAssign for SplatCounters {
    fn add_assign(&mut self, o: Self) {
        self.tested += o.tested;
        self.accepted += o.accepted;
        self.domain_tests += o.domain_tests;
        self.occluded += o.occluded;
        self.rays += o.rays;
        self.rays_reaching += o.rays_reaching;
    }
}
