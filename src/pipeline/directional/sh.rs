//! Real spherical harmonics of bands 0–3, the SH table of the normalised Phong lobe (its zonal
//! coefficients, by Funk–Hecke) and the share of the lobe's peak that bands 0–3 keep.

use super::SH_COEFFS;
use glam::Vec3;

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

/// Share of the Phong lobe's peak that bands 0–3 keep: the truncated lobe
/// Σ_l (2l+1)/(4π)·a_l at the mirror direction over the true (e+2)/(2π). Rotation-invariant.
pub fn sh_peak_share(exponent: f32) -> f32 {
    let a = phong_zonal(exponent);
    let peak: f32 = (0..4)
        .map(|l| (2 * l + 1) as f32 / (4.0 * std::f32::consts::PI) * a[l])
        .sum();
    peak / crate::bsdf::phong_lobe(1.0, exponent)
}
