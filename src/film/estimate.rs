//! The error of a progressive image estimated from its own eye passes (issue 32,
//! docs/deviations.md §51): variance from the spread between passes, kernel bias from each
//! pass's splat at two bandwidths, h and h/k ([`FINE_SCALE`] k = 4).
//!
//! Each finished eye pass i holds a film x_i, weighted by its batches w_i; the image is the
//! weighted mean x̄ = Σ w_i x_i / W. The passes are independent (new eye samples, new photons),
//! and a pass's variance has two parts: its eye samples' (anti-aliasing, NEE), α, which its
//! batches do not average, and its photons', β per batch, which they do: σ_i² = α + β/w_i.
//! So Var(x̄) = α·Σw_i²/W² + β/W. β comes from the spread of L(h) − L(h/k), in which the eye
//! samples' noise cancels ([`DIFFERENCE_VARIANCE`]); α from the weighted spread
//! S = Σ w_i (x_i − x̄)², whose expectation is α·(W − Σw_i²/W) + β·(n − 1). With equal weights
//! this is the textbook s²/n. With one pass far heavier than the rest (the window after a
//! re-splat puts every stored batch onto one pass), the eye samples' noise of that pass stays
//! in the image, and the lighter passes' spread shows it; the form Σ w_i² (x_i − x̄)²/W² used
//! before read 7–10× too little there (docs/deviations.md §51, "Passes of unequal weight").
//! Values of the photons alone (the bias estimate, the difference) have σ_i² = c/w_i, and
//! Var = S/((n − 1)·W).
//!
//! For a second-order kernel (the Epanechnikov kernel, §6) the bias of a density estimate
//! grows as h² (b(h) ≈ c·h²), so the estimates at h and at h/k differ by (1 − 1/k²) of b(h):
//! b(h) ≈ k²/(k² − 1) · (L(h) − L(h/k)). A finer scale rather than the 2h: the pairs
//! within h/k are 1/k² of those within h, so the second splat costs a fraction of the first,
//! where 2h would cost four times as much. k = 4 rather than 2: where a feature (a narrow
//! shadow) is narrower than h/2, L(h) and L(h/2) both read its surroundings and their
//! difference misses the bias, which h/4 still resolves (docs/deviations.md §51, measured on
//! Šibenik's apse and the apartment). Each pass's bias estimate b_i is averaged like the image,
//! and its own noise, Var(b̄), is taken off its square: bias² ≈ b̄² − Var(b̄) (summed over
//! pixels before clamping at zero, so the noise does not add up as a positive bias).
//!
//! All of it is per pixel on luminance (ten sums a pixel, in f64 against cancellation); a
//! pixel's relative error is applied to each channel as `compare`'s relMSE weighs it,
//! (x − r)² / (r² + 0.01), with the image less its estimated bias in place of the reference r
//! (the bias counted only where the passes show it above their noise, [`BIAS_SIGNIFICANCE`]).

use crate::film::Film;
use crate::sampling::luminance;
use glam::Vec3;

/// The estimated error of an image, in `compare`'s relMSE units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ErrorEstimate {
    /// Estimated relMSE: bias² plus variance.
    pub rel_mse: f64,
    /// Its kernel-bias part (bias² with its own noise taken off).
    pub bias2: f64,
    /// The part of the bias² that follows the bandwidth as h⁴, for `--c auto`: the bias
    /// averaged over [`BIAS_POOL_SMOOTH`] before it is squared, which keeps the bias that changes
    /// on the kernels' scale and cancels that of features narrower than the box, where the
    /// kernel is saturated and a smaller C barely changes it (docs/deviations.md §51).
    pub bias2_smooth: f64,
    /// Its variance part (everything the passes' spread shows: splatted light, direct light,
    /// anti-aliasing).
    pub variance: f64,
    /// The variance of the splatted (indirect and caustic) light alone (photons and eye
    /// samples both).
    pub variance_splatted: f64,
    /// The photons' share of the variance, the part a wider kernel smooths (for `--c auto`):
    /// from the spread of L(h) − L(h/k), in which the eye samples' noise cancels
    /// ([`DIFFERENCE_VARIANCE`]).
    pub variance_photons: f64,
    /// Eye passes the estimate is made from.
    pub passes: u32,
}

/// The spread of fewer passes says little (a blotchy two-pass image read 0.0001 in the
/// window): `--c auto`, the window's pause and `--until-error` wait for this many
/// ([`ErrorEstimate::trusted`]).
pub const TRUSTED_PASSES: u32 = 4;

impl ErrorEstimate {
    /// Made from enough passes to act on ([`TRUSTED_PASSES`]).
    pub fn trusted(&self) -> bool {
        self.passes >= TRUSTED_PASSES
    }
}

/// Per pixel, Σw·x and Σw·x² of each of y, s, b, d, a (y: the film's luminance, s: the
/// splatted light's, b: the pass's bias estimate, d: its L(h) − L(h/k) unpooled, a: its bias
/// averaged over the wider box).
const SUMS: usize = 10;

/// Bytes a pixel of the estimate holds: the finished passes' sums, the current pass's
/// [`PassError`] and the error map (for the memory estimate; the pass's values are made from
/// temporary per-pixel buffers of about 52 bytes, freed before the next pass).
pub const BYTES_PER_PIXEL: usize = SUMS * std::mem::size_of::<f64>()
    + std::mem::size_of::<PassError>()
    + std::mem::size_of::<f32>();

/// k: the error estimate's second splat is at h/k, every bandwidth of the batch divided by it
/// (C/k in eq. 8, its bounds with it; docs/deviations.md §51).
pub const FINE_SCALE: f32 = 4.0;

/// k²/(k² − 1): b(h) ≈ BIAS_FACTOR · (L(h) − L(h/k)) for a bias that grows as h².
pub const BIAS_FACTOR: f64 = {
    let k2 = (FINE_SCALE * FINE_SCALE) as f64;
    k2 / (k2 - 1.0)
};

/// Var(L(h) − L(h/k)) over Var(L(h)) for the same photons under the Epanechnikov kernel in
/// two dimensions, for one evaluation point where the photons' density is locally uniform and
/// neither bandwidth is clamped (a pixel of several eye samples, or rays at h_min, depart from
/// it), K_h = 2/(πh²)·(1 − r²/h²): ∫K_h² = (4/3)/(πh²), ∫K_{h/k}² = k²·(4/3)/(πh²), and
/// ∫K_h·K_{h/k} = (2 − 2/(3k²))/(πh²) (the integral over r < h/k), so the difference has
/// (4/3 + 4k²/3 − 4 + 4/(3k²))/(4/3) = (k − 1/k)² times the photons' variance at h: 9/4 at
/// k = 2, 225/16 at k = 4 (docs/deviations.md §51).
pub const DIFFERENCE_VARIANCE: f64 = {
    let k = FINE_SCALE as f64;
    (k - 1.0 / k) * (k - 1.0 / k)
};

/// z: a pixel's mean bias estimate b̄ moves the reference that relMSE divides by only as far
/// as it stands out of its noise, sign(b̄)·√max(0, b̄² − z²·Var(b̄)). Noise alone then seldom
/// moves it, where the unbiased b̄² − Var(b̄) (z = 1) let it move in a third of the pixels and,
/// through relMSE's 1/(r² + 0.01), multiplied a noisy image's estimate up to 19×
/// (docs/deviations.md §51). Var(b̄) is itself estimated from n passes, so b̄/σ̂ follows
/// Student's t with n − 1 degrees of freedom: a pixel without bias passes 3 in 5.8% of cases
/// at 4 passes ([`TRUSTED_PASSES`]), 2.0% at 8, 0.9% at 16 (0.3% for a known σ), and the
/// weight, which then depends on b̄, leaves a small upward bias in a noisy image's estimate.
pub const BIAS_SIGNIFICANCE: f64 = 3.0;

/// One pass's error-estimate values at a pixel ([`Film::pass_error`]), luminance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassError {
    /// The splat kernels' bias, [`BIAS_FACTOR`]·(L(h) − L(h/k)), pooled over [`BIAS_POOL`].
    pub bias: f32,
    /// The same pooled over [`BIAS_POOL_SMOOTH`] (for `--c auto`).
    pub bias_smooth: f32,
    /// L(h) − L(h/k) at this pixel alone (its spread measures the photons' noise).
    pub difference: f32,
    /// The light splatted by photons (what a wider kernel smooths).
    pub splatted: f32,
}

/// Each pass's bias estimate is averaged over a box of (2·BIAS_POOL + 1)² pixels before its
/// spread is taken: the difference of two splats is noisy per pixel. Only 3 × 3: the bias of a
/// feature narrower than the box (a narrow shadow) and that of the ring around it have
/// opposite signs, so a wider box cancels it (at h/4, 7 × 7 saw two thirds of the bias of
/// Šibenik's apse that 3 × 3 sees, three quarters of the apartment's; docs/deviations.md §51).
pub const BIAS_POOL: usize = 1;

/// The box (2·BIAS_POOL_SMOOTH + 1)² over which `--c auto`'s bias is averaged
/// ([`ErrorEstimate::bias2_smooth`]): 7 × 7, as the whole estimate was before the finer
/// scale.
pub const BIAS_POOL_SMOOTH: usize = 3;

/// `bias` (one value per pixel of a `width`-wide image) averaged over a box of
/// (2·`radius` + 1)² pixels ([`BIAS_POOL`], [`BIAS_POOL_SMOOTH`]), clipped at the borders: two
/// running-sum passes.
pub fn pool_bias(bias: &mut [f32], width: usize, radius: usize) {
    if width == 0 || bias.is_empty() {
        return;
    }
    let height = bias.len() / width;
    let mut tmp = vec![0.0f32; bias.len()];
    let mut prefix = vec![0.0f64; width.max(height) + 1];
    // Rows into `tmp`, then columns back: element i of line `start` + i·`stride`.
    box_lines(bias, &mut tmp, height, width, width, 1, radius, &mut prefix);
    box_lines(&tmp, bias, width, height, 1, width, radius, &mut prefix);
}

/// A running-sum box of radius `r` along `lines` lines of `n` values each, line l starting at
/// l·`line_step` with its values `stride` apart, from `src` into `dst`.
#[allow(clippy::too_many_arguments)]
fn box_lines(
    src: &[f32],
    dst: &mut [f32],
    lines: usize,
    n: usize,
    line_step: usize,
    stride: usize,
    r: usize,
    prefix: &mut [f64],
) {
    for l in 0..lines {
        let at = |i: usize| l * line_step + i * stride;
        for i in 0..n {
            prefix[i + 1] = prefix[i] + src[at(i)] as f64;
        }
        for i in 0..n {
            let (lo, hi) = (i.saturating_sub(r), (i + r + 1).min(n));
            dst[at(i)] = ((prefix[hi] - prefix[lo]) / (hi - lo) as f64) as f32;
        }
    }
}

/// A pixel of colour `c` with a squared luminance error `e`, in `compare`'s relMSE units: its
/// relative error e/y² applied to each channel as relMSE weighs it, (x − r)²/(r² + 0.01), with
/// `reference` times the pixel's own value in place of the reference's r (the image less its
/// estimated bias, as a share of the image; 1 for an unbiased image); 0 where the pixel is
/// black.
#[inline]
fn weigh(e: f64, c: Vec3, reference: f64) -> f64 {
    let y = luminance(c) as f64;
    if y <= 0.0 {
        return 0.0;
    }
    let rel = e / (y * y);
    (0..3)
        .map(|k| {
            let x = c[k] as f64;
            let r = reference * x;
            rel * x * x / (r * r + 0.01)
        })
        .sum::<f64>()
        / 3.0
}

/// The error of a mean of `n` independent samples per pixel (a path tracer's image), from each
/// pixel's mean colour and Σ of its samples' squared luminance: the variance of the mean,
/// (Σy² − n·ȳ²)/(n(n − 1)), in relMSE units, and its map (relative RMS per pixel). No bias
/// (an unbiased estimator). None below two samples.
pub fn of_independent_samples(
    mean: &[Vec3],
    sum_sq: &[f64],
    n: u32,
    map: &mut Vec<f32>,
) -> Option<ErrorEstimate> {
    map.clear();
    if n < 2 || mean.len() != sum_sq.len() {
        return None;
    }
    let n = n as f64;
    let mut variance = 0.0;
    for (c, &s2) in mean.iter().zip(sum_sq) {
        let y = luminance(*c) as f64;
        let v = ((s2 - n * y * y) / (n * (n - 1.0))).max(0.0);
        variance += weigh(v, *c, 1.0);
        map.push(if y > 0.0 {
            (v / (y * y)).sqrt() as f32
        } else {
            0.0
        });
    }
    let variance = variance / mean.len().max(1) as f64;
    Some(ErrorEstimate {
        rel_mse: variance,
        variance,
        passes: n as u32,
        ..ErrorEstimate::default()
    })
}

/// The finished passes' sums for [`ErrorEstimate`].
#[derive(Clone, Debug, Default)]
pub struct PassSpread {
    sums: Vec<[f64; SUMS]>,
    /// Σ w² over the passes.
    w2: f64,
    /// Σ w over the passes.
    w: f64,
    /// Passes added (with a weight above zero).
    passes: u32,
}

/// One eye pass's own film (not blended with the others): its image, and its bias estimate
/// and splatted light per pixel.
#[derive(Clone, Copy)]
pub struct PassValues<'a> {
    /// The image.
    pub rgb: &'a [Vec3],
    /// Its [`Film::pass_error`].
    pub pass: &'a [PassError],
}

impl<'a> PassValues<'a> {
    /// A film's values.
    pub fn of(film: &'a Film) -> Self {
        Self {
            rgb: &film.rgb,
            pass: &film.pass_error,
        }
    }

    /// The values at pixel `p` (luminance, splatted light, bias, difference, smooth bias).
    #[inline]
    fn at(&self, p: usize) -> [f64; 5] {
        let e = self.pass.get(p).copied().unwrap_or_default();
        [
            luminance(self.rgb[p]) as f64,
            e.splatted as f64,
            e.bias as f64,
            e.difference as f64,
            e.bias_smooth as f64,
        ]
    }
}

/// Add pass values y, s, b, d, a with weight `w` to a pixel's sums.
#[inline]
fn add_to(s: &mut [f64; SUMS], w: f64, values: [f64; 5]) {
    for (k, x) in values.into_iter().enumerate() {
        s[2 * k] += w * x;
        s[2 * k + 1] += w * x * x;
    }
}

/// Value k's (y, s, b, d, a: 0–4) weighted mean Σw·x/W and weighted spread
/// S = Σ w (x − x̄)² from a pixel's sums, for passes of total weight `w`.
#[inline]
fn mean_and_spread(s: &[f64; SUMS], k: usize, w: f64) -> (f64, f64) {
    let (sx, sxx) = (s[2 * k], s[2 * k + 1]);
    let mean = sx / w;
    (mean, (sxx - mean * sx).max(0.0))
}

impl PassSpread {
    /// Add a finished pass's `film` (its own, not blended) holding `batches` batches.
    pub fn add(&mut self, film: PassValues, batches: usize) {
        let n = film.rgb.len();
        if self.sums.len() != n {
            *self = Self {
                sums: vec![[0.0; SUMS]; n],
                ..Self::default()
            };
        }
        if batches == 0 {
            return;
        }
        let w = batches as f64;
        for (p, s) in self.sums.iter_mut().enumerate() {
            add_to(s, w, film.at(p));
        }
        self.w += w;
        self.w2 += w * w;
        self.passes += 1;
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.sums.len() * std::mem::size_of::<[f64; SUMS]>()
    }

    /// Passes added with a weight above zero.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The estimate for the image whose pixel `p` is `blended(p)` (the batch-weighted mean of
    /// every pass, given as a function so that no image-sized copy is made), with the current
    /// pass `current` of `batches` batches counted as one more pass (none: the finished passes
    /// alone, `blended` then being their mean). None before two passes, and for a black image
    /// (nothing to be wrong about: a camera outside the scene). `map`, when given, receives
    /// each pixel's relative RMS error √(b² + v)/r against the estimated reference r (the
    /// image less its bias where the bias stands out of its noise; 0 where the image is black).
    pub fn estimate(
        &self,
        blended: impl Fn(usize) -> Vec3,
        current: Option<(PassValues, usize)>,
        mut map: Option<&mut Vec<f32>>,
    ) -> Option<ErrorEstimate> {
        let (cw, cur) = match current {
            Some((f, b)) if b > 0 && f.rgb.len() == self.sums.len() => (b as f64, Some(f)),
            _ => (0.0, None),
        };
        let passes = self.passes + cur.is_some() as u32;
        if passes < 2 {
            return None;
        }
        let w = self.w + cw;
        let w2 = self.w2 + cw * cw;
        let n1 = (passes - 1) as f64;
        // E[S] = α·(W − Σw²/W) + β·(n − 1) for a value of both parts (module docs).
        let alpha_weight = w - w2 / w;
        if let Some(m) = map.as_deref_mut() {
            m.clear();
            m.reserve(self.sums.len());
        }
        let (mut bias2, mut variance, mut splatted, mut photons) = (0.0f64, 0.0, 0.0, 0.0);
        let mut bias2_smooth = 0.0f64;
        let mut lit = false;
        for (p, s) in self.sums.iter().enumerate() {
            let mut s = *s;
            if let Some(f) = cur {
                add_to(&mut s, cw, f.at(p));
            }
            let c = blended(p);
            let y = luminance(c) as f64;
            lit |= y > 0.0;
            let spread = |k: usize| mean_and_spread(&s, k, w);
            // The photons' variance per batch, β, from the difference's spread: Var(d_i) =
            // DIFFERENCE_VARIANCE·β/w_i.
            let (_, s_d) = spread(3);
            let beta = s_d / (n1 * DIFFERENCE_VARIANCE);
            // The variance of the mean of a value of both parts (the image, the splatted
            // light): α from its spread less the photons' share, then α·Σw²/W² + β/W. Not
            // clamped per pixel (summed first, as the bias² is).
            let both = |k: usize| {
                let alpha = (spread(k).1 - beta * n1) / alpha_weight;
                alpha * w2 / (w * w) + beta / w
            };
            // The variance of the mean of a value of the photons alone.
            let photons_only = |k: usize| {
                let (mean, s_x) = spread(k);
                (mean, s_x / (n1 * w))
            };
            let v = both(0);
            let vs = both(1);
            let (b_mean, vb) = photons_only(2);
            let b2 = b_mean * b_mean - vb;
            let (a_mean, va) = photons_only(4);
            let a2 = a_mean * a_mean - va;
            // The reference relMSE divides by: the image less its bias where the bias stands
            // out of its noise.
            let z2 = BIAS_SIGNIFICANCE * BIAS_SIGNIFICANCE;
            let bias = b_mean.signum() * (b_mean * b_mean - z2 * vb).max(0.0).sqrt();
            let reference = if y > 0.0 {
                (1.0 - bias / y).max(0.0)
            } else {
                1.0
            };
            // The pixel's relative error, applied to each channel as relMSE weighs it.
            let weigh_own = |e: f64| weigh(e, c, 1.0);
            let weigh = |e: f64| weigh(e, c, reference);
            bias2 += weigh(b2);
            // `--c auto`'s two terms keep the image's own value as the reference: the
            // estimated reference is lowest where the kernels are saturated (a narrow shadow
            // 4× too bright), and weighing those pixels up would ask a smaller C to mend a
            // bias that a smaller C barely changes (docs/deviations.md §51).
            bias2_smooth += weigh_own(a2);
            variance += weigh(v);
            splatted += weigh(vs);
            photons += weigh_own(beta / w);
            if let Some(m) = map.as_deref_mut() {
                // Relative to the estimated reference, as the error against a reference is
                // (`film::error::relative_errors`: 1 where the reference is black).
                let r = reference * y;
                let rel = if r > 1e-6 {
                    (b2.max(0.0) + v.max(0.0)).sqrt() / r
                } else if y > 0.0 {
                    1.0
                } else {
                    0.0
                };
                m.push(rel as f32);
            }
        }
        if !lit {
            if let Some(m) = map {
                m.clear();
            }
            return None;
        }
        let n = self.sums.len().max(1) as f64;
        if !(bias2 + bias2_smooth + variance + splatted + photons).is_finite() {
            // A non-finite pixel (the film's guards make it unlikely): no estimate rather than
            // one that no threshold is ever below.
            if let Some(m) = map {
                m.clear();
            }
            return None;
        }
        let bias2 = (bias2 / n).max(0.0);
        let bias2_smooth = (bias2_smooth / n).max(0.0);
        let variance = (variance / n).max(0.0);
        let splatted = splatted.max(0.0);
        Some(ErrorEstimate {
            rel_mse: bias2 + variance,
            bias2,
            bias2_smooth,
            variance,
            variance_splatted: splatted / n,
            variance_photons: photons / n,
            passes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each box (the reported bias's and auto's) keeps a constant, spreads a spike evenly over
    /// (2r + 1)² pixels inside the image, and clips at the border (a corner pixel averages
    /// (r + 1)² pixels).
    #[test]
    fn the_bias_pools_are_clipped_boxes() {
        let (w, h) = (20, 15);
        for r in [BIAS_POOL, BIAS_POOL_SMOOTH] {
            let mut c = vec![0.5f32; w * h];
            pool_bias(&mut c, w, r);
            assert!(c.iter().all(|v| (v - 0.5).abs() < 1e-6));
            let k = (2 * r + 1) as f32;
            let mut spike = vec![0.0f32; w * h];
            spike[7 * w + 9] = k * k;
            pool_bias(&mut spike, w, r);
            assert!((spike[7 * w + 9] - 1.0).abs() < 1e-5);
            assert!((spike[(7 + r) * w + 9 - r] - 1.0).abs() < 1e-5);
            assert_eq!(spike[(7 + r + 1) * w + 9], 0.0);
            let m = (r + 1) as f32;
            let mut corner = vec![0.0f32; w * h];
            corner[0] = m * m;
            pool_bias(&mut corner, w, r);
            assert!((corner[0] - 1.0).abs() < 1e-5);
        }
    }

    /// relMSE divides by the reference: a pixel whose every pass reads 0.2 with a bias of
    /// 0.16 (a narrow shadow, truly 0.04) has its bias² weighed against 0.04, 0.16²/(0.04² +
    /// 0.01) = 2.207, not against its own 0.2 (0.512, which `--c auto`'s smooth bias² keeps).
    /// A bias that is only noise (±0.16 about zero) leaves the reference at the image's value.
    #[test]
    fn a_bias_above_its_noise_moves_the_reference() {
        let n = 4;
        let grey = vec![Vec3::splat(0.2); n];
        let run = |biases: &[f32]| {
            let mut spread = PassSpread::default();
            for &b in biases {
                let e = vec![
                    PassError {
                        bias: b,
                        bias_smooth: b,
                        ..PassError::default()
                    };
                    n
                ];
                spread.add(
                    PassValues {
                        rgb: &grey,
                        pass: &e,
                    },
                    1,
                );
            }
            let mut map = Vec::new();
            let e = spread
                .estimate(|_| Vec3::splat(0.2), None, Some(&mut map))
                .unwrap();
            (e, map)
        };
        let (certain, map) = run(&[0.16; 8]);
        assert!(
            (certain.bias2 - 0.0256 / 0.0116).abs() < 1e-4,
            "{certain:?}"
        );
        // `--c auto`'s bias² keeps the image's own value: 0.16²/(0.2² + 0.01).
        assert!(
            (certain.bias2_smooth - 0.0256 / 0.05).abs() < 1e-4,
            "{certain:?}"
        );
        // The error map, like the error against a reference, is relative to it: 0.16/0.04.
        assert!(map.iter().all(|&m| (m - 4.0).abs() < 1e-4), "{map:?}");
        let (noise, map) = run(&[0.16, -0.16, 0.16, -0.16, 0.16, -0.16, 0.16, -0.16]);
        assert_eq!(noise.bias2, 0.0, "{noise:?}");
        // A bias that is only noise, and passes that agree: no error in the map.
        assert!(map.iter().all(|&m| m == 0.0), "{map:?}");
        // The variance (the passes agree: none) and auto's own-value terms are untouched.
        assert_eq!(certain.variance, 0.0);
    }

    /// Two grey samples 1 and 3 per pixel: mean 2, variance of the mean s²/n = 2/2 = 1,
    /// relative ¼, weighed per channel as relMSE does.
    #[test]
    fn independent_samples_give_the_variance_of_their_mean() {
        let mean = vec![Vec3::splat(2.0); 4];
        let sum_sq = vec![1.0 + 9.0; 4];
        let mut map = Vec::new();
        let e = of_independent_samples(&mean, &sum_sq, 2, &mut map).unwrap();
        assert!((e.variance - 0.25 * 4.0 / 4.01).abs() < 1e-9, "{e:?}");
        assert_eq!((e.bias2, e.passes), (0.0, 2));
        assert!(map.iter().all(|&m| (m - 0.5).abs() < 1e-6));
        assert!(of_independent_samples(&mean, &sum_sq, 1, &mut map).is_none());
    }

    /// A black image has no estimate (nothing to be wrong about), however many passes: the
    /// window's pause and auto C must not act on a zero.
    #[test]
    fn a_black_image_has_no_estimate() {
        let n = 6;
        let black = vec![Vec3::ZERO; n];
        let errors = vec![PassError::default(); n];
        let mut spread = PassSpread::default();
        for _ in 0..TRUSTED_PASSES {
            spread.add(
                PassValues {
                    rgb: &black,
                    pass: &errors,
                },
                2,
            );
        }
        let mut map = vec![1.0];
        assert_eq!(spread.estimate(|_| Vec3::ZERO, None, Some(&mut map)), None);
        assert!(map.is_empty());
    }

    /// Passes of unequal weight, as the window has them after a re-splat (one pass holding
    /// 100 batches, then eight of one): each pixel's pass values carry an eye part of variance
    /// α, which the pass's batches do not average, and a photon part of β/w, which they do;
    /// the difference L(h) − L(h/k) carries the photon part alone, times
    /// √[`DIFFERENCE_VARIANCE`]. Over 20,000 pixels the estimated variance of the mean is
    /// α·Σw²/W² + β/W within 5%. The w²-weighted spread used before has the expectation
    /// 3.3·10⁻⁵ here against the true 2.2·10⁻³: the heavy pass pulls the mean to itself, and
    /// its own eye noise went unseen.
    #[test]
    fn passes_of_unequal_weight_keep_the_heavy_passs_eye_noise() {
        let n = 20_000;
        let weights = [100u32, 1, 1, 1, 1, 1, 1, 1, 1];
        // Small against the image (5% and 10% relative), so that weighing each pixel by its
        // own noisy value, as the estimate must, adds little.
        let (alpha, beta) = (0.0025f64, 0.01f64);
        let mut rng = crate::sampling::Rng::new(7, 0);
        let mut normal = move || {
            let u1 = (rng.next_f32() as f64).max(1e-12);
            let u2 = rng.next_f32() as f64;
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let mut blended = vec![0.0f64; n];
        let mut spread = PassSpread::default();
        for &w in &weights {
            let wf = w as f64;
            let mut rgb = Vec::with_capacity(n);
            let mut errors = Vec::with_capacity(n);
            for b in blended.iter_mut() {
                let photons = (beta / wf).sqrt() * normal();
                let y = 1.0 + alpha.sqrt() * normal() + photons;
                let d = (DIFFERENCE_VARIANCE * beta / wf).sqrt() * normal();
                *b += wf * y / total;
                rgb.push(Vec3::splat(y as f32));
                errors.push(PassError {
                    difference: d as f32,
                    splatted: y as f32,
                    ..PassError::default()
                });
            }
            spread.add(
                PassValues {
                    rgb: &rgb,
                    pass: &errors,
                },
                w as usize,
            );
        }
        let e = spread
            .estimate(|p| Vec3::splat(blended[p] as f32), None, None)
            .unwrap();
        let w2: f64 = weights.iter().map(|&w| (w as f64).powi(2)).sum();
        let truth = alpha * w2 / (total * total) + beta / total;
        // relMSE against the true image, 1 everywhere.
        let expected = weigh(truth, Vec3::ONE, 1.0);
        let ratio = e.variance / expected;
        assert!(
            (ratio - 1.0).abs() < 0.05,
            "estimated {} against {expected}",
            e.variance
        );
    }

    /// Two passes of equal weight, grey 1 and grey 3, no bias: the mean is 2 and the variance
    /// of the mean s²/n = 2/2 = 1, relative 1/4, weighed per channel as relMSE does (4/4.01).
    #[test]
    fn two_passes_give_the_textbook_variance_of_their_mean() {
        let n = 6;
        let pass = |v: f32| (vec![Vec3::splat(v); n], vec![PassError::default(); n]);
        let (a, ea) = pass(1.0);
        let (b, eb) = pass(3.0);
        let mut spread = PassSpread::default();
        let of = |rgb, pass| PassValues { rgb, pass };
        spread.add(of(&a, &ea), 2);
        assert_eq!(spread.estimate(|_| Vec3::ONE, None, None), None, "one pass");
        let mut map = Vec::new();
        let e = spread
            .estimate(|_| Vec3::splat(2.0), Some((of(&b, &eb), 2)), Some(&mut map))
            .unwrap();
        // Per pixel: √(variance/y²) = √(1/4) = 0.5.
        assert_eq!(map.len(), n);
        assert!(map.iter().all(|&e| (e - 0.5).abs() < 1e-6), "{map:?}");
        let expected = 0.25 * 4.0 / 4.01;
        assert!((e.variance - expected).abs() < 1e-9, "{e:?}");
        assert_eq!(e.bias2, 0.0);
        assert_eq!(e.passes, 2);
    }
}
