//! The eye side of a render: everything that depends on the camera, the resolution and the
//! samples per pixel — eye samples, splat targets and their kd-tree (§7.1), what the eye sees
//! directly (emission through specular chains, NEE direct light) and the accumulators that
//! photon rays are splatted into. Photon rays do not depend on it, so a new view builds a new
//! eye side and re-splats the stored rays.

use crate::film::estimate::FINE_SCALE;
use crate::methods::{MethodError, Timings};
use crate::pipeline::direct::{direct_light, traced_lobe_direct_light};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::{EyePass, EyeSamples, EyeSettings, SplatTargets, eye_pass_until};
use crate::pipeline::photon::{Bandwidth, PhotonRay};
use crate::pipeline::radiance_map::{Accumulators, Channel};
use crate::pipeline::splat::prepare_and_splat;
use crate::pipeline::splat_tree::{DomainCache, SplatTree};
use crate::pipeline::{Stop, stopped};
use crate::sampling::splitmix64;
use crate::scene::{Camera, Scene};
use crate::settings::{DirectMode, RenderSettings};
use glam::Vec3;
use std::time::Instant;

/// When traced glossy lobes (too sharp for the radiance map, §8.1) get their directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LobeDraws {
    /// Once, in the eye pass: the eye path follows the lobe.
    InEyePass,
    /// Anew for every photon batch ([`crate::methods::lobes::TracedLobes`]); the eye pass only
    /// marks them.
    PerBatch,
}

/// Whether the splat targets' positions and normals outlive the splat tree's build (which
/// holds its own copy).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetGeometry {
    /// Kept: the film reads them (pm's density estimate, rc's records).
    Kept,
    /// Freed once the tree is built.
    Freed,
}

/// The error estimate's second splat (docs/deviations.md §51): `rays` of every class splatted
/// at `bw` with the floors of their φ `phis` (`classes`, and the direct photons when `direct_photons` splats them on their
/// own) splatted again onto `tree` at the fine bandwidth h/k ([`FINE_SCALE`]: C/k in eq. 8,
/// its bounds with it), irradiance only, into `acc` (an [`EyeSide::acc_fine`], or a traced
/// lobe batch's). Its pairs are about 1/k² of the first splat's; they are not counted as
/// splats.
#[allow(clippy::too_many_arguments)]
pub fn splat_at_fine_bandwidth(
    tree: &SplatTree,
    rays: &[PhotonRay],
    phis: &[f32],
    bw: &[Bandwidth; 3],
    classes: [bool; 3],
    direct_photons: bool,
    scene: &Scene,
    acc: &mut Accumulators,
) {
    let fine = bw.map(|b| b.scaled(1.0 / FINE_SCALE));
    let [d, i, c] = classes;
    let classes = [d || direct_photons, i, c];
    let mode = DirectionalMode::Diffuse;
    prepare_and_splat(
        tree,
        rays,
        phis,
        &fine,
        classes,
        mode,
        scene,
        acc,
        Some(scene),
        None,
    );
}

/// How to build an eye side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EyeSideOptions {
    /// When traced glossy lobes get their directions.
    pub lobes: LobeDraws,
    /// Which eye pass of the view (0 first): pass 0 draws from the settings' seed, every
    /// later one from its own streams (new sub-pixel positions, NEE samples and branch
    /// choices; docs/deviations.md §41).
    pub pass: u32,
    /// Whether the targets' geometry is kept.
    pub targets: TargetGeometry,
}

/// Eye samples, splat targets, splat tree, direct light and accumulators of one view.
pub struct EyeSide {
    /// Eye samples (SoA, pixel order).
    pub eye: EyeSamples,
    /// Splat targets (eye samples of a pixel on one surface share one).
    pub targets: SplatTargets,
    /// The kd-tree over the splat targets (§7.1).
    pub tree: SplatTree,
    /// Per pixel: emission seen directly or through specular chains.
    pub emitted: Vec<Vec3>,
    /// Per pixel: the sum of the NEE direct light of every draw so far ([`EyeSide::redraw_direct`]).
    pub nee: Vec<Vec3>,
    /// NEE draws summed in `nee` (1 after the eye pass; 0 when no NEE is drawn).
    pub nee_draws: u32,
    /// Eye samples whose NEE estimate was NaN or infinite (dropped).
    pub invalid_direct: u64,
    /// Accumulators for indirect and caustic photons.
    pub acc_indirect: Accumulators,
    /// Accumulators for direct photons (empty unless `--direct photons`).
    pub acc_direct: Accumulators,
    /// Every splatted class again at the fine bandwidth h/k, irradiance only (empty unless the
    /// error is estimated: docs/deviations.md §51).
    pub acc_fine: Accumulators,
    /// The eye pass's settings (for drawing traced lobes anew, [`crate::pipeline::eye::trace_lobes`]).
    pub eye_settings: EyeSettings,
}

impl EyeSide {
    /// Eye pass, splat tree and explicit direct light for one view (`settings`' width,
    /// height and spp), built as `options` say, timed into `timings` (T_E and T_D). With
    /// `cache`, the visible domains earlier eye passes probed serve this one's targets where
    /// they fit ([`DomainCache`]; the caller keeps this pass's with [`DomainCache::keep`]
    /// before it releases it), and its counts of reused and probed domains grow.
    pub fn new(
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        options: EyeSideOptions,
        cache: Option<&mut DomainCache>,
        timings: &mut Timings,
    ) -> Result<Self, MethodError> {
        Self::new_until(scene, camera, settings, options, cache, timings, None)
            .map(|side| side.expect("an eye side without a stop is made whole"))
    }

    /// [`EyeSide::new`], given up (`Ok(None)`) once `stop` is raised: between bands of the
    /// eye pass's rows, chunks of the visible domains' probes, and before the NEE draw. The
    /// window's worker raises it when a new view arrives, which discards this side anyway
    /// (docs/benchmarks.md, "The previewer"); the time spent counts in `timings`.
    pub fn new_until(
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        options: EyeSideOptions,
        mut cache: Option<&mut DomainCache>,
        timings: &mut Timings,
        stop: Stop,
    ) -> Result<Option<Self>, MethodError> {
        if settings.width == 0 || settings.height == 0 || settings.spp == 0 {
            return Err(MethodError::EmptyView);
        }
        let pass = options.pass;
        let t = Instant::now();
        let seed = if pass == 0 {
            settings.seed
        } else {
            settings.seed ^ (pass as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        };
        let eye_settings = EyeSettings {
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            max_specular_depth: settings.max_specular_depth,
            seed,
            merge_targets: settings.merge_targets,
            lobe_limit: settings.radiance_map.lobe_limit(),
            follow_lobes: options.lobes == LobeDraws::InEyePass,
            light_samples: settings.nee_samples,
        };
        // The eye pass, its tree and the targets' visible domains, or None once `stop` is
        // raised (the time spent counts either way).
        let drawn = (|| {
            let pass = eye_pass_until(scene, camera, &eye_settings, stop)?;
            let mut tree = SplatTree::build(&pass.targets.position, &pass.targets.normal);
            if settings.splat_visibility {
                if let Some(c) = cache.as_deref_mut() {
                    c.set_view(settings.width, settings.height);
                }
                let pixels = cache
                    .as_ref()
                    .map(|_| pass.samples.target_pixels(pass.targets.len()));
                let consult = cache.as_deref().zip(pixels.as_deref());
                let (reused, probed) =
                    tree.probe_domains_until(scene, &pass.targets.geo_normal, consult, stop)?;
                if let Some(c) = cache {
                    c.reused += reused;
                    c.probed += probed;
                }
            }
            (!stopped(stop)).then_some((pass, tree))
        })();
        let Some((
            EyePass {
                samples: eye,
                targets,
                emitted,
            },
            tree,
        )) = drawn
        else {
            timings.t_eye += t.elapsed().as_secs_f64();
            return Ok(None);
        };
        let mut targets = targets;
        if options.targets == TargetGeometry::Freed {
            targets.drop_geometry();
        }
        timings.t_eye += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let mut nee = vec![Vec3::ZERO; emitted.len()];
        let (nee, nee_draws, invalid_direct) =
            match add_nee_draw(scene, &eye, settings, seed, &mut nee) {
                Some(invalid) => (nee, 1, invalid),
                None => (Vec::new(), 0, 0),
            };
        timings.t_direct += t.elapsed().as_secs_f64();

        let mode = settings.radiance_map;
        let acc_direct = if settings.direct == DirectMode::Photons {
            Accumulators::for_tree(&tree, &targets.glossy, mode)
        } else {
            Accumulators::default()
        };
        let acc_indirect = Accumulators::for_tree(&tree, &targets.glossy, mode);
        let acc_fine = if settings.estimate_error {
            Accumulators::for_tree(&tree, &targets.glossy, DirectionalMode::Diffuse)
        } else {
            Accumulators::default()
        };
        Ok(Some(Self {
            eye,
            targets,
            tree,
            emitted,
            nee,
            nee_draws,
            invalid_direct,
            acc_indirect,
            acc_direct,
            acc_fine,
            eye_settings,
        }))
    }

    /// Keep in `cache` the visible domains this pass probed for its pixels' first targets
    /// ([`DomainCache::keep`]), before [`EyeSide::release`].
    pub fn keep_domains(&self, cache: &mut DomainCache) {
        if self.tree.domain_fresh.is_empty() {
            return;
        }
        cache.set_view(self.eye_settings.width, self.eye_settings.height);
        cache.keep(&self.tree, &self.eye.target_pixels(self.targets.len()));
    }

    /// Free the per-sample and per-pixel arrays (the eye samples, splat targets,
    /// accumulators and pixel sums), before a new eye pass replaces this side: the peak then
    /// holds one side, not two. Only the tree and the settings remain until it is dropped.
    pub fn release(&mut self) {
        self.eye = EyeSamples::default();
        self.targets = SplatTargets::default();
        self.acc_indirect = Accumulators::default();
        self.acc_direct = Accumulators::default();
        self.acc_fine = Accumulators::default();
        self.emitted = Vec::new();
        self.nee = Vec::new();
        self.nee_draws = 0;
    }

    /// Draw the NEE direct light of these eye samples once more, from the random streams of
    /// draw `nee_draws` (the eye pass drew the first), and add it to the per-pixel sum: a
    /// paced render redraws it between eye passes, with each photon batch, so that direct
    /// light averages over as many draws as the indirect light has batches while the eye
    /// passes themselves (sub-pixel positions, splat targets, their visible domains) are
    /// drawn only as often as they pay (docs/deviations.md §50). Timed into T_D.
    pub fn redraw_direct(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        timings: &mut Timings,
    ) {
        if self.nee_draws == 0 {
            return;
        }
        let t = Instant::now();
        let seed = self.eye_settings.seed ^ splitmix64(self.nee_draws as u64);
        if let Some(invalid) = add_nee_draw(scene, &self.eye, settings, seed, &mut self.nee) {
            self.invalid_direct += invalid;
            self.nee_draws += 1;
        }
        timings.t_direct += t.elapsed().as_secs_f64();
    }

    /// The eye side's direct light per pixel into `out`: emission seen directly plus the
    /// mean of the NEE draws. Leaves `out` alone for a released side.
    pub fn direct_into(&self, out: &mut [Vec3]) {
        if self.emitted.len() != out.len() {
            return;
        }
        out.copy_from_slice(&self.emitted);
        if self.nee_draws > 0 && self.nee.len() == out.len() {
            let inv = 1.0 / self.nee_draws as f32;
            for (o, n) in out.iter_mut().zip(&self.nee) {
                *o += *n * inv;
            }
        }
    }

    /// Empty the accumulators (before a re-splat).
    pub fn clear(&mut self) {
        self.acc_indirect.clear();
        self.acc_direct.clear();
        self.acc_fine.clear();
    }

    /// Bytes held by eye samples, splat tree and accumulators.
    pub fn memory_bytes(&self) -> usize {
        self.eye.memory_bytes()
            + self.tree.memory_bytes()
            + self.acc_indirect.memory_bytes()
            + self.acc_direct.memory_bytes()
            + self.acc_fine.memory_bytes()
    }

    /// Bytes of directional radiance-map records (§8.1) and the glossy splat targets owning
    /// them.
    pub fn directional_memory(&self) -> (usize, usize) {
        (
            self.acc_indirect.directional_bytes() + self.acc_direct.directional_bytes(),
            self.targets.glossy.iter().filter(|&&g| g).count(),
        )
    }

    /// Splatted irradiance E (eq. 5) at every splat target divided by `batches`, from the
    /// indirect and caustic photons (`direct` = false) or from the direct photons.
    pub fn target_irradiance(&self, direct: bool, batches: usize) -> Vec<Vec3> {
        let acc = if direct {
            &self.acc_direct
        } else {
            &self.acc_indirect
        };
        if acc.is_empty() {
            return vec![Vec3::ZERO; self.tree.target_slot.len()];
        }
        let b = batches.max(1) as f32;
        self.tree
            .target_slot
            .iter()
            .map(|&slot| {
                let slot = slot as usize;
                Vec3::new(
                    acc.get(Channel::R, slot),
                    acc.get(Channel::G, slot),
                    acc.get(Channel::B, slot),
                ) / b
            })
            .collect()
    }
}

/// One draw of the eye samples' explicit direct light, added per pixel with the samples'
/// weights to `sum`: NEE with MIS everywhere with `--direct nee`, at the traced glossy lobes
/// only with `--direct photons`. Returns the number of non-finite estimates dropped, or `None`
/// when nothing is drawn (no NEE and nothing traced).
fn add_nee_draw(
    scene: &Scene,
    eye: &EyeSamples,
    settings: &RenderSettings,
    seed: u64,
    sum: &mut [Vec3],
) -> Option<u64> {
    let (per_sample, invalid) = if settings.direct == DirectMode::Nee {
        direct_light(scene, eye, settings.nee_samples, seed)
    } else if eye.any_lobe_traced() {
        traced_lobe_direct_light(scene, eye, settings.nee_samples, seed)
    } else {
        return None;
    };
    for (i, l) in per_sample.iter().enumerate() {
        sum[eye.pixel[i] as usize] += eye.weight[i].get() * *l;
    }
    Some(invalid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::BuiltinScene;

    /// Luminance-free squared difference of two per-pixel images, summed.
    fn sq_diff(a: &[Vec3], b: &[Vec3]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (*x - *y).length_squared() as f64)
            .sum()
    }

    /// Redrawn NEE averages independent draws: the image after k draws lies (1/k − 1/64)
    /// of a draw's variance from the 64-draw mean, so one draw is about 21 times farther
    /// from it than 16 draws are (asserted: more than 5 times), and averaging keeps the
    /// image's mean (within 5%). Draws that reused one stream would not come closer at all.
    #[test]
    fn redrawn_nee_averages_independent_draws() {
        let scene = Scene::builtin(BuiltinScene::CornellClassic);
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp: 1,
            ..RenderSettings::default()
        };
        let camera = scene.camera_or_error(None).unwrap();
        let options = EyeSideOptions {
            lobes: LobeDraws::PerBatch,
            pass: 0,
            targets: TargetGeometry::Freed,
        };
        let mut timings = Timings::default();
        let mut side =
            EyeSide::new(&scene, &camera, &settings, options, None, &mut timings).unwrap();
        let pixels = 24 * 24;
        let image = |side: &EyeSide| {
            let mut out = vec![Vec3::ZERO; pixels];
            side.direct_into(&mut out);
            out
        };
        let one = image(&side);
        let mut sixteen = Vec::new();
        for k in 1..64 {
            side.redraw_direct(&scene, &settings, &mut timings);
            if k == 15 {
                sixteen = image(&side);
            }
        }
        assert_eq!(side.nee_draws, 64);
        let all = image(&side);
        let (far, near) = (sq_diff(&one, &all), sq_diff(&sixteen, &all));
        assert!(far > 5.0 * near, "one draw {far}, sixteen {near}");
        let mean = |v: &[Vec3]| v.iter().map(|x| x.element_sum() as f64).sum::<f64>();
        let (m1, m64) = (mean(&one), mean(&all));
        assert!((m1 / m64 - 1.0).abs() < 0.05, "{m1} vs {m64}");
    }
}
