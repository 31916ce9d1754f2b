//! Eq. 8: the bandwidth of a photon-ray vertex from the user's C, S, R, the class size M and
//! the pilot's statistics; and how many rays sit at its clamps.

use super::{M0, PhotonRay, Pilot, R_MIN};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// User bandwidth parameters (§6, eq. 8).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandwidthParams {
    /// C, smoothness.
    pub smoothness_c: f32,
    /// S ∈ (0, 1], sensitivity.
    pub sensitivity_s: f32,
    /// R ∈ (0, 1], the bandwidth range: every h lies within [R·h̄, h̄/R] of the typical
    /// bandwidth h̄ = C·(M/10⁵)^(−1/6)·μC (§6's bounds "from μC and R"; docs/deviations.md §5).
    pub max_bandwidth_r: f32,
    /// K of the floor from the photons actually stored (issue 30; docs/deviations.md §63):
    /// no ray's end bandwidth is narrower than C times the radius holding K rays of its
    /// class's M where it lands ([`super::HitDensity`]); 0 turns the floor off.
    #[serde(default = "default_floor_neighbours")]
    pub floor_neighbours: f32,
}

fn default_floor_neighbours() -> f32 {
    super::FLOOR_NEIGHBOURS
}

impl Default for BandwidthParams {
    fn default() -> Self {
        Self {
            smoothness_c: 1.0,
            sensitivity_s: 0.4,
            max_bandwidth_r: 0.2,
            floor_neighbours: super::FLOOR_NEIGHBOURS,
        }
    }
}

/// The extra exponent of the progressive bandwidth schedule ([`Bandwidth::progressive`]):
/// beyond the first batch h shrinks as M^(−1/6 − 1/6) = M^(−1/3). Still consistent (h → 0
/// while M·h² grows as M^(1/3)); the window's error is bias-dominated (first-order kernel
/// bias at concave corners), and the faster shrink cut its relMSE at 30 s by 16–34% on four
/// scenes (docs/deviations.md §43, where 0 and 1/12 are measured too).
pub const PROGRESSIVE_SHRINK: f64 = 1.0 / 6.0;

/// The typical bandwidth at C = 1 of a class of `m` rays, (M/10⁵)^(−1/6)·μC: eq. 8's
/// geometric mean over the pilot (§6; docs/deviations.md §5).
pub fn typical_at_c1(mu_c: f32, m: f32) -> f32 {
    (m.max(1.0) / 1e5).powf(-1.0 / 6.0) * mu_c
}

/// Eq. 8 evaluated for one parameter set and class size; cheap per-vertex evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Bandwidth {
    /// C·M^(−1/6)·w (eq. 8 without the per-vertex factor).
    scale: f32,
    half_s: f32,
    /// Smallest bandwidth, R·h̄ (§6's lower bound; scene units).
    pub h_min: f32,
    /// Largest bandwidth, h̄/R (§6's upper bound; scene units).
    pub h_max: f32,
    /// C·√K/√M: a ray's floor is this times its φ ([`super::HitDensity::phi`]; 0 without
    /// a floor).
    floor_scale: f32,
}

impl Bandwidth {
    /// Eq. 8 for the user's C, S, R (`params`), the pilot's μC, the class's photon count M = `m`
    /// and the pilot's ⟨r⟩ = `mean_r` (see [`Pilot::mean_r`]): w = m0·μC/⟨r⟩ (§6).
    pub fn new(params: &BandwidthParams, pilot: &Pilot, m: u64, mean_r: f32) -> Self {
        let m = m.max(1) as f32;
        let mu_c = pilot.mu_c();
        let w = M0 * mu_c / mean_r; // w = m0·μC/⟨r⟩ (§6)
        let scale = params.smoothness_c * m.powf(-1.0 / 6.0) * w; // eq. 8: C/⁶√M · w
        // The typical bandwidth at this M, C·(M/10⁵)^(−1/6)·μC (the geometric mean of eq. 8
        // over the pilot); the bounds "from μC and R" (§6) keep h within a factor 1/R of it.
        let typical = (params.smoothness_c * typical_at_c1(mu_c, m)).max(1e-30);
        let r = params.max_bandwidth_r.clamp(R_MIN, 1.0);
        // The floor's radius holds K of the class's M rays: √(K/(π·M·ρ)) = √K·φ/√M
        // (docs/deviations.md §63), times C as every bandwidth of eq. 8.
        let k = params.floor_neighbours.max(0.0);
        Self {
            scale,
            half_s: 0.5 * params.sensitivity_s,
            h_min: typical * r,
            h_max: typical / r,
            floor_scale: params.smoothness_c * (k / m).sqrt(),
        }
    }

    /// Eq. 8 for the total M = `m` of a progressive render whose batches store about
    /// `m_first` rays of the class each (M₁; 0: eq. 8 alone), shrunk beyond one batch by
    /// (M/M₁)^(−[`PROGRESSIVE_SHRINK`]): so h and its bounds h_min, h_max fall as M^(−1/3)
    /// from batch to batch, not M^(−1/6) (docs/deviations.md §43). The first batch (and any
    /// render of one batch) keeps eq. 8's bandwidth. The floor from the photons stored is
    /// not shrunk: it falls as M^(−1/2) of itself.
    pub fn progressive(
        params: &BandwidthParams,
        pilot: &Pilot,
        m: u64,
        m_first: f64,
        mean_r: f32,
    ) -> Self {
        let mut b = Self::new(params, pilot, m, mean_r);
        let f = Self::shrink(m, m_first);
        b.scale *= f;
        b.h_min *= f;
        b.h_max *= f;
        b
    }

    /// This bandwidth times `f`, bounds included: eq. 8 with C·`f`. The error estimate splats
    /// each batch again at 1/[`crate::film::estimate::FINE_SCALE`] of the bandwidth
    /// (docs/deviations.md §51).
    pub fn scaled(&self, f: f32) -> Self {
        Self {
            scale: self.scale * f,
            h_min: self.h_min * f,
            h_max: self.h_max * f,
            floor_scale: self.floor_scale * f,
            ..*self
        }
    }

    /// The progressive schedule's factor on eq. 8 at M = `m` with M₁ = `m_first`
    /// ([`Bandwidth::progressive`]): 1 up to M₁ (or without one).
    pub fn shrink(m: u64, m_first: f64) -> f32 {
        if m_first > 0.0 && m as f64 > m_first {
            (m as f64 / m_first).powf(-PROGRESSIVE_SHRINK) as f32
        } else {
            1.0
        }
    }

    /// h(x_i) for i > 0 (eq. 8): C·M^(−1/6)·w / √(p̃^S), clamped.
    #[inline]
    pub fn h(&self, pdf: f32) -> f32 {
        (self.scale * pdf.max(f32::MIN_POSITIVE).powf(-self.half_s)).clamp(self.h_min, self.h_max)
    }

    /// The floor on the end bandwidth of a ray whose φ is `phi` ([`super::HitDensity::phi`]):
    /// C·√K·φ/√M, at most h_max (docs/deviations.md §63).
    #[inline]
    pub fn floor(&self, phi: f32) -> f32 {
        if self.floor_scale > 0.0 && phi.is_finite() {
            (phi * self.floor_scale).min(self.h_max)
        } else {
            0.0
        }
    }

    /// (h0, dh) of a ray (§6) whose φ is `phi` (0: no floor): h0 = min(h(x_i), h(x_{i+1})),
    /// dh = max(0, h(x_{i+1}) − h(x_i))/|x_{i+1} − x_i|, with h(x_{i+1}) at least the floor
    /// from the photons stored ([`Self::floor`]).
    /// A ray from afar (bounce 0 with `pdf_start` > 0) is a cylinder of radius h(x_1).
    /// A ray that escapes has no end vertex: it keeps its start bandwidth (a cylinder) up to
    /// where it leaves the scene, so the bounding box only clips it. One that leaves a light
    /// in the scene and escapes starts as a point (h(x_0) = 0): it grows as a cone to the
    /// bandwidth of its end where it is cut (its `pdf_end` is eq. 7's at that length), so
    /// that it splats onto the samples it passes, such as those at a lit floor's open edge
    /// (docs/deviations.md §42; a cylinder of radius 0 splatted nothing there: −41%).
    #[inline]
    pub fn cone(&self, ray: &PhotonRay, phi: f32) -> (f32, f32) {
        let hi = if !ray.from_afar() && ray.bounce() == 0 {
            0.0 // h(x_0) = 0 (eq. 8); a ray from afar has pdf_start > 0: a cylinder
        } else {
            self.h(ray.pdf_start)
        };
        if ray.escapes() && hi > 0.0 {
            return (hi, 0.0);
        }
        let hj = self.h(ray.pdf_end).max(self.floor(phi));
        let dh = (hj - hi).max(0.0) / ray.length.max(1e-12);
        (hi.min(hj), dh)
    }
}

/// Rays of one class whose cone sits at a bandwidth bound: `at_min` start at h_min (h0 =
/// h_min), `at_max` end at h_max. A healthy eq. 8 leaves few at either (docs/deviations.md §5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClampCounts {
    /// Rays of the class counted.
    pub rays: u64,
    /// Rays whose cone starts at h_min (for a ray leaving the light: ends there).
    pub at_min: u64,
    /// Rays whose cone ends at h_max.
    pub at_max: u64,
    /// Rays whose end bandwidth is the floor from the photons stored, wider than eq. 8's
    /// (docs/deviations.md §63).
    #[serde(default)]
    pub at_floor: u64,
}

impl ClampCounts {
    /// Count the rays of every class in `rays`, whose φ are `phis` (empty: no floor), each
    /// under its class's bandwidth of `bw`, in one pass.
    pub fn count(rays: &[PhotonRay], phis: &[f32], bw: &[Bandwidth; 3]) -> [Self; 3] {
        debug_assert!(phis.is_empty() || phis.len() == rays.len());
        rays.par_iter()
            .enumerate()
            .fold(
                || [Self::default(); 3],
                |mut counts, (i, r)| {
                    let (bw, c) = (&bw[r.class() as usize], &mut counts[r.class() as usize]);
                    let phi = super::phi_at(phis, i);
                    let (h0, dh) = bw.cone(r, phi);
                    let h_end = h0 + dh * r.length;
                    c.at_floor += (bw.floor(phi) > bw.h(r.pdf_end)) as u64;
                    c.rays += 1;
                    // h(x_0) = 0 is eq. 8's own start, not a clamp: a ray leaving the light is
                    // at h_min when its end is.
                    c.at_min += (if r.bounce() == 0 { h_end } else { h0 } <= bw.h_min) as u64;
                    c.at_max += (h_end >= bw.h_max) as u64;
                    counts
                },
            )
            .reduce(
                || [Self::default(); 3],
                |mut a, b| {
                    for (a, b) in a.iter_mut().zip(b) {
                        *a += b;
                    }
                    a
                },
            )
    }

    /// `at_min / rays` (0 without rays).
    pub fn fraction_min(&self) -> f64 {
        self.at_min as f64 / self.rays.max(1) as f64
    }

    /// `at_max / rays` (0 without rays).
    pub fn fraction_max(&self) -> f64 {
        self.at_max as f64 / self.rays.max(1) as f64
    }

    /// `at_floor / rays` (0 without rays).
    pub fn fraction_floor(&self) -> f64 {
        self.at_floor as f64 / self.rays.max(1) as f64
    }
}

impl std::ops::AddAssign for ClampCounts {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.at_min += o.at_min;
        self.at_max += o.at_max;
        self.at_floor += o.at_floor;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::photon::PhotonClass;
    use glam::Vec3;

    /// A pilot whose vertices had these p̃ (equal weights).
    fn pilot(pdfs: Vec<f32>) -> Pilot {
        let n = pdfs.len();
        Pilot {
            mean_length: 0.5,
            mean_log_pdf: pdfs.iter().map(|&p| (p as f64).ln()).sum::<f64>() / n.max(1) as f64,
            vertices: n,
        }
    }

    /// An indirect ray of length 2 along x, landing, with p̃ `pdf_start` and `pdf_end`.
    fn indirect_ray(pdf_start: f32, pdf_end: f32) -> PhotonRay {
        PhotonRay {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            length: 2.0,
            power: Vec3::ONE,
            origin_normal: crate::pack::OctOrZero::new(Vec3::X),
            end_shading_ratio: 1.0,
            pdf_start,
            pdf_end,
            tag: crate::pipeline::photon::RayTag::new(1, PhotonClass::Indirect, true),
            end_normal: crate::pack::OctOrZero::new(-Vec3::X),
        }
    }

    #[test]
    fn m0_is_the_sixth_root_of_ten_to_the_fifth() {
        assert!((M0 - 1e5f32.powf(1.0 / 6.0)).abs() < 1e-4);
    }

    #[test]
    fn eq8_bandwidth_formula() {
        let p = pilot(vec![0.5, 2.0, 8.0]);
        let params = BandwidthParams {
            smoothness_c: 0.7,
            sensitivity_s: 0.6,
            max_bandwidth_r: R_MIN,
            ..Default::default()
        };
        let m = 50_000u64;
        let mean_r = p.mean_r(params.sensitivity_s);
        let bw = Bandwidth::new(&params, &p, m, mean_r);
        let w = M0 * p.mu_c() / mean_r;
        for pdf in [0.5f32, 2.0, 8.0] {
            // eq. 8: h = C / ⁶√M · w / √(p̃^S)
            let expect = 0.7 * (m as f32).powf(-1.0 / 6.0) * w / pdf.powf(0.6).sqrt();
            assert!((bw.h(pdf) - expect).abs() < 1e-6 * expect.max(1.0), "{pdf}");
        }
    }

    #[test]
    fn mean_bandwidth_is_mu_c_at_m_1e5_and_c_1() {
        // m0 calibrates the typical (unclamped) bandwidth to μC at M = 10⁵, C = 1 (§6); with
        // ⟨r⟩ a geometric mean, the geometric mean of h is μC.
        let pdfs: Vec<f32> = (1..200).map(|i| 0.05 * i as f32).collect();
        let p = pilot(pdfs.clone());
        let params = BandwidthParams {
            smoothness_c: 1.0,
            sensitivity_s: 0.4,
            max_bandwidth_r: R_MIN,
            ..Default::default()
        };
        let bw = Bandwidth::new(&params, &p, 100_000, p.mean_r(0.4));
        let mean = (pdfs.iter().map(|&x| (bw.h(x) as f64).ln()).sum::<f64>() / pdfs.len() as f64)
            .exp() as f32;
        assert!(
            (mean - p.mu_c()).abs() < 1e-3 * p.mu_c(),
            "{mean} vs {}",
            p.mu_c()
        );
    }

    #[test]
    fn bandwidth_falls_with_the_sixth_root_of_m() {
        let p = pilot(vec![1.0]);
        let params = BandwidthParams {
            max_bandwidth_r: R_MIN,
            ..BandwidthParams::default()
        };
        let a = Bandwidth::new(&params, &p, 1_000, 1.0).h(1.0);
        let b = Bandwidth::new(&params, &p, 64_000, 1.0).h(1.0);
        assert!((a / b - 2.0).abs() < 1e-4);
    }

    #[test]
    fn the_progressive_schedule_shrinks_as_the_cube_root_beyond_the_first_batch() {
        let p = pilot(vec![1.0]);
        let params = BandwidthParams {
            max_bandwidth_r: R_MIN,
            ..BandwidthParams::default()
        };
        let h = |m, first: f64| Bandwidth::progressive(&params, &p, m, first, 1.0);
        // The first batch keeps eq. 8; 64× its M has 1/4 of its bandwidth (eq. 8 alone: 1/2).
        assert_eq!(
            h(1_000, 1e3).h(1.0),
            Bandwidth::new(&params, &p, 1_000, 1.0).h(1.0)
        );
        assert_eq!(
            h(1_000, 0.0).h(1.0),
            Bandwidth::new(&params, &p, 1_000, 1.0).h(1.0)
        );
        let (a, b) = (h(1_000, 1e3), h(64_000, 1e3));
        assert!((a.h(1.0) / b.h(1.0) - 4.0).abs() < 1e-4);
        assert!((a.h_max / b.h_max - 4.0).abs() < 1e-4);
        assert!((a.h_min / b.h_min - 4.0).abs() < 1e-4);
        // Consistent: M·h² still grows (as M^(1/3)).
        let mh2 = |m: f32, bw: Bandwidth| m * bw.h(1.0) * bw.h(1.0);
        assert!((mh2(64_000.0, b) / mh2(1_000.0, a) - 4.0).abs() < 1e-3);
    }

    #[test]
    fn bandwidth_is_clamped() {
        let p = pilot(vec![1.0]);
        let params = BandwidthParams::default();
        let bw = Bandwidth::new(&params, &p, 100_000, 1.0);
        assert_eq!(bw.h(1e-30), bw.h_max);
        assert_eq!(bw.h(1e30), bw.h_min);
        // [R·h̄, h̄/R] around h̄ = μC at M = 10⁵, C = 1.
        assert!((bw.h_max - p.mu_c() / 0.2).abs() < 1e-6);
        assert!((bw.h_min - p.mu_c() * 0.2).abs() < 1e-6);
        // R = 1: one bandwidth for every ray; R beyond 1 is taken as 1.
        for r in [1.0, 5.0] {
            let one = Bandwidth::new(
                &BandwidthParams {
                    max_bandwidth_r: r,
                    ..params
                },
                &p,
                100_000,
                1.0,
            );
            assert_eq!(one.h(1e-3), one.h(1e3));
        }
    }

    #[test]
    fn cone_from_the_two_end_bandwidths() {
        let p = pilot(vec![1.0]);
        let bw = Bandwidth::new(
            &BandwidthParams {
                max_bandwidth_r: R_MIN,
                ..BandwidthParams::default()
            },
            &p,
            100_000,
            1.0,
        );
        let mut ray = indirect_ray(4.0, 1.0);
        // §6: h0 = min(h(x_i), h(x_{i+1})), dh = max(0, h(x_{i+1}) − h(x_i)) / length.
        let (hi, hj) = (bw.h(4.0), bw.h(1.0));
        let (h0, dh) = bw.cone(&ray, 0.0);
        assert_eq!(h0, hi.min(hj));
        assert!((dh - (hj - hi).max(0.0) / 2.0).abs() < 1e-7);
        // A shrinking bandwidth gives a cylinder of the smaller radius.
        ray.pdf_start = 1.0;
        ray.pdf_end = 4.0;
        assert_eq!(bw.cone(&ray, 0.0), (bw.h(4.0), 0.0));
        // h(x_0) = 0: the segment leaving the light starts as a point (eq. 8).
        ray.tag = crate::pipeline::photon::RayTag::new(0, ray.class(), ray.lands());
        ray.pdf_start = 0.0;
        let (h0, dh) = bw.cone(&ray, 0.0);
        assert_eq!(h0, 0.0);
        assert!((dh - bw.h(4.0) / 2.0).abs() < 1e-7);
        // A ray from afar keeps its density: a cylinder of h(x_1), also when it escapes.
        ray.pdf_start = 4.0;
        assert_eq!(bw.cone(&ray, 0.0), (bw.h(4.0), 0.0));
    }

    /// The floor from the photons stored (docs/deviations.md §63): C·√K·φ/√M, at most h_max;
    /// it raises the cone's end radius, never its start; K = 0 is eq. 8 alone; the error
    /// estimate's fine bandwidth scales it as it scales eq. 8; the progressive schedule does
    /// not shrink it.
    #[test]
    fn the_floor_raises_the_end_radius_to_c_root_k_phi_over_root_m() {
        let p = pilot(vec![0.5, 2.0, 8.0]);
        let params = BandwidthParams {
            smoothness_c: 0.5,
            floor_neighbours: 16.0,
            ..Default::default()
        };
        let m = 40_000u64;
        let mean_r = p.mean_r(params.sensitivity_s);
        let bw = Bandwidth::new(&params, &p, m, mean_r);
        let ray = indirect_ray(2.0, 2.0);
        let h = bw.h(2.0);
        // φ whose floor is twice eq. 8's radius: C·√K·φ/√M = 2h.
        let phi = 2.0 * h * (m as f32).sqrt() / (0.5 * 4.0);
        assert!((bw.floor(phi) / (2.0 * h) - 1.0).abs() < 1e-5);
        let (h0, dh) = bw.cone(&ray, phi);
        assert_eq!(h0, h);
        assert!(((h0 + dh * 2.0) / (2.0 * h) - 1.0).abs() < 1e-5);
        // Below eq. 8 it changes nothing; beyond h_max it stops there.
        assert_eq!(bw.cone(&ray, 0.25 * phi), bw.cone(&ray, 0.0));
        assert_eq!(bw.floor(1e9 * phi), bw.h_max);
        // K = 0: off.
        let off = Bandwidth::new(
            &BandwidthParams {
                floor_neighbours: 0.0,
                ..params
            },
            &p,
            m,
            mean_r,
        );
        assert_eq!(off.cone(&ray, phi), (h, 0.0));
        // The estimate's h/k: the floor scales with it.
        let fine = bw.scaled(0.25);
        assert!((fine.floor(phi) / (0.5 * h) - 1.0).abs() < 1e-5);
        // The progressive schedule shrinks eq. 8 but not the floor, which falls as M^(−1/2)
        // of itself.
        let later = Bandwidth::progressive(&params, &p, 4 * m, m as f64, mean_r);
        assert!((later.floor(phi) / (0.5 * bw.floor(phi)) - 1.0).abs() < 1e-5);
    }
}
