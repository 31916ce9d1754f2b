//! The rendering methods, one file each, behind one interface ([`Method`]) and one factory
//! ([`build`]):
//!
//! | method | file | what it is |
//! |---|---|---|
//! | `rs` | [`rs`] | photon ray splatting (the paper), with the optional radiance cache (§8.3) and image-space filter (§8.2) |
//! | `rc` | [`rc`] | radiance caching: indirect-diffuse photon rays splatted onto sparse cache records only (§8.3) |
//! | `pm` | [`pm`] | photon mapping with K-NN density estimation (Jensen), on the same eye samples and photons |
//! | `pt` | [`pt`] | the unbiased path tracer (NEE + MIS), the reference |
//! | `rs-fg`, `pm-fg` | [`fg`] | final gathering (§8.4) over splatted rays or photon maps |
//!
//! rs, rc and pm share the photon core ([`photon_core::PhotonCore`]: the eye side
//! [`eye_side::EyeSide`], the stored photon rays [`photon_store::PhotonStore`] and the batch
//! loop) as a [`photon_method::PhotonMethod`]; each adds only how its film is resolved (a
//! [`photon_method::Resolver`]) and how it uses the core (a
//! [`photon_core::CoreConfig`]). The headless
//! budget loop ([`render_method`]), `compare`, `bench` and the previewer's worker drive a
//! `dyn Method` and never branch on which one it is. To add a method, write one file with a
//! type implementing [`Method`] and add one line to [`build`].
//!
//! Also here: [`memory`] (a render's memory estimate, checked before anything is allocated),
//! [`lobes`] (rs's traced glossy lobes drawn anew per batch) and [`testing`] (reads and drives
//! for the integration tests only).

pub mod eye_side;
pub mod fg;
pub mod lobes;
pub mod memory;
pub mod photon_core;
pub mod photon_method;
pub mod photon_store;
pub mod pm;
pub mod pt;
pub mod rc;
pub mod rs;
pub mod testing;

use crate::film::Film;
use crate::pipeline::cache::Cache;
use crate::pipeline::photon::ClampCounts;
use crate::pipeline::photon_map::PmStats;
use crate::scene::{Camera, Scene};
use crate::settings::{Changes, Effect, MethodKind, RenderSettings, SettingsError};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// Why a method cannot be built or cannot take a change; the caller keeps what it had.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MethodError {
    /// A setting outside the limits table.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The render would not fit in the machine's memory ([`memory::check`]).
    #[error(
        "this render needs about {} ({width}×{height} pixels × {spp} samples, {photons} photons \
         per batch) but {} are available; lower the size, samples or photons",
        gib(*needed),
        gib(*available)
    )]
    TooLarge {
        /// Bytes the render would need.
        needed: u64,
        /// Bytes available.
        available: u64,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// Its eye samples per pixel.
        spp: u32,
        /// Its photons per batch.
        photons: u64,
    },
    /// The scene has no camera of that name.
    #[error("{0}")]
    NoCamera(String),
    /// A view with no pixels or no samples.
    #[error("width, height and samples per pixel must be positive")]
    EmptyView,
    /// The settings name another method than the one asked for.
    #[error("{0:?} is not a final-gathering method")]
    NotFinalGathering(MethodKind),
}

/// `bytes` in GiB with one decimal.
fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// What one [`Method::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Re-worked stored data for a changed view or parameters (a re-splat): the image moves
    /// back towards what it held before the change.
    Resplatted,
    /// Added new light: a photon batch, a path-tracing pass or a gathering pass.
    Traced,
    /// Splatted part of a new or re-splatted batch (the window cuts a splat into pieces, so
    /// that a command waits for a piece, not a batch): the light is not counted yet, so no image is
    /// taken until the batch is whole ([`Method::mid_step`]).
    Partial,
    /// Drew an eye side that had been given up for a new view (the window's stop flag,
    /// [`Method::set_stop`]), or gave it up again: no light added, and the step's time is an
    /// eye pass's, not a splat's. Mid-step while it is still owed.
    Side,
}

/// Seconds spent per phase (Table 2: T_E, T_L, T_S).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// T_E: eye pass and splat-tree build (final gathering: also its gather rays).
    pub t_eye: f64,
    /// Explicit direct light (NEE) at eye samples.
    pub t_direct: f64,
    /// T_L: pilot and light pass.
    pub t_light: f64,
    /// T_S: bandwidth and splatting, the cache pass, or the density estimate (the path
    /// tracer's whole time is counted here).
    pub t_splat: f64,
    /// Folding accumulators into the film.
    pub t_resolve: f64,
}

impl Timings {
    /// ΣT over every phase.
    pub fn total(&self) -> f64 {
        self.t_eye + self.t_direct + self.t_light + self.t_splat + self.t_resolve
    }
}

impl std::ops::AddAssign for Timings {
    fn add_assign(&mut self, o: Self) {
        self.t_eye += o.t_eye;
        self.t_direct += o.t_direct;
        self.t_light += o.t_light;
        self.t_splat += o.t_splat;
        self.t_resolve += o.t_resolve;
    }
}

/// Bytes held by each part of a render (the stats' memory breakdown). Zero where a method
/// has no such part.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MemoryBreakdown {
    /// Eye samples of the current eye pass.
    pub eye_samples: usize,
    /// Splat targets (positions, normals, glossy flags).
    pub splat_targets: usize,
    /// The splat kd-tree (nodes, leaves, chunks, slot maps, blocker planes).
    pub splat_tree: usize,
    /// Accumulators, without the directional records.
    pub accumulators: usize,
    /// Directional records at glossy targets (§8.1).
    pub directional_records: usize,
    /// Stored photon rays.
    pub photon_rays: usize,
    /// The emission guide's cells and distributions (docs/deviations.md §44).
    #[serde(default)]
    pub emission_guide: usize,
    /// The count of where the photon rays landed, for the floor from the photons stored
    /// (docs/deviations.md §63).
    #[serde(default)]
    pub photon_density: usize,
    /// Per-pixel sums: emission and NEE light, traced lobes, finished eye passes.
    pub pixel_sums: usize,
    /// One film with its AOVs.
    pub film: usize,
    /// The scene: triangles, shading data and the BVH.
    pub scene: usize,
    /// The scene's decoded texture images and its emissive textures' light tables.
    #[serde(default)]
    pub textures: usize,
}

impl MemoryBreakdown {
    /// The sum of the parts.
    pub fn total(&self) -> usize {
        self.eye_samples
            + self.splat_targets
            + self.splat_tree
            + self.accumulators
            + self.directional_records
            + self.photon_rays
            + self.emission_guide
            + self.photon_density
            + self.pixel_sums
            + self.film
            + self.scene
            + self.textures
    }
}

/// Counters and memory of a method, for the stats panel, `--stats` and `bench`. Fields a
/// method does not have stay zero or `None`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MethodStats {
    /// Photons traced (0 for the path tracer).
    pub photons_traced: u64,
    /// Stored photon rays over all stored batches, plus those a headless rs render freed once
    /// they were splatted ([`Method::headless`]).
    pub photon_rays: usize,
    /// Photon rays per class (direct, indirect, caustic) over all traced batches.
    pub photon_rays_per_class: [u64; 3],
    /// Bytes of the stored photon rays.
    pub photon_ray_bytes: usize,
    /// Units of work the image holds: photon batches, path-tracing or gathering passes.
    pub passes: u64,
    /// Batches dropped from the ray store (over budget) whose light the image still holds.
    pub folded_batches: usize,
    /// Where the render's memory is (bytes), for the stats JSON and the window.
    pub memory: MemoryBreakdown,
    /// Eye passes the image averages over (rs with `progressive_eye`; 1 otherwise, 0 for
    /// methods without eye samples of their own).
    pub eye_passes: u32,
    /// Batches whose rays are stored (re-splattable).
    pub stored_batches: usize,
    /// Bytes held by eye samples, splat tree and accumulators.
    pub splat_bytes: usize,
    /// Bytes of the directional radiance-map records (§8.1), included in `splat_bytes`.
    pub directional_bytes: usize,
    /// Splat targets on glossy surfaces (the ones with directional records).
    pub glossy_targets: usize,
    /// Glossy eye samples whose lobe goes through the radiance map (§8.1).
    pub glossy_map_samples: usize,
    /// Glossy eye samples whose lobe is too sharp for the map and traced by the eye path.
    pub glossy_traced_samples: usize,
    /// Eye samples of the current view.
    pub eye_samples: usize,
    /// Splat targets (eye samples after merging).
    pub splat_targets: usize,
    /// Nodes of the splat tree.
    pub splat_tree_nodes: usize,
    /// Eye samples tested for feasibility and accepted (Alg. 1).
    pub tested_pairs: u64,
    /// Eye samples that received energy.
    pub accepted_pairs: u64,
    /// Splatted pairs near a wall, tested cell by cell against their target's visible kernel
    /// domain (docs/deviations.md §40); the others lie on an open plane.
    pub domain_tests: u64,
    /// Of those, the pairs outside it: light that would have leaked through a surface.
    pub occluded_pairs: u64,
    /// Pixels' first splat targets of this render's eye passes that took the visible domain
    /// an earlier pass probed nearby on their plane, and those that cast their own probes
    /// (docs/deviations.md §40, "Probes kept across eye passes").
    pub domains_reused: u64,
    /// See `domains_reused`.
    pub domains_probed: u64,
    /// Photon rays splatted onto the eye side (each class's splat counts its own rays).
    pub splat_rays: u64,
    /// Of those, the rays that splatted onto at least one eye sample.
    pub rays_reaching: u64,
    /// Batches the emission guide learned from (docs/deviations.md §44); `None` when
    /// photons leave the lights in proportion to power.
    pub guide_batches: Option<u32>,
    /// ⟨D⟩ of the pilot (§6), the unit of eq. 7's lengths.
    pub pilot_mean_length: Option<f32>,
    /// Rays per class (direct, indirect, caustic) at the bandwidth bounds h_min and h_max.
    pub bandwidth_clamps: Option<[ClampCounts; 3]>,
    /// Gather statistics of photon mapping's last estimate.
    pub pm: Option<PmStats>,
    /// Radiance cache records of the last film.
    pub cache_records: Option<usize>,
    /// Records created per pass of the last cache.
    pub cache_records_per_pass: Option<Vec<usize>>,
}

/// A rendering method: progressive work in steps, a view that can change, and a film.
pub trait Method: Send {
    /// Which method this is.
    fn kind(&self) -> MethodKind;

    /// The settings it renders with (the view's width, height and spp included).
    fn settings(&self) -> &RenderSettings;

    /// The camera it renders from.
    fn camera(&self) -> &Camera;

    /// One unit of progressive work (one photon batch, one re-splatted batch, one pass; in
    /// the window, one piece of a batch's splat: [`Step::Partial`]).
    fn step(&mut self) -> Step;

    /// True while stored work is being redone after a change (the next step re-splats).
    fn catching_up(&self) -> bool {
        false
    }

    /// True between the pieces of a step ([`Step::Partial`]): the film would hold part of a
    /// batch's light, uncounted, until the next steps finish it.
    fn mid_step(&self) -> bool {
        false
    }

    /// The view is interactive (a camera being dragged, the coarse first image): the window
    /// wants a frame per step then, so re-splats are not cut into pieces.
    fn set_interactive(&mut self, _interactive: bool) {}

    /// A flag the window's worker raises when a new view arrives: work for the current,
    /// resting view that the new one discards (an eye pass) may be given up, leaving the
    /// method [`Method::mid_step`] until its next step.
    fn set_stop(&mut self, _stop: std::sync::Arc<std::sync::atomic::AtomicBool>) {}

    /// A new camera, resolution or sample count. Methods with view-independent stored work
    /// (photon rays) keep it and re-use it; the others start again.
    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), MethodError>;

    /// Apply settings that need no re-trace: photons per batch, bandwidth (a re-splat), the
    /// radiance map's directional mode, cache and filter parameters. The view fields are
    /// ignored ([`Method::set_view`]); what needs a new method from [`build`] is
    /// [`Effect::Retrace`] in the settings table ([`needs_rebuild`]).
    fn update(&mut self, settings: &RenderSettings) -> Result<(), MethodError>;

    /// Keep at most this many photon rays for re-splatting (older batches are folded).
    fn set_ray_budget(&mut self, _rays: usize) {}

    /// Nothing will re-splat (a headless render, [`run`]): a method whose film never reads
    /// its stored photon rays (rs) frees each batch once it is splatted; the others keep
    /// every batch, as their films gather them.
    fn headless(&mut self) {}

    /// The render is paced by the clock (a time budget, the window) rather than by a count of
    /// steps: a method may then balance the cost of its eye passes against its batches by
    /// their measured times (rs: docs/deviations.md §50). Renders of a given number of steps
    /// do not call it and stay deterministic.
    fn pace(&mut self) {}

    /// The image so far (resolving what the steps accumulated).
    fn film(&mut self) -> Film;

    /// The film of a finished render ([`finish`]): the method may first free what only
    /// further steps need, so it takes no step afterwards. Its stats still report the memory
    /// it held.
    fn final_film(&mut self) -> Film {
        self.film()
    }

    /// Units of work whose light the film holds.
    fn passes(&self) -> u64;

    /// Time spent per phase.
    fn timings(&self) -> Timings;

    /// Counters and memory (may count bandwidth clamps, hence `&mut`).
    fn stats(&mut self) -> MethodStats;

    /// The radiance cache of the last film, if the method keeps one.
    fn cache(&self) -> Option<&Cache> {
        None
    }
}

/// Build the method `settings.method` for `scene` seen by the settings' named camera (the
/// scene's first when none is named).
pub fn build(scene: Arc<Scene>, settings: RenderSettings) -> Result<Box<dyn Method>, MethodError> {
    let camera = camera_for(&scene, &settings)?;
    build_for(scene, settings, camera)
}

/// The settings' named camera of `scene` (its first when none is named).
pub fn camera_for(scene: &Scene, settings: &RenderSettings) -> Result<Camera, MethodError> {
    scene
        .camera_or_error(settings.camera.as_deref())
        .map_err(MethodError::NoCamera)
}

/// Build the method `settings.method` for `scene` seen by `camera`. This is the one place
/// that knows every method. Settings outside their limits, or a render that would not fit
/// in memory, are refused here, before anything is allocated.
pub fn build_for(
    scene: Arc<Scene>,
    settings: RenderSettings,
    camera: Camera,
) -> Result<Box<dyn Method>, MethodError> {
    check(&settings)?;
    Ok(match settings.method {
        MethodKind::Rs => Box::new(rs::RaySplatting::new(scene, settings, camera)?),
        MethodKind::Rc => Box::new(rc::RadianceCaching::new(scene, settings, camera)?),
        MethodKind::Pm => Box::new(pm::PhotonMapping::new(scene, settings, camera)?),
        MethodKind::Pt => Box::new(pt::PathTracer::for_render(scene, camera, &settings)),
        MethodKind::RsFg | MethodKind::PmFg => {
            Box::new(fg::FinalGathering::new(scene, settings, camera)?)
        }
    })
}

/// Settings within the limits table and a render that fits in the machine's memory: checked
/// by the factory and by every method's `set_view`, before anything is allocated.
pub fn check(settings: &RenderSettings) -> Result<(), MethodError> {
    settings.validate()?;
    memory::check(settings, memory::available_bytes())
}

/// `settings` with a new view ([`RenderSettings::with_view`]), or the refusal that every
/// `set_view` gives before it allocates anything ([`check`]).
pub fn checked_view(
    settings: &RenderSettings,
    width: u32,
    height: u32,
    spp: u32,
) -> Result<RenderSettings, MethodError> {
    let view = settings.with_view(width, height, spp);
    check(&view)?;
    Ok(view)
}

/// True when going from `old` to `new` changes what is traced ([`Effect::Retrace`] in the
/// settings table), so the method must be built again rather than updated.
pub fn needs_rebuild(old: &RenderSettings, new: &RenderSettings) -> bool {
    Changes::between(old, new).any(Effect::Retrace)
}

/// How long a headless render runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Until the film holds one unit of work: one photon batch, one pass of `pt_spp` paths per
    /// pixel, one complete gathering pass.
    Fixed,
    /// Steps until the film holds this many units of work (a path tracer with `pt_spp` = 1
    /// and `Passes(n)` traces n paths per pixel, one step each, so progress can be shown).
    Passes(u64),
    /// Steps until this many seconds are spent (at least one step; a final-gathering pass
    /// then may be partial, its steps being bands of rows).
    Seconds(f64),
}

/// A finished headless render and what it cost.
pub struct Rendered {
    /// The image.
    pub film: Film,
    /// Time per phase.
    pub timings: Timings,
    /// Counters and memory at the end.
    pub stats: MethodStats,
    /// Photons traced (0 for pt).
    pub photons: u64,
    /// Steps whose light the image holds.
    pub passes: u64,
    /// Pixels that are NaN or infinite.
    pub invalid: u64,
    /// The smoothness C the last batch was splatted with (under `--c auto`, the chosen one).
    pub smoothness_c: f32,
}

/// Run `method` for `budget`, calling `progress` after every step; `progress` returning false
/// stops early (an interrupt).
pub fn run(
    method: &mut dyn Method,
    budget: Budget,
    mut progress: impl FnMut(&mut dyn Method) -> bool,
) {
    let start = Instant::now();
    // Nothing re-splats in a headless render: stored rays are kept only where the film reads
    // them (docs/benchmarks.md, "Memory").
    method.headless();
    if matches!(budget, Budget::Seconds(_)) {
        method.pace();
    }
    loop {
        method.step();
        if !progress(&mut *method) {
            break;
        }
        let more = match budget {
            Budget::Fixed => method.passes() == 0,
            Budget::Passes(n) => method.passes() < n,
            Budget::Seconds(b) => start.elapsed().as_secs_f64() < b,
        };
        if !more {
            break;
        }
    }
    while method.catching_up() || method.mid_step() {
        method.step();
    }
}

/// Render `scene` with the method `kind` and `settings` for `budget`. rs, rc and pm share the
/// eye pass and the light pass for a given seed, so they see the same eye samples and photons.
pub fn render_method(
    scene: &Arc<Scene>,
    kind: MethodKind,
    settings: &RenderSettings,
    budget: Budget,
) -> Result<Rendered, MethodError> {
    let settings = RenderSettings {
        method: kind,
        ..settings.clone()
    };
    let mut m = build(scene.clone(), settings)?;
    run(m.as_mut(), budget, |_| true);
    Ok(finish(m.as_mut()))
}

/// The film, timings and counters of a method whose work is done.
pub fn finish(m: &mut dyn Method) -> Rendered {
    let film = m.final_film();
    let stats = m.stats();
    Rendered {
        invalid: film.invalid_pixels() as u64,
        film,
        timings: m.timings(),
        photons: stats.photons_traced,
        passes: m.passes(),
        smoothness_c: m.settings().bandwidth.smoothness_c,
        stats,
    }
}

/// Peak resident memory of this process in MB (Linux VmHWM; 0 where unavailable).
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(0.0)
}
