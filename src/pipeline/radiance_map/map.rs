//! The per-pixel radiance map (§3, §4): accumulators or interpolated cache values folded through
//! each eye sample's BSDF, with the SplatInfo statistics.

use super::{Accumulators, Channel, Interpolated};
use crate::pipeline::directional::{
    DirectionalMode, SH_COEFFS, hist_lobe_weights, sh_basis, sh_lobe_integral,
};
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::splat_tree::LANES;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

pub use crate::film::SplatInfo;

/// Per-pixel indirect (splatted) radiance and splat statistics.
#[derive(Clone, Debug)]
pub struct RadianceMap {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Outgoing radiance towards the eye from splatted light, the eye samples' BSDFs applied.
    pub radiance: Vec<Vec3>,
    /// Splat statistics per pixel.
    pub info: Vec<SplatInfo>,
    /// Eye-sample contributions dropped because they were NaN or infinite.
    pub invalid: u64,
}

impl RadianceMap {
    /// A black map of `width` × `height` pixels.
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
    /// record (§8.1). `target_slot` maps splat targets to slots. Rows of pixels run in
    /// parallel: `eye`'s samples must be in pixel order (as every eye pass makes them).
    pub fn resolve_from(
        &mut self,
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
        let w = self.width as usize;
        if w == 0 {
            return;
        }
        let rows = sample_rows(eye, w, self.height as usize);
        // Rows of pixels in parallel: the samples are in pixel order, a row's are one range.
        self.invalid = self
            .radiance
            .par_chunks_mut(w)
            .zip(self.info.par_chunks_mut(w))
            .enumerate()
            .map(|(y, (radiance, info))| {
                let mut weight_norm = vec![0.0f32; w];
                let mut invalid = 0;
                for i in rows[y]..rows[y + 1] {
                    let slot = target_slot[eye.target[i] as usize] as usize;
                    let a = &acc.chunks[slot / LANES].ch;
                    let l = slot % LANES;
                    let get = |c: Channel| a[c as usize][l];
                    let px = eye.pixel[i] as usize - y * w;
                    let out = sample_radiance(eye, i, slot, acc, inv_b, Shading::Records);
                    if !out.is_finite() {
                        invalid += 1;
                        continue;
                    }
                    radiance[px] += out;
                    let info = &mut info[px];
                    let share = eye.weight[i].get().max_element();
                    let wsum = get(Channel::Weight);
                    info.kernel_weight += share * wsum * inv_b;
                    info.splats += share * get(Channel::Count) * inv_b;
                    info.mean_bandwidth += share * get(Channel::WeightedH);
                    info.harmonic_mean_distance += share * get(Channel::WeightedInvDist);
                    weight_norm[px] += share * wsum;
                }
                for (info, &norm) in info.iter_mut().zip(&weight_norm) {
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
                invalid
            })
            .sum();
    }
}

/// Where each row of a `width` × `height` image's eye samples begins, and one past the last
/// row's. The resolves run row-parallel on this: the samples must be in pixel order and
/// inside the image, as every eye pass makes them.
fn sample_rows(eye: &EyeSamples, width: usize, height: usize) -> Vec<usize> {
    debug_assert!(eye.pixel.is_sorted(), "eye samples out of pixel order");
    let rows: Vec<usize> = (0..=height)
        .map(|y| eye.pixel.partition_point(|&p| (p as usize) < y * width))
        .collect();
    debug_assert_eq!(rows[height], eye.len(), "eye samples outside the image");
    rows
}

/// How [`add_radiance_at`] shades a sample from its target's accumulated light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    /// As the accumulators hold it: glossy lobes from their directional records (§8.1).
    Records,
    /// From the irradiance alone, directional records left out (glossy lobes as the diffuse
    /// mode shades them): two sets of accumulators, one with records and one without, compare
    /// like with like this way (the error estimate's two bandwidths, docs/deviations.md §51).
    Irradiance,
}

/// Add the radiance of slot accumulators (summed over `batches` light passes), shaded as
/// `shading` says, to `out[at(i)]` for eye sample `i` (None: not added), as
/// [`RadianceMap::resolve_from`] folds it, without the splat statistics: direct photons added
/// onto the film's direct light in place (`at` the sample's pixel), or sums that are not one
/// per pixel ([`crate::methods::lobes::TracedLobes`] keeps them for the pixels with a traced
/// lobe only). Returns the contributions dropped as NaN or infinite.
pub fn add_radiance_at(
    eye: &EyeSamples,
    target_slot: &[u32],
    acc: &Accumulators,
    batches: u32,
    out: &mut [Vec3],
    at: impl Fn(usize) -> Option<usize>,
    shading: Shading,
) -> u64 {
    if batches == 0 || acc.is_empty() {
        return 0;
    }
    let inv_b = 1.0 / batches as f32;
    let mut invalid = 0;
    for i in 0..eye.len() {
        let Some(o) = at(i) else {
            continue;
        };
        let slot = target_slot[eye.target[i] as usize] as usize;
        let l = sample_radiance(eye, i, slot, acc, inv_b, shading);
        if l.is_finite() {
            out[o] += l;
        } else {
            invalid += 1;
        }
    }
    invalid
}

/// Radiance eye sample `i` sends towards the eye, its path weight applied, from the light its
/// splat target's `slot` accumulated over 1/`inv_b` batches, shaded as `shading` says.
#[inline]
fn sample_radiance(
    eye: &EyeSamples,
    i: usize,
    slot: usize,
    acc: &Accumulators,
    inv_b: f32,
    shading: Shading,
) -> Vec3 {
    let a = &acc.chunks[slot / LANES].ch;
    let l = slot % LANES;
    let get = |c: Channel| a[c as usize][l];
    let e = Vec3::new(get(Channel::R), get(Channel::G), get(Channel::B)) * inv_b;
    let (record, mode) = match shading {
        Shading::Records => (acc.record(slot), acc.mode),
        Shading::Irradiance => (None, DirectionalMode::Diffuse),
    };
    eye.weight[i].get() * shade(eye, i, e, record, inv_b, mode)
}

impl RadianceMap {
    /// Fold interpolated cache values (§8.3; already batch-averaged) into pixels, through each
    /// eye sample's BSDF as [`RadianceMap::resolve_from`] does, replacing the map's radiance,
    /// or adding to it with `add` (rc's interpolated light onto its splatted caustics).
    /// SplatInfo is left as it was. `eye`'s samples must be in pixel order, as for
    /// [`RadianceMap::resolve_from`].
    pub fn resolve_interpolated(
        &mut self,
        eye: &EyeSamples,
        values: &Interpolated,
        mode: DirectionalMode,
        add: bool,
    ) {
        if !add {
            self.radiance.fill(Vec3::ZERO);
            self.invalid = 0;
        }
        let w = self.width as usize;
        if w == 0 {
            return;
        }
        let rows = sample_rows(eye, w, self.height as usize);
        self.invalid += self
            .radiance
            .par_chunks_mut(w)
            .enumerate()
            .map(|(y, radiance)| {
                let mut invalid = 0;
                for i in rows[y]..rows[y + 1] {
                    let e = values.irradiance[i];
                    let out = eye.weight[i].get() * shade(eye, i, e, values.dir(i), 1.0, mode);
                    if !out.is_finite() {
                        invalid += 1;
                        continue;
                    }
                    radiance[eye.pixel[i] as usize - y * w] += out;
                }
                invalid
            })
            .sum::<u64>();
    }
}

/// Radiance eye sample `i` reflects towards the eye (before its path weight) from irradiance
/// `e` and, on a glossy surface, its directional record scaled by `rec_scale`:
/// kd/π·E + ks·(lobe ⋆ record); without a record the lobe's reflectance is treated as matte.
/// A traced lobe reflects no splatted light here: the eye path carries it (kd/π·E only).
#[inline]
fn shade(
    eye: &EyeSamples,
    i: usize,
    e: Vec3,
    rec: Option<&[f32]>,
    rec_scale: f32,
    mode: DirectionalMode,
) -> Vec3 {
    let diffuse = eye.albedo[i].get() * FRAC_1_PI * e;
    if !eye.lobe_in_map(i) {
        return diffuse;
    }
    // The specular layer's albedo towards the eye, its lobe's shape from the record; none
    // for a viewer below the shading normal (docs/deviations.md §53).
    let cos_o = eye.wo[i].get().dot(eye.normal[i].get());
    if cos_o <= 0.0 {
        return diffuse;
    }
    let ks = crate::bsdf::specular_albedo(
        cos_o,
        eye.alpha[i].to_f32(),
        eye.specular[i].get(),
        eye.f90[i].to_f32(),
    );
    diffuse
        + match rec {
            Some(rec) => ks * glossy_radiance(eye, i, mode, rec) * rec_scale,
            None => ks * FRAC_1_PI * e,
        }
}

/// ∫ lobe(ωo, ω)·(L cos θ)(ω) dω at glossy eye sample `i` from its directional record (before
/// ks and the batch average), the lobe being the normalised Phong lobe around the mirror
/// direction of ωo (§8.1).
pub(crate) fn glossy_radiance(
    eye: &EyeSamples,
    i: usize,
    mode: DirectionalMode,
    rec: &[f32],
) -> Vec3 {
    let n = eye.normal[i].get();
    let wo = eye.wo[i].get();
    let r = crate::bsdf::reflect(wo, n);
    let alpha = eye.alpha[i].to_f32();
    let exponent = crate::bsdf::phong_equivalent(alpha);
    match mode {
        DirectionalMode::Diffuse => Vec3::ZERO,
        // The GGX lobe's zonal projection for this view direction, about its axis; the
        // integration is one dot product per channel.
        DirectionalMode::Sh => {
            let (axis, zonal) = crate::bsdf::ggx_zonal(wo, n, alpha);
            let y = sh_basis(axis);
            Vec3::new(
                sh_lobe_integral(&rec[0..SH_COEFFS], &zonal, &y),
                sh_lobe_integral(&rec[SH_COEFFS..2 * SH_COEFFS], &zonal, &y),
                sh_lobe_integral(&rec[2 * SH_COEFFS..], &zonal, &y),
            )
            .max(Vec3::ZERO)
        }
        // Integrate the lobe over each stratum's filter footprint (§8.1's table, per exponent
        // like the SH zonal table; docs/deviations.md §27): energy-conserving for every lobe,
        // so none falls between strata.
        DirectionalMode::Histogram => {
            let w = hist_lobe_weights(r, exponent);
            let mut sum = Vec3::ZERO;
            for (k, wk) in w.iter().enumerate() {
                sum += *wk * Vec3::new(rec[3 * k], rec[3 * k + 1], rec[3 * k + 2]);
            }
            sum
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::eye::EyeSample;

    /// A NaN or infinite accumulator never reaches a pixel: the sample is dropped and counted.
    #[test]
    fn resolve_drops_and_counts_invalid_contributions() {
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
                alpha: 1.0,
                f90: 0.0,
                primary: true,
                lobe_traced: false,
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
        map.resolve_from(&eye, &[0, 1, 2], &acc, 1);
        assert_eq!(map.invalid, 2);
        assert!(map.radiance.iter().all(|r| r.is_finite()));
        // The valid sample of pixel 0 still counts.
        assert!(map.radiance[0].x > 0.0);
    }
}
