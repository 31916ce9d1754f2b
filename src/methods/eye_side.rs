//! The eye side of a render: everything that depends on the camera, the resolution and the
//! samples per pixel — eye samples, splat targets and their kd-tree (§7.1), what the eye sees
//! directly (emission through specular chains, NEE direct light) and the accumulators that
//! photon rays are splatted into. Photon rays do not depend on it, so a new view builds a new
//! eye side and re-splats the stored rays.

use crate::methods::{MethodError, Timings};
use crate::pipeline::direct::{direct_light, traced_lobe_direct_light};
use crate::pipeline::eye::{EyePass, EyeSamples, EyeSettings, SplatTargets, eye_pass};
use crate::pipeline::radiance_map::{Accumulators, Channel};
use crate::pipeline::splat_tree::SplatTree;
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
    /// Per pixel: emission seen directly or through specular chains, plus NEE direct light
    /// (eye weights applied): the film's direct light before splatted direct photons and
    /// traced lobes (one sum, not two: docs/benchmarks.md, "Memory").
    pub direct: Vec<Vec3>,
    /// Eye samples whose NEE estimate was NaN or infinite (dropped).
    pub invalid_direct: u64,
    /// Accumulators for indirect and caustic photons.
    pub acc_indirect: Accumulators,
    /// Accumulators for direct photons (empty unless `--direct photons`).
    pub acc_direct: Accumulators,
    /// The eye pass's settings (for drawing traced lobes anew, [`crate::pipeline::eye::trace_lobes`]).
    pub eye_settings: EyeSettings,
}

impl EyeSide {
    /// Eye pass, splat tree and explicit direct light for one view (`settings`' width,
    /// height and spp), built as `options` say, timed into `timings` (T_E and T_D).
    pub fn new(
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        options: EyeSideOptions,
        timings: &mut Timings,
    ) -> Result<Self, MethodError> {
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
        };
        let EyePass {
            samples: eye,
            targets,
            emitted: mut direct,
        } = eye_pass(scene, camera, &eye_settings);
        let mut tree = SplatTree::build(&targets.position, &targets.normal);
        if settings.splat_visibility {
            tree.probe_domains(scene, &targets.geo_normal);
        }
        let mut targets = targets;
        if options.targets == TargetGeometry::Freed {
            targets.drop_geometry();
        }
        timings.t_eye += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let mut invalid_direct = 0;
        let any_traced = eye.any_lobe_traced();
        if settings.direct == DirectMode::Nee || any_traced {
            let (per_sample, invalid) = if settings.direct == DirectMode::Nee {
                direct_light(scene, &eye, settings.nee_samples, seed)
            } else {
                traced_lobe_direct_light(scene, &eye, settings.nee_samples, seed)
            };
            invalid_direct = invalid;
            for (i, l) in per_sample.iter().enumerate() {
                direct[eye.pixel[i] as usize] += eye.weight[i].get() * *l;
            }
        }
        timings.t_direct += t.elapsed().as_secs_f64();

        let mode = settings.radiance_map;
        let acc_direct = if settings.direct == DirectMode::Photons {
            Accumulators::for_tree(&tree, &targets.glossy, mode)
        } else {
            Accumulators::default()
        };
        let acc_indirect = Accumulators::for_tree(&tree, &targets.glossy, mode);
        Ok(Self {
            eye,
            targets,
            tree,
            direct,
            invalid_direct,
            acc_indirect,
            acc_direct,
            eye_settings,
        })
    }

    /// Free the per-sample and per-pixel arrays (the eye samples, splat targets,
    /// accumulators and pixel sums), before a new eye pass replaces this side: the peak then
    /// holds one side, not two. Only the tree and the settings remain until it is dropped.
    pub fn release(&mut self) {
        self.eye = EyeSamples::default();
        self.targets = SplatTargets::default();
        self.acc_indirect = Accumulators::default();
        self.acc_direct = Accumulators::default();
        self.direct = Vec::new();
    }

    /// Empty both accumulators (before a re-splat).
    pub fn clear(&mut self) {
        self.acc_indirect.clear();
        self.acc_direct.clear();
    }

    /// Bytes held by eye samples, splat tree and accumulators.
    pub fn memory_bytes(&self) -> usize {
        self.eye.memory_bytes()
            + self.tree.memory_bytes()
            + self.acc_indirect.memory_bytes()
            + self.acc_direct.memory_bytes()
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
