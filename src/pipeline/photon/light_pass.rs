//! The light pass (§3, §6): photons traced until each class of Table 2 has its budget of rays.

use super::density::HitDensity;
use super::guide::EmissionGuide;
use super::trace::{PathUnits, TaggedRay, trace_photon};
use super::{MAX_PATH_SEGMENTS, PhotonClass, PhotonRay};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Photons per class for one light pass (Table 2's M split by its fractions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassBudgets(pub [u64; 3]);

impl ClassBudgets {
    /// M = `m` photon rays split by Table 2's class `fractions` (direct, indirect, caustic),
    /// rounded; the direct class gets none unless `splat_direct` (direct light by NEE instead).
    pub fn from_fractions(m: u64, fractions: [f32; 3], splat_direct: bool) -> Self {
        let mut b = [0u64; 3];
        for (i, f) in fractions.iter().enumerate() {
            b[i] = (m as f64 * f.max(0.0) as f64).round() as u64;
        }
        if !splat_direct {
            b[PhotonClass::Direct as usize] = 0;
        }
        Self(b)
    }

    /// Rays over all classes.
    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }
}

/// Result of one light pass.
#[derive(Clone, Debug, Default)]
pub struct PhotonBatch {
    /// The stored rays, powers normalised by their class's `emitted`, in photon order.
    pub rays: Vec<PhotonRay>,
    /// Photons emitted while filling each class (the power normalisation of that class).
    pub emitted: [u64; 3],
    /// Photons traced in total (a statistic: it depends on how many threads traced).
    pub traced: u64,
    /// Rays stored per class.
    pub stored: [u64; 3],
    /// Photon paths cut short and rays dropped because a power, direction, length or p̃ was
    /// NaN or infinite (counted, never splatted).
    pub invalid: u64,
}

/// Settings of the light pass.
#[derive(Clone, Copy, Debug)]
pub struct LightPassSettings<'a> {
    /// Rays to store per class.
    pub budgets: ClassBudgets,
    /// Stop after this many photons per stored-photon budget even if a class never fills
    /// (a scene without specular objects has no caustic photons).
    pub max_emitted_factor: u64,
    /// Seed of the photons' random streams (photon i uses stream `first_photon + i`).
    pub seed: u64,
    /// Offset of this batch's photon indices (so batches use disjoint random streams); the next
    /// batch starts at `first_photon + max(emitted)`, which does not depend on thread count.
    pub first_photon: u64,
    /// Eq. 7's length unit, from the pilot ([`Pilot::units`](super::Pilot::units)).
    pub units: PathUnits,
    /// Photons leave the lights as this guide says (docs/deviations.md §44), and their rays
    /// carry its cells; without one, in proportion to power with no cells.
    pub guide: Option<&'a EmissionGuide>,
}

/// Trace photons until every class has its budget of stored rays (Table 2's fractions), or
/// until `max_emitted_factor × total budget` photons were emitted.
pub fn light_pass(scene: &Scene, s: &LightPassSettings) -> PhotonBatch {
    let mut rays = Vec::new();
    if s.budgets.total() > 0 {
        rays.reserve_exact(s.budgets.total() as usize + 3 * MAX_PATH_SEGMENTS as usize);
    }
    // Each class stores at most its budget: the rays go straight into the batch, a wave at
    // a time (collecting every wave first held the batch twice over, +50 MB at M = 500,000).
    let mut batch = drive(scene, s, |parts, fill| {
        for r in parts.iter().flatten() {
            if fill.keeps(r, s.first_photon) {
                rays.push(r.ray);
            }
        }
    });
    // Every ray kept is of a photon before its class filled (local < emitted[c]); its power
    // is divided by the photons emitted for its class.
    let (emitted_per_class, mut invalid, mut stored) = (batch.emitted, 0u64, [0u64; 3]);
    rays.retain_mut(|ray| {
        let c = ray.class() as usize;
        // Validity before the normalisation, as `plan_light_pass` must judge it (a tiny
        // negative power would divide to −0 and pass).
        let valid = ray.is_valid();
        ray.power /= emitted_per_class[c] as f32;
        invalid += !valid as u64;
        stored[c] += valid as u64;
        valid
    });
    batch.invalid += invalid;
    batch.stored = stored;
    batch.rays = rays;
    batch
}

/// A light pass whose rays are handed on a wave at a time instead of stored
/// ([`plan_light_pass`], then [`LightPassPlan::stream`]): a headless rs render splats each
/// wave and drops it, so the batch is never held whole (docs/benchmarks.md, "Memory").
#[derive(Clone, Debug)]
pub struct LightPassPlan {
    /// The batch's counts ([`PhotonBatch::emitted`], `stored`, `traced`, `invalid`) as
    /// [`light_pass`] gives them; no rays.
    pub batch: PhotonBatch,
    /// Each wave that stores a ray: the classes it stores, and its photons (local indices)
    /// that store one, in order.
    waves: Vec<([bool; 3], Vec<u64>)>,
}

/// The first of a streamed light pass's two passes: trace the photons [`light_pass`] would
/// and count, without keeping them, the rays each class stores and the photons it took to
/// fill (a class's power normalisation and eq. 8's M are known only once it is full, so the
/// rays cannot be splatted while they are first traced). With `density`, counts where the
/// rays land there, so that the streamed rays get their floors (docs/deviations.md §63).
pub fn plan_light_pass(
    scene: &Scene,
    s: &LightPassSettings,
    mut density: Option<&mut HitDensity>,
) -> LightPassPlan {
    let mut waves = Vec::new();
    let (mut invalid, mut stored) = (0u64, [0u64; 3]);
    let mut kept = Vec::new();
    let mut batch = drive(scene, s, |parts, fill| {
        // Only photons that store a ray are traced again: not those spent looking for a class
        // that never fills, such as caustics where few specular surfaces are (Šibenik: the
        // second trace cost 2.6 s of T_L's 2.4 s when every photon was traced again).
        let mut photons = Vec::new();
        for r in parts.iter().flatten() {
            if fill.keeps(r, s.first_photon) {
                // Judged before the normalisation, as `light_pass` and `stream` judge it:
                // dividing by the photons emitted is not known yet.
                let valid = r.ray.is_valid();
                invalid += !valid as u64;
                stored[r.ray.class() as usize] += valid as u64;
                let local = r.photon - s.first_photon;
                if valid && photons.last() != Some(&local) {
                    photons.push(local);
                }
                if valid && density.is_some() {
                    kept.push(r.ray);
                }
            }
        }
        if let Some(d) = density.as_deref_mut() {
            d.add_rays(&kept);
            kept.clear();
        }
        if !photons.is_empty() {
            waves.push((fill.want, photons));
        }
    });
    batch.invalid += invalid;
    batch.stored = stored;
    LightPassPlan { batch, waves }
}

impl LightPassPlan {
    /// The second pass: trace the photons that store rays again (each photon has its own
    /// random stream, so they are the same paths) and hand `sink` each wave's stored rays, normalised, in
    /// photon order: the rays [`light_pass`] would store, a wave at a time.
    pub fn stream(&self, scene: &Scene, s: &LightPassSettings, mut sink: impl FnMut(&[PhotonRay])) {
        let emitted = self.batch.emitted;
        let mut rays = Vec::new();
        for (want, photons) in &self.waves {
            let (parts, _) = trace_wave(scene, s, photons, *want);
            rays.clear();
            for r in parts.into_iter().flatten() {
                let c = r.ray.class() as usize;
                if r.photon - s.first_photon < emitted[c] && r.ray.is_valid() {
                    let mut ray = r.ray;
                    ray.power /= emitted[c] as f32;
                    rays.push(ray);
                }
            }
            if !rays.is_empty() {
                sink(&rays);
            }
        }
    }
}

/// Where a light pass stands after a wave: which photons it traced, the classes it stored
/// and the photon at which each class filled its budget.
struct Fill {
    start: u64,
    end: u64,
    want: [bool; 3],
    keep: [bool; 3],
    full_at: [Option<u64>; 3],
}

impl Fill {
    /// The light pass keeps ray `r`: its class is stored and had not filled before its
    /// photon (the photon that fills a class keeps its later rays of that class too: at most
    /// MAX_PATH_SEGMENTS more per class).
    #[inline]
    fn keeps(&self, r: &TaggedRay, first_photon: u64) -> bool {
        let c = r.ray.class() as usize;
        self.keep[c] && self.full_at[c].is_none_or(|f| r.photon - first_photon < f)
    }
}

/// The wave loop shared by [`light_pass`] and [`plan_light_pass`]: trace waves of photons
/// until every stored class has its budget or the emission cap is reached, finding in photon
/// order where each class fills; `on_wave` sees each wave's rays with the fill so far. Returns
/// the batch's counts without rays or `stored`.
fn drive(
    scene: &Scene,
    s: &LightPassSettings,
    mut on_wave: impl FnMut(&[Vec<TaggedRay>], &Fill),
) -> PhotonBatch {
    let budgets = s.budgets.0;
    let total_budget = s.budgets.total();
    let mut batch = PhotonBatch::default();
    if total_budget == 0 {
        return batch;
    }
    let cap = total_budget.saturating_mul(s.max_emitted_factor.max(1));
    let wave = CHUNK * 4 * rayon::current_num_threads().max(1) as u64;
    let mut counts = [0u64; 3];
    let mut fill = Fill {
        start: 0,
        end: 0,
        want: [false; 3],
        keep: [budgets[0] > 0, budgets[1] > 0, budgets[2] > 0],
        full_at: [None; 3],
    };
    while fill.end < cap && (0..3).any(|c| fill.keep[c] && fill.full_at[c].is_none()) {
        fill.start = fill.end;
        fill.end = (fill.start + wave).min(cap);
        // Only classes that still need rays are stored in this wave.
        fill.want = std::array::from_fn(|c| fill.keep[c] && fill.full_at[c].is_none());
        let photons: Vec<u64> = (fill.start..fill.end).collect();
        let (parts, invalid) = trace_wave(scene, s, &photons, fill.want);
        batch.invalid += invalid;
        // Find, in photon order, where each class reaches its budget.
        for r in parts.iter().flatten() {
            let c = r.ray.class() as usize;
            if fill.full_at[c].is_none() {
                counts[c] += 1;
                if counts[c] >= budgets[c] {
                    fill.full_at[c] = Some(r.photon - s.first_photon + 1);
                }
            }
        }
        on_wave(&parts, &fill);
    }
    for c in 0..3 {
        batch.emitted[c] = if fill.keep[c] {
            fill.full_at[c].unwrap_or(fill.end)
        } else {
            0
        };
    }
    batch.traced = fill.end;
    batch
}

/// Photons traced per task.
const CHUNK: u64 = 2048;

/// Trace the pass's `photons` (local indices, in order) in parallel, storing rays of the
/// classes `want`: their rays in photon order (one part per chunk of photons), and the paths
/// cut short for NaN or infinite values.
fn trace_wave(
    scene: &Scene,
    s: &LightPassSettings,
    photons: &[u64],
    want: [bool; 3],
) -> (Vec<Vec<TaggedRay>>, u64) {
    let parts: Vec<(Vec<TaggedRay>, u64)> = photons
        .par_chunks(CHUNK as usize)
        .map(|chunk| {
            let mut out = Vec::with_capacity(CHUNK as usize * 2);
            let mut invalid = 0u64;
            for &id in chunk {
                trace_photon(
                    scene,
                    s.first_photon + id,
                    s.seed,
                    want,
                    s.units,
                    s.guide,
                    &mut out,
                    &mut invalid,
                );
            }
            (out, invalid)
        })
        .collect();
    let invalid = parts.iter().map(|p| p.1).sum();
    (parts.into_iter().map(|p| p.0).collect(), invalid)
}
