//! Splat accumulators per eye sample and the per-pixel radiance map with its SplatInfo (§3).
//!
//! Splatting adds into [`Accumulators`] (structure of arrays over the splat tree's slots, so a
//! subtree's accumulators are contiguous and 8 lanes add at once); [`RadianceMap::resolve_from`]
//! folds them through each eye sample's BSDF and weight into pixels. Diffuse RGB here;
//! directional storage (SH, histogram, §8.1) is a later extension of this module.

use crate::eye::EyeSamples;
use crate::splat_tree::LANES;
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

/// The sums of one chunk of [`LANES`] slots, channel-major inside the chunk.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct AccumChunk {
    pub ch: [[f32; LANES]; Channel::COUNT],
}

/// Per-slot sums over all splats of all batches, one block per chunk of slots.
#[derive(Clone, Debug, Default)]
pub struct Accumulators {
    chunks: Vec<AccumChunk>,
}

impl Accumulators {
    pub fn new(slots: usize) -> Self {
        Self {
            chunks: vec![AccumChunk::default(); slots.div_ceil(LANES)],
        }
    }

    /// Slots held (a multiple of [`LANES`]).
    pub fn len(&self) -> usize {
        self.chunks.len() * LANES
    }

    pub fn is_empty(&self) -> bool {
        self.chunks.is_empty()
    }

    pub fn clear(&mut self) {
        self.chunks.fill(AccumChunk::default());
    }

    #[inline]
    pub fn get(&self, c: Channel, slot: usize) -> f32 {
        self.chunks[slot / LANES].ch[c as usize][slot % LANES]
    }

    #[inline]
    pub fn set(&mut self, c: Channel, slot: usize, value: f32) {
        self.chunks[slot / LANES].ch[c as usize][slot % LANES] = value;
    }

    pub fn memory_bytes(&self) -> usize {
        self.chunks.len() * std::mem::size_of::<AccumChunk>()
    }

    /// Disjoint mutable views of increasing, non-overlapping slot ranges (start, len), both
    /// multiples of [`LANES`].
    pub fn split(
        &mut self,
        ranges: impl Iterator<Item = (usize, usize)>,
    ) -> Vec<&mut [AccumChunk]> {
        let mut out = Vec::new();
        let mut rest: &mut [AccumChunk] = &mut self.chunks;
        let mut at = 0;
        for (start, len) in ranges {
            debug_assert!(start % LANES == 0 && len % LANES == 0);
            let (_, tail) = rest.split_at_mut(start / LANES - at);
            let (mine, tail) = tail.split_at_mut(len / LANES);
            out.push(mine);
            rest = tail;
            at = (start + len) / LANES;
        }
        out
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
        for i in 0..eye.len() {
            let slot = target_slot[eye.target[i] as usize] as usize;
            let a = &acc.chunks[slot / LANES].ch;
            let l = slot % LANES;
            let get = |c: Channel| a[c as usize][l];
            let px = eye.pixel[i] as usize;
            let w = eye.weight[i];
            let flux = Vec3::new(get(Channel::R), get(Channel::G), get(Channel::B));
            self.diffuse[px] += w * eye.albedo[i] * FRAC_1_PI * flux * inv_b;
            let info = &mut self.info[px];
            let share = w.max_element();
            let wsum = get(Channel::Weight);
            info.kernel_weight += share * wsum * inv_b;
            info.splats += share * get(Channel::Count) * inv_b;
            info.mean_bandwidth += share * get(Channel::WeightedH);
            info.harmonic_mean_distance += share * get(Channel::WeightedInvDist);
            weight_norm[px] += share * wsum;
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
