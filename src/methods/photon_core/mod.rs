//! The photon core that rs, rc and pm share ([`PhotonCore`]): one view's eye side, the stored
//! photon rays and the batch bookkeeping. A step traces a batch of photon rays and splats it
//! with the bandwidth for the total M so far, or re-splats one stored batch after a change of
//! C/S/R or of the view (newest first; the film averages over the batches splatted so far).
//! Each method's way of turning the accumulated light into a film is its
//! [`crate::methods::photon_method::Resolver`]; how a method uses the core is its
//! [`CoreConfig`].
//!
//! Eye passes (rs, docs/deviations.md §41): as batches go on, the eye samples are drawn anew
//! (new sub-pixel positions, NEE samples, branch choices). A finished pass's film is kept as a
//! sum weighted by the batches it held; new batches are splatted onto the new pass with the
//! bandwidth of the total M (as always), and the film is the batch-weighted mean over every
//! pass. So the whole image converges, not only the splatted light: the stochastic
//! progressive photon mapping of visible points, with photon rays.
//!
//! The files: this one holds the state, its configuration and the changes (re-splat, view,
//! update); `batches` traces and splats; `passes` keeps the finished eye passes; `film` makes
//! a film from the accumulators; `report` says what the core holds.

mod batches;
pub use batches::{MAX_SPLAT_PIECES, SPLAT_PIECES};
mod film;
mod passes;
mod report;

pub use film::{Combine, DirectPhotons, SampleLight, SplatStats};

use crate::methods::eye_side::{EyeSide, EyeSideOptions, LobeDraws, TargetGeometry};
use crate::methods::lobes::TracedLobes;
use crate::methods::photon_store::PhotonStore;
use crate::methods::{MemoryBreakdown, MethodError, Step, Timings};
use crate::pipeline::eye::SplatTargets;
use crate::pipeline::photon::{Bandwidth, BandwidthParams, ClampCounts};
use crate::pipeline::radiance_map::Accumulators;
use crate::pipeline::splat::SplatCounters;
use crate::pipeline::splat_tree::DomainCache;
use crate::scene::{Camera, Scene};
use crate::settings::{DirectMode, Effect, RenderSettings};
use passes::{BandwidthHistory, EarlierPasses};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// Photon classes (direct, indirect, caustic) splatted onto every splat target as batches
/// arrive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Classes {
    /// Direct photons into the same accumulators as the others (no method does: with
    /// `--direct photons` they go to their own accumulators, whatever this says).
    pub direct: bool,
    /// Indirect-diffuse photons.
    pub indirect: bool,
    /// Caustic photons.
    pub caustic: bool,
}

impl Classes {
    /// None: photon mapping gathers when the film is made.
    pub const NONE: Self = Self {
        direct: false,
        indirect: false,
        caustic: false,
    };

    /// The mask the splatting stages take, in class order.
    pub fn mask(self) -> [bool; 3] {
        [self.direct, self.indirect, self.caustic]
    }
}

/// Whether the eye samples are drawn once per view or anew as batches go on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EyePasses {
    /// One eye pass per view.
    One,
    /// A new eye pass whenever the current one has held its share of photons (with the
    /// `progressive_eye` setting; docs/deviations.md §41).
    Redrawn,
}

/// Whether the film reads the stored photon rays (pm gathers them, rc splats them onto its
/// cache records).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoredRays {
    /// The film reads them: every batch is kept, headless renders included.
    Read,
    /// Only re-splats read them: a headless render frees each batch once it is splatted.
    Unread,
}

/// How a photon method uses the core: its resolver's choices, named.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoreConfig {
    /// Classes splatted onto every splat target as batches arrive.
    pub splatted: Classes,
    /// When traced glossy lobes get their directions.
    pub lobes: LobeDraws,
    /// Eye passes per view.
    pub eye_passes: EyePasses,
    /// Whether the splat targets' positions and normals outlive the splat tree's build.
    pub targets: TargetGeometry,
    /// Whether the film reads the stored photon rays.
    pub stored_rays: StoredRays,
}

/// An eye pass lasts until its batches hold this many photons per eye sample: shorter passes
/// converged faster down to one pass per batch in the window (docs/deviations.md §41, where
/// 0.5, 0.2, 0.1 and 0.05 were measured), and the bound keeps tiny batches from spending all
/// their time in eye passes.
pub const EYE_PASS_PHOTONS_PER_SAMPLE: f64 = 0.05;

/// A paced render ([`PhotonCore::pace`]) draws a new eye pass only once the photon batches
/// splatted onto the current one have taken this many times the pass's own cost: at most
/// half of the time goes to eye passes where they are dear (visible domains' probes at a
/// high resolution, a room's few photons per batch), and cheap ones stay one per batch
/// (docs/deviations.md §50).
pub const EYE_PASS_COST_RATIO: f64 = 1.0;

/// `--c auto` changes C by at most this factor per eye pass (docs/deviations.md §51).
pub const AUTO_C_STEP: f32 = 1.1;

/// One view's eye side, the stored photon rays and the batch bookkeeping of the photon-based
/// methods. Its state is private: anyone may read it through the accessors below; only the
/// crate changes it (the methods' one step API is [`crate::methods::photon_method::PhotonMethod`],
/// which draws the eye passes around [`PhotonCore::step`]).
pub struct PhotonCore {
    scene: Arc<Scene>,
    /// The settings (the view's width, height and spp included).
    settings: RenderSettings,
    camera: Camera,
    config: CoreConfig,
    /// Everything that depends on the view.
    side: EyeSide,
    /// The visible domains earlier eye passes and views probed, which later targets take
    /// where they fit (docs/deviations.md §40).
    domains: DomainCache,
    /// The stored photon rays.
    store: PhotonStore,
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
    generation: u64,
    /// Splatting counters.
    counters: SplatCounters,
    /// The light through traced lobes drawn per batch (with [`LobeDraws::PerBatch`]).
    lobes: TracedLobes,
    /// The current eye pass of this view (0 first).
    eye_pass: u32,
    /// The films of the finished eye passes of this view.
    earlier: EarlierPasses,
    /// The bandwidths of the batches the current eye pass holds (`--c auto`).
    pass_history: BandwidthHistory,
    /// Batches the last re-splat put onto one eye pass (a new view, a C, S or R change):
    /// `--c auto` holds its C until the passes drawn since outweigh that one.
    resplatted: usize,
    /// A new or re-splatted batch whose splat is cut into pieces (the window), until its last
    /// piece.
    splatting: Option<batches::PartialSplat>,
    /// Re-splatted batches (and the bandwidths they were splatted with) whose error-estimate
    /// splat at h/k waits until every stored batch is back in the image: the window's first
    /// frame after a change does not wait for it (docs/deviations.md §51, "The fine splat
    /// deferred"). Until they are paid the pass has no estimate of its own.
    fine_owed: Vec<(usize, [Bandwidth; 3])>,
    /// A batch of this eye side skipped its fine splat (an interactive view, which is
    /// replaced before its estimate would mean anything): the side makes no estimate.
    fine_skipped: bool,
    /// The streamed batches' rays at the bandwidth bounds and the floor, per class (a
    /// headless render keeps no batch to count them from later).
    streamed_clamps: [ClampCounts; 3],
    /// A headless render splats each batch whole (its progress reads whole films).
    whole_batches: bool,
    /// Seconds the last batch splatted in pieces took, its pieces added up: the next batch's
    /// pieces are sized by it ([`batches::PIECE_SECONDS`]).
    last_splat: f64,
    /// The window's view is interactive: re-splats go whole, a frame per step
    /// ([`PhotonCore::set_interactive`]).
    interactive: bool,
    /// The memory and splat-tree nodes held before [`PhotonCore::release_search`] (the
    /// stats report what the render held, not what its final resolve left).
    held: Option<(MemoryBreakdown, usize)>,
    /// Time per phase.
    timings: Timings,
    /// Eye passes and NEE draws paced by their measured cost ([`PhotonCore::pace`]).
    paced: bool,
    /// What the current eye pass and its NEE draws cost, and what was spent since.
    pub(crate) clock: PassClock,
    /// Raised by the window's worker when a new view arrives: an eye side being drawn for a
    /// resting view is given up, since the new view discards it
    /// ([`PhotonCore::set_stop`]; a dragged view's sides are always finished).
    stop: Option<Arc<AtomicBool>>,
    /// The eye pass whose side was given up and is still to be drawn (its view and settings
    /// already adopted): the next step draws it before anything else, and until then the
    /// core is mid-step (no film is taken).
    owed: Option<u32>,
}

/// The costs a paced render weighs (docs/deviations.md §50), in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PassClock {
    /// The current eye pass's own cost (eye pass, splat tree, visible domains, NEE).
    pub pass_cost: f64,
    /// Spent on new batches (and NEE redraws) since the pass was drawn.
    pub pass_spent: f64,
    /// The last NEE draw's cost.
    pub nee_cost: f64,
    /// Spent on new batches since the last NEE draw.
    pub since_nee: f64,
}

impl PassClock {
    /// A clock for an eye side whose drawing moved the timings from `before` to `after`.
    fn started(before: &Timings, after: &Timings) -> Self {
        Self {
            pass_cost: after.t_eye + after.t_direct - before.t_eye - before.t_direct,
            nee_cost: after.t_direct - before.t_direct,
            ..Self::default()
        }
    }

    /// Another NEE draw pays: the batches since the last took longer than it did.
    fn nee_due(&self) -> bool {
        self.since_nee >= self.nee_cost
    }

    /// A new eye pass pays: the batches on this one took [`EYE_PASS_COST_RATIO`] times its cost.
    fn pass_due(&self) -> bool {
        self.pass_spent >= EYE_PASS_COST_RATIO * self.pass_cost
    }
}

impl PhotonCore {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by `camera`, used as
    /// `config` says.
    pub(crate) fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
        config: CoreConfig,
    ) -> Result<Self, MethodError> {
        let mut timings = Timings::default();
        let mut domains = DomainCache::default();
        let side = EyeSide::new(
            &scene,
            &camera,
            &settings,
            side_options(config, 0),
            Some(&mut domains),
            &mut timings,
        )?;
        let lobes = TracedLobes::new(&side.eye);
        let t = Instant::now();
        let mut store = PhotonStore::new(&scene, settings.seed);
        store.set_progressive_bandwidth(settings.progressive_bandwidth);
        // Photon mapping gathers: no floors to keep (docs/deviations.md §63).
        store.set_floors(config.splatted != Classes::NONE);
        // Only a method that splats its indirect light onto the eye samples learns where
        // photons reach them (rs): rc splats only caustics there, pm gathers.
        store.set_guided(&scene, settings.guided_emission && config.splatted.indirect);
        store.set_batch_photons(settings.photons);
        timings.t_light = t.elapsed().as_secs_f64();
        Ok(Self {
            scene,
            settings,
            camera,
            config,
            side,
            domains,
            store,
            resplat_queue: Vec::new(),
            splatted: 0,
            folded: 0,
            folded_total: 0,
            generation: 0,
            counters: SplatCounters::default(),
            lobes,
            eye_pass: 0,
            earlier: EarlierPasses::default(),
            pass_history: BandwidthHistory::default(),
            resplatted: 0,
            splatting: None,
            fine_owed: Vec::new(),
            fine_skipped: false,
            streamed_clamps: [ClampCounts::default(); 3],
            whole_batches: false,
            last_splat: 0.0,
            interactive: false,
            held: None,
            paced: false,
            clock: PassClock::started(&Timings::default(), &timings),
            timings,
            stop: None,
            owed: None,
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    /// The settings (the view's width, height and spp included).
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Eye samples, splat targets, tree, direct light and accumulators of the current pass.
    pub fn side(&self) -> &EyeSide {
        &self.side
    }

    /// The splat targets, their slots in the splat tree and the accumulators of indirect
    /// and caustic light, for a resolver that estimates into them (photon mapping's density
    /// estimate, which is redone whenever [`PhotonCore::generation`] moves; writing here does
    /// not move it).
    pub(crate) fn targets_and_accumulators(
        &mut self,
    ) -> (&SplatTargets, &[u32], &mut Accumulators) {
        let side = &mut self.side;
        (
            &side.targets,
            &side.tree.target_slot,
            &mut side.acc_indirect,
        )
    }

    /// The stored photon rays.
    pub fn store(&self) -> &PhotonStore {
        &self.store
    }

    /// Counts every change of the accumulated light (a batch traced or re-splatted, a view).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Time per phase so far.
    pub fn timings(&self) -> Timings {
        self.timings
    }

    /// Add what a resolver spent and counted while making a film.
    pub(crate) fn record(&mut self, timings: Timings, counters: SplatCounters) {
        self.timings += timings;
        self.counters += counters;
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

    /// True while stored batches wait to be re-splatted after a parameter or view change
    /// (their error-estimate splats included).
    pub fn resplat_pending(&self) -> bool {
        !self.resplat_queue.is_empty()
            || !self.fine_owed.is_empty()
            || self.splatting.as_ref().is_some_and(|p| !p.is_new())
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
    /// otherwise trace and splat a new batch with the bandwidth for the total M so far
    /// (docs/deviations.md §43). A new eye pass, when one is due, is the caller's to draw
    /// first ([`PhotonCore::wants_new_eye_pass`]), since it keeps the finished pass's film.
    pub(crate) fn step(&mut self) -> Step {
        if let Some(p) = self.splatting.take() {
            let t = Instant::now();
            // A new batch's pieces count towards the pacing clock as a whole batch does.
            let new = p.is_new();
            let step = self.splat_piece(p);
            if new {
                let spent = t.elapsed().as_secs_f64();
                self.clock.pass_spent += spent;
                self.clock.since_nee += spent;
            }
            step
        } else if let Some(b) = self.resplat_queue.pop() {
            // In pieces too in the window: a re-splat at its full size takes as long as a
            // batch (docs/benchmarks.md, "The previewer"); whole while the view is dragged.
            let pieces = if self.interactive { 1 } else { self.pieces() };
            let p = self.begin_pieces(b, false, pieces);
            self.splat_piece(p)
        } else if let Some((b, bw)) = self.fine_owed.pop() {
            self.splat_fine(b, &bw);
            // The image does not change until the last: no frame for the others.
            if self.fine_owed.is_empty() {
                Step::Resplatted
            } else {
                Step::Partial
            }
        } else {
            let t = Instant::now();
            if self.paced_passes() && self.pass_batches() > 0 && self.clock.nee_due() {
                let before = self.timings.t_direct;
                self.side
                    .redraw_direct(&self.scene, &self.settings, &mut self.timings);
                self.clock.nee_cost = self.timings.t_direct - before;
                self.clock.since_nee = 0.0;
            }
            // The next NEE draw weighs the batches since this one, not the draw itself (which
            // would make every draw pay for the next); the pass weighs both.
            let batch = Instant::now();
            let step = self.run_batch();
            // One reading of the clock ends both spans, so the batch's never outlasts the
            // step's (two readings let it, by the time between them).
            let end = Instant::now();
            self.clock.pass_spent += (end - t).as_secs_f64();
            self.clock.since_nee += (end - batch).as_secs_f64();
            step
        }
    }

    /// A batch is splatted in pieces and not finished yet ([`Step::Partial`]).
    pub fn mid_batch(&self) -> bool {
        self.splatting.is_some()
    }

    /// The window's view is interactive (a drag sends a new view every frame, each of which
    /// re-splats from the start): re-splats then go whole, so that every view gets its frame
    /// (in pieces, a stream of views would cut each re-splat short and show nothing).
    pub(crate) fn set_interactive(&mut self, interactive: bool) {
        self.interactive = interactive;
    }

    /// The render is paced by the clock (a time budget, the window), not by a count of
    /// batches: eye passes and NEE draws are then drawn as often as they pay for themselves
    /// against the photon batches (docs/deviations.md §50). A render of a given number of
    /// batches stays unpaced, and so deterministic.
    pub(crate) fn pace(&mut self) {
        self.paced = true;
    }

    /// Pacing applies to a method whose eye passes are redrawn (rs).
    fn paced_passes(&self) -> bool {
        self.paced && self.config.eye_passes == EyePasses::Redrawn && self.eye_passes_allowed()
    }

    /// True when the current eye pass has held its share of photons
    /// ([`EYE_PASS_PHOTONS_PER_SAMPLE`]) and a new one should be drawn before the next batch.
    pub(crate) fn wants_new_eye_pass(&self) -> bool {
        self.config.eye_passes == EyePasses::Redrawn
            && self.eye_passes_allowed()
            && self.resplat_queue.is_empty()
            && self.fine_owed.is_empty()
            && self.splatting.is_none()
            && self.pass_batches() as f64 * self.settings.photons as f64
                >= EYE_PASS_PHOTONS_PER_SAMPLE * self.side.eye.len().max(1) as f64
            && (!self.paced_passes() || self.clock.pass_due())
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
    pub(crate) fn next_eye_pass(&mut self, film: &crate::film::Film) {
        let pass = self.eye_pass + 1;
        self.earlier.add(
            film,
            self.pass_batches(),
            self.store.invalid_photon_rays,
            &self.pass_history,
        );
        self.pass_history = BandwidthHistory::default();
        if self.settings.auto_c {
            self.choose_c();
        }
        // The domains this pass probed serve the next one where they fit.
        self.side.keep_domains(&mut self.domains);
        // Free the finished side's arrays first (its film is kept), so that the peak holds
        // one eye side, not two (a `--time-budget` render of CORNELL BOX I at 500×500×4:
        // docs/benchmarks.md, "Memory").
        self.side.release();
        self.lobes = TracedLobes::default();
        let _ = self.draw_side(pass);
    }

    /// Draw eye pass `pass`'s side for the current view and settings (pass 0: a new view,
    /// whose stored batches are then re-splatted onto it), unless the stop is raised first:
    /// it is then owed ([`PhotonCore::owes_side`]) and the next step tries again. A later
    /// pass that cannot be drawn (unreachable for a view that was drawn once) starts the view
    /// again from the stored rays rather than leaving it to splat onto nothing.
    fn draw_side(&mut self, pass: u32) -> Result<(), MethodError> {
        let before = self.timings;
        // A dragged view's sides are finished: each of its views wants a frame.
        let stop = self.stop.as_deref().filter(|_| !self.interactive);
        let side = EyeSide::new_until(
            &self.scene,
            &self.camera,
            &self.settings,
            side_options(self.config, pass),
            Some(&mut self.domains),
            &mut self.timings,
            stop,
        );
        let side = match side {
            Err(_) if pass > 0 => return self.draw_side(0),
            drawn => drawn?,
        };
        let Some(side) = side else {
            self.owed = Some(pass);
            return Ok(());
        };
        self.side = side;
        self.owed = None;
        // A new side's accumulators are empty, fine ones included.
        self.fine_owed.clear();
        self.fine_skipped = false;
        self.eye_pass = pass;
        self.clock = PassClock::started(&before, &self.timings);
        self.lobes = TracedLobes::new(&self.side.eye);
        if pass == 0 {
            // What reached the old view's eye samples says little about the new one's.
            self.store.reset_guide();
            self.begin_resplat(self.settings.bandwidth);
        } else {
            self.splatted = 0;
            self.folded = 0;
            self.generation += 1;
        }
        Ok(())
    }

    /// An eye side was given up and is still to be drawn.
    pub fn owes_side(&self) -> bool {
        self.owed.is_some()
    }

    /// Draw the side that was given up (the next step's first work); true when it is drawn.
    pub(crate) fn draw_owed(&mut self) -> bool {
        if let Some(pass) = self.owed {
            let _ = self.draw_side(pass);
        }
        self.owed.is_none()
    }

    /// The flag the window's worker raises when a new view arrives (see `stop`).
    pub(crate) fn set_stop(&mut self, stop: Arc<AtomicBool>) {
        self.stop = Some(stop);
    }

    /// `--c auto` (docs/deviations.md §51): from the finished passes' estimated kernel bias²
    /// A (its smooth part, [`crate::film::estimate::ErrorEstimate::bias2_smooth`], the bias
    /// that follows h²) and photon variance V (the share a wider kernel smooths), and the bandwidths their
    /// batches had, the model's coefficients (bias ∝ h², variance ∝ 1/h² per batch) and from
    /// them the C that every batch of an image of as many batches would best share, each at
    /// C times the factor eq. 8 and the progressive schedule give it
    /// ([`BandwidthHistory::best_c`]); C moves towards it by at most [`AUTO_C_STEP`] a pass
    /// once the estimate is [`crate::film::estimate::ErrorEstimate::trusted`]. The target is
    /// absolute, made from every batch's own bandwidth, so a C that moved does not feed back
    /// into it as a lagging image bias would. Later batches are splatted with the new C
    /// (stored ones are not re-splatted). Under the schedule (deviations §43) the best shared
    /// C of a longer render is larger, as W^(1/6) for constant coefficients, and C follows it.
    fn choose_c(&mut self) {
        let Some(e) = self.earlier.estimate() else {
            return;
        };
        if !e.trusted() {
            return;
        }
        // After a re-splat one pass holds every stored batch, and its estimate at the old
        // batches' bandwidths pulled C down at every camera move in the window (CORNELL BOX I,
        // four moves: 0.70 → 0.57 → 0.52 → 0.48 → 0.37, each then climbing back slowly): C
        // holds until the passes drawn since hold as many batches as it.
        if self.earlier.batches < 2 * self.resplatted {
            return;
        }
        // Where the passes cannot tell the bias (or the splatted noise) from zero, the model
        // has nothing to weigh: C stays.
        let Some(best) = self
            .earlier
            .history
            .best_c(e.bias2_smooth, e.variance_photons)
        else {
            return;
        };
        let c = self.settings.bandwidth.smoothness_c;
        let ratio = ((best / c as f64) as f32).clamp(1.0 / AUTO_C_STEP, AUTO_C_STEP);
        let limit = crate::settings::limits::SMOOTHNESS_C;
        self.settings.bandwidth.smoothness_c = (c * ratio).clamp(limit.min, limit.max);
    }

    /// Note the bandwidth batch `m` was splatted with onto the current pass (its most
    /// populous class's h_min, a fixed fraction R of its typical h) and the C it had.
    pub(super) fn note_bandwidth(&mut self, bw: &[Bandwidth; 3], m: [u64; 3]) {
        let c = (0..3).max_by_key(|&c| m[c]).unwrap_or(0);
        let smoothness = self.settings.bandwidth.smoothness_c;
        self.pass_history.add(bw[c].h_min, smoothness);
    }

    /// `film` of the current pass becomes the batch-weighted mean over every eye pass.
    pub(crate) fn blend_earlier(&self, film: &mut crate::film::Film) {
        self.earlier.blend(film, self.pass_batches());
    }

    /// Start re-splatting every stored batch with new bandwidth parameters (no re-tracing).
    /// Folded batches cannot be re-splatted: their light leaves the image.
    pub(crate) fn begin_resplat(&mut self, params: BandwidthParams) {
        self.settings.bandwidth = params;
        self.side.clear();
        self.lobes.clear();
        self.splatted = 0;
        self.folded = 0;
        self.folded_total = 0;
        // Earlier eye passes hold light of the old bandwidth: every stored batch goes onto
        // the current pass instead.
        self.earlier = EarlierPasses::default();
        self.pass_history = BandwidthHistory::default();
        // A batch cut short is stored: it is re-splatted with the others (a new one's reach
        // goes untaught and the store folds after the next new batch).
        self.splatting = None;
        // The fine accumulators were cleared with the others: every batch is owed again.
        self.fine_owed.clear();
        self.fine_skipped = false;
        self.generation += 1;
        // Newest first: it has the smallest bandwidth, so the first frame is the sharpest.
        self.resplat_queue = (0..self.store.batches().len()).collect();
        self.resplatted = self.resplat_queue.len();
    }

    /// A new camera, resolution or sample count: new eye pass and splat tree, then a
    /// progressive re-splat of the stored rays (photon rays do not depend on the view).
    pub(crate) fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), MethodError> {
        let settings = crate::methods::checked_view(&self.settings, width, height, spp)?;
        // The domains the last view probed serve the new one where they fit: the test is
        // geometric (a "nothing met" is never taken), the pixel only says where to look.
        self.side.keep_domains(&mut self.domains);
        let old = (
            std::mem::replace(&mut self.settings, settings),
            std::mem::replace(&mut self.camera, camera),
        );
        let drawn = self.draw_side(0);
        if drawn.is_err() {
            (self.settings, self.camera) = old;
        }
        drawn
    }

    /// Apply the settings whose change needs no re-trace ([`Effect::Resplat`] and
    /// [`Effect::Resolve`] in the settings table; the view's are [`PhotonCore::set_view`]'s).
    /// A new C, S or R re-splats the stored rays; a new batch size or schedule re-splats when
    /// it moves the progressive schedule's M₁ (deviations §43); a new radiance map builds new
    /// accumulators, then re-splats; the cache and the filter reach the next film.
    pub(crate) fn update(&mut self, s: &RenderSettings) -> Result<(), MethodError> {
        // A side still owed stays owed: a re-splat begun here clears only accumulators
        // (empty ones when the side was released) and queues the stored batches, which wait
        // for the side (the core is mid-step until it is drawn); a new map or estimate draws
        // a new side for the view anyway.
        // Both need a new eye side (its accumulators), then a re-splat.
        let new_map = s.radiance_map != self.settings.radiance_map;
        let new_estimate = s.estimate_error != self.settings.estimate_error;
        // Under `--c auto` the C is the render's own: the caller's is only where it started.
        let auto_c = s.auto_c.then_some(self.settings.bandwidth.smoothness_c);
        let mut s = s.clone();
        if let Some(c) = auto_c {
            s.bandwidth.smoothness_c = c;
        }
        let s = &s;
        let new_bandwidth = s.bandwidth != self.settings.bandwidth;
        self.settings.adopt(s, &[Effect::Resolve, Effect::Resplat]);
        // Either can move the progressive schedule's M₁ (deviations §43).
        let schedule = self
            .store
            .set_progressive_bandwidth(s.progressive_bandwidth);
        let mut resplat = self.store.set_batch_photons(s.photons) || schedule;
        // Earlier passes' films were made without the cache and filter now asked for: their
        // batches go onto the current pass (a re-splat), so that the change reaches all of it.
        resplat |= !self.eye_passes_allowed() && self.earlier.batches > 0;
        if new_map || new_estimate {
            // New accumulators (with the new directional records, or with or without the
            // half-bandwidth ones of the error estimate), then a re-splat; refused, the
            // accumulators keep the mode they were built for.
            let (w, h, spp) = (self.settings.width, self.settings.height, self.settings.spp);
            let result = self.set_view(self.camera.clone(), w, h, spp);
            if result.is_err() {
                self.settings.radiance_map = self.side.acc_indirect.mode;
                self.settings.estimate_error = !self.side.acc_fine.is_empty();
            }
            return result;
        }
        if resplat || new_bandwidth {
            self.begin_resplat(s.bandwidth);
        }
        Ok(())
    }

    /// Keep at most this many photon rays for re-splatting (older batches are folded).
    pub(crate) fn set_ray_budget(&mut self, rays: usize) {
        self.store.max_stored_rays = rays;
    }

    /// Nothing will re-splat (a headless render): a film that never reads the stored rays
    /// lets each batch be freed once it is splatted.
    pub(crate) fn headless(&mut self) {
        self.whole_batches = true;
        if self.config.stored_rays == StoredRays::Unread {
            self.store.max_stored_rays = 0;
            self.store.keep_newest = false;
        }
    }
}

/// The eye side's options for eye pass `pass` of a method configured as `config`.
fn side_options(config: CoreConfig, pass: u32) -> EyeSideOptions {
    EyeSideOptions {
        lobes: config.lobes,
        pass,
        targets: config.targets,
    }
}
