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

use crate::pipeline::directional::{
    DirectionalMode, SH_COEFFS, phong_zonal, sh_basis, sh_lobe_integral, strata,
};
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::splat_tree::{LANES, PADDING, SplatTree};
use crate::scene::Scene;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// Marks a slot without a directional record.
pub const NO_RECORD: u32 = u32::MAX;

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

/// Per-slot sums over all splats of all batches, one block per chunk of slots, and the
/// directional records of glossy slots.
#[derive(Clone, Debug, Default)]
pub struct Accumulators {
    chunks: Vec<AccumChunk>,
    pub mode: DirectionalMode,
    /// Per slot: its directional record, or [`NO_RECORD`]. Records are numbered in slot order,
    /// so a subtree's records are contiguous.
    slot_record: Vec<u32>,
    /// Per chunk: whether any of its slots has a record.
    chunk_has_record: Vec<bool>,
    /// Records, [`DirectionalMode::record_floats`] each: SH channel-major (c·16 + k),
    /// histogram stratum-major (s·3 + c).
    records: Vec<f32>,
}

/// One subtree's disjoint share of the accumulators for lock-free parallel splatting.
pub struct AccView<'a> {
    pub chunks: &'a mut [AccumChunk],
    /// The slot records of these chunks' slots (global record numbers).
    pub slot_record: &'a [u32],
    pub chunk_has_record: &'a [bool],
    /// The records numbered from `first_record`.
    pub records: &'a mut [f32],
    pub first_record: u32,
}

impl Accumulators {
    /// Sums for `slots` slots, no directional records.
    pub fn new(slots: usize) -> Self {
        Self {
            chunks: vec![AccumChunk::default(); slots.div_ceil(LANES)],
            slot_record: vec![NO_RECORD; slots.div_ceil(LANES) * LANES],
            chunk_has_record: vec![false; slots.div_ceil(LANES)],
            ..Self::default()
        }
    }

    /// Sums for every slot of `tree` and, unless `mode` is diffuse, a directional record for
    /// each slot whose target is glossy.
    pub fn for_tree(tree: &SplatTree, glossy: &[bool], mode: DirectionalMode) -> Self {
        let mut acc = Self::new(tree.slots());
        acc.mode = mode;
        if mode == DirectionalMode::Diffuse {
            return acc;
        }
        let mut n = 0u32;
        for (slot, &t) in tree.slot_target.iter().enumerate() {
            if t != PADDING && glossy[t as usize] {
                acc.slot_record[slot] = n;
                acc.chunk_has_record[slot / LANES] = true;
                n += 1;
            }
        }
        acc.records = vec![0.0; n as usize * mode.record_floats()];
        acc
    }

    /// Directional records held.
    pub fn record_count(&self) -> usize {
        self.records.len() / self.mode.record_floats().max(1)
    }

    /// The directional record of `slot`, if it has one.
    #[inline]
    pub fn record(&self, slot: usize) -> Option<&[f32]> {
        let r = self.slot_record[slot];
        (r != NO_RECORD).then(|| {
            let f = self.mode.record_floats();
            &self.records[r as usize * f..(r as usize + 1) * f]
        })
    }

    /// Mutable directional record of `slot`, if it has one.
    #[inline]
    pub fn record_mut(&mut self, slot: usize) -> Option<&mut [f32]> {
        let r = self.slot_record[slot];
        let f = self.mode.record_floats();
        (r != NO_RECORD).then(|| &mut self.records[r as usize * f..(r as usize + 1) * f])
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
        self.records.fill(0.0);
    }

    /// Zeroed accumulators of the same layout.
    pub fn zeroed(&self) -> Self {
        Self {
            chunks: vec![AccumChunk::default(); self.chunks.len()],
            mode: self.mode,
            slot_record: self.slot_record.clone(),
            chunk_has_record: self.chunk_has_record.clone(),
            records: vec![0.0; self.records.len()],
        }
    }

    /// Add the sums of `other` (same layout).
    pub fn add(&mut self, other: &Accumulators) {
        for (a, b) in self.chunks.iter_mut().zip(&other.chunks) {
            for (ca, cb) in a.ch.iter_mut().zip(&b.ch) {
                for (x, y) in ca.iter_mut().zip(cb) {
                    *x += y;
                }
            }
        }
        for (x, y) in self.records.iter_mut().zip(&other.records) {
            *x += y;
        }
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
        self.chunks.len() * std::mem::size_of::<AccumChunk>() + self.directional_bytes()
    }

    /// Bytes of the directional records (and their slot index).
    pub fn directional_bytes(&self) -> usize {
        if self.mode == DirectionalMode::Diffuse {
            0
        } else {
            self.records.len() * 4 + self.slot_record.len() * 4
        }
    }

    /// Disjoint mutable views of increasing, non-overlapping slot ranges (start, len), both
    /// multiples of [`LANES`].
    pub fn split(&mut self, ranges: impl Iterator<Item = (usize, usize)>) -> Vec<AccView<'_>> {
        let f = self.mode.record_floats();
        let mut out = Vec::new();
        let mut rest: &mut [AccumChunk] = &mut self.chunks;
        let mut rest_rec: &mut [f32] = &mut self.records;
        let mut at = 0;
        let mut at_rec = 0usize;
        for (start, len) in ranges {
            debug_assert!(start % LANES == 0 && len % LANES == 0);
            let (_, tail) = rest.split_at_mut(start / LANES - at);
            let (mine, tail) = tail.split_at_mut(len / LANES);
            rest = tail;
            at = (start + len) / LANES;
            let slot_record = &self.slot_record[start..start + len];
            // Records of this range: numbered in slot order, so contiguous.
            let mut first = None;
            let mut last = 0;
            for &r in slot_record.iter().filter(|&&r| r != NO_RECORD) {
                first.get_or_insert(r);
                last = r;
            }
            let (first_record, count) = match first {
                Some(a) => (a as usize, (last - a + 1) as usize),
                None => (at_rec, 0),
            };
            let (_, tail) = rest_rec.split_at_mut((first_record - at_rec) * f);
            let (mine_rec, tail) = tail.split_at_mut(count * f);
            rest_rec = tail;
            at_rec = first_record + count;
            out.push(AccView {
                chunks: mine,
                slot_record,
                chunk_has_record: &self.chunk_has_record[start / LANES..(start + len) / LANES],
                records: mine_rec,
                first_record: first_record as u32,
            });
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
    /// Outgoing radiance towards the eye from splatted light, the eye samples' BSDFs applied.
    pub radiance: Vec<Vec3>,
    pub info: Vec<SplatInfo>,
    /// Eye-sample contributions dropped because they were NaN or infinite.
    pub invalid: u64,
}

impl RadianceMap {
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            radiance: vec![Vec3::ZERO; n],
            info: vec![SplatInfo::default(); n],
            invalid: 0,
        }
    }

    /// Fold slot accumulators (summed over `batches` light passes) into pixels. Per eye sample,
    /// L = weight · (kd/π · E + L_glossy), E the batch-averaged splatted irradiance (eq. 6) at
    /// its splat target and L_glossy the lobe integrated against the target's directional
    /// record (§8.1). `target_slot` maps splat targets to slots.
    pub fn resolve_from(
        &mut self,
        scene: &Scene,
        eye: &EyeSamples,
        target_slot: &[u32],
        acc: &Accumulators,
        batches: u32,
    ) {
        self.radiance.fill(Vec3::ZERO);
        self.info.fill(SplatInfo::default());
        self.invalid = 0;
        if batches == 0 {
            return;
        }
        let inv_b = 1.0 / batches as f32;
        let mut weight_norm = vec![0.0f32; self.radiance.len()];
        for i in 0..eye.len() {
            let slot = target_slot[eye.target[i] as usize] as usize;
            let a = &acc.chunks[slot / LANES].ch;
            let l = slot % LANES;
            let get = |c: Channel| a[c as usize][l];
            let px = eye.pixel[i] as usize;
            let w = eye.weight[i];
            let e = Vec3::new(get(Channel::R), get(Channel::G), get(Channel::B)) * inv_b;
            let out = w * shade(scene, eye, i, e, acc.record(slot), inv_b, acc.mode);
            if !out.is_finite() {
                self.invalid += 1;
                continue;
            }
            self.radiance[px] += out;
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

impl RadianceMap {
    /// Fold interpolated cache values (§8.3; already batch-averaged) into pixels, through each
    /// eye sample's BSDF as [`RadianceMap::resolve_from`] does. SplatInfo is left as it was.
    pub fn resolve_interpolated(
        &mut self,
        scene: &Scene,
        eye: &EyeSamples,
        values: &Interpolated,
        mode: DirectionalMode,
    ) {
        self.radiance.fill(Vec3::ZERO);
        self.invalid = 0;
        for i in 0..eye.len() {
            let e = values.irradiance[i];
            let out = eye.weight[i] * shade(scene, eye, i, e, values.dir(i), 1.0, mode);
            if !out.is_finite() {
                self.invalid += 1;
                continue;
            }
            self.radiance[eye.pixel[i] as usize] += out;
        }
    }
}

/// Radiance eye sample `i` reflects towards the eye (before its path weight) from irradiance
/// `e` and, on a glossy surface, its directional record scaled by `rec_scale`:
/// kd/π·E + ks·(lobe ⋆ record); without a record the lobe's reflectance is treated as matte.
#[inline]
fn shade(
    scene: &Scene,
    eye: &EyeSamples,
    i: usize,
    e: Vec3,
    rec: Option<&[f32]>,
    rec_scale: f32,
    mode: DirectionalMode,
) -> Vec3 {
    let diffuse = eye.albedo[i] * FRAC_1_PI * e;
    if !eye.is_glossy(i) {
        return diffuse;
    }
    let ks = eye.specular[i];
    diffuse
        + match rec {
            Some(rec) => ks * glossy_radiance(scene, eye, i, mode, rec) * rec_scale,
            None => ks * FRAC_1_PI * e,
        }
}

/// ∫ lobe(ωo, ω)·(L cos θ)(ω) dω at glossy eye sample `i` from its directional record (before
/// ks and the batch average), the lobe being the normalised Phong lobe around the mirror
/// direction of ωo (§8.1).
pub(crate) fn glossy_radiance(
    scene: &Scene,
    eye: &EyeSamples,
    i: usize,
    mode: DirectionalMode,
    rec: &[f32],
) -> Vec3 {
    let n = eye.normal[i];
    let r = crate::bsdf::reflect(eye.wo[i], n);
    let exponent = scene.glossy_exponent(eye.material[i]);
    match mode {
        DirectionalMode::Diffuse => Vec3::ZERO,
        // The SH table entry for this view direction: the zonal lobe rotated to r; the
        // integration is one dot product per channel.
        DirectionalMode::Sh => {
            let zonal = phong_zonal(exponent);
            let y = sh_basis(r);
            Vec3::new(
                sh_lobe_integral(&rec[0..SH_COEFFS], &zonal, &y),
                sh_lobe_integral(&rec[SH_COEFFS..2 * SH_COEFFS], &zonal, &y),
                sh_lobe_integral(&rec[2 * SH_COEFFS..], &zonal, &y),
            )
            .max(Vec3::ZERO)
        }
        // Sample the BSDF at the strata (§8.1): the deposit weights interpolate the incident
        // direction between neighbouring strata, so each stratum's sum is reflected as if it
        // arrived from the stratum's direction.
        DirectionalMode::Histogram => {
            let mut sum = Vec3::ZERO;
            for (k, s) in strata().iter().enumerate() {
                let f = crate::bsdf::phong_lobe(r.dot(*s), exponent);
                if f > 0.0 {
                    sum += f * Vec3::new(rec[3 * k], rec[3 * k + 1], rec[3 * k + 2]);
                }
            }
            sum
        }
    }
}

/// Interpolated incident light per eye sample.
#[derive(Clone, Debug, Default)]
pub struct Interpolated {
    pub irradiance: Vec<Vec3>,
    /// Per eye sample: its index among the glossy samples, or u32::MAX.
    pub glossy_index: Vec<u32>,
    /// Directional floats of the glossy samples (`floats` each).
    pub directional: Vec<f32>,
    pub floats: usize,
    /// Compatible records covering each eye sample.
    pub coverage: Vec<u32>,
}

impl Interpolated {
    /// Zeroed values for `eye`, with directional room for its glossy samples.
    pub fn zeroed(eye: &EyeSamples, floats: usize) -> Self {
        let mut n = 0u32;
        let glossy_index = (0..eye.len())
            .map(|i| {
                if floats > 0 && eye.is_glossy(i) {
                    n += 1;
                    n - 1
                } else {
                    u32::MAX
                }
            })
            .collect();
        Self {
            irradiance: vec![Vec3::ZERO; eye.len()],
            glossy_index,
            directional: vec![0.0; n as usize * floats],
            floats,
            coverage: vec![0; eye.len()],
        }
    }

    /// The directional floats of eye sample `i`, if it is glossy.
    #[inline]
    pub fn dir(&self, i: usize) -> Option<&[f32]> {
        let g = self.glossy_index[i];
        (g != u32::MAX)
            .then(|| &self.directional[g as usize * self.floats..(g as usize + 1) * self.floats])
    }

    #[inline]
    pub fn dir_mut(&mut self, i: usize) -> Option<&mut [f32]> {
        let (g, f) = (self.glossy_index[i], self.floats);
        (g != u32::MAX).then(|| &mut self.directional[g as usize * f..(g as usize + 1) * f])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::eye::EyeSample;
    use crate::scene::{BuiltinScene, Scene};

    /// A NaN or infinite accumulator never reaches a pixel: the sample is dropped and counted.
    #[test]
    fn resolve_drops_and_counts_invalid_contributions() {
        let scene = Scene::builtin(BuiltinScene::CornellClassic);
        let mut eye = EyeSamples::default();
        for (i, pixel) in [0u32, 0, 1].into_iter().enumerate() {
            let s = EyeSample {
                position: Vec3::ZERO,
                normal: Vec3::Y,
                geo_normal: Vec3::Y,
                offset: 0.0,
                wo: Vec3::Y,
                material: 0,
                pixel,
                weight: Vec3::splat(0.5),
                albedo: Vec3::splat(0.5),
                specular: Vec3::ZERO,
                primary: true,
            };
            eye.push_sample(&s, i as u32);
        }
        let mut acc = Accumulators::new(8);
        for slot in 0..3 {
            acc.set(Channel::R, slot, 1.0);
        }
        acc.set(Channel::G, 1, f32::INFINITY);
        acc.set(Channel::B, 2, f32::NAN);
        let mut map = RadianceMap::new(2, 1);
        map.resolve_from(&scene, &eye, &[0, 1, 2], &acc, 1);
        assert_eq!(map.invalid, 2);
        assert!(map.radiance.iter().all(|r| r.is_finite()));
        // The valid sample of pixel 0 still counts.
        assert!(map.radiance[0].x > 0.0);
    }
}
