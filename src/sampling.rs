//! Random numbers and the small geometric sampling routines every pass shares.
//!
//! The generator is PCG32 (O'Neill 2014), seeded per photon / per pixel from a global
//! seed and a stream index, so results do not depend on how rayon splits the work.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// PCG32 (XSH RR variant), 64-bit state.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    const MULT: u64 = 6_364_136_223_846_793_005;

    /// A generator for `stream` under `seed`; distinct streams are independent sequences.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (splitmix64(stream ^ 0x9e37_79b9_7f4a_7c15) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(splitmix64(seed));
        rng.next_u32();
        rng
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform numbers in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Veach's power heuristic (β = 2; Veach 1997, §9.2) of multiple importance sampling:
/// the weight of the sampler with density `a` against one with density `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_finite() {
        0.0
    } else {
        1.0
    }
}

// The sets of [`PixelPoints`] each decision draws from, apart so that no two share points
// (the eye pass and its first NEE draw are seeded alike).
/// NEE's light samples at eye samples.
pub const NEE_LIGHT_SET: u32 = 0;
/// NEE's BSDF samples at eye samples.
pub const NEE_BSDF_SET: u32 = 1;
/// Rough glass's light samples in the eye chain, at chain depth d from this set plus d.
pub const GLASS_LIGHT_SETS: u32 = 2;
/// The microfacet normals drawn where an eye chain splits at rough glass.
pub const GLASS_SPLIT_SET: u32 = 1 << 16;

/// One pixel's stratified sample points for a sampling decision repeated at each of its eye
/// samples (light samples, BSDF samples of NEE): an Owen-scrambled Sobol' sequence (Burley
/// 2020, "Practical Hash-based Owen Scrambling", through the `sobol_burley` crate), scrambled
/// per pixel and render seed, whose point `rank · per_sample + k` is the `k`-th draw of the
/// pixel's eye sample of rank `rank`. Every point is uniform on [0, 1)⁴ (the estimate stays
/// unbiased), and the pixel's points together are stratified: of 16 light samples in a pixel,
/// each quarter of the light's importance gets four, where independent draws leave a small
/// bright light a binomial count (docs/deviations.md §59).
#[derive(Clone, Copy, Debug)]
pub struct PixelPoints {
    seed: u32,
    rank: u32,
    per_sample: u32,
    split: bool,
}

impl PixelPoints {
    /// The points of eye sample `rank` of `pixel`, which draws `per_sample` points per set.
    pub fn new(seed: u64, pixel: u32, rank: u32, per_sample: u32) -> Self {
        let seed = splitmix64(seed ^ splitmix64(pixel as u64 ^ 0x50b0_1000_0000)) as u32;
        Self {
            seed,
            rank,
            per_sample,
            split: false,
        }
    }

    /// The points of the `j`-th of `ways` paths an eye sample splits into, with the same
    /// `per_sample`: rank `rank · ways + j` of the pixel's split paths, under a scramble of
    /// their own, so that the pixel's split paths together are stratified as its eye samples
    /// are and share no point with its unsplit ones.
    pub fn split(&self, ways: u32, j: u32) -> Self {
        Self {
            seed: splitmix64(self.seed as u64 ^ 0x5b11_7000_0000) as u32,
            rank: self.rank.saturating_mul(ways).saturating_add(j),
            split: true,
            ..*self
        }
    }

    /// These are a split path's points ([`PixelPoints::split`]): the path has split.
    pub fn is_split(&self) -> bool {
        self.split
    }

    /// These points drawing `per_sample` per set instead (a decision made once per eye
    /// sample takes one).
    pub fn per_sample(&self, per_sample: u32) -> Self {
        Self {
            per_sample,
            ..*self
        }
    }

    /// Draw `k` of this eye sample in the set `set` of four dimensions. Every set is the
    /// sequence's first four dimensions under a scramble of its own (Burley's padding, §4 of
    /// the paper above), so that each keeps their 2D stratification and the sets are
    /// independent of each other. Past the sequence's 2^16 points a pixel goes on with a
    /// fresh scramble, still uniform.
    #[inline]
    pub fn point(&self, k: u32, set: u32) -> [f32; 4] {
        let index = self.rank.saturating_mul(self.per_sample).wrapping_add(k);
        let scramble = splitmix64(((index >> 16) as u64) << 32 | set as u64) as u32;
        sobol_burley::sample_4d(index & 0xffff, 0, self.seed ^ scramble)
    }
}

/// SplitMix64's finaliser (Steele et al. 2014): a well-mixed 64-bit value from `z`, to
/// derive independent seeds from one seed and a counter.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// An orthonormal basis around `n` (Duff et al. 2017, "Building an orthonormal basis, revisited").
#[inline]
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Local (tangent-space, z up) direction to world space around `n`.
#[inline]
pub fn to_world(local: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = onb(n);
    t * local.x + b * local.y + n * local.z
}

/// Cosine-weighted hemisphere direction around +z; pdf = cos θ / π.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Shirley–Chiu concentric mapping of the unit square onto the unit disc.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Uniform direction on the unit sphere; pdf = 1 / (4π).
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of half-angle acos(`cos_max`) around +z; pdf = 1 / (2π(1 − cos_max)).
#[inline]
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform barycentrics on a triangle (the square-root mapping); returns (b1, b2).
#[inline]
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let su = u.x.sqrt();
    (1.0 - su, u.y * su)
}

/// A discrete distribution sampled by binary search over its CDF.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    cdf: Vec<f32>,
    total: f64,
}

impl Distribution1D {
    /// `None` when there is no positive weight.
    pub fn new(weights: &[f64]) -> Option<Self> {
        let total: f64 = weights.iter().filter(|w| w.is_finite() && **w > 0.0).sum();
        if total.is_nan() || total <= 0.0 || !total.is_finite() {
            return None;
        }
        let mut acc = 0.0f64;
        let cdf = weights
            .iter()
            .map(|&w| {
                if w.is_finite() && w > 0.0 {
                    acc += w;
                }
                (acc / total) as f32
            })
            .collect();
        Some(Self { cdf, total })
    }

    /// Number of outcomes (weights given, zero ones included).
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// No outcomes.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Sum of the positive, finite weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of index `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        cdf_pmf(&self.cdf, i)
    }

    /// Sample an index and where `u` fell inside its bin: (index, pmf, u remapped to [0, 1)),
    /// for a piecewise-constant continuous distribution (uniform within each bin).
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (usize, f32, f32) {
        cdf_sample_continuous(&self.cdf, u)
    }

    /// Sample an index; returns (index, pmf).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        cdf_sample(&self.cdf, u)
    }
}

/// Probability of index `i` of a normalised CDF (non-decreasing, last entry 1): what
/// [`Distribution1D`] holds, or a slice of many such CDFs stored end to end.
#[inline]
pub fn cdf_pmf(cdf: &[f32], i: usize) -> f32 {
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    cdf[i] - lo
}

/// An index of a normalised CDF drawn by `u`; returns (index, pmf).
#[inline]
pub fn cdf_sample(cdf: &[f32], u: f32) -> (usize, f32) {
    let mut i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    // Skip zero-probability entries that a rounding edge could land on.
    while cdf_pmf(cdf, i) <= 0.0 && i + 1 < cdf.len() {
        i += 1;
    }
    (i, cdf_pmf(cdf, i))
}

/// [`cdf_sample`] with where `u` fell inside its bin: (index, pmf, u remapped to [0, 1)).
#[inline]
pub fn cdf_sample_continuous(cdf: &[f32], u: f32) -> (usize, f32, f32) {
    let (i, pmf) = cdf_sample(cdf, u);
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    let within = if pmf > 0.0 {
        ((u - lo) / pmf).clamp(0.0, 1.0 - f32::EPSILON)
    } else {
        0.5
    };
    (i, pmf, within)
}

/// Rec. 709 luminance of a linear RGB triple.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel's 16 points (4 eye samples × 4 draws) are stratified: one in each sixteenth
    /// of every dimension, one in each cell of a 4×4 grid over the light's 2D sample (the
    /// set's first two dimensions). Over many pixels every one of those points, and one past
    /// the sequence's 2^16 points (a fresh scramble), is uniform: mean 1/2 and mean squared
    /// deviation 1/12 within 4.5 standard errors of 4,000 pixels (0.0206 and 6.4%), so that
    /// estimates drawn from them stay unbiased; and two sets are independent (correlation of
    /// their first dimensions within 4.5/√4000).
    #[test]
    fn pixel_points_are_stratified_and_uniform() {
        let pixels = 4000u32;
        let sets = [0, 1, 2, 9];
        // Sums of x, (x − 1/2)² per (set, rank, draw, dimension); rank 4 is 2^14, whose
        // points start at 2^16.
        let mut moments = vec![[0.0f64; 2]; sets.len() * 5 * 4 * 4];
        let mut cross = 0.0f64;
        for pixel in 0..pixels {
            for (si, &set) in sets.iter().enumerate() {
                let mut cells = [0u32; 16];
                let mut strata = [[0u32; 16]; 4];
                for (ri, rank) in [0, 1, 2, 3, 1 << 14].into_iter().enumerate() {
                    let points = PixelPoints::new(9, pixel, rank, 4);
                    for k in 0..4 {
                        let p = points.point(k, set);
                        for (d, &x) in p.iter().enumerate() {
                            assert!((0.0..1.0).contains(&x));
                            let m = &mut moments[((si * 5 + ri) * 4 + k as usize) * 4 + d];
                            m[0] += x as f64;
                            m[1] += (x as f64 - 0.5).powi(2);
                            if rank < 4 {
                                strata[d][(x * 16.0) as usize] += 1;
                            }
                        }
                        if rank < 4 {
                            cells[(p[0] * 4.0) as usize * 4 + (p[1] * 4.0) as usize] += 1;
                        }
                        if set == 0 && rank == 1 {
                            let other = points.point(k, 1)[0];
                            cross += (p[0] as f64 - 0.5) * (other as f64 - 0.5);
                        }
                    }
                }
                assert_eq!(cells, [1; 16], "pixel {pixel}, set {set}");
                assert!(
                    strata.iter().all(|s| *s == [1; 16]),
                    "pixel {pixel}, set {set}"
                );
            }
        }
        let n = pixels as f64;
        for [sum, sq] in moments {
            let (mean, var) = (sum / n, sq / n);
            assert!(
                (mean - 0.5).abs() < 4.5 * (1.0 / 12.0 / n).sqrt(),
                "mean {mean}"
            );
            // The squared deviation's own variance is 1/80 − 1/144.
            let se = ((1.0 / 80.0 - 1.0 / 144.0) / n).sqrt();
            assert!((var - 1.0 / 12.0).abs() < 4.5 * se, "variance {var}");
        }
        // Correlation of set 0's and set 1's first dimension over 4 draws of each pixel.
        let correlation = cross / (4.0 * n) * 12.0;
        assert!(
            correlation.abs() < 4.5 / (4.0 * n).sqrt(),
            "correlation {correlation}"
        );
    }

    /// Where an eye path splits (rough glass in the eye chain, docs/deviations.md §60), the
    /// pixel's 4 eye samples × 4 split paths draw their normals as 16 stratified points (one
    /// in each cell of a 4×4 grid), and the split paths' own light samples (2 each) are
    /// together stratified, one in each 32nd of a dimension, and none of them is a point
    /// of the pixel's unsplit eye samples.
    #[test]
    fn split_paths_take_points_of_their_own() {
        for pixel in 0..500 {
            let mut cells = [0u32; 16];
            let mut strata = [0u32; 32];
            let mut unsplit = Vec::new();
            let mut children = Vec::new();
            for rank in 0..4 {
                let points = PixelPoints::new(3, pixel, rank, 2);
                for k in 0..2 {
                    unsplit.push(points.point(k, 5)[0].to_bits());
                }
                for j in 0..4 {
                    let [x, y, ..] = points.per_sample(4).point(j, GLASS_SPLIT_SET);
                    cells[(x * 4.0) as usize * 4 + (y * 4.0) as usize] += 1;
                    let child = points.split(4, j);
                    for k in 0..2 {
                        let x = child.point(k, 5)[0];
                        strata[(x * 32.0) as usize] += 1;
                        children.push(x.to_bits());
                    }
                }
            }
            assert_eq!(cells, [1; 16], "pixel {pixel}");
            assert_eq!(strata, [1; 32], "pixel {pixel}");
            assert!(
                children.iter().all(|c| !unsplit.contains(c)),
                "pixel {pixel}"
            );
        }
    }

    #[test]
    fn rng_is_uniform_enough() {
        let mut rng = Rng::new(7, 3);
        let n = 200_000;
        let mut bins = [0u32; 10];
        for _ in 0..n {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
        }
        // Each bin expects n/10 = 20,000 with sd ≈ 134; 5 sd is a safe bound.
        for b in bins {
            assert!((b as i64 - 20_000).abs() < 700, "bin count {b}");
        }
    }

    #[test]
    fn streams_differ() {
        let a: Vec<u32> = (0..8)
            .scan(Rng::new(1, 0), |r, _| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..8)
            .scan(Rng::new(1, 1), |r, _| Some(r.next_u32()))
            .collect();
        assert_ne!(a, b);
    }

    #[test]
    fn onb_is_orthonormal() {
        let mut rng = Rng::new(3, 9);
        for _ in 0..1000 {
            let n = uniform_sphere(rng.next_2d());
            let (t, b) = onb(n);
            assert!((t.length() - 1.0).abs() < 1e-4);
            assert!((b.length() - 1.0).abs() < 1e-4);
            assert!(t.dot(n).abs() < 1e-4 && b.dot(n).abs() < 1e-4 && t.dot(b).abs() < 1e-4);
        }
    }

    #[test]
    fn distribution_matches_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]).unwrap();
        assert!((d.pmf(0) - 0.25).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
        assert_eq!(d.sample(0.1).0, 0);
        assert_eq!(d.sample(0.25).0, 2);
        assert_eq!(d.sample(0.999).0, 2);
        assert!(Distribution1D::new(&[0.0, f64::NAN]).is_none());
    }
}
