//! Splat accumulators per eye sample and the per-pixel radiance map with its SplatInfo (§3).
//!
//! Splatting adds into [`SplatAccum`] per eye sample (in kd-tree order, so a subtree's
//! accumulators are contiguous); [`RadianceMap::resolve_from`] folds them through each eye
//! sample's BSDF and weight into pixels. Diffuse RGB here; directional storage (SH, histogram,
//! §8.1) is a later extension of this module.

use crate::eye::EyeSamples;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// Sums at one eye sample over all splats of all batches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct SplatAccum {
    /// Σ ΔΦ·K·cos θ: irradiance estimate (eq. 5) before the BSDF.
    pub flux: Vec3,
    /// Σ K·cos θ: kernel-weight sum (SplatInfo).
    pub weight: f32,
    /// Σ K·cos θ·h: for the kernel-weighted mean splat bandwidth.
    pub weighted_h: f32,
    /// Σ K·cos θ / d: for the weighted harmonic mean distance to ray origins (SplatInfo).
    pub weighted_inv_dist: f32,
    /// Number of accepted splats.
    pub count: u32,
    _pad: u32,
}

/// Per-pixel splat statistics (§3: kernel-weight sum and harmonic mean distance; plus the
/// mean bandwidth for the false-colour view of Fig. 5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatInfo {
    /// Kernel-weight sum per batch, averaged over the pixel's eye samples.
    pub kernel_weight: f32,
    /// Kernel-weighted mean bandwidth (m); 0 where nothing splatted.
    pub mean_bandwidth: f32,
    /// Weighted harmonic mean distance to the photon-ray origins (m); 0 where nothing splatted.
    pub harmonic_mean_distance: f32,
    /// Accepted splats per batch, summed over the pixel's eye samples.
    pub splats: f32,
}

/// Per-pixel indirect (splatted) radiance and splat statistics.
#[derive(Clone, Debug)]
pub struct RadianceMap {
    pub width: u32,
    pub height: u32,
    /// Outgoing radiance towards the eye from splatted light, Lambertian BSDF applied.
    pub diffuse: Vec<Vec3>,
    pub info: Vec<SplatInfo>,
}

impl RadianceMap {
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            diffuse: vec![Vec3::ZERO; n],
            info: vec![SplatInfo::default(); n],
        }
    }

    /// Fold eye-sample accumulators (summed over `batches` light passes) into pixels:
    /// L = Σ_samples weight · ρ/π · E, with E the batch-averaged splatted irradiance (eq. 6).
    pub fn resolve_from(&mut self, eye: &EyeSamples, acc: &[SplatAccum], batches: u32) {
        self.diffuse.fill(Vec3::ZERO);
        self.info.fill(SplatInfo::default());
        if batches == 0 {
            return;
        }
        let inv_b = 1.0 / batches as f32;
        let mut weight_norm = vec![0.0f32; self.diffuse.len()];
        for (i, a) in acc.iter().enumerate() {
            let px = eye.pixel[i] as usize;
            let w = eye.weight[i];
            self.diffuse[px] += w * eye.albedo[i] * FRAC_1_PI * a.flux * inv_b;
            let info = &mut self.info[px];
            let share = w.max_element();
            info.kernel_weight += share * a.weight * inv_b;
            info.splats += a.count as f32 * inv_b;
            info.mean_bandwidth += share * a.weighted_h;
            info.harmonic_mean_distance += share * a.weighted_inv_dist;
            weight_norm[px] += share * a.weight;
        }
        for (info, &wsum) in self.info.iter_mut().zip(&weight_norm) {
            if wsum > 0.0 {
                info.mean_bandwidth /= wsum;
                info.harmonic_mean_distance = if info.harmonic_mean_distance > 0.0 {
                    wsum / info.harmonic_mean_distance
                } else {
                    0.0
                };
            } else {
                info.mean_bandwidth = 0.0;
                info.harmonic_mean_distance = 0.0;
            }
        }
    }
}
