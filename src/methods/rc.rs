//! rc: radiance caching (§8.3). Caustic photon rays are splatted onto every splat target as
//! batches arrive, as in rs (caustics are sharp by nature); indirect-diffuse light is splatted
//! only onto sparse cache records, picked in image-space passes by the error ε when the film is
//! made, and interpolated between them.

use crate::methods::Timings;
use crate::methods::eye_side::{LobeDraws, TargetGeometry};
use crate::methods::photon_core::{
    Classes, Combine, CoreConfig, EyePasses, PhotonCore, SampleLight, SplatStats, StoredRays,
};
use crate::methods::photon_method::{PhotonMethod, Resolved, Resolver};
use crate::pipeline::cache::{self, Cache, PixelGeometry, RecordValue, record_value};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::radiance_map::{Accumulators, Interpolated};
use crate::pipeline::splat::{SplatBatch, SplatCounters, prepare, splat};
use crate::pipeline::splat_tree::SplatTree;
use crate::settings::MethodKind;
use glam::Vec3;
use std::time::Instant;

/// Radiance caching.
pub type RadianceCaching = PhotonMethod<RcResolver>;

/// rc's resolver: the cache built by splatting, interpolated, plus the splatted caustics.
#[derive(Default)]
pub struct RcResolver {
    cache: Option<Cache>,
}

impl Resolver for RcResolver {
    const KIND: MethodKind = MethodKind::Rc;
    const CONFIG: CoreConfig = CoreConfig {
        splatted: Classes {
            direct: false,
            indirect: false,
            caustic: true,
        },
        lobes: LobeDraws::InEyePass,
        eye_passes: EyePasses::One,
        targets: TargetGeometry::Kept,
        stored_rays: StoredRays::Read,
    };

    fn film(&mut self, core: &mut PhotonCore) -> Resolved {
        let t = Instant::now();
        let b = core.pass_batches() as u32;
        // The cache pass counts as splatting (T_S), not as resolving.
        let mut timings = Timings::default();
        let tc = Instant::now();
        let (cache, values, counters) = cache_by_splatting(core);
        timings.t_splat = tc.elapsed().as_secs_f64();
        // The caustics, splatted onto every target; the interpolated light is added to them.
        let mut map = core.resolve_indirect(b);
        if !cache.is_empty() {
            core.resolve_samples(
                &mut map,
                SampleLight {
                    values: Some(values),
                    batches: b,
                    splat_stats: SplatStats::None,
                    combine: Combine::Add,
                },
            );
        }
        self.cache = Some(cache);
        let film = core.compose(map, b, core.direct_photons());
        timings.t_resolve = t.elapsed().as_secs_f64() - timings.t_splat;
        Resolved {
            film,
            timings,
            counters,
        }
    }

    fn cache(&self) -> Option<&Cache> {
        self.cache.as_ref()
    }
}

/// Every pass of the cache splats the stored indirect photon rays onto its new records only.
/// Returns the cache, the eye samples' values from it and the passes' splatting counters.
fn cache_by_splatting(core: &PhotonCore) -> (Cache, Interpolated, SplatCounters) {
    let settings = core.settings();
    let side = core.side();
    let (w, h) = (settings.width, settings.height);
    let geo = PixelGeometry::new(&side.eye, w, h);
    let mode = side.acc_indirect.mode;
    // Photon directions serve the directional records of glossy targets only: without any,
    // the rays are prepared without them (records and values keep the map's layout).
    let ray_mode = if side.targets.glossy.iter().any(|&g| g) {
        mode
    } else {
        DirectionalMode::Diffuse
    };
    // Rays are prepared once for every pass.
    let batches: Vec<SplatBatch> = core
        .store()
        .batches()
        .iter()
        .map(|b| {
            prepare(
                &b.rays,
                &b.phis,
                &core.bandwidths(b.m),
                [false, true, false],
                ray_mode,
                core.scene(),
            )
        })
        .collect();
    // Without indirect photon rays (a row of fractions such as CORNELL BOX II's (0.2, 0, 0.8))
    // there is no light to cache: records would all be dark, each as small as the image
    // allows, and their passes cost more than the splatted caustics.
    if batches.iter().all(|b| b.rays.is_empty()) {
        return (
            Cache::default(),
            Interpolated::default(),
            SplatCounters::default(),
        );
    }
    let inv_b = 1.0 / batches.len().max(1) as f32;
    let scene = core.scene();
    let mut counters = SplatCounters::default();
    let (cache, values) = cache::build(
        &side.eye,
        &geo,
        core.camera(),
        &settings.cache,
        mode,
        |samples| {
            if samples.is_empty() {
                return Vec::new();
            }
            // Samples of a pixel often share a splat target: each target is splatted once.
            let of_sample: Vec<usize> = samples
                .iter()
                .map(|&i| side.eye.target[i as usize] as usize)
                .collect();
            let mut targets = of_sample.clone();
            targets.sort_unstable();
            targets.dedup();
            let pos: Vec<Vec3> = targets.iter().map(|&t| side.targets.position[t]).collect();
            let nrm: Vec<Vec3> = targets.iter().map(|&t| side.targets.normal[t]).collect();
            let glossy: Vec<bool> = targets.iter().map(|&t| side.targets.glossy[t]).collect();
            let mut tree = SplatTree::build(&pos, &nrm);
            if settings.splat_visibility {
                let geo_normals: Vec<Vec3> = targets
                    .iter()
                    .map(|&t| side.targets.geo_normal[t])
                    .collect();
                tree.probe_domains(scene, &geo_normals, None);
            }
            let mut acc = Accumulators::for_tree(&tree, &glossy, mode);
            for batch in &batches {
                counters += splat(&tree, batch, &mut acc, Some(scene));
            }
            let values: Vec<RecordValue> = (0..targets.len())
                .map(|k| record_value(&acc, tree.target_slot[k] as usize, inv_b))
                .collect();
            of_sample
                .iter()
                .map(|t| values[targets.binary_search(t).expect("a sample's own target")].clone())
                .collect()
        },
    );
    (cache, values, counters)
}
