//! Splat accumulators per eye sample and the per-pixel radiance map with its SplatInfo (§3).
//!
//! Splatting adds into [`Accumulators`] (structure of arrays over the splat tree's slots, so a
//! subtree's accumulators are contiguous and 8 lanes add at once); [`RadianceMap::resolve_from`]
//! folds them through each eye sample's BSDF and weight into pixels.
//!
//! Every slot keeps the irradiance sum (one coefficient: all a Lambertian needs, §8.1). Slots
//! on glossy surfaces additionally own a directional record, in spherical harmonics (16
//! coefficients per channel) or as a 20-strata histogram, chosen by [`DirectionalMode`]; only
//! those slots pay for it.
//!
//! The accumulators are in `accumulators`, the per-pixel map and its resolves in `map`; both
//! are re-exported here.
//!
//! [`DirectionalMode`]: crate::pipeline::directional::DirectionalMode

mod accumulators;
mod map;

pub use accumulators::{AccView, AccumChunk, Accumulators};
pub use map::{RadianceMap, Shading, SplatInfo, add_radiance_at};

use crate::pipeline::eye::EyeSamples;
use glam::Vec3;
use rayon::prelude::*;

/// Marks a slot without a directional record.
pub const NO_RECORD: u32 = u32::MAX;

/// The sums kept per slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// Σ ΔΦ·K·cos θ per colour: the irradiance estimate of eq. 5 before the BSDF.
    R = 0,
    /// Green channel of Σ ΔΦ·K·cos θ.
    G = 1,
    /// Blue channel of Σ ΔΦ·K·cos θ.
    B = 2,
    /// Σ K·cos θ: the kernel-weight sum (SplatInfo).
    Weight = 3,
    /// Σ K·cos θ·h: for the kernel-weighted mean bandwidth.
    WeightedH = 4,
    /// Σ K·cos θ / d: for the weighted harmonic mean distance to ray origins (SplatInfo).
    WeightedInvDist = 5,
    /// Number of accepted splats.
    Count = 6,
}

impl Channel {
    /// Number of channels.
    pub const COUNT: usize = 7;
}

/// Interpolated incident light per eye sample.
#[derive(Clone, Debug, Default)]
pub struct Interpolated {
    /// Batch-averaged irradiance E per eye sample (eq. 5, 6).
    pub irradiance: Vec<Vec3>,
    /// Per eye sample: its index among the glossy samples, or u32::MAX.
    pub glossy_index: Vec<u32>,
    /// Directional floats of the glossy samples (`floats` each).
    pub directional: Vec<f32>,
    /// Floats per directional record (`DirectionalMode::record_floats`; 0 in diffuse mode).
    pub floats: usize,
    /// Compatible records covering each eye sample.
    pub coverage: Vec<u32>,
}

impl Interpolated {
    /// Zeroed values for `eye`, with directional room for its glossy samples.
    pub fn zeroed(eye: &EyeSamples, floats: usize) -> Self {
        let n = eye.len();
        let mut glossy_index = filled(u32::MAX, n);
        let mut glossy = 0u32;
        if floats > 0 {
            for (i, g) in glossy_index.iter_mut().enumerate() {
                if eye.lobe_in_map(i) {
                    *g = glossy;
                    glossy += 1;
                }
            }
        }
        Self {
            irradiance: filled(Vec3::ZERO, n),
            glossy_index,
            directional: vec![0.0; glossy as usize * floats],
            floats,
            coverage: filled(0, n),
        }
    }

    /// The directional floats of eye sample `i`, if it is glossy.
    #[inline]
    pub fn dir(&self, i: usize) -> Option<&[f32]> {
        let g = self.glossy_index[i];
        (g != u32::MAX)
            .then(|| &self.directional[g as usize * self.floats..(g as usize + 1) * self.floats])
    }

    /// Mutable directional floats of eye sample `i`, if it is glossy.
    #[inline]
    pub fn dir_mut(&mut self, i: usize) -> Option<&mut [f32]> {
        let (g, f) = (self.glossy_index[i], self.floats);
        (g != u32::MAX).then(|| &mut self.directional[g as usize * f..(g as usize + 1) * f])
    }
}

/// `n` copies of `v`, written in parallel: the first touch of fresh pages is most of the cost
/// of a per-sample array.
fn filled<T: Copy + Send + Sync>(v: T, n: usize) -> Vec<T> {
    let mut out = Vec::with_capacity(n);
    out.par_extend(rayon::iter::repeat_n(v, n));
    out
}
