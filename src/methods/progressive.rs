//! The progressive loop that rs, rc and pm share ([`Progressive`]): trace a batch of photon
//! rays and splat it with the bandwidth for the total M so far, or re-splat one stored batch
//! after a change of C/S/R or of the view; and [`PhotonMethod`], which wraps it with a
//! method's own way of resolving the film (a [`Resolver`]: rs, rc or pm).
//!
//! Re-splatting is progressive: [`Progressive::step`] splats one stored batch (newest first)
//! per call, and the film averages over the batches splatted so far.
//!
//! Eye passes (issue 16, rs): as batches go on, the eye samples are drawn anew (new sub-pixel
//! positions, NEE samples, branch choices). A finished pass's film is kept as a sum weighted
//! by the batches it held; new batches are splatted onto the new pass with the bandwidth of
//! the total M (as always), and the film is the batch-weighted mean over every pass. So the
//! whole image converges, not only the splatted light: the stochastic progressive photon
//! mapping of visible points, with photon rays.

use crate::film::Film;
use crate::methods::eye_side::EyeSide;
use crate::methods::lobes::TracedLobes;
use crate::methods::photon_store::PhotonStore;
use crate::methods::{MemoryBreakdown, Method, MethodStats, Step, Timings};
use crate::pipeline::cache::{Cache, PixelGeometry, sample_values};
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::filter::filter_samples;
use crate::pipeline::photon::{Bandwidth, BandwidthParams, PhotonRay, plan_light_pass};
use crate::pipeline::photon_map::PmStats;
use crate::pipeline::radiance_map::{Interpolated, RadianceMap, add_radiance_at};
use crate::pipeline::splat::{SplatCounters, prepare_and_splat};
use crate::scene::{Camera, Scene};
use crate::settings::{DirectMode, MethodKind, RenderSettings};
use glam::Vec3;
use std::sync::Arc;
use std::time::Instant;

/// Eye side, photon store and the batch bookkeeping of the photon-based methods.
pub struct Progressive {
    /// The scene.
    pub scene: Arc<Scene>,
    /// The settings (the view's width, height and spp included).
    pub settings: RenderSettings,
    /// The camera.
    pub camera: Camera,
    /// Everything that depends on the view.
    pub side: EyeSide,
    /// The stored photon rays.
    pub store: PhotonStore,
    /// Classes (direct, indirect, caustic) splatted onto every splat target as batches
    /// arrive; none for photon mapping, which gathers when the film is made.
    splatted_classes: [bool; 3],
    /// Stored batches (indices into the store) still to be re-splatted, next last.
    resplat_queue: Vec<usize>,
    /// Batches whose light the accumulators hold.
    splatted: usize,
    /// Batches dropped from the store (over budget) whose light this eye pass's accumulators
    /// still hold.
    folded: usize,
    /// Batches dropped from the store whose light the image still holds (in this pass's
    /// accumulators or an earlier pass's film).
    folded_total: usize,
    /// Counts every change of the accumulated light (a batch traced or re-splatted, a view).
    pub generation: u64,
    /// Splatting counters.
    pub counters: SplatCounters,
    /// Draw traced lobes anew per batch (rs) rather than once in the eye pass.
    redraw_lobes: bool,
    /// The light through traced lobes drawn per batch (with `redraw_lobes`).
    lobes: TracedLobes,
    /// Draw new eye passes as batches go on (the resolver allows it and `progressive_eye`).
    redraw_eye: bool,
    /// The current eye pass of this view (0 first).
    eye_pass: u32,
    /// The films of the finished eye passes of this view.
    earlier: EarlierPasses,
    /// Keep the splat targets' positions and normals ([`Resolver::READS_TARGETS`]).
    keep_targets: bool,
    /// The memory and splat-tree nodes held before [`Progressive::release_search`] (the
    /// stats report what the render held, not what its final resolve left).
    held: Option<(MemoryBreakdown, usize)>,
    /// Time per phase.
    pub timings: Timings,
}

/// An eye pass lasts until its batches hold this many photons per eye sample: shorter passes
/// converged faster down to one pass per batch in the window (docs/deviations.md §41, where
/// 0.5, 0.2, 0.1 and 0.05 were measured), and the bound keeps tiny batches from spending all
/// their time in eye passes.
pub const EYE_PASS_PHOTONS_PER_SAMPLE: f64 = 0.05;

/// The films of finished eye passes, each weighted by the batches it held.
#[derive(Clone, Debug, Default)]
struct EarlierPasses {
    /// Σ batches · film, per pixel.
    rgb: Vec<Vec3>,
    direct: Vec<Vec3>,
    indirect: Vec<Vec3>,
    /// Σ batches.
    batches: usize,
    /// Passes in the sums.
    passes: u32,
    /// Their dropped contributions.
    invalid: u64,
}

impl EarlierPasses {
    fn add(&mut self, film: &Film, batches: usize, store_invalid: u64) {
        let n = film.rgb.len();
        if self.rgb.len() != n {
            *self = Self {
                rgb: vec![Vec3::ZERO; n],
                direct: vec![Vec3::ZERO; n],
                indirect: vec![Vec3::ZERO; n],
                ..Self::default()
            };
        }
        let w = batches as f32;
        for (sum, px) in [
            (&mut self.rgb, &film.rgb),
            (&mut self.direct, &film.direct),
            (&mut self.indirect, &film.indirect),
        ] {
            for (s, p) in sum.iter_mut().zip(px) {
                *s += w * *p;
            }
        }
        self.batches += batches;
        self.passes += 1;
        // The store's dropped photon rays are a running total every film carries: counted
        // once, by the current pass's film.
        self.invalid += film.invalid_contributions - film.invalid_contributions.min(store_invalid);
    }

    /// `film` (of the current pass, holding `batches`) becomes the mean over every pass.
    fn blend(&self, film: &mut Film, batches: usize) {
        if self.batches == 0 || self.rgb.len() != film.rgb.len() {
            return;
        }
        let w = batches as f32;
        let inv = 1.0 / (self.batches + batches) as f32;
        for (sum, px) in [
            (&self.rgb, &mut film.rgb),
            (&self.direct, &mut film.direct),
            (&self.indirect, &mut film.indirect),
        ] {
            for (s, p) in sum.iter().zip(px.iter_mut()) {
                *p = (*s + w * *p) * inv;
            }
        }
        film.invalid_contributions += self.invalid;
    }
}

impl Progressive {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by `camera`;
    /// `splatted_classes` are splatted onto every target as batches arrive; traced glossy
    /// lobes get new directions per batch when `redraw_lobes`, else one in the eye pass.
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
        splatted_classes: [bool; 3],
        redraw_lobes: bool,
        redraw_eye: bool,
        keep_targets: bool,
    ) -> Result<Self, String> {
        let mut timings = Timings::default();
        let side = EyeSide::new(
            &scene,
            &camera,
            &settings,
            !redraw_lobes,
            0,
            keep_targets,
            &mut timings,
        )?;
        let lobes = TracedLobes::new(&side.eye);
        let t = Instant::now();
        let mut store = PhotonStore::new(&scene, settings.seed);
        store.set_progressive_bandwidth(settings.progressive_bandwidth);
        store.set_batch_photons(settings.photons);
        timings.t_light = t.elapsed().as_secs_f64();
        Ok(Self {
            scene,
            settings,
            camera,
            side,
            store,
            splatted_classes,
            resplat_queue: Vec::new(),
            splatted: 0,
            folded: 0,
            folded_total: 0,
            generation: 0,
            counters: SplatCounters::default(),
            redraw_lobes,
            lobes,
            redraw_eye,
            eye_pass: 0,
            earlier: EarlierPasses::default(),
            keep_targets,
            held: None,
            timings,
        })
    }

    /// Batches whose light the image holds (stored and splatted, plus folded), over every
    /// eye pass.
    pub fn batch_count(&self) -> usize {
        self.earlier.batches + self.pass_batches()
    }

    /// Batches whose light the current eye pass's accumulators hold.
    pub fn pass_batches(&self) -> usize {
        self.splatted + self.folded
    }

    /// Eye passes of this view so far (the current one included).
    pub fn eye_passes(&self) -> u32 {
        self.earlier.passes + 1
    }

    /// True when the current eye pass has held its share of photons
    /// ([`EYE_PASS_PHOTONS_PER_SAMPLE`]) and a new one should be drawn before the next batch.
    pub fn wants_new_eye_pass(&self) -> bool {
        self.redraw_eye
            && self.eye_passes_allowed()
            && self.resplat_queue.is_empty()
            && self.pass_batches() as f64 * self.settings.photons as f64
                >= EYE_PASS_PHOTONS_PER_SAMPLE * self.side.eye.len().max(1) as f64
    }

    /// Eye passes are drawn with `progressive_eye`, but not while the image-space filter
    /// (§8.2) or the radiance cache (§8.3) reads the radiance map: both work on one pass's
    /// samples with a radius or records sized by that pass's batches, so averaging filtered
    /// passes would keep a one-batch blur forever (deviations §41).
    fn eye_passes_allowed(&self) -> bool {
        self.settings.progressive_eye && !self.settings.filter.enabled && !self.settings.cache_on
    }

    /// Keep `film` (the current pass's, not blended) with the weight of its batches and draw
    /// a new eye pass; the next batches are splatted onto it.
    pub fn next_eye_pass(&mut self, film: &Film) {
        let pass = self.eye_pass + 1;
        self.earlier
            .add(film, self.pass_batches(), self.store.invalid_photon_rays);
        // Free the finished side's arrays first (its film is kept), so that the peak holds
        // one eye side, not two (a `--time-budget` render of CORNELL BOX I at 500×500×4:
        // docs/benchmarks.md, "Memory").
        self.side.release();
        self.lobes = TracedLobes::default();
        match EyeSide::new(
            &self.scene,
            &self.camera,
            &self.settings,
            !self.redraw_lobes,
            pass,
            self.keep_targets,
            &mut self.timings,
        ) {
            Ok(side) => self.side = side,
            Err(_) => {
                // Unreachable for a view that was built once; should it happen, the view
                // starts again from the stored rays rather than splatting onto nothing.
                let (w, h, spp) = (self.settings.width, self.settings.height, self.settings.spp);
                let _ = self.set_view(self.camera.clone(), w, h, spp);
                return;
            }
        }
        self.eye_pass = pass;
        self.lobes = TracedLobes::new(&self.side.eye);
        self.splatted = 0;
        self.folded = 0;
        self.generation += 1;
    }

    /// `film` of the current pass becomes the batch-weighted mean over every eye pass.
    pub fn blend_earlier(&self, film: &mut Film) {
        self.earlier.blend(film, self.pass_batches());
    }

    /// True while stored batches wait to be re-splatted after a parameter or view change.
    pub fn resplat_pending(&self) -> bool {
        !self.resplat_queue.is_empty()
    }

    /// Direct light comes from splatted direct photons.
    pub fn splat_direct(&self) -> bool {
        self.settings.direct == DirectMode::Photons
    }

    /// Eq. 8's bandwidth per class for class sizes `m` under the current C, S, R.
    pub fn bandwidths(&self, m: [u64; 3]) -> [Bandwidth; 3] {
        self.store.bandwidths(&self.settings.bandwidth, m)
    }

    /// Do one unit of work: re-splat the next stored batch if a re-splat is pending,
    /// otherwise trace and splat a new batch.
    pub fn step(&mut self) -> Step {
        if let Some(b) = self.resplat_queue.pop() {
            let t = Instant::now();
            self.splat_stored(b);
            self.timings.t_splat += t.elapsed().as_secs_f64();
            self.draw_lobes(b);
            Step::Resplatted
        } else {
            self.run_batch();
            Step::Traced
        }
    }

    /// Trace one light pass of M photons, splat it with the bandwidth for the total M so
    /// far. Finishes a pending re-splat first.
    pub fn run_batch(&mut self) {
        debug_assert!(
            !self.side.tree.is_released(),
            "a render takes no step after its final film"
        );
        while self.resplat_pending() {
            self.step();
        }
        if self.store.frees_every_batch() {
            self.stream_batch();
        } else {
            let t = Instant::now();
            let b = self
                .store
                .trace(&self.scene, &self.settings, self.splat_direct());
            self.timings.t_light += t.elapsed().as_secs_f64();

            let t = Instant::now();
            self.splat_stored(b);
            self.timings.t_splat += t.elapsed().as_secs_f64();
            self.draw_lobes(b);
        }
        let t = Instant::now();
        self.folded_total += self.store.fold();
        // The dropped batches are the oldest; those of earlier eye passes were not splatted
        // onto this one, whose batches are the newest `splatted` of the store.
        let stored = self.store.batches().len();
        if self.splatted > stored {
            self.folded += self.splatted - stored;
            self.splatted = stored;
        }
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// [`Progressive::run_batch`] when no batch is kept once splatted (a headless rs render):
    /// the light pass is counted first, then traced again a wave at a time, and each wave is
    /// splatted (onto the eye side and the traced lobes) and dropped, so the batch's rays are
    /// never held whole (docs/benchmarks.md, "Memory"). The same rays, in the same order, with
    /// the same bandwidths as a stored batch; the second trace costs one more T_L.
    fn stream_batch(&mut self) {
        let t = Instant::now();
        let lps = self
            .store
            .light_pass_settings(&self.settings, self.splat_direct());
        let plan = plan_light_pass(&self.scene, &lps);
        let b = self.store.add_streamed(&plan, self.settings.photons);
        self.timings.t_light += t.elapsed().as_secs_f64();
        let bw = self.bandwidths(self.store.batches()[b].m);
        let mut lobes = if self.redraw_lobes {
            self.lobes.begin_batch(
                &self.scene,
                &self.camera,
                &self.settings,
                &self.side,
                self.splatted_classes,
                &mut self.timings,
            )
        } else {
            None
        };

        let t = Instant::now();
        let mut t_splat = 0.0;
        let (scene, side, counters) = (&self.scene, &mut self.side, &mut self.counters);
        let (classes, direct) = (self.splatted_classes, self.settings.direct);
        let mode = self.settings.radiance_map;
        plan.stream(scene, &lps, |rays| {
            let t = Instant::now();
            let photons = direct == DirectMode::Photons;
            *counters += splat_rays(scene, side, rays, &bw, classes, photons, mode);
            if let Some(l) = lobes.as_mut() {
                l.gather(scene, rays, &bw);
            }
            t_splat += t.elapsed().as_secs_f64();
        });
        self.timings.t_light += t.elapsed().as_secs_f64() - t_splat;
        let t = Instant::now();
        if let Some(l) = lobes {
            self.lobes.finish_batch(&self.scene, l);
        }
        self.timings.t_splat += t_splat + t.elapsed().as_secs_f64();
        self.splatted += 1;
        self.generation += 1;
    }

    /// Splat stored batch `b` with the bandwidth of its M under the current parameters.
    fn splat_stored(&mut self, b: usize) {
        let batch = &self.store.batches()[b];
        let bw = self.bandwidths(batch.m);
        self.counters += splat_rays(
            &self.scene,
            &mut self.side,
            &batch.rays,
            &bw,
            self.splatted_classes,
            self.settings.direct == DirectMode::Photons,
            self.settings.radiance_map,
        );
        self.splatted += 1;
        self.generation += 1;
    }

    /// With `redraw_lobes`, new directions for the traced glossy lobes, and stored batch `b`
    /// gathered where they land (timed into T_E, T_D and T_S by the lobes themselves).
    fn draw_lobes(&mut self, b: usize) {
        if !self.redraw_lobes {
            return;
        }
        let batch = &self.store.batches()[b];
        let bw = self.bandwidths(batch.m);
        self.lobes.add_batch(
            &self.scene,
            &self.camera,
            &self.settings,
            &self.side,
            &batch.rays,
            &bw,
            self.splatted_classes,
            &mut self.timings,
        );
    }

    /// Start re-splatting every stored batch with new bandwidth parameters (no re-tracing).
    /// Folded batches cannot be re-splatted: their light leaves the image.
    pub fn begin_resplat(&mut self, params: BandwidthParams) {
        self.settings.bandwidth = params;
        self.side.clear();
        self.lobes.clear();
        self.splatted = 0;
        self.folded = 0;
        self.folded_total = 0;
        // Earlier eye passes hold light of the old bandwidth: every stored batch goes onto
        // the current pass instead.
        self.earlier = EarlierPasses::default();
        self.generation += 1;
        // Newest first: it has the smallest bandwidth, so the first frame is the sharpest.
        self.resplat_queue = (0..self.store.batches().len()).collect();
    }

    /// A new camera, resolution or sample count: new eye pass and splat tree, then a
    /// progressive re-splat of the stored rays (photon rays do not depend on the view).
    pub fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), String> {
        let settings = self.settings.with_view(width, height, spp);
        crate::methods::check(&settings)?;
        self.side = EyeSide::new(
            &self.scene,
            &camera,
            &settings,
            !self.redraw_lobes,
            0,
            self.keep_targets,
            &mut self.timings,
        )?;
        self.eye_pass = 0;
        self.lobes = TracedLobes::new(&self.side.eye);
        self.settings = settings;
        self.camera = camera;
        self.begin_resplat(self.settings.bandwidth);
        Ok(())
    }

    /// Apply settings that need no re-trace ([`Method::update`]).
    pub fn update(&mut self, s: &RenderSettings) -> Result<(), String> {
        self.settings.photons = s.photons;
        self.settings.cache = s.cache;
        self.settings.cache_on = s.cache_on;
        self.settings.filter = s.filter;
        self.settings.progressive_eye = s.progressive_eye;
        self.settings.progressive_bandwidth = s.progressive_bandwidth;
        // Either can move the progressive schedule's M₁ (deviations §43).
        let schedule = self
            .store
            .set_progressive_bandwidth(s.progressive_bandwidth);
        if self.store.set_batch_photons(s.photons) || schedule {
            self.begin_resplat(s.bandwidth);
        }
        // Earlier passes' films were made without the cache and filter now asked for: their
        // batches go onto the current pass (a re-splat), so that the change reaches all of it.
        if !self.eye_passes_allowed() && self.earlier.batches > 0 {
            self.begin_resplat(s.bandwidth);
        }
        if s.radiance_map != self.settings.radiance_map {
            // New accumulators with the new directional records, then a re-splat.
            self.settings.radiance_map = s.radiance_map;
            self.settings.bandwidth = s.bandwidth;
            let (w, h, spp) = (self.settings.width, self.settings.height, self.settings.spp);
            return self.set_view(self.camera.clone(), w, h, spp);
        }
        if s.bandwidth != self.settings.bandwidth {
            self.begin_resplat(s.bandwidth);
        }
        Ok(())
    }

    /// Resolve `acc_indirect` into a radiance map, averaged over `batches`.
    pub fn resolve_indirect(&self, batches: u32) -> RadianceMap {
        let side = &self.side;
        let mut map = RadianceMap::new(self.settings.width, self.settings.height);
        map.resolve_from(
            &self.scene,
            &side.eye,
            &side.tree.target_slot,
            &side.acc_indirect,
            batches,
        );
        map
    }

    /// Resolve `map` again from per-sample incident light: `cached` (the cache's values,
    /// [`crate::pipeline::cache::build`]), or else the accumulators' own values over
    /// `batches`, filtered in image space when the filter is on (§8.2), with the splat statistics of `map` when `splat_stats`
    /// (none exist at interpolated samples: the filter then takes its default radius). The
    /// light replaces the map's, or is added to it with `add`.
    pub fn resolve_samples(
        &self,
        map: &mut RadianceMap,
        cached: Option<Interpolated>,
        batches: u32,
        splat_stats: bool,
        add: bool,
    ) {
        let side = &self.side;
        let geo = PixelGeometry::new(&side.eye, self.settings.width, self.settings.height);
        let mode = side.acc_indirect.mode;
        let mut values = match cached {
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
            let splats: Vec<f32> = if splat_stats {
                map.info.iter().map(|i| i.splats).collect()
            } else {
                vec![0.0; map.info.len()]
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
        map.resolve_interpolated(&self.scene, &side.eye, &values, mode, add);
    }

    /// Compose the film: emission + direct light (NEE, or splatted direct photons when
    /// `direct_photons`) + the indirect radiance map, with AOVs.
    pub fn compose(&self, map: RadianceMap, batches: u32, direct_photons: bool) -> Film {
        let (w, h) = (self.settings.width, self.settings.height);
        let side = &self.side;
        // The map's radiance and statistics become the film's (moved: docs/benchmarks.md,
        // "Memory").
        let invalid_map = map.invalid;
        let mut film = Film::around(w, h, map.radiance, map.info);
        // Direct light goes straight into the film (no second map, no copy: docs/benchmarks.md,
        // "Memory").
        // (A released side, after a failed eye pass, has no sums: its film stays black.)
        if side.direct.len() == film.direct.len() {
            film.direct.copy_from_slice(&side.direct);
        }
        if direct_photons {
            film.invalid_contributions += add_radiance_at(
                &self.scene,
                &side.eye,
                &side.tree.target_slot,
                &side.acc_direct,
                batches,
                &mut film.direct,
                |i| Some(side.eye.pixel[i] as usize),
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
        film
    }

    /// Free the splat tree's search structure before a finished render's last resolve (it
    /// takes no more steps); the stats keep reporting the memory held until then.
    pub fn release_search(&mut self) {
        if self.held.is_none() {
            self.held = Some((self.memory(), self.side.tree.nodes.len()));
        }
        self.side.tree.release_search();
    }

    /// Where this render's memory is (issue 16): what it held before
    /// [`Progressive::release_search`], if that was called.
    pub fn memory(&self) -> MemoryBreakdown {
        if let Some((m, _)) = self.held {
            return m;
        }
        let side = &self.side;
        let (directional, _) = side.directional_memory();
        let pixels = (self.settings.width * self.settings.height) as usize;
        let vec3 = std::mem::size_of::<Vec3>();
        MemoryBreakdown {
            eye_samples: side.eye.memory_bytes(),
            splat_targets: side.targets.memory_bytes(),
            splat_tree: side.tree.memory_bytes(),
            accumulators: side.acc_indirect.memory_bytes() + side.acc_direct.memory_bytes()
                - directional,
            directional_records: directional,
            photon_rays: self.store.memory_bytes(),
            pixel_sums: side.direct.len() * vec3
                + self.lobes.memory_bytes()
                + 3 * self.earlier.rgb.len() * vec3,
            film: pixels * Film::BYTES_PER_PIXEL,
            scene: self.scene.memory_bytes(),
        }
    }

    /// The counters every photon-based method shares.
    pub fn stats(&mut self) -> MethodStats {
        let (directional_bytes, glossy_targets) = self.side.directional_memory();
        let (glossy_map_samples, glossy_traced_samples) = self.side.eye.glossy_counts();
        let clamps = self.store.clamps(&self.settings.bandwidth);
        MethodStats {
            photons_traced: self.store.photons_traced,
            photon_rays: self.store.rays() + self.store.released,
            photon_rays_per_class: self.store.rays_per_class(),
            photon_ray_bytes: self.store.memory_bytes(),
            passes: self.batch_count() as u64,
            folded_batches: self.folded_total,
            eye_passes: self.eye_passes(),
            memory: self.memory(),
            stored_batches: self.store.batches().len(),
            splat_bytes: self.side.memory_bytes(),
            directional_bytes,
            glossy_targets,
            glossy_map_samples,
            glossy_traced_samples,
            eye_samples: self.side.eye.len(),
            splat_targets: self.side.tree.samples,
            splat_tree_nodes: self
                .held
                .map_or(self.side.tree.nodes.len(), |(_, nodes)| nodes),
            tested_pairs: self.counters.tested,
            accepted_pairs: self.counters.accepted,
            shadow_tests: self.counters.shadow_tests,
            occluded_pairs: self.counters.occluded,
            pilot_mean_length: Some(self.store.pilot().mean_length),
            bandwidth_clamps: Some(clamps),
            ..MethodStats::default()
        }
    }
}

/// Splat `rays` of the `classes` (direct, indirect, caustic) onto the eye side's targets
/// (direct photons, when `direct_photons`, into their own accumulators).
fn splat_rays(
    scene: &Scene,
    side: &mut EyeSide,
    rays: &[PhotonRay],
    bw: &[Bandwidth; 3],
    classes: [bool; 3],
    direct_photons: bool,
    mode: crate::pipeline::directional::DirectionalMode,
) -> SplatCounters {
    let mut counters = SplatCounters::default();
    if classes == [false; 3] {
        return counters;
    }
    counters += prepare_and_splat(
        &side.tree,
        rays,
        bw,
        classes,
        mode,
        scene,
        &mut side.acc_indirect,
        Some(scene),
    );
    if direct_photons {
        counters += prepare_and_splat(
            &side.tree,
            rays,
            bw,
            [true, false, false],
            mode,
            scene,
            &mut side.acc_direct,
            Some(scene),
        );
    }
    counters
}

/// How a photon-based method turns its accumulated light into a film.
pub trait Resolver: Send {
    /// Which method this resolver makes.
    const KIND: MethodKind;
    /// Classes (direct, indirect, caustic) splatted onto every splat target as batches
    /// arrive (direct photons go to their own accumulators when `--direct photons`).
    const SPLATTED: [bool; 3];
    /// Traced glossy lobes get new directions per photon batch, so that they converge with
    /// the batches ([`TracedLobes`]); otherwise one direction per eye sample in the eye pass.
    const REDRAWS_LOBES: bool = false;
    /// Eye passes are drawn anew as batches go on (with `progressive_eye`): the resolver
    /// reads the current pass's accumulators only, over [`Progressive::pass_batches`].
    const REDRAWS_EYE: bool = false;
    /// The film reads the splat targets' positions and normals (pm's density estimate,
    /// rc's records); without it they are freed once the splat tree is built.
    const READS_TARGETS: bool = true;
    /// The film reads the stored photon rays (pm gathers them, rc splats them onto its
    /// cache records); without it a headless render frees each batch once it is splatted.
    const READS_STORED_RAYS: bool = true;

    /// The film from the core's state (may build a cache or a density estimate, timed into
    /// the core's T_S).
    fn film(&mut self, core: &mut Progressive) -> Film;

    /// The radiance cache of the last film, if any.
    fn cache(&self) -> Option<&Cache> {
        None
    }

    /// Photon mapping's gather statistics, if any.
    fn pm_stats(&self) -> Option<PmStats> {
        None
    }
}

/// A photon-based method: the shared progressive core and its own resolver.
pub struct PhotonMethod<R> {
    /// Eye side, photon store and batch bookkeeping.
    pub core: Progressive,
    /// How the film is made.
    pub resolver: R,
}

impl<R: Resolver + Default> PhotonMethod<R> {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by `camera`.
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
    ) -> Result<Self, String> {
        let settings = RenderSettings {
            method: R::KIND,
            ..settings
        };
        Ok(Self {
            core: Progressive::new(
                scene,
                settings,
                camera,
                R::SPLATTED,
                R::REDRAWS_LOBES,
                R::REDRAWS_EYE,
                R::READS_TARGETS,
            )?,
            resolver: R::default(),
        })
    }

    /// As [`PhotonMethod::new`], from the settings' named camera (or the scene's first).
    pub fn open(scene: Arc<Scene>, settings: RenderSettings) -> Result<Self, String> {
        let camera = scene.camera_or_error(settings.camera.as_deref())?;
        Self::new(scene, settings, camera)
    }
}

impl<R: Resolver> PhotonMethod<R> {
    /// Trace and splat one batch (after any pending re-splat, and on a new eye pass when the
    /// current one has had its share).
    pub fn run_batch(&mut self) {
        while self.core.resplat_pending() {
            self.core.step();
        }
        self.maybe_next_eye_pass();
        self.core.run_batch();
    }

    /// Draw a new eye pass when the current one has had its share of photons, keeping the
    /// current pass's film.
    fn maybe_next_eye_pass(&mut self) {
        if self.core.wants_new_eye_pass() {
            let film = self.resolver.film(&mut self.core);
            self.core.next_eye_pass(&film);
        }
    }

    /// Re-splat every stored batch with new bandwidth parameters, all at once.
    pub fn resplat(&mut self, params: BandwidthParams) {
        self.core.begin_resplat(params);
        while self.core.resplat_pending() {
            self.core.step();
        }
    }

    /// Batches whose light the image holds.
    pub fn batch_count(&self) -> usize {
        self.core.batch_count()
    }

    /// The eye samples of the current view.
    pub fn eye_samples(&self) -> &EyeSamples {
        &self.core.side.eye
    }

    /// The positions of the current view's splat targets, from the splat tree (rs frees the
    /// targets' own copy once the tree is built).
    pub fn target_positions(&self) -> Vec<Vec3> {
        let tree = &self.core.side.tree;
        tree.target_slot.iter().map(|&s| tree.position(s)).collect()
    }

    /// Batch-averaged splatted irradiance E (eq. 5) at every splat target of the current
    /// eye pass, from the indirect and caustic photons (`direct` = false) or from the direct
    /// photons (`direct` = true).
    pub fn target_irradiance(&self, direct: bool) -> Vec<Vec3> {
        self.core
            .side
            .target_irradiance(direct, self.core.pass_batches())
    }
}

impl<R: Resolver> Method for PhotonMethod<R> {
    fn kind(&self) -> MethodKind {
        R::KIND
    }

    fn settings(&self) -> &RenderSettings {
        &self.core.settings
    }

    fn camera(&self) -> &Camera {
        &self.core.camera
    }

    fn step(&mut self) -> Step {
        if !self.core.resplat_pending() {
            self.maybe_next_eye_pass();
        }
        self.core.step()
    }

    fn catching_up(&self) -> bool {
        self.core.resplat_pending()
    }

    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), String> {
        self.core.set_view(camera, width, height, spp)
    }

    fn update(&mut self, settings: &RenderSettings) -> Result<(), String> {
        self.core.update(settings)
    }

    fn set_ray_budget(&mut self, rays: usize) {
        self.core.store.max_stored_rays = rays;
    }

    fn headless(&mut self) {
        if !R::READS_STORED_RAYS {
            self.core.store.max_stored_rays = 0;
            self.core.store.keep_newest = false;
        }
    }

    fn film(&mut self) -> Film {
        let mut film = self.resolver.film(&mut self.core);
        self.core.blend_earlier(&mut film);
        film
    }

    fn final_film(&mut self) -> Film {
        // A film that never reads stored rays resolves from the accumulators through
        // `target_slot` alone: the rest of the splat tree goes first (9 MB of CORNELL BOX I's
        // peak at 500×500×4).
        if !R::READS_STORED_RAYS {
            self.core.release_search();
        }
        self.film()
    }

    fn passes(&self) -> u64 {
        self.core.batch_count() as u64
    }

    fn timings(&self) -> Timings {
        self.core.timings
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
