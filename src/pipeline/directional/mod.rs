//! Directional bases of the radiance map (§8.1): real spherical harmonics of bands 0–3 and the
//! 20-strata histogram on the vertices of a regular dodecahedron with its directional filter.
//!
//! Directions are world-space unit vectors. Records store cos θ-weighted incident radiance (the
//! splat weight K·cos θ already holds cos θ, §8.1: "we encode the term cos θ in the radiance SH
//! coefficients"), so the reflected radiance is ∫ f(ωo, ω)·(L cos θ)(ω) dω.
//!
//! The SH basis and the Phong lobe's SH table are in `sh`; the strata, their directional
//! filter and their lobe table in `histogram`; here are the modes and their resolution limits.
//! Unit tests are in `tests`.

mod histogram;
mod sh;
#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests;

pub use histogram::{
    FilterTaps, HIST_TABLE_MAX_EXPONENT, filter_table, filter_taps, hist_lobe_weights,
    hist_peak_share, hist_peak_share_at, strata,
};
pub use sh::{phong_zonal, sh_band, sh_basis, sh_lobe_integral, sh_peak_share};

use crate::choice::Choice;
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

/// The resolution criterion of a directional mode: a lobe is represented faithfully while the
/// mode's reconstruction of it from light arriving along one direction (its impulse response)
/// keeps at least this share of the lobe's true peak: highlights at most 20% low. Measured on
/// the plate sweep (docs/deviations.md §37), where half the peak (the width of the mode's own
/// blur) left SH's highlight at roughness 0.65 40% low, 16× the traced lobe's error.
pub const RESOLVED_PEAK_SHARE: f32 = 0.8;

/// The largest exponent whose peak share (falling with the exponent) is at least
/// [`RESOLVED_PEAK_SHARE`], by bisection in ln e over [1, `hi`].
fn resolution_limit(share: impl Fn(f32) -> f32, hi: f32) -> f32 {
    let (mut a, mut b) = (0.0f32, hi.ln());
    if share(1.0) < RESOLVED_PEAK_SHARE {
        return 1.0;
    }
    for _ in 0..40 {
        let m = 0.5 * (a + b);
        if share(m.exp()) >= RESOLVED_PEAK_SHARE {
            a = m;
        } else {
            b = m;
        }
    }
    a.exp()
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

/// The widest GGX lobe the radiance map holds, as the Phong exponent of the same width
/// (`bsdf::phong_equivalent`): 1, roughness ≥ 0.9. A mode's own limit
/// ([`DirectionalMode::phong_limit`]) is stated for the Phong lobe, symmetric about the
/// mirror direction as the map's zonal integration assumes; a GGX lobe is not (it leans and
/// stretches at grazing angles), and through 16 SH coefficients a metal of roughness 0.75–0.9
/// came out 7–33% too bright and worse than shading it matte (`tests/glossy.rs`,
/// docs/deviations.md §49).
pub const GGX_MAP_EXPONENT: f32 = 1.0;

impl DirectionalMode {
    /// The sharpest glossy lobe, as a Phong exponent, that goes through this mode's records;
    /// sharper lobes are traced by the eye path. The mode's Phong limit
    /// ([`DirectionalMode::phong_limit`]) restated for GGX lobes: never above
    /// [`GGX_MAP_EXPONENT`]. Infinite in diffuse mode, which traces none.
    pub fn lobe_limit(self) -> f32 {
        match self {
            DirectionalMode::Diffuse => f32::INFINITY,
            _ => self.phong_limit().min(GGX_MAP_EXPONENT),
        }
    }

    /// The sharpest Phong lobe (largest exponent) this mode's records represent faithfully
    /// ([`RESOLVED_PEAK_SHARE`]). Infinite in diffuse mode, the paper without §8.1, which
    /// shades every lobe matte and traces none (the baseline). SH bands 0–3: e ≈ 4.7
    /// (perceptual roughness ≈ 0.74); the 20-strata histogram keeps less than the share even
    /// at e = 1 (0.73), the floor of its lobe table, so only lobes of e ≤ 1 (roughness ≥ 0.9)
    /// go through it.
    pub fn phong_limit(self) -> f32 {
        static SH: OnceLock<f32> = OnceLock::new();
        static HIST: OnceLock<f32> = OnceLock::new();
        match self {
            DirectionalMode::Diffuse => f32::INFINITY,
            DirectionalMode::Sh => *SH.get_or_init(|| resolution_limit(sh_peak_share, 1e4)),
            DirectionalMode::Histogram => {
                *HIST.get_or_init(|| resolution_limit(hist_peak_share, HIST_TABLE_MAX_EXPONENT))
            }
        }
    }

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
