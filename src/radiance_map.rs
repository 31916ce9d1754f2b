//! Splat accumulators per eye sample and the per-pixel radiance map with its SplatInfo (§3).
//!
//! Splatting adds into [`Accumulators`] (structure of arrays over the splat tree's slots, so a
//! subtree's accumulators are contiguous and 8 lanes add at once); [`RadianceMap::resolve_from`]
//! folds them through each eye sample's BSDF and weight into pixels. Diffuse RGB here;
//! directional storage (SH, histogram, §8.1) is a later extension of this module.

use crate::eye::EyeSamples;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// The sums kept per slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// Σ ΔΦ·K·cos θ per colour: the irradiance estimate of eq. 5 before the BSDF.
    R = 0,
    G = 1,
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
    pub const COUNT: usize = 7;
}

/// Per-slot sums over all splats of all batches.
#[derive(Clone, Debug, Default)]
pub struct Accumulators {
    channels: [Vec<f32>; Channel::COUNT],
}

impl Accumulators {
    pub fn new(slots: usize) -> Self {
        Self {
            channels: std::array::from_fn(|_| vec![0.0; slots]),
        }
    }

    pub fn len(&self) -> usize {
        self.channels[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn clear(&mut self) {
        for c in &mut self.channels {
            c.fill(0.0);
        }
    }

    pub fn get(&self, c: Channel, slot: usize) -> f32 {
        self.channels[c as usize][slot]
    }

    pub fn memory_bytes(&self) -> usize {
        self.len() * 4 * Channel::COUNT
    }

    /// Disjoint mutable views of increasing, non-overlapping slot ranges (start, len).
    pub fn split(
        &mut self,
        ranges: impl Iterator<Item = (usize, usize)> + Clone,
    ) -> Vec<[&mut [f32]; Channel::COUNT]> {
        let mut per_channel: Vec<Vec<&mut [f32]>> = self
            .channels
            .iter_mut()
            .map(|ch| {
                let mut out = Vec::new();
                let mut rest: &mut [f32] = ch;
                let mut at = 0;
                for (start, len) in ranges.clone() {
                    let (_, tail) = rest.split_at_mut(start - at);
                    let (mine, tail) = tail.split_at_mut(len);
                    out.push(mine);
                    rest = tail;
                    at = start + len;
                }
                out
            })
            .collect();
        let n = per_channel[0].len();
        let mut views = Vec::with_capacity(n);
        for _ in 0..n {
            views.push(std::array::from_fn(|c| per_channel[c].remove(0)));
        }
        views
    }
}

/// Per-pixel splat statistics (§3: kernel-weight sum and harmonic mean distance; plus the
/// mean bandwidth for the false-colour view of Fig. 5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatInfo {
    /// Kernel-weight sum per batch, weighted by the pixel's eye-sample weights.
    pub kernel_weight: f32,
    /// Kernel-weighted mean bandwidth (m); 0 where nothing splatted.
    pub mean_bandwidth: f32,
    /// Weighted harmonic mean distance to the photon-ray origins (m); 0 where nothing splatted.
    pub harmonic_mean_distance: f32,
    /// Accepted splats per batch, weighted by the pixel's eye-sample weights.
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

    /// Fold slot accumulators (summed over `batches` light passes) into pixels:
    /// L = Σ_samples weight · ρ/π · E, E the batch-averaged splatted irradiance (eq. 6) at
    /// the sample's splat target. `target_slot` maps splat targets to slots.
    pub fn resolve_from(
        &mut self,
        eye: &EyeSamples,
        target_slot: &[u32],
        acc: &Accumulators,
        batches: u32,
    ) {
        self.diffuse.fill(Vec3::ZERO);
        self.info.fill(SplatInfo::default());
        if batches == 0 {
            return;
        }
        let inv_b = 1.0 / batches as f32;
        let mut weight_norm = vec![0.0f32; self.diffuse.len()];
        let ch = |c: Channel| &acc.channels[c as usize];
        let (r, g, b) = (ch(Channel::R), ch(Channel::G), ch(Channel::B));
        let (wsum, wh, wd, cnt) = (
            ch(Channel::Weight),
            ch(Channel::WeightedH),
            ch(Channel::WeightedInvDist),
            ch(Channel::Count),
        );
        for i in 0..eye.len() {
            let slot = target_slot[eye.target[i] as usize] as usize;
            let px = eye.pixel[i] as usize;
            let w = eye.weight[i];
            let flux = Vec3::new(r[slot], g[slot], b[slot]);
            self.diffuse[px] += w * eye.albedo[i] * FRAC_1_PI * flux * inv_b;
            let info = &mut self.info[px];
            let share = w.max_element();
            info.kernel_weight += share * wsum[slot] * inv_b;
            info.splats += share * cnt[slot] * inv_b;
            info.mean_bandwidth += share * wh[slot];
            info.harmonic_mean_distance += share * wd[slot];
            weight_norm[px] += share * wsum[slot];
        }
        for (info, &norm) in self.info.iter_mut().zip(&weight_norm) {
            if norm > 0.0 {
                info.mean_bandwidth /= norm;
                info.harmonic_mean_distance = if info.harmonic_mean_distance > 0.0 {
                    norm / info.harmonic_mean_distance
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
