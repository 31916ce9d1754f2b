//! rs: photon ray splatting, the paper's method. Every batch of photon rays (indirect and
//! caustic, and direct with `--direct photons`) is splatted onto every splat target as it
//! arrives (Alg. 1); the film is the radiance map over the batches so far (§4, eq. 5),
//! optionally read through the radiance cache (§8.3, the previewer's ε slider) and filtered in
//! image space (§8.2).

use crate::film::Film;
use crate::methods::progressive::{PhotonMethod, Progressive, Resolver};
use crate::pipeline::cache::{self, Cache, PixelGeometry, record_value};
use crate::pipeline::radiance_map::Interpolated;
use crate::settings::MethodKind;
use std::time::Instant;

/// Photon ray splatting.
pub type RaySplatting = PhotonMethod<RsFilm>;

/// rs's film: the full radiance map, optionally through the cache and the filter.
#[derive(Default)]
pub struct RsFilm {
    /// The radiance cache of the last film (with `cache_on`).
    cache: Option<Cache>,
}

impl Resolver for RsFilm {
    const KIND: MethodKind = MethodKind::Rs;
    const SPLATTED: [bool; 3] = [false, true, true];
    const REDRAWS_LOBES: bool = true;
    const REDRAWS_EYE: bool = true;
    const READS_TARGETS: bool = false;
    const READS_STORED_RAYS: bool = false;

    fn film(&mut self, core: &mut Progressive) -> Film {
        let t = Instant::now();
        let b = core.pass_batches() as u32;
        self.cache = None;
        // The cache pass counts as splatting (T_S), not as resolving.
        let mut cache_time = 0.0;
        let mut cached = None;
        if core.settings.cache_on {
            let t = Instant::now();
            let (cache, values) = cache_from_map(core, b);
            (self.cache, cached) = (Some(cache), Some(values));
            cache_time = t.elapsed().as_secs_f64();
            core.timings.t_splat += cache_time;
        }
        let mut map = core.resolve_indirect(b);
        if cached.is_some() || core.settings.filter.enabled {
            core.resolve_samples(&mut map, cached, b, true, false);
        }
        let film = core.compose(map, b, core.splat_direct());
        core.timings.t_resolve += t.elapsed().as_secs_f64() - cache_time;
        film
    }

    fn cache(&self) -> Option<&Cache> {
        self.cache.as_ref()
    }
}

/// The cache's record values read from the full radiance map: no splatting, so ε can move
/// freely (§8.3 in the previewer). Returns the cache and the eye samples' values from it.
fn cache_from_map(core: &Progressive, batches: u32) -> (Cache, Interpolated) {
    let side = &core.side;
    let geo = PixelGeometry::new(&side.eye, core.settings.width, core.settings.height);
    let acc = &side.acc_indirect;
    let inv_b = 1.0 / batches.max(1) as f32;
    cache::build(
        &side.eye,
        &geo,
        &core.camera,
        &core.settings.cache,
        acc.mode,
        |samples| {
            samples
                .iter()
                .map(|&i| {
                    let slot = side.tree.target_slot[side.eye.target[i as usize] as usize] as usize;
                    record_value(acc, slot, inv_b)
                })
                .collect()
        },
    )
}
