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
/// image of W batches has bias β·Σh²/W and variance ν·Σh⁻²/W². Each batch's h is C times a
/// factor s that eq. 8, its bounds and the progressive schedule give it whatever the C
/// (§43: s falls as the batches go on), so the C that every batch would share in the best
/// image of as many batches follows from the moments of s.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BandwidthHistory {
    /// Σ h² over the batches.
    pub h2: f64,
    /// Σ 1/h² over the batches.
    pub inv_h2: f64,
    /// Σ s² over the batches, s = h/C.
    pub s2: f64,
    /// Σ 1/s² over the batches.
    pub inv_s2: f64,
    /// Batches.
    pub batches: f64,
}

impl BandwidthHistory {
    /// A batch splatted at (typical) bandwidth `h` with smoothness `c`.
    pub fn add(&mut self, h: f32, c: f32) {
        if h > 0.0 && h.is_finite() && c > 0.0 && c.is_finite() {
            let h2 = (h as f64) * (h as f64);
            let s2 = h2 / ((c as f64) * (c as f64));
            self.h2 += h2;
            self.inv_h2 += 1.0 / h2;
            self.s2 += s2;
            self.inv_s2 += 1.0 / s2;
            self.batches += 1.0;
        }
    }

    /// Both histories' batches.
    pub fn merge(&mut self, other: &Self) {
        self.h2 += other.h2;
        self.inv_h2 += other.inv_h2;
        self.s2 += other.s2;
        self.inv_s2 += other.inv_s2;
        self.batches += other.batches;
    }

    /// The C that minimises the error of an image of as many batches, each at C times its own
    /// s, given the image's estimated kernel bias² `a` and photon variance `v` (deviations
    /// §51). The batches give the model's coefficients whatever their Cs were:
    /// α = a/(Σh²/W)² and ν = v·W²/Σh⁻². With h = C·s for every batch the image has
    /// E(C) = α·C⁴·m₂² + ν·m₋₂/(W·C²) (m₂, m₋₂ the means of s² and s⁻²), least at
    /// C*⁶ = ν·m₋₂/(2α·W·m₂²): where the photon variance is twice the bias² (for batches that
    /// all had one C, C* = C·(v/2a)^(1/6)). None when the history is empty or the estimate
    /// cannot weigh the two.
    pub fn best_c(&self, a: f64, v: f64) -> Option<f64> {
        let w = self.batches;
        if w <= 0.0 || a <= 0.0 || v <= 0.0 || self.inv_h2 <= 0.0 || self.s2 <= 0.0 {
            return None;
        }
        let mean_h2 = self.h2 / w;
        let alpha = a / (mean_h2 * mean_h2);
        let nu = v * w * w / self.inv_h2;
        let (m2, m_2) = (self.s2 / w, self.inv_s2 / w);
        let c6 = nu * m_2 / (2.0 * alpha * w * m2 * m2);
        c6.is_finite().then(|| c6.powf(1.0 / 6.0))
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

    /// Some passes carry estimate values and some do not (a fine splat skipped while the view
    /// was interactive, then a view refused): the spread no longer describes the mean, so
    /// there is no estimate until a re-splat starts the passes anew.
    fn incomplete(&self) -> bool {
        let with_values = self.spread.passes();
        with_values > 0 && with_values < self.passes
    }

    /// Bytes of the per-pixel sums.
    pub(super) fn memory_bytes(&self) -> usize {
        3 * self.rgb.len() * std::mem::size_of::<Vec3>() + self.spread.memory_bytes()
    }

    /// The estimated error of the finished passes' mean (docs/deviations.md §51): None
    /// before two passes, or when the error is not estimated.
    pub(super) fn estimate(&self) -> Option<ErrorEstimate> {
        if self.batches == 0 || self.incomplete() {
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
        if self.incomplete() {
            film.estimate = None;
            film.estimated_error.clear();
        } else if !film.pass_error.is_empty() {
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

#[cfg(test)]
mod tests {
    use super::BandwidthHistory;

    /// Batches of one C: the best shared C is where the photon variance is twice the bias²,
    /// C·(v/2a)^(1/6), whatever the schedule's factors.
    #[test]
    fn batches_of_one_c_balance_variance_against_twice_the_bias() {
        let mut h = BandwidthHistory::default();
        for i in 1..=40 {
            h.add(0.3 * (i as f32).powf(-1.0 / 3.0), 1.5);
        }
        let (a, v) = (0.002, 0.009);
        let c = h.best_c(a, v).unwrap();
        let expected = 1.5 * (v / (2.0 * a)).powf(1.0 / 6.0);
        assert!((c / expected - 1.0).abs() < 1e-5, "{c} against {expected}");
        assert_eq!(h.best_c(0.0, v), None);
        assert_eq!(BandwidthHistory::default().best_c(a, v), None);
    }

    /// Batches whose Cs differed: best_c is the least of the model's error over every C the
    /// batches could have shared (α and ν from the image's a and v and the bandwidths the
    /// batches had; each batch at C times its own factor s = h/C), found by a search.
    #[test]
    fn the_best_shared_c_minimises_the_models_error() {
        let mut hist = BandwidthHistory::default();
        let mut batches = Vec::new();
        for i in 1..=30 {
            let s = 0.2 * (i as f64).powf(-1.0 / 3.0);
            let c = if i < 10 {
                1.0
            } else {
                1.0 + 0.05 * (i - 10) as f64
            };
            batches.push((s, c));
            hist.add((s * c) as f32, c as f32);
        }
        let (a, v) = (0.004, 0.003);
        let w = batches.len() as f64;
        let mean_h2 = batches.iter().map(|(s, c)| (s * c).powi(2)).sum::<f64>() / w;
        let alpha = a / (mean_h2 * mean_h2);
        let nu = v * w * w / batches.iter().map(|(s, c)| (s * c).powi(-2)).sum::<f64>();
        let error = |c: f64| {
            let bias = batches.iter().map(|(s, _)| (s * c).powi(2)).sum::<f64>() / w;
            let variance = batches.iter().map(|(s, _)| (s * c).powi(-2)).sum::<f64>() / (w * w);
            alpha * bias * bias + nu * variance
        };
        let searched = (1..=4000)
            .map(|k| k as f64 * 0.001)
            .min_by(|x, y| error(*x).total_cmp(&error(*y)))
            .unwrap();
        let c = hist.best_c(a, v).unwrap();
        assert!(
            (c - searched).abs() < 2e-3,
            "{c} against the search's {searched}"
        );
    }
}
