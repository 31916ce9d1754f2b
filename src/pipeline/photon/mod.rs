//! Light pass (§3, §6): photons leave the lights in proportion to power, scatter by BSDF
//! importance sampling with Russian roulette, and every segment x_i → x_{i+1} is stored as a
//! [`PhotonRay`] with the clamped path pdf p̃ of eq. 7 at both ends. A pilot phase estimates
//! ⟨D⟩ and ⟨r⟩ for the bandwidth normalisation w of eq. 8.
//!
//! Bandwidth (eq. 8) is a pure function of the stored ray, the parameters and the pilot
//! statistics, so moving C/S/R re-splats stored rays without re-tracing.
//!
//! | part | module |
//! |---|---|
//! | eq. 8's bandwidth, its parameters and clamp counts | `bandwidth` |
//! | the floor from the photons stored: their landings counted | `density` |
//! | the pilot phase: ⟨D⟩ and ⟨r⟩ | `pilot` |
//! | tracing one photon path, eq. 7's p̃ | `trace` |
//! | photons where the camera looks: the emission guide | `guide` |
//! | class budgets and the light pass | `light_pass` |

mod bandwidth;
mod density;
mod guide;
mod light_pass;
mod pilot;
mod trace;

pub use bandwidth::{Bandwidth, BandwidthParams, ClampCounts};
pub use density::{FLOOR_NEIGHBOURS, HitDensity};
pub use guide::{EmissionGuide, GUIDE_MIX};
pub use light_pass::{
    ClassBudgets, LightPassPlan, LightPassSettings, PhotonBatch, light_pass, plan_light_pass,
};
pub use pilot::{Pilot, pilot};
pub use trace::PathUnits;

use crate::pack::OctOrZero;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The paper's a in μC = a·⟨D⟩ (§6).
pub const MU_C_FACTOR: f32 = 0.2;
/// m0 = ⁶√(10⁵) = 10^(5/6) ≈ 6.8 (§6; docs/deviations.md §1 on the garbled root).
pub const M0: f32 = 6.812_921;
/// The clamp distance D̃ of eq. 7 as a fraction of the pilot's ⟨D⟩ (the paper leaves it
/// scene-dependent without a value; docs/deviations.md §3): D̃ = μC, the typical kernel
/// radius at M = 10⁵, since a segment shorter than a kernel says nothing about how the
/// density changes across one. A fraction of the light's own length scale, never of the
/// bounding box, so far-away geometry cannot change it.
pub const D_TILDE_FRACTION: f32 = MU_C_FACTOR;
/// Stand-in solid-angle density of a specular bounce for eq. 7 (a delta has none): about
/// that of a lobe 6° wide, so caustic paths get the small bandwidths §6 describes.
pub const SPECULAR_PDF: f32 = 100.0;
/// R is kept in [R_MIN, 1] (R = 1: one bandwidth for every ray).
pub const R_MIN: f32 = 1e-3;
/// Photon paths end after this many segments whatever Russian roulette says.
pub const MAX_PATH_SEGMENTS: u32 = 32;
/// Photons traced per pilot phase (§6).
pub const PILOT_PHOTONS: u32 = 8192;

/// Table 2's photon classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum PhotonClass {
    /// Light → first hit.
    Direct = 0,
    /// At least one non-specular bounce before the segment.
    Indirect = 1,
    /// Light, then only specular bounces, then the segment (caustic paths L S+ …).
    Caustic = 2,
}

impl PhotonClass {
    /// The three classes in the order of their index (`class as usize`).
    pub const ALL: [PhotonClass; 3] = [
        PhotonClass::Direct,
        PhotonClass::Indirect,
        PhotonClass::Caustic,
    ];
}

/// One stored photon ray (segment x_i → x_{i+1}).
#[derive(Clone, Copy, Debug)]
pub struct PhotonRay {
    /// x_i: where the segment starts (world space, already offset off its surface).
    pub origin: Vec3,
    /// Unit direction from x_i to x_{i+1}.
    pub dir: Vec3,
    /// ‖x_{i+1} − x_i‖ in scene units; for a ray that escapes, the distance to where it
    /// leaves the scene's bounds.
    pub length: f32,
    /// Power carried, already divided by the number of photons emitted for its class.
    pub power: Vec3,
    /// Normal of the surface at the origin on the side the ray leaves (zero for point lights;
    /// octahedral, within 10⁻⁴ rad).
    pub origin_normal: OctOrZero,
    /// |ω·n_s| / |ω·n_g| at the end vertex (1 if it escapes): converts the ray's flux through
    /// the geometric surface into the shading-normal cosine that the path tracer and the
    /// splat kernel use, for photon mapping's density estimate (Veach 1997, §5.3).
    pub end_shading_ratio: f32,
    /// p̃(x_i | x_{i−1}); for bounce 0, 0 (h(x_0) = 0) or, for a ray from afar (a
    /// directional light, the sun, the environment), its constant density p̃(x_1 | x_0).
    pub pdf_start: f32,
    /// p̃(x_{i+1} | x_i), eq. 7.
    pub pdf_end: f32,
    /// The bounce, class and landing flag, and the emission cell of the photon
    /// ([`RayTag`]: packed into one word so that a ray stays 64 bytes).
    pub tag: RayTag,
    /// Geometric normal of the surface the ray hits, facing the ray (zero if it escapes;
    /// octahedral, within 10⁻⁴ rad).
    pub end_normal: OctOrZero,
}

/// What a [`PhotonRay`] is, packed in 32 bits: the bounce i (0 for the segment leaving the
/// light; below [`MAX_PATH_SEGMENTS`] = 32, 5 bits), Table 2's class (2 bits), whether the ray
/// ends on a non-specular surface (where photon mapping stores a photon; 1 bit), and the
/// emission guide's cell of the photon it belongs to (24 bits, [`NO_CELL`] without one;
/// docs/deviations.md §44).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayTag(u32);

/// The cell of a photon emitted without the emission guide's cells.
pub const NO_CELL: u32 = (1 << 24) - 1;

const _: () = assert!(MAX_PATH_SEGMENTS <= 32 && std::mem::size_of::<PhotonRay>() == 64);

impl RayTag {
    /// Bounce `bounce` (at most 31), class `class`, landing on a non-specular surface when
    /// `lands`; no cell.
    pub fn new(bounce: u32, class: PhotonClass, lands: bool) -> Self {
        Self(bounce.min(31) | (class as u32) << 5 | (lands as u32) << 7 | NO_CELL << 8)
    }

    /// The same with emission cell `cell` (below [`NO_CELL`]; larger is none).
    pub fn with_cell(self, cell: u32) -> Self {
        Self(self.0 & 0xff | cell.min(NO_CELL) << 8)
    }
}

/// The φ of ray `i` in `phis`, the floors of a slice of rays
/// ([`HitDensity::phi`]): one per ray, or empty for none (0: no floor).
#[inline]
pub fn phi_at(phis: &[f32], i: usize) -> f32 {
    phis.get(i).copied().unwrap_or(0.0)
}

impl PhotonRay {
    /// i: 0 for the segment leaving the light.
    #[inline]
    pub fn bounce(&self) -> u8 {
        (self.tag.0 & 31) as u8
    }

    /// Table 2's class of the segment.
    #[inline]
    pub fn class(&self) -> PhotonClass {
        PhotonClass::ALL[(self.tag.0 >> 5 & 3) as usize]
    }

    /// The ray ends on a non-specular surface (where photon mapping stores a photon).
    #[inline]
    pub fn lands(&self) -> bool {
        self.tag.0 & 128 != 0
    }

    /// The emission guide's cell of the photon ([`NO_CELL`]: none).
    #[inline]
    pub fn cell(&self) -> u32 {
        self.tag.0 >> 8
    }

    /// The first segment of a photon from the environment or the sun (docs/deviations.md,
    /// "Light from afar"): it starts on the bounding sphere's disc, not on a light.
    #[inline]
    pub fn from_afar(&self) -> bool {
        self.bounce() == 0 && self.pdf_start > 0.0
    }

    /// The ray hits nothing (it was clipped where it leaves the scene's bounds).
    #[inline]
    pub fn escapes(&self) -> bool {
        self.end_normal.is_zero()
    }

    /// Every number finite (power non-negative): a ray that may be splatted.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.length.is_finite()
            && self.power.is_finite()
            && self.power.min_element() >= 0.0
            && self.end_shading_ratio.is_finite()
            && self.pdf_start.is_finite()
            && self.pdf_end.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_with_non_finite_numbers_are_invalid() {
        let good = PhotonRay {
            origin: Vec3::ZERO,
            dir: Vec3::Y,
            length: 1.0,
            power: Vec3::ONE,
            origin_normal: OctOrZero::new(Vec3::Y),
            end_shading_ratio: 1.0,
            pdf_start: 0.0,
            pdf_end: 1.0,
            tag: RayTag::new(0, PhotonClass::Direct, true),
            end_normal: OctOrZero::new(-Vec3::Y),
        };
        assert!(good.is_valid());
        for bad in [
            PhotonRay {
                power: Vec3::new(1.0, f32::INFINITY, 0.0),
                ..good
            },
            PhotonRay {
                power: Vec3::new(-1.0, 0.0, 0.0),
                ..good
            },
            PhotonRay {
                length: f32::NAN,
                ..good
            },
            PhotonRay {
                pdf_end: f32::INFINITY,
                ..good
            },
            PhotonRay {
                dir: Vec3::new(f32::NAN, 0.0, 0.0),
                ..good
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
