//! The pilot phase (§6): ⟨D⟩ and ⟨r⟩ for the normalisation w of eq. 8.

use super::trace::{PathUnits, TaggedRay, trace_photon};
use super::{MU_C_FACTOR, PILOT_PHOTONS};
use crate::scene::Scene;
use rayon::prelude::*;

/// Statistics of the pilot phase (§6).
///
/// Both statistics are weighted by the share of power a segment's end vertex sends on (the
/// Russian-roulette survival probability): segments that escape the scene or end on a black
/// surface carry no light further and say nothing about the scale of the lighting, so a black
/// ground plane far away, or an open side, cannot change the bandwidths (docs/deviations.md §2).
#[derive(Clone, Copy, Debug)]
pub struct Pilot {
    /// ⟨D⟩: weighted mean photon-segment length (a length, so that μC = a·⟨D⟩ is one;
    /// docs/deviations.md §2). Eq. 7's lengths are measured in this unit.
    pub mean_length: f32,
    /// Weighted mean of ln p̃ (dimensionless, eq. 7) over the pilot's vertices: the geometric
    /// mean of r = p̃^(−S/2) for any S is exp(−S/2 · this).
    pub mean_log_pdf: f64,
    /// Pilot vertices that entered the statistics.
    pub vertices: usize,
}

impl Pilot {
    /// μC = a·⟨D⟩ (§6).
    pub fn mu_c(&self) -> f32 {
        MU_C_FACTOR * self.mean_length
    }

    /// The units of eq. 7 for the light pass.
    pub fn units(&self) -> PathUnits {
        PathUnits {
            length: self.mean_length,
        }
    }

    /// ⟨r⟩, r = 1/√(p̃^S) (§6), as a geometric mean: p̃ spans many orders of magnitude over
    /// bounces, and an arithmetic mean is then set by a few deep vertices
    /// (docs/deviations.md §5).
    pub fn mean_r(&self, s: f32) -> f32 {
        if self.vertices == 0 {
            return 1.0;
        }
        ((-0.5 * s as f64 * self.mean_log_pdf).exp() as f32).clamp(f32::MIN_POSITIVE, f32::MAX)
    }
}

/// The pilot shooting phase (§6): trace a few thousand photons, record segment lengths and
/// vertex pdfs. It runs twice over the same photons: once for ⟨D⟩, once for eq. 7's p̃ in
/// units of it.
pub fn pilot(scene: &Scene, seed: u64) -> Pilot {
    let trace = |units: PathUnits| -> Vec<TaggedRay> {
        (0..PILOT_PHOTONS as u64 / 512)
            .into_par_iter()
            .map(|c| {
                let mut out = Vec::new();
                let mut invalid = 0;
                for id in c * 512..(c + 1) * 512 {
                    trace_photon(
                        scene,
                        id,
                        seed ^ 0x005e_ed0f_9110,
                        [true; 3],
                        units,
                        None,
                        &mut out,
                        &mut invalid,
                    );
                }
                out.retain(|r| r.ray.is_valid());
                out
            })
            .flatten_iter()
            .collect()
    };
    let first = trace(PathUnits::PROVISIONAL);
    let (mut len_sum, mut w_sum) = (0.0f64, 0.0f64);
    for r in first.iter().filter(|r| !r.parallel) {
        let w = r.onward as f64;
        len_sum += w * r.ray.length as f64;
        w_sum += w;
    }
    let mean_length = if w_sum > 0.0 && len_sum > 0.0 {
        (len_sum / w_sum) as f32
    } else {
        // No photon bounces anywhere (every surface black, or nothing to hit): the plain mean
        // length of what was traced, or the scene's size as a last resort.
        let n = first.len().max(1) as f64;
        let plain = first.iter().map(|r| r.ray.length as f64).sum::<f64>() / n;
        if plain > 0.0 {
            plain as f32
        } else {
            0.1 * scene.diagonal()
        }
    };
    let units = PathUnits {
        length: mean_length,
    };
    let second = trace(units);
    let (mut log_sum, mut w_sum, mut vertices) = (0.0f64, 0.0f64, 0usize);
    for r in &second {
        let p = r.ray.pdf_end;
        if r.onward > 0.0 && p.is_finite() && p > 0.0 {
            log_sum += r.onward as f64 * (p as f64).ln();
            w_sum += r.onward as f64;
            vertices += 1;
        }
    }
    Pilot {
        mean_length,
        mean_log_pdf: if w_sum > 0.0 { log_sum / w_sum } else { 0.0 },
        vertices,
    }
}
