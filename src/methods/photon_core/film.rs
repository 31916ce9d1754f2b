//! Making a film from the core's accumulators: the radiance map (eq. 5), per-sample light
//! resolved again (the cache's values, the filter), and the composed film with its AOVs.

use super::PhotonCore;
use crate::film::Film;
use crate::film::estimate::{BIAS_FACTOR, BIAS_POOL, BIAS_POOL_SMOOTH, PassError, pool_bias};
use crate::pipeline::cache::{PixelGeometry, sample_values};
use crate::pipeline::filter::filter_samples;
use crate::pipeline::radiance_map::{Interpolated, RadianceMap, Shading, add_radiance_at};
use crate::sampling::luminance;
use glam::Vec3;

/// Per-sample incident light for [`PhotonCore::resolve_samples`].
pub struct SampleLight {
    /// The cache's values ([`crate::pipeline::cache::build`]); `None`: the accumulators'
    /// own over `batches`.
    pub values: Option<Interpolated>,
    /// Batches the light is averaged over.
    pub batches: u32,
    /// Where the filter reads each pixel's splat statistics.
    pub splat_stats: SplatStats,
    /// Whether the light replaces the map's or is added to it.
    pub combine: Combine,
}

/// Where the image-space filter reads each pixel's splat statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplatStats {
    /// From the radiance map's `SplatInfo` (every sample was splatted).
    FromMap,
    /// None exist (interpolated samples): the filter takes its default radius.
    None,
}

/// How resolved light meets the map's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Combine {
    /// It replaces the map's light.
    Replace,
    /// It is added to the map's light (rc: onto the splatted caustics).
    Add,
}

/// Whether the film adds the direct photons' accumulators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectPhotons {
    /// Direct photons were splatted into their own accumulators: add them.
    Splatted,
    /// None were splatted (NEE gives direct light, or a density estimate holds them).
    NotSplatted,
}

impl PhotonCore {
    /// [`DirectPhotons::Splatted`] with `--direct photons`.
    pub fn direct_photons(&self) -> DirectPhotons {
        if self.splat_direct() {
            DirectPhotons::Splatted
        } else {
            DirectPhotons::NotSplatted
        }
    }

    /// Resolve `acc_indirect` into a radiance map, averaged over `batches`.
    pub fn resolve_indirect(&self, batches: u32) -> RadianceMap {
        let side = &self.side;
        let mut map = RadianceMap::new(self.settings.width, self.settings.height);
        map.resolve_from(
            &side.eye,
            &side.tree.target_slot,
            &side.acc_indirect,
            batches,
        );
        map
    }

    /// Resolve `map` again from per-sample incident light (`light`: the cache's values or
    /// the accumulators' own), filtered in image space when the filter is on (§8.2).
    pub fn resolve_samples(&self, map: &mut RadianceMap, light: SampleLight) {
        let side = &self.side;
        let geo = PixelGeometry::new(&side.eye, self.settings.width, self.settings.height);
        let mode = side.acc_indirect.mode;
        let batches = light.batches;
        let mut values = match light.values {
            Some(values) => values,
            None => sample_values(
                &side.eye,
                &side.tree.target_slot,
                &side.acc_indirect,
                batches,
            ),
        };
        let filter = self.settings.filter;
        if filter.enabled {
            let splats: Vec<f32> = match light.splat_stats {
                SplatStats::FromMap => map.info.iter().map(|i| i.splats).collect(),
                SplatStats::None => vec![0.0; map.info.len()],
            };
            filter_samples(
                &side.eye,
                &geo,
                &self.camera,
                &splats,
                batches,
                filter,
                &mut values,
            );
        }
        let add = light.combine == Combine::Add;
        map.resolve_interpolated(&side.eye, &values, mode, add);
    }

    /// Compose the film: emission + direct light (NEE, and the direct photons' accumulators
    /// with [`DirectPhotons::Splatted`]) + the indirect radiance map, with AOVs.
    pub fn compose(&self, map: RadianceMap, batches: u32, direct_photons: DirectPhotons) -> Film {
        let (w, h) = (self.settings.width, self.settings.height);
        let side = &self.side;
        // The map's radiance and statistics become the film's (moved: docs/benchmarks.md,
        // "Memory").
        let invalid_map = map.invalid;
        let mut film = Film::around(w, h, map.radiance, map.info);
        // Direct light goes straight into the film (no second map, no copy: docs/benchmarks.md,
        // "Memory").
        // (A released side, after a failed eye pass, has no sums: its film stays black.)
        side.direct_into(&mut film.direct);
        if direct_photons == DirectPhotons::Splatted {
            film.invalid_contributions += add_radiance_at(
                &side.eye,
                &side.tree.target_slot,
                &side.acc_direct,
                batches,
                &mut film.direct,
                |i| Some(side.eye.pixel[i] as usize),
                Shading::Records,
            );
        }
        film.invalid_contributions +=
            invalid_map + side.invalid_direct + self.store.invalid_photon_rays + self.lobes.invalid;
        self.lobes.add_means(&mut film.direct, &mut film.indirect);
        for i in 0..film.direct.len() {
            let (mut d, mut ind) = (film.direct[i], film.indirect[i]);
            // The last guard: nothing non-finite reaches the film.
            if !(d + ind).is_finite() {
                film.invalid_contributions += 1;
                (d, ind) = (Vec3::ZERO, Vec3::ZERO);
            }
            film.direct[i] = d;
            film.indirect[i] = ind;
            film.rgb[i] = d + ind;
        }
        side.eye.glossy_sources(&mut film.glossy_source);
        film.pass_error = self.pass_error(&film, batches);
        film
    }

    /// This pass's values for the error estimate per pixel (docs/deviations.md §51): the
    /// splat kernels' bias, k²/(k² − 1)·(L(h) − L(h/k)) from the accumulators at h and those at h/k
    /// (both shaded from irradiance alone; the eye samples' and what their traced lobes
    /// reflect), pooled over neighbouring pixels, the difference
    /// L(h) − L(h/k) itself per pixel (for the photons' share of the variance), and the light
    /// splatted by photons (`film` less the eye side's direct light); empty unless the error is
    /// estimated and every batch of the pass is splatted at h/k too.
    fn pass_error(&self, film: &Film, batches: u32) -> Vec<PassError> {
        let side = &self.side;
        // Fine splats still owed (or skipped) leave L(h/k) short of L(h): no estimate yet.
        let fine_whole = self.fine_owed.is_empty() && !self.fine_skipped;
        if side.acc_fine.is_empty() || side.emitted.is_empty() || !fine_whole {
            return Vec::new();
        }
        let n = side.emitted.len();
        let pixel = |i: usize| Some(side.eye.pixel[i] as usize);
        let (slots, eye) = (&side.tree.target_slot, &side.eye);
        let shade = |acc, out: &mut [Vec3]| {
            add_radiance_at(eye, slots, acc, batches, out, pixel, Shading::Irradiance)
        };
        let (mut at_h, mut at_fine) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        shade(&side.acc_indirect, &mut at_h);
        shade(&side.acc_direct, &mut at_h);
        shade(&side.acc_fine, &mut at_fine);
        // The light the traced glossy lobes reflect carries the kernels' bias at their far
        // end as much as the eye samples' own splat does.
        self.lobes.add_estimate_means(&mut at_h, &mut at_fine);
        let difference: Vec<f32> = at_h
            .iter()
            .zip(&at_fine)
            .map(|(h, fine)| {
                let d = luminance(*h) - luminance(*fine);
                if d.is_finite() { d } else { 0.0 }
            })
            .collect();
        let mut bias: Vec<f32> = difference.iter().map(|d| BIAS_FACTOR as f32 * d).collect();
        let mut bias_smooth = bias.clone();
        let width = self.settings.width as usize;
        pool_bias(&mut bias, width, BIAS_POOL);
        pool_bias(&mut bias_smooth, width, BIAS_POOL_SMOOTH);
        // The eye side's own direct light (emission, NEE) is what is not splatted.
        let mut eye_direct = vec![Vec3::ZERO; n];
        side.direct_into(&mut eye_direct);
        bias.iter()
            .zip(&bias_smooth)
            .zip(&difference)
            .zip(film.rgb.iter().zip(&eye_direct))
            .map(
                |(((&bias, &bias_smooth), &difference), (rgb, d))| PassError {
                    bias,
                    bias_smooth,
                    difference,
                    splatted: luminance(*rgb - *d).max(0.0),
                },
            )
            .collect()
    }
}
