//! pm: photon mapping with K-NN density estimation (Jensen), visualised directly, on the same
//! eye samples and photon rays as rs: the end points of the stored rays form a global map
//! (direct photons too with `--direct photons`, indirect photons) and a caustic map, gathered
//! at every splat target when the film is made. The largest gather radius is rs's h_max.

use crate::film::Film;
use crate::methods::progressive::{PhotonMethod, Progressive, Resolver};
use crate::pipeline::photon::PhotonRay;
use crate::pipeline::photon_map::{PmStats, build_maps, estimate_targets};
use crate::settings::MethodKind;
use std::time::Instant;

/// Photon mapping.
pub type PhotonMapping = PhotonMethod<PmFilm>;

/// pm's film: a density estimate at every splat target, redone when photons or the view
/// changed.
#[derive(Default)]
pub struct PmFilm {
    /// The core's generation the current estimate was made for.
    estimated: Option<u64>,
    /// Gather statistics of the last estimate.
    stats: Option<PmStats>,
}

impl PmFilm {
    /// Build the maps from every stored batch and estimate at every splat target.
    fn estimate(&mut self, core: &mut Progressive) {
        let t = Instant::now();
        let batches: Vec<&[PhotonRay]> = core.store.batches().iter().map(|b| &b.rays[..]).collect();
        let (global, caustic) = build_maps(&batches, core.splat_direct());
        let r_max = core.store.largest_h_max(&core.settings.bandwidth);
        let side = &mut core.side;
        self.stats = Some(estimate_targets(
            &global,
            &caustic,
            &side.targets.position,
            &side.targets.normal,
            &side.tree.target_slot,
            (core.settings.pm_k, core.settings.pm_caustic_k),
            r_max,
            &mut side.acc_indirect,
        ));
        self.estimated = Some(core.generation);
        core.timings.t_splat += t.elapsed().as_secs_f64();
    }
}

impl Resolver for PmFilm {
    const KIND: MethodKind = MethodKind::Pm;
    const SPLATTED: [bool; 3] = [false; 3];

    fn film(&mut self, core: &mut Progressive) -> Film {
        if self.estimated != Some(core.generation) {
            self.estimate(core);
        }
        let t = Instant::now();
        // The estimate is already averaged over the batches.
        let mut map = core.resolve_indirect(1);
        if core.settings.filter.enabled {
            core.resolve_samples(&mut map, None, 1, true, false);
        }
        // Direct photons, when stored, are in the global map already.
        let film = core.compose(map, 1, false);
        core.timings.t_resolve += t.elapsed().as_secs_f64();
        film
    }

    fn pm_stats(&self) -> Option<PmStats> {
        self.stats
    }
}
