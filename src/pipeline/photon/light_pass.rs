//! The light pass (§3, §6): photons traced until each class of Table 2 has its budget of rays.

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
pub struct LightPassSettings {
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
}

/// Trace photons until every class has its budget of stored rays (Table 2's fractions), or
/// until `max_emitted_factor × total budget` photons were emitted.
pub fn light_pass(scene: &Scene, s: &LightPassSettings) -> PhotonBatch {
    let budgets = s.budgets.0;
    let keep = [budgets[0] > 0, budgets[1] > 0, budgets[2] > 0];
    let total_budget = s.budgets.total();
    let mut batch = PhotonBatch::default();
    if total_budget == 0 {
        return batch;
    }
    let cap = total_budget.saturating_mul(s.max_emitted_factor.max(1));
    let chunk = 2048u64;
    let wave = chunk * 4 * rayon::current_num_threads().max(1) as u64;
    let mut counts = [0u64; 3];
    let mut full_at: [Option<u64>; 3] = [None; 3];
    let mut emitted = 0u64;
    // Each class stores at most its budget: the rays go straight into the batch, a wave at
    // a time (collecting every wave first held the batch twice over, +50 MB at M = 500,000).
    // The photon that fills a class keeps its later rays of that class too: at most
    // MAX_PATH_SEGMENTS more per class.
    batch
        .rays
        .reserve_exact(total_budget as usize + 3 * MAX_PATH_SEGMENTS as usize);
    while emitted < cap && (0..3).any(|c| keep[c] && full_at[c].is_none()) {
        let start = emitted;
        let end = (start + wave).min(cap);
        // Only classes that still need rays are stored in this wave.
        let want = [
            keep[0] && full_at[0].is_none(),
            keep[1] && full_at[1].is_none(),
            keep[2] && full_at[2].is_none(),
        ];
        let wave_parts: Vec<Vec<TaggedRay>> = (start..end)
            .step_by(chunk as usize)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|c0| {
                let mut out = Vec::with_capacity(chunk as usize * 2);
                let mut invalid = 0u64;
                for id in c0..(c0 + chunk).min(end) {
                    trace_photon(
                        scene,
                        s.first_photon + id,
                        s.seed,
                        want,
                        s.units,
                        &mut out,
                        &mut invalid,
                    );
                }
                (out, invalid)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .map(|(out, invalid)| {
                batch.invalid += invalid;
                out
            })
            .collect();
        // Find, in photon order, where each class reaches its budget.
        for part in &wave_parts {
            for r in part {
                let c = r.ray.class as usize;
                if full_at[c].is_none() {
                    counts[c] += 1;
                    if counts[c] >= budgets[c] {
                        full_at[c] = Some(r.photon - s.first_photon + 1);
                    }
                }
            }
        }
        for r in wave_parts.into_iter().flatten() {
            let c = r.ray.class as usize;
            let local = r.photon - s.first_photon;
            if keep[c] && full_at[c].is_none_or(|f| local < f) {
                batch.rays.push(r.ray);
            }
        }
        emitted = end;
    }
    for c in 0..3 {
        batch.emitted[c] = if keep[c] {
            full_at[c].unwrap_or(emitted)
        } else {
            0
        };
    }
    batch.traced = emitted;
    // Every ray kept is of a photon before its class filled (local < emitted[c]); its power
    // is divided by the photons emitted for its class.
    let (emitted_per_class, mut invalid, mut stored) = (batch.emitted, 0u64, [0u64; 3]);
    batch.rays.retain_mut(|ray| {
        let c = ray.class as usize;
        ray.power /= emitted_per_class[c] as f32;
        let valid = ray.is_valid();
        invalid += !valid as u64;
        stored[c] += valid as u64;
        valid
    });
    batch.invalid += invalid;
    batch.stored = stored;
    batch
}
