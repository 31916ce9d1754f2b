//! rc: radiance caching (§8.3). Caustic photon rays are splatted onto every splat target as
//! batches arrive, as in rs (caustics are sharp by nature); indirect-diffuse light is splatted
//! only onto sparse cache records, picked in image-space passes by the error ε when the film is
//! made, and interpolated between them.

use crate::film::Film;
use crate::methods::progressive::{PhotonMethod, Progressive, Resolver};
use crate::pipeline::cache::{self, Cache, PixelGeometry, RecordValue, record_value};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::radiance_map::{Accumulators, Interpolated};
use crate::pipeline::splat::{SplatBatch, SplatCounters, prepare, splat};
use crate::pipeline::splat_tree::SplatTree;
use crate::settings::MethodKind;
use glam::Vec3;
use std::time::Instant;

/// Radiance caching.
pub type RadianceCaching = PhotonMethod<RcFilm>;

/// rc's film: the cache built by splatting, interpolated, plus the splatted caustics.
#[derive(Default)]
pub struct RcFilm {
    cache: Option<Cache>,
}

impl Resolver for RcFilm {
    const KIND: MethodKind = MethodKind::Rc;
    const SPLATTED: [bool; 3] = [false, false, true];

    fn film(&mut self, core: &mut Progressive) -> Film {
        let t = Instant::now();
        let b = core.pass_batches() as u32;
        // The cache pass counts as splatting (T_S), not as resolving.
        let tc = Instant::now();
        let (cache, values) = cache_by_splatting(core);
        let cache_time = tc.elapsed().as_secs_f64();
        core.timings.t_splat += cache_time;
        // The caustics, splatted onto every target; the interpolated light is added to them.
        let mut map = core.resolve_indirect(b);
        if !cache.is_empty() {
            core.resolve_samples(&mut map, Some(values), b, false, true);
        }
        self.cache = Some(cache);
        let film = core.compose(map, b, core.splat_direct());
        core.timings.t_resolve += t.elapsed().as_secs_f64() - cache_time;
        film
    }

    fn cache(&self) -> Option<&Cache> {
        self.cache.as_ref()
    }
}

/// Every pass of the cache splats the stored indirect photon rays onto its new records only.
/// Returns the cache and the eye samples' values from it.
fn cache_by_splatting(core: &mut Progressive) -> (Cache, Interpolated) {
    let (w, h) = (core.settings.width, core.settings.height);
    let geo = PixelGeometry::new(&core.side.eye, w, h);
    let mode = core.side.acc_indirect.mode;
    // Photon directions serve the directional records of glossy targets only: without any,
    // the rays are prepared without them (records and values keep the map's layout).
    let ray_mode = if core.side.targets.glossy.iter().any(|&g| g) {
        mode
    } else {
        DirectionalMode::Diffuse
    };
    // Rays are prepared once for every pass.
    let batches: Vec<SplatBatch> = core
        .store
        .batches()
        .iter()
        .map(|b| {
            prepare(
                &b.rays,
                &core.bandwidths(b.m),
                [false, true, false],
                ray_mode,
                &core.scene,
            )
        })
        .collect();
    // Without indirect photon rays (a row of fractions such as CORNELL BOX II's (0.2, 0, 0.8))
    // there is no light to cache: records would all be dark, each as small as the image
    // allows, and their passes cost more than the splatted caustics.
    if batches.iter().all(|b| b.rays.is_empty()) {
        return (Cache::default(), Interpolated::default());
    }
    let inv_b = 1.0 / batches.len().max(1) as f32;
    let side = &core.side;
    let mut counters = SplatCounters::default();
    let built = cache::build(
        &side.eye,
        &geo,
        &core.camera,
        &core.settings.cache,
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
            if core.settings.splat_visibility {
                let geo_normals: Vec<Vec3> = targets
                    .iter()
                    .map(|&t| side.targets.geo_normal[t])
                    .collect();
                tree.find_blockers(&core.scene, &geo_normals);
            }
            let mut acc = Accumulators::for_tree(&tree, &glossy, mode);
            for batch in &batches {
                counters += splat(&tree, batch, &mut acc, Some(&core.scene));
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
    core.counters += counters;
    built
}
