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
}

impl EarlierPasses {
    pub(super) fn add(&mut self, film: &Film, batches: usize, store_invalid: u64) {
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
        self.spread.estimate(|p| self.rgb[p] * inv, None)
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
            let rgb = &film.rgb;
            let pass = PassValues::of(film);
            film.estimate = self
                .spread
                .estimate(|p| (self.rgb[p] + w * rgb[p]) * inv, Some((pass, batches)));
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
