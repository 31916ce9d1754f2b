//! The progressive worker: one thread owns the scene, the renderer (eye samples, splat tree,
//! stored photon rays, accumulators) and loops — take pending commands, do one step (re-splat
//! a stored batch or trace and splat a new one), and about ten times a second publish a frame.
//!
//! The UI talks to it only through channels: commands in, frames out (a one-slot channel; a
//! stale frame is dropped, never queued), events out (scene loaded, load failed). Commands that
//! arrive together are coalesced and applied once, at the batch boundary.

use crate::film::Film;
use crate::methods::{self, Method, Step};
use crate::pipeline::cache::CacheParams;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::filter::FilterParams;
use crate::pipeline::photon::BandwidthParams;
use crate::scene::{Camera, Scene};
use crate::settings::{DirectMode, MethodKind, RenderSettings, limits};
use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TryRecvError, bounded, unbounded};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Something the UI asks of the worker.
#[derive(Clone, Debug)]
pub enum Command {
    /// New C, S, R: re-splat the stored photon rays (no re-trace).
    SetBandwidth(BandwidthParams),
    /// Photons (M) per batch from the next batch on.
    SetPhotonsPerBatch(u64),
    SetSamplesPerPixel(u32),
    SetResolution {
        width: u32,
        height: u32,
    },
    /// Switching direct light between NEE and photons restarts tracing.
    SetDirect(DirectMode),
    /// Directional storage at glossy samples (§8.1): new accumulators, then a re-splat of
    /// the stored rays (no re-trace).
    SetRadianceMap(DirectionalMode),
    /// Resolve the radiance map through the radiance cache (§8.3) with these parameters: the
    /// cache pass re-runs over the current map, no re-trace and no re-splat.
    SetCache {
        on: bool,
        params: CacheParams,
    },
    /// The image-space filter of the indirect light (§8.2); applied when the next frame is
    /// resolved.
    SetFilter(FilterParams),
    /// A new view; `interactive` views render at reduced resolution until a final one arrives.
    SetCamera {
        camera: Camera,
        interactive: bool,
    },
    /// Keep at most this many photon rays for re-splatting; older batches are folded.
    SetRayBudget(usize),
    Pause,
    Resume,
    /// Load a .gltf/.glb; on failure the current scene stays and `Event::LoadFailed` says why.
    LoadScene(PathBuf),
    /// Drop all photons and trace from scratch.
    Restart,
    /// Path trace the current view progressively (the reference view mode) instead of tracing
    /// photon batches, or stop doing so.
    SetReference(bool),
    Shutdown,
}

/// Something the worker tells the UI.
#[derive(Clone, Debug)]
pub enum Event {
    SceneLoaded {
        name: String,
        path: Option<PathBuf>,
        cameras: Vec<Camera>,
        /// Centre of the scene's bounding box (the orbit's pivot).
        center: glam::Vec3,
        warnings: Vec<String>,
    },
    LoadFailed(String),
    /// The worker could not apply a change (the previous state stays).
    Error(String),
}

/// Counters shown in the stats panel.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionStats {
    pub photons_traced: u64,
    pub photon_rays: usize,
    pub photon_ray_bytes: usize,
    /// Batches whose light the image holds.
    pub batches: usize,
    /// Batches folded into the image and dropped from the ray store (budget exceeded).
    pub folded_batches: usize,
    /// Batches whose rays are stored (re-splattable).
    pub stored_batches: usize,
    /// Bytes held by eye samples, splat tree and accumulators.
    pub splat_bytes: usize,
    /// Bytes of the directional radiance-map records (§8.1), included in `splat_bytes`.
    pub directional_bytes: usize,
    /// Splat targets on glossy surfaces (the ones with directional records).
    pub glossy_targets: usize,
    /// Radiance cache records of this frame (0 when the cache is off).
    pub cache_records: usize,
    pub photons_per_second: f64,
    /// Splat time of the last step, milliseconds.
    pub last_splat_ms: f64,
    pub eye_samples: usize,
    pub splat_targets: usize,
    /// Seconds since the current scene was loaded or tracing restarted.
    pub elapsed_s: f64,
    pub paused: bool,
    pub resplat_pending: bool,
    /// Paths per pixel of the reference image, 0 when it is off.
    pub reference_spp: u32,
    /// Fractions of the indirect photon rays whose bandwidth sits at h_min and at h_max
    /// (eq. 8's bounds; docs/deviations.md §5).
    pub indirect_at_h_min: f64,
    pub indirect_at_h_max: f64,
}

/// A published image and everything needed to describe it.
#[derive(Clone, Debug)]
pub struct Frame {
    pub film: Film,
    /// Increases with every published frame.
    pub seq: u64,
    /// Increases with every applied change (parameters, view, scene, restart).
    pub generation: u64,
    pub scene_name: String,
    pub scene_path: Option<PathBuf>,
    pub camera: Camera,
    pub settings: RenderSettings,
    /// Rendered at reduced resolution (while the camera moves, and for the first frame).
    pub interactive: bool,
    /// The radiance cache's records: pixel x, y, radius (pixels), pass (Fig. 8b).
    pub cache_records: Vec<[f32; 4]>,
    pub stats: SessionStats,
    /// The path-traced reference of the same view, while the reference mode is on.
    pub reference: Option<Film>,
}

#[derive(Clone, Debug)]
pub struct SessionConfig {
    /// Full-resolution settings; `photons` is M per batch.
    pub settings: RenderSettings,
    pub max_stored_rays: usize,
    pub publish_interval: Duration,
    /// Interactive views divide width and height by this and use 1 sample per pixel.
    pub interactive_divisor: u32,
}

impl Default for SessionConfig {
    fn default() -> Self {
        Self {
            settings: RenderSettings {
                spp: 1,
                photons: 20_000,
                ..RenderSettings::default()
            },
            max_stored_rays: 4_000_000,
            publish_interval: Duration::from_millis(100),
            interactive_divisor: 2,
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
        let handle = std::thread::Builder::new()
            .name("raysplat-worker".into())
            .spawn(move || {
                let events = event_tx.clone();
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    Worker::new(scene, scene_path, config, frame_tx, stale, event_tx, notify)
                        .run(cmd_rx)
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
            handle: Some(handle),
        }
    }

    pub fn send(&self, c: Command) {
        // A stopped worker has told the UI why through an event.
        let _ = self.cmd_tx.send(c);
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
        let _ = self.cmd_tx.send(Command::Shutdown);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// Changes gathered from one drain of the command queue, applied once.
#[derive(Default)]
struct Pending {
    load: Option<PathBuf>,
    restart: bool,
    view: bool,
    interactive: Option<bool>,
    bandwidth: Option<BandwidthParams>,
    /// Settings that need no re-trace changed ([`Method::update`]).
    update: bool,
}

struct Worker {
    scene: Arc<Scene>,
    scene_path: Option<PathBuf>,
    config: SessionConfig,
    camera: Camera,
    interactive: bool,
    renderer: Option<Box<dyn Method>>,
    /// A (re)start renders its first frame at the interactive resolution, then switches to
    /// full resolution (re-splatting, no re-trace): an image appears sooner.
    coarse_start: bool,
    paused: bool,
    /// The reference mode's path tracer, for the current view.
    reference: Option<Box<dyn Method>>,
    reference_on: bool,
    generation: u64,
    seq: u64,
    started: Instant,
    frame_tx: Sender<Frame>,
    stale: Receiver<Frame>,
    event_tx: Sender<Event>,
    notify: Option<Notify>,
    last_splat_ms: f64,
}

impl Worker {
    fn new(
        scene: Arc<Scene>,
        scene_path: Option<PathBuf>,
        config: SessionConfig,
        frame_tx: Sender<Frame>,
        stale: Receiver<Frame>,
        event_tx: Sender<Event>,
        notify: Option<Notify>,
    ) -> Self {
        let camera = scene.cameras[0].clone();
        let mut w = Self {
            scene,
            scene_path,
            config,
            camera,
            interactive: false,
            renderer: None,
            coarse_start: false,
            paused: false,
            reference: None,
            reference_on: false,
            generation: 0,
            seq: 0,
            started: Instant::now(),
            frame_tx,
            stale,
            event_tx,
            notify,
            last_splat_ms: 0.0,
        };
        w.announce_scene();
        w.restart();
        w
    }

    fn run(mut self, cmd_rx: Receiver<Command>) {
        let mut last_publish: Option<Instant> = None;
        // Something the UI has not seen yet (a change, a pause, a re-splatted batch).
        let mut unseen = true;
        loop {
            let busy = self
                .renderer
                .as_ref()
                .is_some_and(|r| r.catching_up() || !self.paused);
            let mut commands = Vec::new();
            if !busy {
                match cmd_rx.recv_timeout(Duration::from_millis(250)) {
                    Ok(c) => commands.push(c),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            }
            loop {
                match cmd_rx.try_recv() {
                    Ok(c) => commands.push(c),
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return,
                }
            }
            unseen |= !commands.is_empty();
            let mut pending = Pending::default();
            for c in commands {
                if !self.take(c, &mut pending) {
                    return;
                }
            }
            self.apply(pending);
            let mut traced = false;
            if self.reference_on && !self.paused && self.renderer.is_some() {
                self.reference_step();
                traced = true;
            } else if let Some(r) = self.renderer.as_mut()
                && (r.catching_up() || !self.paused)
            {
                let t = Instant::now();
                match r.step() {
                    // Show re-splat progress at once: it follows a user's change.
                    Step::Resplatted => unseen = true,
                    Step::Traced => traced = true,
                }
                self.last_splat_ms = t.elapsed().as_secs_f64() * 1e3;
            }
            let due = last_publish.is_none_or(|t| t.elapsed() >= self.config.publish_interval);
            if unseen || (traced && due) {
                self.publish();
                last_publish = Some(Instant::now());
                unseen = false;
                if self.coarse_start && self.renderer.as_ref().is_some_and(|r| r.passes() > 0) {
                    self.coarse_start = false;
                    if !self.interactive {
                        self.apply(Pending {
                            view: true,
                            ..Pending::default()
                        });
                    }
                }
            }
        }
    }

    /// Record a command; false on shutdown.
    fn take(&mut self, c: Command, p: &mut Pending) -> bool {
        let s = &mut self.config.settings;
        match c {
            Command::SetBandwidth(b) => p.bandwidth = Some(b),
            Command::SetPhotonsPerBatch(n) => {
                s.photons = limits::PHOTONS.clamp(n);
                p.update = true;
            }
            Command::SetSamplesPerPixel(spp) => {
                s.spp = limits::SPP.clamp(spp);
                p.view = true;
            }
            Command::SetResolution { width, height } => {
                s.width = limits::RESOLUTION.clamp(width);
                s.height = limits::RESOLUTION.clamp(height);
                p.view = true;
            }
            Command::SetCache { on, mut params } => {
                params.error = limits::CACHE_ERROR.clamp(params.error);
                params.min_records = limits::MIN_RECORDS.clamp(params.min_records);
                s.cache_on = on;
                s.cache = params;
                p.update = true;
            }
            Command::SetFilter(mut f) => {
                f.strength = limits::FILTER_STRENGTH.clamp(f.strength);
                s.filter = f;
                p.update = true;
            }
            Command::SetRadianceMap(m) => {
                s.radiance_map = m;
                p.update = true;
            }
            Command::SetDirect(d) => {
                if s.direct != d {
                    s.direct = d;
                    p.restart = true;
                }
            }
            Command::SetCamera {
                camera,
                interactive,
            } => {
                self.camera = camera;
                p.view = true;
                p.interactive = Some(interactive);
            }
            Command::SetRayBudget(n) => {
                self.config.max_stored_rays = limits::RAY_BUDGET.clamp(n);
                if let Some(r) = self.renderer.as_mut() {
                    r.set_ray_budget(self.config.max_stored_rays);
                }
            }
            Command::Pause => self.paused = true,
            Command::Resume => self.paused = false,
            Command::LoadScene(path) => p.load = Some(path),
            Command::Restart => p.restart = true,
            Command::SetReference(on) => {
                self.reference_on = on;
                if !on {
                    self.reference = None;
                }
            }
            Command::Shutdown => return false,
        }
        true
    }

    /// Apply gathered changes at the batch boundary.
    fn apply(&mut self, p: Pending) {
        if p.view || p.restart || p.load.is_some() {
            // The reference shows the current view only.
            self.reference = None;
        }
        if let Some(mut b) = p.bandwidth {
            b.smoothness_c = limits::SMOOTHNESS_C.clamp(b.smoothness_c);
            b.sensitivity_s = limits::SENSITIVITY_S.clamp(b.sensitivity_s);
            b.max_bandwidth_r = limits::MAX_BANDWIDTH_R.clamp(b.max_bandwidth_r);
            self.config.settings.bandwidth = b;
        }
        if let Some(i) = p.interactive {
            self.interactive = i;
        }
        if let Some(path) = p.load {
            match Scene::load(&path) {
                Ok(scene) => {
                    self.scene = Arc::new(scene);
                    self.scene_path = Some(path);
                    self.camera = self.scene.cameras[0].clone();
                    self.interactive = false;
                    self.announce_scene();
                    self.restart();
                    return;
                }
                Err(e) => {
                    self.emit(Event::LoadFailed(e.to_string()));
                }
            }
        }
        if p.restart || self.renderer.is_none() {
            self.restart();
            return;
        }
        let Some(r) = self.renderer.as_mut() else {
            return;
        };
        let s = &self.config.settings;
        let changed = p.update || p.bandwidth.is_some();
        if changed && let Err(e) = r.update(s) {
            self.emit(Event::Error(e));
            return;
        }
        if p.view {
            let (w, h, spp) = if self.interactive {
                let d = self.config.interactive_divisor.max(1);
                (
                    limits::RESOLUTION.clamp(s.width / d),
                    limits::RESOLUTION.clamp(s.height / d),
                    1,
                )
            } else {
                (s.width, s.height, s.spp)
            };
            if let Err(e) = r.set_view(self.camera.clone(), w, h, spp) {
                self.emit(Event::Error(e));
                return;
            }
        }
        if p.view || changed {
            self.generation += 1;
        }
    }

    /// Add one path per pixel to the reference of the current view.
    fn reference_step(&mut self) {
        let Some(r) = self.renderer.as_ref() else {
            return;
        };
        if self.reference.is_none() {
            let settings = RenderSettings {
                method: MethodKind::Pt,
                pt_spp: 1,
                ..r.settings().clone()
            };
            match methods::build_for(self.scene.clone(), settings, r.camera().clone()) {
                Ok(pt) => self.reference = Some(pt),
                Err(e) => {
                    self.reference_on = false;
                    self.emit(Event::Error(e));
                    return;
                }
            }
        }
        if let Some(pt) = self.reference.as_mut() {
            pt.step();
        }
    }

    fn restart(&mut self) {
        self.started = Instant::now();
        let mut settings = self.config.settings.clone();
        self.coarse_start = self.config.interactive_divisor > 1;
        if self.interactive || self.coarse_start {
            let d = self.config.interactive_divisor.max(1);
            settings.width = limits::RESOLUTION.clamp(settings.width / d);
            settings.height = limits::RESOLUTION.clamp(settings.height / d);
            settings.spp = 1;
        }
        match methods::build_for(self.scene.clone(), settings, self.camera.clone()) {
            Ok(mut r) => {
                r.set_ray_budget(self.config.max_stored_rays);
                self.renderer = Some(r);
            }
            Err(e) => self.emit(Event::Error(e)),
        }
        self.generation += 1;
    }

    fn announce_scene(&self) {
        self.emit(Event::SceneLoaded {
            name: self.scene.name.clone(),
            path: self.scene_path.clone(),
            cameras: self.scene.cameras.clone(),
            center: self.scene.center(),
            warnings: self.scene.warnings.clone(),
        });
    }

    fn emit(&self, e: Event) {
        let _ = self.event_tx.send(e);
        if let Some(n) = &self.notify {
            n();
        }
    }

    fn publish(&mut self) {
        let Some(r) = self.renderer.as_mut() else {
            return;
        };
        let film = r.film();
        let m = r.stats();
        let elapsed = self.started.elapsed().as_secs_f64();
        // The indirect class's rays at the bandwidth bounds (all classes when it is empty).
        let (at_min, at_max) = m.bandwidth_clamps.map_or((0.0, 0.0), |clamps| {
            let pick = if clamps[1].rays > 0 {
                clamps[1]
            } else {
                let mut all = clamps[0];
                all += clamps[2];
                all
            };
            (pick.fraction_min(), pick.fraction_max())
        });
        let stats = SessionStats {
            photons_traced: m.photons_traced,
            photon_rays: m.photon_rays,
            photon_ray_bytes: m.photon_ray_bytes,
            batches: m.passes as usize,
            folded_batches: m.folded_batches,
            stored_batches: m.stored_batches,
            splat_bytes: m.splat_bytes,
            directional_bytes: m.directional_bytes,
            glossy_targets: m.glossy_targets,
            cache_records: m.cache_records.unwrap_or(0),
            photons_per_second: m.photons_traced as f64 / elapsed.max(1e-9),
            last_splat_ms: self.last_splat_ms,
            eye_samples: m.eye_samples,
            splat_targets: m.splat_targets,
            elapsed_s: elapsed,
            paused: self.paused,
            resplat_pending: r.catching_up(),
            reference_spp: self.reference.as_ref().map_or(0, |p| p.passes() as u32),
            indirect_at_h_min: at_min,
            indirect_at_h_max: at_max,
        };
        self.seq += 1;
        let frame = Frame {
            film,
            seq: self.seq,
            generation: self.generation,
            scene_name: self.scene.name.clone(),
            scene_path: self.scene_path.clone(),
            camera: r.camera().clone(),
            settings: r.settings().clone(),
            interactive: self.interactive || self.coarse_start,
            cache_records: r.cache().map_or_else(Vec::new, |c| {
                c.records
                    .iter()
                    .map(|k| {
                        [
                            k.pixel.0 as f32,
                            k.pixel.1 as f32,
                            k.radius_px,
                            k.pass as f32,
                        ]
                    })
                    .collect()
            }),
            stats,
            reference: self.reference.as_mut().map(|p| p.film()),
        };
        // Keep only the newest frame: drop one the UI has not taken yet.
        while self.stale.try_recv().is_ok() {}
        let _ = self.frame_tx.try_send(frame);
        if let Some(n) = &self.notify {
            n();
        }
    }
}
