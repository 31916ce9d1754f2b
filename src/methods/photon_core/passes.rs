//! The films of an eye side's finished eye passes (docs/deviations.md §41): each kept as a sum
//! weighted by the batches it held, and blended with the current pass's film.

use crate::film::Film;
use crate::film::estimate::{ErrorEstimate, PassSpread, PassValues};
use glam::Vec3;

/// The films of finished eye passes, each weighted by the batches it held.
#[derive(Clone, Debug, Default)]
pub(super) struct EarlierPasses {
    /// Σ batches · film, per pixel.
    rgb: Vec<Vec3>,
    direct: Vec<Vec3>,
    indirect: Vec<Vec3>,
    /// Σ batches.
    pub(super) batches: usize,
    /// Passes in the sums.
    pub(super) passes: u32,
    /// Their dropped contributions.
    invalid: u64,
    /// Their spread, for the error estimate (films with a bias estimate only).
    spread: PassSpread,
    /// The bandwidths their batches were splatted with (`--c auto`'s model).
    pub(super) history: BandwidthHistory,
}

/// The bandwidths an image's batches were splatted with, for `--c auto`'s model
/// (docs/deviations.md §51): a batch at bandwidth h adds bias ∝ h² and variance ∝ 1/h², so the
/// image of W batches has bias β·Σh²/W and variance ν·Σh⁻²/W².
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BandwidthHistory {
    /// Σ h² over the batches.
    pub h2: f64,
    /// Σ 1/h² over the batches.
    pub inv_h2: f64,
    /// Batches.
    pub batches: f64,
    /// The last batch's h.
    pub last: f32,
}

impl BandwidthHistory {
    /// A batch splatted at (typical) bandwidth `h`.
    pub fn add(&mut self, h: f32) {
        if h > 0.0 && h.is_finite() {
            let h2 = (h as f64) * (h as f64);
            self.h2 += h2;
            self.inv_h2 += 1.0 / h2;
            self.batches += 1.0;
            self.last = h;
        }
    }

    /// Both histories' batches.
    pub fn merge(&mut self, other: &Self) {
        self.h2 += other.h2;
        self.inv_h2 += other.inv_h2;
        self.batches += other.batches;
        if other.batches > 0.0 {
            self.last = other.last;
        }
    }

    /// The bandwidth h* that minimises the error of an image of as many batches, all at h*,
    /// given its estimated kernel bias² `a` and splatted variance `v` (deviations §51):
    /// with bias² = α·(Σh²/W)² and variance = ν·Σh⁻²/W², E(h) = α·h⁴ + ν/(W·h²) is least at
    /// h*⁶ = ν/(2αW). None when the history is empty or the estimate cannot weigh the two.
    pub fn best_h(&self, a: f64, v: f64) -> Option<f64> {
        let w = self.batches;
        if w <= 0.0 || a <= 0.0 || v <= 0.0 || self.inv_h2 <= 0.0 {
            return None;
        }
        let mean_h2 = self.h2 / w;
        let alpha = a / (mean_h2 * mean_h2);
        let nu = v * w * w / self.inv_h2;
        Some((nu / (2.0 * alpha * w)).powf(1.0 / 6.0))
    }
}

impl EarlierPasses {
    pub(super) fn add(
        &mut self,
        film: &Film,
        batches: usize,
        store_invalid: u64,
        history: &BandwidthHistory,
    ) {
        let n = film.rgb.len();
        if self.rgb.len() != n {
            *self = Self {
                rgb: vec![Vec3::ZERO; n],
                direct: vec![Vec3::ZERO; n],
                indirect: vec![Vec3::ZERO; n],
                ..Self::default()
            };
        }
        let w = batches as f32;
        for (sum, px) in [
            (&mut self.rgb, &film.rgb),
            (&mut self.direct, &film.direct),
            (&mut self.indirect, &film.indirect),
        ] {
            for (s, p) in sum.iter_mut().zip(px) {
                *s += w * *p;
            }
        }
        if !film.pass_error.is_empty() {
            self.spread.add(PassValues::of(film), batches);
        }
        self.batches += batches;
        self.passes += 1;
        self.history.merge(history);
        // The store's dropped photon rays are a running total every film carries: counted
        // once, by the current pass's film.
        self.invalid += film.invalid_contributions - film.invalid_contributions.min(store_invalid);
    }

    /// Bytes of the per-pixel sums.
    pub(super) fn memory_bytes(&self) -> usize {
        3 * self.rgb.len() * std::mem::size_of::<Vec3>() + self.spread.memory_bytes()
    }

    /// The estimated error of the finished passes' mean (docs/deviations.md §51): None
    /// before two passes, or when the error is not estimated.
    pub(super) fn estimate(&self) -> Option<ErrorEstimate> {
        if self.batches == 0 {
            return None;
        }
        let inv = 1.0 / self.batches as f32;
        self.spread.estimate(|p| self.rgb[p] * inv, None, None)
    }

    /// `film` (of the current pass, holding `batches`) becomes the mean over every pass.
    pub(super) fn blend(&self, film: &mut Film, batches: usize) {
        if self.batches == 0 || self.rgb.len() != film.rgb.len() {
            return;
        }
        let w = batches as f32;
        let inv = 1.0 / (self.batches + batches) as f32;
        // The estimate first, while the film still holds the current pass's own values: each
        // pixel's blended value is (Σ + w·x)/W, made on the fly (no copy of the film).
        if !film.pass_error.is_empty() {
            let mut map = std::mem::take(&mut film.estimated_error);
            let rgb = &film.rgb;
            let pass = PassValues::of(film);
            film.estimate = self.spread.estimate(
                |p| (self.rgb[p] + w * rgb[p]) * inv,
                Some((pass, batches)),
                Some(&mut map),
            );
            if film.estimate.is_none() {
                map.clear();
            }
            film.estimated_error = map;
        }
        for (sum, px) in [
            (&self.rgb, &mut film.rgb),
            (&self.direct, &mut film.direct),
            (&self.indirect, &mut film.indirect),
        ] {
            for (s, p) in sum.iter().zip(px.iter_mut()) {
                *p = (*s + w * *p) * inv;
            }
        }
        film.invalid_contributions += self.invalid;
    }
}
