//! Traced glossy lobes drawn anew for every photon batch (rs; docs/deviations.md §38): the eye samples whose
//! lobe is too sharp for the radiance map get one new direction per batch, the eye samples it
//! reaches get that batch's photon rays splatted onto them (with the batch's bandwidth, as the
//! main eye side) and their own direct light, and the film holds the mean over batches. So the
//! previewer's reflections converge with the batches like the rest of the image, and a
//! headless render of one batch is the same estimate as directions drawn in the eye pass.

use crate::methods::Timings;
use crate::methods::eye_side::{EyeSide, splat_at_fine_bandwidth};
use crate::pipeline::direct::{direct_light, traced_lobe_direct_light};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::eye::trace_lobes;
use crate::pipeline::photon::{Bandwidth, PhotonRay};
use crate::pipeline::radiance_map::{Accumulators, Shading, add_radiance_at};
use crate::pipeline::splat::prepare_and_splat;
use crate::pipeline::splat_tree::SplatTree;
use crate::scene::{Camera, Scene};
use crate::settings::{DirectMode, RenderSettings};
use glam::Vec3;
use std::time::Instant;

/// The light the traced lobes reflect, summed over the batches drawn so far, for the pixels
/// that have a traced lobe only (few, in most scenes: 2.9 of the 5.7 MB two full-size sums
/// held on CORNELL BOX I at 500×500, docs/benchmarks.md, "Memory").
#[derive(Clone, Debug, Default)]
pub struct TracedLobes {
    /// The pixels with an eye sample whose lobe is traced, ascending: the sums' index.
    pixels: Vec<u32>,
    /// Per entry of `pixels`: emission and direct light seen through the traced lobes, summed.
    direct: Vec<Vec3>,
    /// Per entry of `pixels`: splatted light seen through the traced lobes, summed.
    indirect: Vec<Vec3>,
    /// Batches in the sums.
    batches: u32,
    /// Per entry of `pixels`, for the error estimate (docs/deviations.md §51): the splatted
    /// light seen through the traced lobes at the batches' bandwidth h and at h/k, both shaded
    /// from irradiance alone as the eye side's two splats are, over every batch of `batches`
    /// (the estimate is on or off for a whole eye side); empty unless it is estimated.
    at_h: Vec<Vec3>,
    at_fine: Vec<Vec3>,
    /// Directions drawn so far (never reset: every draw is a new random stream).
    draws: u64,
    /// Contributions dropped as NaN or infinite.
    pub invalid: u64,
}

impl TracedLobes {
    /// Empty sums for the pixels of `eye` (in pixel order) with a traced lobe.
    pub fn new(eye: &EyeSamples) -> Self {
        let mut pixels: Vec<u32> = (0..eye.len())
            .filter(|&i| eye.lobe_traced(i))
            .map(|i| eye.pixel[i])
            .collect();
        pixels.dedup();
        Self {
            direct: vec![Vec3::ZERO; pixels.len()],
            indirect: vec![Vec3::ZERO; pixels.len()],
            pixels,
            ..Self::default()
        }
    }

    /// The sums' entry of `pixel` among `pixels` (a [`TracedLobes::pixels`]), if it has a
    /// traced lobe.
    #[inline]
    fn entry(pixels: &[u32], pixel: u32) -> Option<usize> {
        pixels.binary_search(&pixel).ok()
    }

    /// Forget the sums (before a re-splat); the next draws are still new directions.
    pub fn clear(&mut self) {
        self.direct.fill(Vec3::ZERO);
        self.indirect.fill(Vec3::ZERO);
        self.at_h.fill(Vec3::ZERO);
        self.at_fine.fill(Vec3::ZERO);
        self.batches = 0;
        self.invalid = 0;
    }

    /// Bytes held by the sums and their pixel index.
    pub fn memory_bytes(&self) -> usize {
        (self.direct.len() + self.indirect.len() + self.at_h.len() + self.at_fine.len())
            * std::mem::size_of::<Vec3>()
            + self.pixels.len() * 4
    }

    /// Batches in the sums.
    pub fn batches(&self) -> u32 {
        self.batches
    }

    /// Draw new directions for the traced lobes of `side` and gather one batch of photon rays
    /// (`classes` splatted, direct photons on their own when `direct_photons`) where they land.
    #[allow(clippy::too_many_arguments)]
    pub fn add_batch(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        side: &EyeSide,
        rays: &[PhotonRay],
        phis: &[f32],
        bw: &[Bandwidth; 3],
        classes: [bool; 3],
        fine: bool,
        timings: &mut Timings,
    ) {
        let Some(mut batch) =
            self.begin_batch(scene, camera, settings, side, classes, fine, timings)
        else {
            return;
        };
        let t = Instant::now();
        batch.gather(scene, rays, phis, bw);
        self.finish_batch(batch);
        timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// The first part of [`TracedLobes::add_batch`]: draw new directions, add the emission and
    /// direct light they see, and return where they land, ready to gather the batch's rays
    /// ([`LobeBatch::gather`], any number of times), or None where no lobe is traced. With
    /// `fine` the batch is gathered at the error estimate's fine bandwidth too (when the side
    /// estimates; an interactive view makes no estimate and skips it).
    #[allow(clippy::too_many_arguments)]
    pub fn begin_batch(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        side: &EyeSide,
        classes: [bool; 3],
        fine: bool,
        timings: &mut Timings,
    ) -> Option<LobeBatch> {
        self.batches += 1;
        if !side.acc_fine.is_empty() && self.at_h.len() != self.pixels.len() {
            self.at_h = vec![Vec3::ZERO; self.pixels.len()];
            self.at_fine = vec![Vec3::ZERO; self.pixels.len()];
        }
        if !side.eye.any_lobe_traced() {
            return None;
        }
        let draw = self.draws;
        self.draws += 1;
        let t = Instant::now();
        let pass = trace_lobes(scene, camera, &side.eye, &side.eye_settings, draw);
        for (d, &p) in self.direct.iter_mut().zip(&self.pixels) {
            *d += pass.emitted[p as usize];
        }
        if pass.samples.is_empty() {
            timings.t_eye += t.elapsed().as_secs_f64();
            return None;
        }
        let mut tree = SplatTree::build(&pass.targets.position, &pass.targets.normal);
        if settings.splat_visibility {
            tree.probe_domains(scene, &pass.targets.geo_normal, None);
        }
        timings.t_eye += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let samples = &pass.samples;
        // The eye pass's seed: each eye pass (docs/deviations.md §41) draws its own NEE streams.
        let seed = side.eye_settings.seed ^ (draw + 1).wrapping_mul(0x5851_f42d_4c95_7f2d);
        let (nee, invalid) = if settings.direct == DirectMode::Nee {
            direct_light(scene, samples, settings.nee_samples, seed)
        } else {
            traced_lobe_direct_light(scene, samples, settings.nee_samples, seed)
        };
        self.invalid += invalid;
        for (i, l) in nee.iter().enumerate() {
            if let Some(e) = Self::entry(&self.pixels, samples.pixel[i]) {
                self.direct[e] += samples.weight[i].get() * *l;
            }
        }
        timings.t_direct += t.elapsed().as_secs_f64();

        let mode = settings.radiance_map;
        let acc = |on: bool| on.then(|| Accumulators::for_tree(&tree, &pass.targets.glossy, mode));
        let direct_photons = settings.direct == DirectMode::Photons;
        let fine = (fine && !side.acc_fine.is_empty() && (classes != [false; 3] || direct_photons))
            .then(|| Accumulators::for_tree(&tree, &pass.targets.glossy, DirectionalMode::Diffuse));
        Some(LobeBatch {
            classes,
            indirect: acc(classes != [false; 3]),
            direct: acc(direct_photons),
            fine,
            samples: pass.samples,
            tree,
        })
    }

    /// The last part of [`TracedLobes::add_batch`]: add the light `batch` gathered to the
    /// sums.
    pub fn finish_batch(&mut self, batch: LobeBatch) {
        let target_slot = &batch.tree.target_slot;
        let pixels = &self.pixels;
        let samples = &batch.samples;
        let at = |i: usize| Self::entry(pixels, samples.pixel[i]);
        for (acc, sums) in [
            (&batch.indirect, &mut self.indirect),
            (&batch.direct, &mut self.direct),
        ] {
            if let Some(acc) = acc {
                // Straight into the sums (a full-size radiance map per gather was +8 MB at
                // the peak of a 500×500 render: docs/benchmarks.md, "Memory").
                self.invalid +=
                    add_radiance_at(samples, target_slot, acc, 1, sums, at, Shading::Records);
            }
        }
        let Some(fine) = &batch.fine else {
            return;
        };
        // add_radiance_at leaves non-finite values out; they were counted above.
        let shading = Shading::Irradiance;
        for acc in [&batch.indirect, &batch.direct].into_iter().flatten() {
            add_radiance_at(samples, target_slot, acc, 1, &mut self.at_h, at, shading);
        }
        add_radiance_at(
            samples,
            target_slot,
            fine,
            1,
            &mut self.at_fine,
            at,
            shading,
        );
    }

    /// Add the mean over batches of the splatted light through traced lobes at h and at h/k
    /// (shaded from irradiance alone) to the per-pixel `at_h` and `at_fine` of the error
    /// estimate's pass values (docs/deviations.md §51): a glossy reflection of splatted light
    /// carries the kernels' bias of the surfaces it reflects. Nothing unless it is estimated.
    pub fn add_estimate_means(&self, at_h: &mut [Vec3], at_fine: &mut [Vec3]) {
        if self.batches == 0 || self.at_h.is_empty() {
            return;
        }
        let b = self.batches as f32;
        for (k, &p) in self.pixels.iter().enumerate() {
            at_h[p as usize] += self.at_h[k] / b;
            at_fine[p as usize] += self.at_fine[k] / b;
        }
    }

    /// Add the mean over batches of the direct and splatted light through traced lobes to
    /// the per-pixel `direct` and `indirect`.
    pub fn add_means(&self, direct: &mut [Vec3], indirect: &mut [Vec3]) {
        if self.batches == 0 {
            return;
        }
        let b = self.batches as f32;
        for (k, &p) in self.pixels.iter().enumerate() {
            direct[p as usize] += self.direct[k] / b;
            indirect[p as usize] += self.indirect[k] / b;
        }
    }
}

/// One draw of the traced lobes with the light gathered so far ([`TracedLobes::begin_batch`]).
pub struct LobeBatch {
    /// Classes gathered into `indirect`.
    classes: [bool; 3],
    /// The eye samples the lobes reached.
    samples: EyeSamples,
    /// Their splat tree.
    tree: SplatTree,
    /// Light of `classes` at their targets (None when no class is splatted).
    indirect: Option<Accumulators>,
    /// Direct photons at their targets (with `--direct photons`).
    direct: Option<Accumulators>,
    /// Every class of `indirect` and `direct` at the fine bandwidth h/k, irradiance only (the
    /// error estimate's second splat, docs/deviations.md §51; None unless it is estimated).
    fine: Option<Accumulators>,
}

impl LobeBatch {
    /// Splat `rays` (of the batch, or one wave of it) onto the lobes' targets with the
    /// batch's bandwidths `bw` and the floors of the rays' φ `phis` (empty: none).
    pub fn gather(&mut self, scene: &Scene, rays: &[PhotonRay], phis: &[f32], bw: &[Bandwidth; 3]) {
        let tree = &self.tree;
        for (acc, classes) in [
            (&mut self.indirect, self.classes),
            (&mut self.direct, [true, false, false]),
        ] {
            if let Some(acc) = acc {
                let mode = acc.mode;
                let vis = Some(scene);
                prepare_and_splat(tree, rays, phis, bw, classes, mode, scene, acc, vis, None);
            }
        }
        if let Some(acc) = &mut self.fine {
            let direct_photons = self.direct.is_some();
            let classes = self.classes;
            splat_at_fine_bandwidth(tree, rays, phis, bw, classes, direct_photons, scene, acc);
        }
    }
}
