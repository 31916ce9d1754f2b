//! pm: photon mapping with K-NN density estimation (Jensen), visualised directly, on the same
//! eye samples and photon rays as rs: the end points of the stored rays form a global map
//! (direct photons too with `--direct photons`, indirect photons) and a caustic map, gathered
//! at every splat target when the film is made. The largest gather radius is rs's h_max.

use crate::methods::Timings;
use crate::methods::eye_side::{LobeDraws, TargetGeometry};
use crate::methods::photon_core::{
    Classes, Combine, CoreConfig, DirectPhotons, EyePasses, PhotonCore, SampleLight, SplatStats,
    StoredRays,
};
use crate::methods::photon_method::{PhotonMethod, Resolved, Resolver};
use crate::pipeline::photon::PhotonRay;
use crate::pipeline::photon_map::{PmStats, build_maps, estimate_targets};
use crate::pipeline::splat::SplatCounters;
use crate::settings::MethodKind;
use std::time::Instant;

/// Photon mapping.
pub type PhotonMapping = PhotonMethod<PmResolver>;

/// pm's resolver: a density estimate at every splat target, redone when photons or the view
/// changed.
#[derive(Default)]
pub struct PmResolver {
    /// The core's generation the current estimate was made for.
    estimated: Option<u64>,
    /// Gather statistics of the last estimate.
    stats: Option<PmStats>,
}

impl PmResolver {
    /// Build the maps from every stored batch and estimate at every splat target; returns
    /// the time it took (T_S).
    fn estimate(&mut self, core: &mut PhotonCore) -> f64 {
        let t = Instant::now();
        let batches: Vec<&[PhotonRay]> =
            core.store().batches().iter().map(|b| &b.rays[..]).collect();
        let (global, caustic) = build_maps(&batches, core.splat_direct());
        let settings = core.settings();
        let r_max = core.store().largest_h_max(&settings.bandwidth);
        let k = (settings.pm_k, settings.pm_caustic_k);
        drop(batches);
        let (targets, slots, acc) = core.targets_and_accumulators();
        let stats = estimate_targets(
            &global,
            &caustic,
            &targets.position,
            &targets.normal,
            slots,
            k,
            r_max,
            acc,
        );
        self.stats = Some(stats);
        self.estimated = Some(core.generation());
        t.elapsed().as_secs_f64()
    }
}

impl Resolver for PmResolver {
    const KIND: MethodKind = MethodKind::Pm;
    const CONFIG: CoreConfig = CoreConfig {
        splatted: Classes::NONE,
        lobes: LobeDraws::InEyePass,
        eye_passes: EyePasses::One,
        targets: TargetGeometry::Kept,
        stored_rays: StoredRays::Read,
    };

    fn film(&mut self, core: &mut PhotonCore) -> Resolved {
        let mut timings = Timings::default();
        if self.estimated != Some(core.generation()) {
            timings.t_splat = self.estimate(core);
        }
        let t = Instant::now();
        // The estimate is already averaged over the batches.
        let mut map = core.resolve_indirect(1);
        if core.settings().filter.enabled {
            core.resolve_samples(
                &mut map,
                SampleLight {
                    values: None,
                    batches: 1,
                    splat_stats: SplatStats::FromMap,
                    combine: Combine::Replace,
                },
            );
        }
        // Direct photons, when stored, are in the global map already.
        let film = core.compose(map, 1, DirectPhotons::NotSplatted);
        timings.t_resolve = t.elapsed().as_secs_f64();
        Resolved {
            film,
            timings,
            counters: SplatCounters::default(),
        }
    }

    fn pm_stats(&self) -> Option<PmStats> {
        self.stats
    }
}
