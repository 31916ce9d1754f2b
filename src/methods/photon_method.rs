//! [`PhotonMethod`]: a photon-based method (rs, rc, pm) as the shared [`PhotonCore`] and the
//! method's own [`Resolver`], which turns the core's accumulated light into a film. This is
//! the one step API of the photon methods: the worker, the headless loop and the tests all
//! drive them through [`Method`].

use crate::film::Film;
use crate::methods::photon_core::{CoreConfig, PhotonCore, StoredRays};
use crate::methods::{Method, MethodError, MethodStats, Step, Timings};
use crate::pipeline::cache::Cache;
use crate::pipeline::photon_map::PmStats;
use crate::pipeline::splat::SplatCounters;
use crate::scene::{Camera, Scene};
use crate::settings::{MethodKind, RenderSettings};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// A film and what making it cost: the core adds the timings and counters to its own
/// ([`PhotonCore::record`]).
pub struct Resolved {
    /// The film of the current eye pass.
    pub film: Film,
    /// Time spent (a cache pass is T_S, the rest T_resolve).
    pub timings: Timings,
    /// Splatting counters (rc's cache passes).
    pub counters: SplatCounters,
}

/// How a photon-based method turns its accumulated light into a film.
pub trait Resolver: Send {
    /// Which method this resolver makes.
    const KIND: MethodKind;
    /// How the method uses the photon core.
    const CONFIG: CoreConfig;

    /// The film of the core's current eye pass (may build a cache, or estimate a density
    /// into the core's accumulators).
    fn film(&mut self, core: &mut PhotonCore) -> Resolved;

    /// The radiance cache of the last film, if any.
    fn cache(&self) -> Option<&Cache> {
        None
    }

    /// Photon mapping's gather statistics, if any.
    fn pm_stats(&self) -> Option<PmStats> {
        None
    }
}

/// A photon-based method: the shared photon core and its own resolver.
pub struct PhotonMethod<R> {
    core: PhotonCore,
    resolver: R,
}

impl<R: Resolver + Default> PhotonMethod<R> {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by `camera`.
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
    ) -> Result<Self, MethodError> {
        let settings = RenderSettings {
            method: R::KIND,
            ..settings
        };
        Ok(Self {
            core: PhotonCore::new(scene, settings, camera, R::CONFIG)?,
            resolver: R::default(),
        })
    }
}

impl<R: Resolver> PhotonMethod<R> {
    /// The photon core (read-only: it changes through [`Method`]).
    pub fn core(&self) -> &PhotonCore {
        &self.core
    }

    /// The photon core, for the test helpers that reach below [`Method`]
    /// ([`crate::methods::testing`]).
    pub(crate) fn core_mut(&mut self) -> &mut PhotonCore {
        &mut self.core
    }

    /// The resolver's film of the current eye pass, its costs recorded in the core.
    fn resolve(&mut self) -> Film {
        let r = self.resolver.film(&mut self.core);
        self.core.record(r.timings, r.counters);
        r.film
    }
}

impl<R: Resolver> Method for PhotonMethod<R> {
    fn kind(&self) -> MethodKind {
        R::KIND
    }

    fn settings(&self) -> &RenderSettings {
        self.core.settings()
    }

    fn camera(&self) -> &Camera {
        self.core.camera()
    }

    /// Re-splat one stored batch, or trace and splat a new one; before a new batch, a new
    /// eye pass when the current one has had its share of photons (its film is kept).
    fn step(&mut self) -> Step {
        // A side given up for a new view that has not come (or a view's own, given up for
        // the next) is drawn first, and the step ends there: a paused window steps an owed
        // side but traces no batch.
        if self.core.owes_side() {
            self.core.draw_owed();
            return Step::Side;
        }
        if !self.core.resplat_pending() && self.core.wants_new_eye_pass() {
            let film = self.resolve();
            self.core.next_eye_pass(&film);
            if self.core.owes_side() {
                return Step::Side;
            }
        }
        self.core.step()
    }

    fn catching_up(&self) -> bool {
        self.core.resplat_pending()
    }

    fn mid_step(&self) -> bool {
        self.core.mid_batch() || self.core.owes_side()
    }

    fn set_stop(&mut self, stop: Arc<AtomicBool>) {
        self.core.set_stop(stop);
    }

    fn set_interactive(&mut self, interactive: bool) {
        self.core.set_interactive(interactive);
    }

    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), MethodError> {
        self.core.set_view(camera, width, height, spp)
    }

    fn update(&mut self, settings: &RenderSettings) -> Result<(), MethodError> {
        self.core.update(settings)
    }

    fn set_ray_budget(&mut self, rays: usize) {
        self.core.set_ray_budget(rays);
    }

    fn headless(&mut self) {
        self.core.headless();
    }

    fn pace(&mut self) {
        self.core.pace();
    }

    fn film(&mut self) -> Film {
        let mut film = self.resolve();
        self.core.blend_earlier(&mut film);
        film
    }

    fn final_film(&mut self) -> Film {
        // A film that never reads stored rays resolves from the accumulators through
        // `target_slot` alone: the rest of the splat tree goes first (9 MB of CORNELL BOX I's
        // peak at 500×500×4).
        if R::CONFIG.stored_rays == StoredRays::Unread {
            self.core.release_search();
        }
        self.film()
    }

    fn passes(&self) -> u64 {
        self.core.batch_count() as u64
    }

    fn timings(&self) -> Timings {
        self.core.timings()
    }

    fn stats(&mut self) -> MethodStats {
        let mut s = self.core.stats();
        s.pm = self.resolver.pm_stats();
        if let Some(c) = self.resolver.cache() {
            s.cache_records = Some(c.records.len());
            s.cache_records_per_pass = Some(c.per_pass.clone());
        }
        s
    }

    fn cache(&self) -> Option<&Cache> {
        self.resolver.cache()
    }
}
