//! Directional bases of the radiance map (§8.1): real spherical harmonics of bands 0–3 and the
//! 20-strata histogram on the vertices of a regular dodecahedron with its directional filter.
//!
//! Directions are world-space unit vectors. Records store cos θ-weighted incident radiance (the
//! splat weight K·cos θ already holds cos θ, §8.1: "we encode the term cos θ in the radiance SH
//! coefficients"), so the reflected radiance is ∫ f(ωo, ω)·(L cos θ)(ω) dω.

use crate::choice::Choice;
use glam::Vec3;
use serde::{Deserialize, Serialize};

use std::sync::OnceLock;

/// Coefficients per colour channel in SH mode: bands l = 0..3.
pub const SH_COEFFS: usize = 16;
/// Strata of the histogram mode (§8.1: N = 20, the dodecahedron's vertices).
pub const STRATA: usize = 20;
/// Most strata one photon direction deposits into (the filter's support).
pub const FILTER_TAPS: usize = 8;
/// Cells per side of the octahedral map of photon directions: N_D = [`FILTER_RES`]².
pub const FILTER_RES: usize = 32;
/// Angular radius of the directional filter kernel around a stratum (50°): every direction
/// has at least one stratum within 37.4° (the face centres), so every direction is covered.
const FILTER_COS: f32 = 0.642_787_6;

/// The real SH basis Y_lm(d) for l ≤ 3 in the usual order (l, m = −l..l), orthonormal on the
/// sphere (Sloan, "Stupid spherical harmonics tricks", constants).
#[inline]
pub fn sh_basis(d: Vec3) -> [f32; SH_COEFFS] {
    let (x, y, z) = (d.x, d.y, d.z);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    [
        0.282_094_8,
        -0.488_602_5 * y,
        0.488_602_5 * z,
        -0.488_602_5 * x,
        1.092_548_4 * x * y,
        -1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z2 - 1.0),
        -1.092_548_4 * x * z,
        0.546_274_2 * (x2 - y2),
        -0.590_043_6 * y * (3.0 * x2 - y2),
        2.890_611_4 * x * y * z,
        -0.457_045_8 * y * (5.0 * z2 - 1.0),
        0.373_176_33 * z * (5.0 * z2 - 3.0),
        -0.457_045_8 * x * (5.0 * z2 - 1.0),
        1.445_305_7 * z * (x2 - y2),
        -0.590_043_6 * x * (x2 - 3.0 * y2),
    ]
}

/// Band of coefficient index k.
#[inline]
pub fn sh_band(k: usize) -> usize {
    match k {
        0 => 0,
        1..=3 => 1,
        4..=8 => 2,
        _ => 3,
    }
}

/// The SH table of the normalised Phong lobe g(t) = (e+2)/(2π)·max(0, t)^e: by Funk–Hecke,
/// ∫ g(r·ω) Y_lm(ω) dω = a_l · Y_lm(r) with a_l = 2π ∫_0^1 g(t) P_l(t) dt, so the table over
/// all outgoing directions is these four numbers rotated to the mirror direction r (§8.1's
/// precomputed BSDF table; docs/deviations.md). Closed forms of ∫_0^1 t^e P_l(t) dt.
pub fn phong_zonal(exponent: f32) -> [f32; 4] {
    let e = exponent as f64;
    let i0 = 1.0 / (e + 1.0);
    let i1 = 1.0 / (e + 2.0);
    let i2 = 0.5 * (3.0 / (e + 3.0) - 1.0 / (e + 1.0));
    let i3 = 0.5 * (5.0 / (e + 4.0) - 3.0 / (e + 2.0));
    [i0, i1, i2, i3].map(|i| ((e + 2.0) * i) as f32)
}

/// ∫ g(r·ω)·ρ(ω) dω for the Phong lobe around `r` and ρ given by its SH coefficients (one
/// channel): Σ_l a_l Σ_m ρ_lm Y_lm(r).
#[inline]
pub fn sh_lobe_integral(coeffs: &[f32], zonal: &[f32; 4], y_r: &[f32; SH_COEFFS]) -> f32 {
    let mut s = 0.0;
    for k in 0..SH_COEFFS {
        s += zonal[sh_band(k)] * coeffs[k] * y_r[k];
    }
    s
}

/// The 20 stratum directions: the vertices of a regular dodecahedron, normalised.
pub fn strata() -> &'static [Vec3; STRATA] {
    static S: OnceLock<[Vec3; STRATA]> = OnceLock::new();
    S.get_or_init(|| {
        let phi = (1.0 + 5f32.sqrt()) / 2.0;
        let ip = 1.0 / phi;
        let mut v = Vec::with_capacity(STRATA);
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    v.push(Vec3::new(sx, sy, sz));
                }
            }
        }
        for a in [-1.0, 1.0] {
            for b in [-1.0, 1.0] {
                v.push(Vec3::new(0.0, a * ip, b * phi));
                v.push(Vec3::new(a * ip, b * phi, 0.0));
                v.push(Vec3::new(a * phi, 0.0, b * ip));
            }
        }
        std::array::from_fn(|i| v[i].normalize())
    })
}

/// The filter weights of one photon direction: up to [`FILTER_TAPS`] strata, weights sum to 1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterTaps {
    /// The strata (indices into [`strata`]) the direction deposits into.
    pub stratum: [u8; FILTER_TAPS],
    /// Each tap's weight (zero for unused taps).
    pub weight: [f32; FILTER_TAPS],
}

/// Octahedral map of the sphere onto [0,1]² (Praun & Hoppe 2003).
#[inline]
fn octahedral(d: Vec3) -> (f32, f32) {
    let a = d.x.abs() + d.y.abs() + d.z.abs();
    let (mut u, mut v) = (d.x / a, d.y / a);
    if d.z < 0.0 {
        let (pu, pv) = (u, v);
        u = (1.0 - pv.abs()) * pu.signum();
        v = (1.0 - pu.abs()) * pv.signum();
    }
    (0.5 * (u + 1.0), 0.5 * (v + 1.0))
}

#[inline]
fn octahedral_inverse(u: f32, v: f32) -> Vec3 {
    let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum())
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).normalize()
}

/// The directional filter [Stü98] evaluated at `d`: k(d·s) = max(0, d·s − cos 50°)²,
/// normalised over the strata.
fn filter_at(d: Vec3) -> FilterTaps {
    let mut taps = FilterTaps::default();
    let mut n = 0;
    let mut sum = 0.0;
    let mut all: Vec<(f32, usize)> = strata()
        .iter()
        .enumerate()
        .map(|(i, s)| ((d.dot(*s) - FILTER_COS).max(0.0).powi(2), i))
        .filter(|(w, _)| *w > 0.0)
        .collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (w, i) in all.into_iter().take(FILTER_TAPS) {
        taps.stratum[n] = i as u8;
        taps.weight[n] = w;
        sum += w;
        n += 1;
    }
    for w in &mut taps.weight[..n] {
        *w /= sum;
    }
    taps
}

/// Precomputed filter weights for N_D = [`FILTER_RES`]² discrete photon directions (§8.1),
/// indexed by the octahedral cell of the direction.
pub fn filter_table() -> &'static [FilterTaps] {
    static T: OnceLock<Vec<FilterTaps>> = OnceLock::new();
    T.get_or_init(|| {
        (0..FILTER_RES * FILTER_RES)
            .map(|c| {
                let (i, j) = (c % FILTER_RES, c / FILTER_RES);
                let u = (i as f32 + 0.5) / FILTER_RES as f32;
                let v = (j as f32 + 0.5) / FILTER_RES as f32;
                filter_at(octahedral_inverse(u, v))
            })
            .collect()
    })
}

/// The filter taps for direction `d` (table lookup, nearest of the N_D directions).
#[inline]
pub fn filter_taps(d: Vec3) -> &'static FilterTaps {
    let (u, v) = octahedral(d);
    let i = ((u * FILTER_RES as f32) as usize).min(FILTER_RES - 1);
    let j = ((v * FILTER_RES as f32) as usize).min(FILTER_RES - 1);
    &filter_table()[j * FILTER_RES + i]
}

/// How the radiance map stores the direction of incident light at glossy samples (§8.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DirectionalMode {
    /// Irradiance only: glossy surfaces are shaded as if matte with their whole reflectance.
    Diffuse,
    /// 16 spherical-harmonic coefficients (bands 0–3) per channel at glossy samples.
    #[default]
    Sh,
    /// 20 directional strata (dodecahedron vertices) per channel at glossy samples.
    Histogram,
}

impl DirectionalMode {
    /// Floats per directional record (all three channels).
    pub fn record_floats(self) -> usize {
        match self {
            DirectionalMode::Diffuse => 0,
            DirectionalMode::Sh => 3 * SH_COEFFS,
            DirectionalMode::Histogram => 3 * STRATA,
        }
    }
}

impl Choice for DirectionalMode {
    const ALL: &'static [Self] = &[
        DirectionalMode::Diffuse,
        DirectionalMode::Sh,
        DirectionalMode::Histogram,
    ];

    fn name(self) -> &'static str {
        match self {
            DirectionalMode::Diffuse => "diffuse",
            DirectionalMode::Sh => "sh",
            DirectionalMode::Histogram => "histogram",
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, uniform_sphere};
    use std::f32::consts::PI;

    /// Midpoint quadrature over the sphere in (cos θ, φ): returns (direction, dω) pairs.
    fn sphere_grid(n: usize) -> Vec<(Vec3, f32)> {
        let mut out = Vec::with_capacity(2 * n * n);
        let dw = 4.0 * PI / (2 * n * n) as f32;
        for i in 0..n {
            let z = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
            let r = (1.0 - z * z).sqrt();
            for j in 0..2 * n {
                let p = (j as f32 + 0.5) * PI / n as f32;
                out.push((Vec3::new(r * p.cos(), r * p.sin(), z), dw));
            }
        }
        out
    }

    #[test]
    fn sh_basis_is_orthonormal() {
        let grid = sphere_grid(200);
        let mut gram = [[0.0f64; SH_COEFFS]; SH_COEFFS];
        for (d, dw) in &grid {
            let y = sh_basis(*d);
            for a in 0..SH_COEFFS {
                for b in 0..SH_COEFFS {
                    gram[a][b] += (y[a] * y[b] * dw) as f64;
                }
            }
        }
        for a in 0..SH_COEFFS {
            for b in 0..SH_COEFFS {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!(
                    (gram[a][b] - want).abs() < 2e-3,
                    "<Y{a},Y{b}> = {}",
                    gram[a][b]
                );
            }
        }
    }

    /// The clamped cosine max(0, d·n) projects onto the known zonal coefficients
    /// (Ramamoorthi & Hanrahan 2001: √(4π/(2l+1))·Â_l with Â_0 = π, Â_1 = 2π/3, Â_2 = π/4,
    /// Â_3 = 0) and reconstructs within 0.1 everywhere and 0.04 RMS (bands ≥ 4 are dropped;
    /// the largest error sits at the horizon's kink, as Ramamoorthi & Hanrahan report).
    #[test]
    fn clamped_cosine_projects_and_reconstructs() {
        let n = Vec3::new(0.3, -0.5, 0.81).normalize();
        let grid = sphere_grid(200);
        let mut c = [0.0f32; SH_COEFFS];
        for (d, dw) in &grid {
            let f = d.dot(n).max(0.0);
            let y = sh_basis(*d);
            for k in 0..SH_COEFFS {
                c[k] += f * y[k] * dw;
            }
        }
        // Expected: a_l Y_lm(n) with a_l = 2π ∫ max(0,t) P_l(t) dt = (2π/3)·... via Funk–Hecke.
        let a = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0];
        let yn = sh_basis(n);
        for k in 0..SH_COEFFS {
            assert!(
                (c[k] - a[sh_band(k)] * yn[k]).abs() < 2e-3,
                "coefficient {k}: {} vs {}",
                c[k],
                a[sh_band(k)] * yn[k]
            );
        }
        let (mut max_err, mut sq) = (0.0f32, 0.0f32);
        for (d, dw) in &grid {
            let y = sh_basis(*d);
            let rec: f32 = (0..SH_COEFFS).map(|k| c[k] * y[k]).sum();
            let e = rec - d.dot(n).max(0.0);
            max_err = max_err.max(e.abs());
            sq += e * e * dw;
        }
        let rms = (sq / (4.0 * PI)).sqrt();
        assert!(max_err < 0.1, "max reconstruction error {max_err}");
        assert!(rms < 0.04, "RMS reconstruction error {rms}");
    }

    /// Funk–Hecke rotation of the zonal table equals brute-force projection of the lobe.
    #[test]
    fn phong_zonal_matches_numeric_projection() {
        for e in [1.0f32, 4.0, 9.2, 30.0] {
            let r = Vec3::new(-0.2, 0.7, 0.4).normalize();
            let grid = sphere_grid(300);
            let mut c = [0.0f32; SH_COEFFS];
            for (d, dw) in &grid {
                let g = crate::bsdf::phong_lobe(d.dot(r), e);
                let y = sh_basis(*d);
                for k in 0..SH_COEFFS {
                    c[k] += g * y[k] * dw;
                }
            }
            let z = phong_zonal(e);
            let yr = sh_basis(r);
            for k in 0..SH_COEFFS {
                let want = z[sh_band(k)] * yr[k];
                assert!(
                    (c[k] - want).abs() < 5e-3 * (1.0 + e / 10.0),
                    "e={e} k={k}: {} vs {want}",
                    c[k]
                );
            }
        }
    }

    #[test]
    fn strata_are_a_regular_dodecahedron() {
        let s = strata();
        for a in s {
            // Three nearest neighbours at 41.81°.
            let near = s
                .iter()
                .filter(|b| (a.dot(**b) - 0.745_356).abs() < 1e-4)
                .count();
            assert_eq!(near, 3);
        }
        let sum: Vec3 = s.iter().copied().sum();
        assert!(sum.length() < 1e-5);
    }

    #[test]
    fn filter_is_a_partition_of_unity_favouring_the_nearest_stratum() {
        let mut rng = Rng::new(3, 4);
        for _ in 0..2000 {
            let d = uniform_sphere(rng.next_2d());
            let t = filter_taps(d);
            let sum: f32 = t.weight.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5);
            let nearest = (0..STRATA)
                .max_by(|&a, &b| d.dot(strata()[a]).total_cmp(&d.dot(strata()[b])))
                .unwrap();
            // The table is per cell: its direction is within a cell of d, so the top tap is
            // the nearest stratum or one next to it.
            assert!(strata()[t.stratum[0] as usize].dot(strata()[nearest]) > 0.7);
        }
    }

    /// Each stratum's filter footprint has solid angle 4π/20 (the dodecahedron's symmetry):
    /// spreading every stratum's sum over its footprint keeps the total.
    #[test]
    fn filter_footprints_share_the_sphere_equally() {
        let mut h = [0.0f32; STRATA * 3];
        for (i, v) in h.iter_mut().enumerate() {
            *v = (i % 7) as f32 * 0.1 + 0.05;
        }
        let grid = sphere_grid(200);
        // Integrate the plain footprints (no surface).
        let total: Vec3 = grid
            .iter()
            .map(|(d, dw)| {
                let t = filter_taps(*d);
                let mut s = Vec3::ZERO;
                for k in 0..FILTER_TAPS {
                    let i = t.stratum[k] as usize * 3;
                    s += t.weight[k] * Vec3::new(h[i], h[i + 1], h[i + 2]);
                }
                s * (STRATA as f32 / (4.0 * PI)) * *dw
            })
            .sum();
        let want = Vec3::new(
            h.iter().step_by(3).sum(),
            h.iter().skip(1).step_by(3).sum(),
            h.iter().skip(2).step_by(3).sum(),
        );
        assert!(
            ((total - want) / want).abs().max_element() < 0.03,
            "{total} vs {want}"
        );
    }
}
