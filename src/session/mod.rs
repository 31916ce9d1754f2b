//! The progressive worker: one thread owns the scene, the renderer (eye samples, splat tree,
//! stored photon rays, accumulators) and loops — take pending commands, do one step (re-splat
//! a stored batch or trace and splat a new one), and about ten times a second publish a frame.
//!
//! The UI talks to it only through channels: commands in, frames out (a one-slot channel; a
//! stale frame is dropped, never queued), events out (scene loaded, load failed). Commands that
//! arrive together are coalesced and applied once, at the batch boundary.
//!
//! This module holds the channel types and the UI's [`Session`] handle; the worker thread's
//! loop is in `worker`.

mod worker;

use worker::Worker;

use crate::film::Film;
use crate::methods::MethodStats;
use crate::pipeline::cache::CacheParams;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::filter::FilterParams;
use crate::pipeline::photon::BandwidthParams;
use crate::scene::{Camera, EnvironmentSettings, Scene};
use crate::settings::{DirectMode, RenderSettings};
use crossbeam_channel::{Receiver, Sender, bounded, unbounded};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// A dragged view is never smaller than the full size divided by this (the coarse first
/// image's quarter): beyond it the frame is too coarse to steer the camera by.
pub const MAX_DRAG_DIVISOR: f32 = 4.0;

/// Something the UI asks of the worker.
#[derive(Clone, Debug)]
pub enum Command {
    /// New C, S, R: re-splat the stored photon rays (no re-trace).
    SetBandwidth(BandwidthParams),
    /// Photons (M) per batch from the next batch on.
    SetPhotonsPerBatch(u64),
    /// Camera rays per pixel, applied as a new view (no re-trace).
    SetSamplesPerPixel(u32),
    /// Image size, applied as a new view (no re-trace).
    SetResolution {
        /// Width (pixels).
        width: u32,
        /// Height (pixels).
        height: u32,
    },
    /// Switching direct light between NEE and photons restarts tracing.
    SetDirect(DirectMode),
    /// Light samples per eye sample and NEE draw, from the next draw on (no re-trace, no
    /// re-splat).
    SetNeeSamples(u32),
    /// Directional storage at glossy samples (§8.1): new accumulators, then a re-splat of
    /// the stored rays (no re-trace).
    SetRadianceMap(DirectionalMode),
    /// Test visibility inside the splat footprint (docs/deviations.md §40): shadow rays for
    /// pairs behind a nearby wall. The splat trees are probed anew: restarts tracing.
    SetSplatVisibility(bool),
    /// Emit photons where the camera looks (docs/deviations.md §44), or by power: restarts
    /// tracing.
    SetGuidedEmission(bool),
    /// Resolve the radiance map through the radiance cache (§8.3) with these parameters: the
    /// cache pass re-runs over the current map, no re-trace and no re-splat.
    SetCache {
        /// Use the cache at all.
        on: bool,
        /// Cache error ε and records per pixel.
        params: CacheParams,
    },
    /// The image-space filter of the indirect light (§8.2); applied when the next frame is
    /// resolved.
    SetFilter(FilterParams),
    /// A new view; `interactive` views render at reduced resolution until a final one arrives.
    SetCamera {
        /// The new view.
        camera: Camera,
        /// The camera is still moving (render at reduced resolution).
        interactive: bool,
    },
    /// Keep at most this many photon rays for re-splatting; older batches are folded.
    SetRayBudget(usize),
    /// Stop tracing new batches (a pending re-splat still finishes).
    Pause,
    /// Trace batches again.
    Resume,
    /// Load a .gltf/.glb; on failure the current scene stays and `Event::LoadFailed` says why.
    LoadScene(PathBuf),
    /// Light the scene (and every scene loaded later) with this environment: re-traces.
    /// On failure (an unreadable map, a scene left without light) the lighting stays and
    /// `Event::Error` says why.
    SetEnvironment(EnvironmentSettings),
    /// Drop all photons and trace from scratch.
    Restart,
    /// Path trace the current view progressively (the reference view mode) instead of tracing
    /// photon batches, or stop doing so.
    SetReference(bool),
    /// Path trace the current view progressively beside the photon batches (the split view),
    /// the two sharing the worker's time equally, or stop doing so.
    SetSplit(bool),
    /// Estimate the image's error from its own eye passes (docs/deviations.md §51): a new
    /// eye side, then a re-splat (no re-trace).
    SetErrorEstimate(bool),
    /// Choose C between eye passes from the estimated error (`--c auto`; turns the estimate
    /// on): a re-splat.
    SetAutoC(bool),
    /// Pause once the estimated relMSE falls below this (none: never). After such a pause,
    /// a resume refines on until the estimate has risen above the threshold again (a change
    /// of view or parameters) and fallen below it once more.
    SetPauseBelow(Option<f64>),
    /// End the worker thread.
    Shutdown,
}

/// Something the worker tells the UI.
#[derive(Clone, Debug)]
pub enum Event {
    /// A scene was loaded (also sent for the scene the session starts with).
    SceneLoaded {
        /// The scene's display name.
        name: String,
        /// The file it came from (`None` for an embedded or built-in scene).
        path: Option<PathBuf>,
        /// Its cameras (never empty).
        cameras: Vec<Camera>,
        /// Centre of the scene's bounding box (the orbit's pivot).
        center: glam::Vec3,
        /// What the loader skipped or repaired.
        warnings: Vec<String>,
        /// The environment lighting it (resolved: never `Auto`).
        environment: EnvironmentSettings,
        /// One line when the environment was chosen for the user (a file without lights).
        notice: Option<String>,
    },
    /// The scene is now lit by `environment` (resolved) and tracing restarted.
    EnvironmentChanged {
        /// The environment lighting it.
        environment: EnvironmentSettings,
        /// One line when the environment was chosen for the user (a file without lights).
        notice: Option<String>,
    },
    /// A [`Command::LoadScene`] failed, and why; the previous scene stays.
    LoadFailed(String),
    /// The worker could not apply a change (the previous state stays).
    Error(String),
}

/// Counters shown in the stats panel: the method's own ([`MethodStats`], as the stats JSON of
/// a headless render has them) and the session's.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionStats {
    /// The method's counters and memory.
    pub method: MethodStats,
    /// `photons_traced` / `elapsed_s`.
    pub photons_per_second: f64,
    /// The last batch's step (NEE redraws, tracing, splatting), milliseconds; 0 after a
    /// restart until a batch is done.
    pub last_splat_ms: f64,
    /// Seconds spent unpaused since the current scene was loaded or tracing restarted.
    pub elapsed_s: f64,
    /// The worker is paused.
    pub paused: bool,
    /// Stored batches are still being re-splatted after a change.
    pub resplat_pending: bool,
    /// Paths per pixel of the reference image, 0 when it is off.
    pub reference_spp: u32,
    /// relMSE of the image against the reference (the reference's own noise included), when
    /// both exist at the same size.
    pub reference_rel_mse: Option<f64>,
    /// The reference's own variance in relMSE units (from its paths' spread): the part of
    /// `reference_rel_mse` that is the reference's noise, not the image's error.
    pub reference_noise: Option<f64>,
    /// The worker paused itself because the estimated relMSE fell below this threshold.
    pub paused_below: Option<f64>,
    /// Fraction of the indirect photon rays whose bandwidth sits at h_min (eq. 8's lower
    /// bound; docs/deviations.md §5); of all rays when there are no indirect ones.
    pub indirect_at_h_min: f64,
    /// Fraction of the indirect photon rays whose bandwidth sits at h_max (eq. 8's upper
    /// bound); of all rays when there are no indirect ones.
    pub indirect_at_h_max: f64,
    /// Fraction of the indirect photon rays (of all when there are none) whose end bandwidth
    /// is the floor from the photons stored, wider than eq. 8's (docs/deviations.md §63).
    pub indirect_at_floor: f64,
}

/// A published image and everything needed to describe it.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The image and its AOVs.
    pub film: Film,
    /// Increases with every published frame.
    pub seq: u64,
    /// Increases with every applied change (parameters, view, scene, restart).
    pub generation: u64,
    /// Display name of the scene rendered.
    pub scene_name: String,
    /// Its file (`None` for an embedded or built-in scene).
    pub scene_path: Option<PathBuf>,
    /// The view rendered.
    pub camera: Camera,
    /// The settings it was rendered with.
    pub settings: RenderSettings,
    /// Rendered at reduced resolution (while the camera moves, and for the first frame).
    pub interactive: bool,
    /// The radiance cache's records: pixel x, y, radius (pixels), pass (Fig. 8b).
    pub cache_records: Vec<[f32; 4]>,
    /// Counters at the time it was published.
    pub stats: SessionStats,
    /// The path-traced reference of the same view, while the reference mode is on.
    pub reference: Option<Film>,
}

/// How a [`Session`] starts.
#[derive(Clone, Debug)]
pub struct SessionConfig {
    /// Full-resolution settings; `photons` is M per batch.
    pub settings: RenderSettings,
    /// Most photon rays kept for re-splatting ([`Command::SetRayBudget`]).
    pub max_stored_rays: usize,
    /// Least time between two frames published while tracing (changes publish at once).
    pub publish_interval: Duration,
    /// Interactive views divide width and height by at least this and use 1 sample per
    /// pixel; a dragged view divides by more (up to [`MAX_DRAG_DIVISOR`]) when its frames
    /// take longer than `drag_frame_budget`.
    pub interactive_divisor: u32,
    /// What a dragged view's frame (its eye side and the newest batch's re-splat) may take:
    /// the worker sizes the dragged views to it from the last ones' cost (adaptive resolution,
    /// docs/deviations.md §62).
    pub drag_frame_budget: Duration,
    /// The coarse first image divides width and height by this (1: none), with the
    /// interactive views' samples and half a batch; full size follows at once.
    pub first_divisor: u32,
    /// The environment every scene is lit by (`Auto`: none when the file has lights, uniform
    /// when it has none).
    pub environment: EnvironmentSettings,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            // One eye sample per pixel and 4 light samples each: Table 2's 4 NEE samples per
            // pixel at a quarter of its eye pass (docs/deviations.md §50).
            settings: RenderSettings {
                spp: 1,
                photons: 20_000,
                nee_samples: crate::settings::FRONT_END_NEE_SAMPLES,
                // The render chooses C from its own error estimate (docs/deviations.md §51):
                // the best C differs between scenes and between cameras of one scene, and
                // a user should not have to find it. The estimate comes with it.
                auto_c: true,
                estimate_error: true,
                ..RenderSettings::default()
            },
            max_stored_rays: 4_000_000,
            publish_interval: Duration::from_millis(100),
            interactive_divisor: 2,
            // Two thirds of the window's 300 ms camera target: the rest is the step in flight
            // a move waits for (a batch's piece, 50–125 ms on CORNELL BOX I at 500×500).
            drag_frame_budget: Duration::from_millis(200),
            // A quarter of the size: with the visible domains' probes (16 per eye sample) at
            // half size the first image took 560–640 ms (docs/benchmarks.md "The previewer").
            first_divisor: 4,
            environment: EnvironmentSettings::default(),
        }
    }
}

/// Called after a frame or event is sent (e.g. `egui::Context::request_repaint`).
pub type Notify = Arc<dyn Fn() + Send + Sync>;

/// The UI's handle on the worker thread.
pub struct Session {
    cmd_tx: Sender<Command>,
    frame_rx: Receiver<Frame>,
    event_rx: Receiver<Event>,
    /// Raised with a command that brings a new view ([`Session::send`]); the worker lowers
    /// it when it reads its commands.
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl Session {
    /// Start the worker on `scene`. The first frame follows as soon as the eye pass and the
    /// first batch are done.
    pub fn spawn(
        scene: Arc<Scene>,
        scene_path: Option<PathBuf>,
        config: SessionConfig,
        notify: Option<Notify>,
    ) -> Self {
        // Build the splat's kept-fraction table (≈ 30 ms, docs/deviations.md §23) beside the
        // first eye pass rather than in front of the first splat.
        std::thread::spawn(|| crate::pipeline::splat::kept_fraction(1.0, 0.0));
        let (cmd_tx, cmd_rx) = unbounded();
        let (frame_tx, frame_rx) = bounded(1);
        let (event_tx, event_rx) = unbounded();
        let stale = frame_rx.clone();
        let stop = Arc::new(AtomicBool::new(false));
        let worker_stop = stop.clone();
        let handle = std::thread::Builder::new()
            .name("raysplat-worker".into())
            .spawn(move || {
                let events = event_tx.clone();
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    Worker::new(scene, scene_path, config, frame_tx, stale, event_tx, notify)
                        .run(cmd_rx, worker_stop)
                }));
                if let Err(e) = result {
                    let msg = e
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_else(|| "unknown panic".into());
                    let _ = events.send(Event::Error(format!("the render worker stopped: {msg}")));
                }
            })
            .expect("spawning the worker thread");
        Self {
            cmd_tx,
            frame_rx,
            event_rx,
            stop,
            handle: Some(handle),
        }
    }

    /// Queue a command for the worker (ignored once the worker has stopped).
    pub fn send(&self, c: Command) {
        // A command that discards the current view's eye pass lets the worker give up the one
        // it may be drawing (raised after the send: the worker that sees it finds the command
        // at its next drain).
        let new_view = matches!(
            c,
            Command::SetCamera { .. }
                | Command::SetResolution { .. }
                | Command::SetSamplesPerPixel(_)
                | Command::LoadScene(_)
                | Command::Restart
                | Command::Shutdown
        );
        // A stopped worker has told the UI why through an event.
        let _ = self.cmd_tx.send(c);
        if new_view {
            self.stop.store(true, Ordering::Release);
        }
    }

    /// The newest frame published since the last call, if any.
    pub fn try_frame(&self) -> Option<Frame> {
        let mut last = None;
        while let Ok(f) = self.frame_rx.try_recv() {
            last = Some(f);
        }
        last
    }

    /// Wait up to `timeout` for a frame.
    pub fn wait_frame(&self, timeout: Duration) -> Option<Frame> {
        self.frame_rx.recv_timeout(timeout).ok()
    }

    /// Every event sent since the last call.
    pub fn try_events(&self) -> Vec<Event> {
        self.event_rx.try_iter().collect()
    }

    /// False once the worker thread has ended.
    pub fn is_alive(&self) -> bool {
        self.handle.as_ref().is_some_and(|h| !h.is_finished())
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        self.send(Command::Shutdown);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}
