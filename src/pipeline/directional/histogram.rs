//! The 20-strata histogram (§8.1): the strata on the dodecahedron's vertices, the directional
//! filter \[Stü98\] that spreads a photon direction over them (tabulated over an octahedral
//! map), the lobe table that integrates a Phong lobe over each stratum's footprint, and the
//! share of the lobe's peak the strata keep.

use super::{FILTER_RES, FILTER_TAPS, STRATA};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::OnceLock;

/// Angular radius of the directional filter kernel around a stratum (50°): every direction
/// has at least one stratum within 37.4° (the face centres), so every direction is covered.
const FILTER_COS: f32 = 0.642_787_6;

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
pub(super) fn filter_at(d: Vec3) -> FilterTaps {
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

/// Exponents of the histogram's lobe table, on a grid linear in ln e from 1 to this.
/// Lobes sharper than the histogram's resolution limit are traced; the table reaches past it
/// for the few that are not (at the eye path's depth limit), and clamps beyond.
pub const HIST_TABLE_MAX_EXPONENT: f32 = 64.0;
const HIST_E_STEPS: usize = 33;
const HIST_C_STEPS: usize = 129;

/// The histogram's lobe table (§8.1's precomputed BSDF table for the strata): for exponent e
/// and c = r·s (r the mirror direction, s a stratum), Ĝ_e(c) = ∫ g_e(r·ω)·κ(ω·s) dω, the
/// normalised Phong lobe integrated over the stratum's filter footprint κ(t) = max(0, t −
/// cos 50°)² (the deposit kernel before its normalisation over the strata). Midpoint rule in
/// the footprint's polar coordinates, 32 × 64 (about 40 ms once, in parallel).
fn hist_lobe_table() -> &'static [f32] {
    static T: OnceLock<Vec<f32>> = OnceLock::new();
    T.get_or_init(|| {
        let (nt, np) = (32usize, 64usize);
        let theta_max = FILTER_COS.acos();
        let dt = theta_max / nt as f32;
        let dp = 2.0 * std::f32::consts::PI / np as f32;
        let cos_phi: Vec<f32> = (0..np).map(|j| ((j as f32 + 0.5) * dp).cos()).collect();
        let mut table = vec![0.0f32; HIST_E_STEPS * HIST_C_STEPS];
        table
            .par_chunks_mut(HIST_C_STEPS)
            .enumerate()
            .for_each(|(ei, row)| {
                let e = hist_exponent(ei);
                for (ci, out) in row.iter_mut().enumerate() {
                    let c = -1.0 + 2.0 * ci as f32 / (HIST_C_STEPS - 1) as f32;
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    let mut sum = 0.0f64;
                    for i in 0..nt {
                        let th = (i as f32 + 0.5) * dt;
                        let (st, ct) = th.sin_cos();
                        let k = (ct - FILTER_COS).max(0.0).powi(2);
                        let mut ring = 0.0f32;
                        // ω at polar angle θ around s: r·ω = c·cos θ + √(1−c²)·sin θ·cos φ.
                        for &cp in &cos_phi {
                            ring += crate::bsdf::phong_lobe(c * ct + s * st * cp, e);
                        }
                        sum += (k * ring * st * dt * dp) as f64;
                    }
                    *out = sum as f32;
                }
            });
        table
    })
}

/// Exponent of row `ei` of the histogram's lobe table.
fn hist_exponent(ei: usize) -> f32 {
    (HIST_TABLE_MAX_EXPONENT.ln() * ei as f32 / (HIST_E_STEPS - 1) as f32).exp()
}

/// The lobe table's two rows around `exponent` and the weight of the upper one.
#[inline]
fn hist_rows(exponent: f32) -> (usize, usize, f32) {
    let x = exponent.clamp(1.0, HIST_TABLE_MAX_EXPONENT).ln() / HIST_TABLE_MAX_EXPONENT.ln()
        * (HIST_E_STEPS - 1) as f32;
    let lo = (x as usize).min(HIST_E_STEPS - 2);
    (lo, lo + 1, (x - lo as f32).clamp(0.0, 1.0))
}

/// Per-stratum weights W_s of the normalised Phong lobe of `exponent` around `r` for the
/// 20-strata histogram: Σ_s W_s·h_s is the lobe integrated against the incident light, each
/// stratum's sum h_s spread over its filter footprint. The weights are Ĝ_e(r·s) normalised so
/// that Σ_s W_s·(4π/20) = ∫ g_e = (e+2)/(e+1): light arriving evenly from every direction
/// (each stratum then holds 4π/20 of it) is reflected exactly, whatever r is — the lobe's
/// whole mass is always shared among the strata, so no lobe falls between them.
#[inline]
pub fn hist_lobe_weights(r: Vec3, exponent: f32) -> [f32; STRATA] {
    let table = hist_lobe_table();
    let (lo, hi, t) = hist_rows(exponent);
    let (row_lo, row_hi) = (
        &table[lo * HIST_C_STEPS..(lo + 1) * HIST_C_STEPS],
        &table[hi * HIST_C_STEPS..(hi + 1) * HIST_C_STEPS],
    );
    let mut w = [0.0f32; STRATA];
    let mut sum = 0.0;
    for (k, s) in strata().iter().enumerate() {
        let x = (r.dot(*s).clamp(-1.0, 1.0) + 1.0) * 0.5 * (HIST_C_STEPS - 1) as f32;
        let i = (x as usize).min(HIST_C_STEPS - 2);
        let f = x - i as f32;
        let a = row_lo[i] + f * (row_lo[i + 1] - row_lo[i]);
        let b = row_hi[i] + f * (row_hi[i + 1] - row_hi[i]);
        w[k] = (a + t * (b - a)).max(0.0);
        sum += w[k];
    }
    if sum > 0.0 {
        let e = exponent.max(0.0);
        let scale = (e + 2.0) / (e + 1.0) * (STRATA as f32 / (4.0 * std::f32::consts::PI)) / sum;
        for x in &mut w {
            *x *= scale;
        }
    }
    w
}

/// Share of the Phong lobe's peak the histogram keeps for light from `d` reflected about
/// r = d: the deposit kernel's taps at d against the lobe weights.
pub fn hist_peak_share_at(d: Vec3, exponent: f32) -> f32 {
    let taps = filter_at(d);
    let w = hist_lobe_weights(d, exponent);
    let mut s = 0.0;
    for k in 0..FILTER_TAPS {
        s += taps.weight[k] * w[taps.stratum[k] as usize];
    }
    s / crate::bsdf::phong_lobe(1.0, exponent)
}

/// The histogram's peak share at its least favourable directions: the worst over a Fibonacci
/// set of 256 directions (the dodecahedron's face centres, farthest from every stratum, are
/// within a few degrees of one of them).
pub fn hist_peak_share(exponent: f32) -> f32 {
    let n = 256;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as f32 / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let p = golden * i as f32;
            hist_peak_share_at(Vec3::new(r * p.cos(), r * p.sin(), z), exponent)
        })
        .fold(f32::INFINITY, f32::min)
}
