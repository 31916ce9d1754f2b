//! The worker thread: drains commands, applies them at the batch boundary, steps the method,
//! and publishes frames.

use super::{Command, Event, Frame, MAX_DRAG_DIVISOR, Notify, SessionConfig, SessionStats};
use crate::methods::{self, Method, Step};
use crate::scene::{Camera, EnvironmentSettings, Scene};
use crate::settings::{Changes, Effect, MethodKind, RenderSettings, limits};
use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Changes gathered from one drain of the command queue, applied once. Changes of the render
/// settings are not listed here: `apply` reads them from the settings table
/// ([`Changes::between`] the settings last applied and the new ones).
#[derive(Default)]
struct Pending {
    load: Option<PathBuf>,
    restart: bool,
    /// A new camera (or the full resolution after the coarse first image).
    view: bool,
    /// A command arrived: `apply` compares the render settings with those last applied (a
    /// change the method refused is tried again at the next command, not on every turn of
    /// the loop).
    settings: bool,
    interactive: Option<bool>,
    /// The environment changed (`SessionConfig::environment` holds it).
    environment: bool,
}

pub(super) struct Worker {
    scene: Arc<Scene>,
    scene_path: Option<PathBuf>,
    config: SessionConfig,
    /// The settings the running method was last given (full size: the method itself may
    /// render the interactive size).
    applied: RenderSettings,
    camera: Camera,
    interactive: bool,
    /// The settings whose method could not be built (the previous one keeps running).
    failed: Option<RenderSettings>,
    renderer: Option<Box<dyn Method>>,
    /// A (re)start renders its first frame at the interactive resolution, then switches to
    /// full resolution (re-splatting, no re-trace): an image appears sooner.
    coarse_start: bool,
    paused: bool,
    /// The reference mode's path tracer, for the current view.
    reference: Option<Box<dyn Method>>,
    reference_on: bool,
    /// The split view: the reference refines beside the method, each taking turns by the
    /// time it has spent since the reference started.
    split_on: bool,
    /// Seconds of batches and of reference paths since the reference started (split view).
    t_method: f64,
    t_reference: f64,
    /// Pause once the estimated relMSE is below this.
    pause_below: Option<f64>,
    /// The next estimate below `pause_below` pauses (cleared by such a pause, set again once
    /// the estimate is missing or above the threshold).
    pause_armed: bool,
    /// The threshold the worker paused itself at (cleared by a resume).
    paused_below: Option<f64>,
    generation: u64,
    seq: u64,
    /// Time spent unpaused since the restart.
    run_clock: RunClock,
    frame_tx: Sender<Frame>,
    stale: Receiver<Frame>,
    event_tx: Sender<Event>,
    notify: Option<Notify>,
    last_splat_ms: f64,
    /// The pieces of the batch in flight so far, milliseconds.
    splat_ms_sum: f64,
    /// Raised by the session with a command that brings a new view; lowered here before the
    /// commands are read ([`crate::methods::Method::set_stop`]).
    stop: Option<Arc<AtomicBool>>,
    /// The size of the dragged views, from what the last ones cost.
    drag: DragSize,
}

impl Worker {
    pub(super) fn new(
        scene: Arc<Scene>,
        scene_path: Option<PathBuf>,
        config: SessionConfig,
        frame_tx: Sender<Frame>,
        stale: Receiver<Frame>,
        event_tx: Sender<Event>,
        notify: Option<Notify>,
    ) -> Self {
        let camera = scene.cameras[0].clone();
        let (scene, lighting_error) = lit(scene, &config.environment);
        let drag = DragSize::new(config.interactive_divisor, config.drag_frame_budget);
        let mut w = Self {
            scene,
            scene_path,
            applied: config.settings.clone(),
            config,
            camera,
            interactive: false,
            drag,
            failed: None,
            renderer: None,
            coarse_start: false,
            paused: false,
            reference: None,
            reference_on: false,
            split_on: false,
            t_method: 0.0,
            t_reference: 0.0,
            pause_below: None,
            pause_armed: true,
            paused_below: None,
            generation: 0,
            seq: 0,
            run_clock: RunClock::new(),
            frame_tx,
            stale,
            event_tx,
            notify,
            last_splat_ms: 0.0,
            splat_ms_sum: 0.0,
            stop: None,
        };
        w.announce_scene();
        if let Some(e) = lighting_error {
            w.emit(Event::Error(e));
        }
        w.restart();
        w
    }

    pub(super) fn run(mut self, cmd_rx: Receiver<Command>, stop: Arc<AtomicBool>) {
        if let Some(r) = self.renderer.as_mut() {
            r.set_stop(stop.clone());
        }
        self.stop = Some(stop.clone());
        let mut last_publish: Option<Instant> = None;
        // Something the UI has not seen yet (a change, a pause, a re-splatted batch).
        let mut unseen = true;
        loop {
            let busy = self
                .renderer
                .as_ref()
                .is_some_and(|r| r.catching_up() || r.mid_step() || !self.paused);
            let mut commands = Vec::new();
            // Lowered before the commands are read: a command sent after this raises it
            // again, and is read by this drain or the next. A raise whose command this drain
            // reads (the usual case for a camera that comes to rest while the worker waits)
            // gives up the view's side at its first band, and the next step draws it.
            stop.store(false, Ordering::Release);
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
            // A renderer that `apply` rebuilt learns it too.
            self.sync_interactive();
            let mut traced = false;
            // The reference mode waits for a batch in pieces to be whole.
            let whole_batch = self.renderer.as_ref().is_some_and(|r| !r.mid_step());
            if self.reference_on && !self.paused && whole_batch {
                // The method is not stepped: a view applied now is never measured.
                self.drag.cancel();
                traced = self.reference_step();
            } else if self.reference_turn() {
                let t = Instant::now();
                traced = self.reference_step();
                self.t_reference += t.elapsed().as_secs_f64();
            } else if let Some(r) = self.renderer.as_mut()
                && (r.catching_up() || r.mid_step() || !self.paused)
            {
                let t = Instant::now();
                // Re-splat pieces are not the method's turn in the split view (a whole
                // re-splat step never was).
                let resplat = r.catching_up();
                let step = r.step();
                match step {
                    // Show re-splat progress at once: it follows a user's change.
                    Step::Resplatted => unseen = true,
                    Step::Traced => {
                        traced = true;
                        self.t_method += t.elapsed().as_secs_f64();
                    }
                    // Part of a batch: commands are read again before the next piece.
                    Step::Partial if !resplat => self.t_method += t.elapsed().as_secs_f64(),
                    Step::Partial => {}
                    // An eye side drawn (or given up again) for a new view: the method's
                    // time, but not a splat's.
                    Step::Side => self.t_method += t.elapsed().as_secs_f64(),
                }
                // A view's first frame with its light: what it cost sizes the dragged views.
                if matches!(step, Step::Resplatted | Step::Traced) {
                    let s = &self.config.settings;
                    self.drag.end(s.width as u64 * s.height as u64);
                }
                // The stats show a whole batch's splat time, its pieces added up.
                if step != Step::Side {
                    self.splat_ms_sum += t.elapsed().as_secs_f64() * 1e3;
                }
                if !r.mid_step() {
                    self.last_splat_ms = std::mem::take(&mut self.splat_ms_sum);
                }
            }
            let due = last_publish.is_none_or(|t| t.elapsed() >= self.config.publish_interval);
            // Never between the pieces of a batch: its light is not counted yet.
            let whole = !self.renderer.as_ref().is_some_and(|r| r.mid_step());
            if whole && (unseen || (traced && due)) {
                self.publish();
                last_publish = Some(Instant::now());
                unseen = false;
                // After the first coarse image, or at once in the reference mode, which never
                // steps the renderer (it stayed at half resolution before).
                let first_done = self.renderer.as_ref().is_some_and(|r| r.passes() > 0);
                if self.coarse_start && (first_done || self.reference_on) {
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

    /// Record a command; false on shutdown. A command that sets render settings only writes
    /// them: what the change asks of the method is the settings table's to say (`apply`).
    fn take(&mut self, c: Command, p: &mut Pending) -> bool {
        let s = &mut self.config.settings;
        p.settings = true;
        match c {
            Command::SetBandwidth(b) => s.bandwidth = b,
            Command::SetPhotonsPerBatch(n) => s.photons = n,
            Command::SetSamplesPerPixel(spp) => s.spp = spp,
            Command::SetResolution { width, height } => {
                s.width = width;
                s.height = height;
            }
            Command::SetCache { on, params } => {
                s.cache_on = on;
                s.cache = params;
            }
            Command::SetFilter(f) => s.filter = f,
            Command::SetRadianceMap(m) => s.radiance_map = m,
            Command::SetDirect(d) => s.direct = d,
            Command::SetNeeSamples(n) => s.nee_samples = limits::NEE_SAMPLES.clamp(n),
            Command::SetSplatVisibility(on) => s.splat_visibility = on,
            Command::SetGuidedEmission(on) => s.guided_emission = on,
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
            Command::Pause => {
                self.run_clock.tick(self.paused);
                self.paused = true;
            }
            Command::Resume => {
                self.run_clock.tick(self.paused);
                self.paused = false;
                self.paused_below = None;
            }
            Command::LoadScene(path) => p.load = Some(path),
            Command::SetEnvironment(env) => {
                self.config.environment = env;
                p.environment = true;
            }
            Command::Restart => p.restart = true,
            Command::SetReference(on) => {
                self.reference_on = on;
                if !on && !self.split_on {
                    self.reference = None;
                }
            }
            Command::SetSplit(on) => {
                self.split_on = on;
                if !on && !self.reference_on {
                    self.reference = None;
                }
            }
            Command::SetErrorEstimate(on) => s.estimate_error = on,
            Command::SetAutoC(on) => {
                // Off, the batches keep the C the render chose last, as the window's slider
                // shows it (no re-splat to an older C).
                if !on
                    && s.auto_c
                    && let Some(r) = self.renderer.as_ref()
                {
                    s.bandwidth.smoothness_c = r.settings().bandwidth.smoothness_c;
                }
                s.auto_c = on;
            }
            Command::SetPauseBelow(threshold) => {
                self.pause_below = threshold;
                self.pause_armed = true;
                if threshold.is_none() {
                    // Still paused, but no longer by the threshold the panel would name.
                    self.paused_below = None;
                }
            }
            Command::Shutdown => return false,
        }
        true
    }

    /// Apply gathered changes at the batch boundary.
    fn apply(&mut self, p: Pending) {
        if p.view || p.restart || p.load.is_some() || p.environment {
            // The reference shows the current view only.
            self.reference = None;
        }
        // Whatever the commands asked for, into the limits table's ranges (one place).
        self.config.settings = std::mem::take(&mut self.config.settings).within_limits();
        if let Some(i) = p.interactive {
            self.interactive = i;
        }
        // Before a view is set: a dragged view's (or the coarse first image's) eye side is
        // never given up, a resting view's may be.
        self.sync_interactive();
        if let Some(path) = p.load {
            match Scene::load(&path) {
                Ok(scene) => {
                    // Lit as asked; a map that cannot be read leaves the scene's own lighting.
                    let (scene, lighting_error) = lit(Arc::new(scene), &self.config.environment);
                    self.scene = scene;
                    self.scene_path = Some(path);
                    self.camera = self.scene.cameras[0].clone();
                    self.interactive = false;
                    self.announce_scene();
                    if let Some(e) = lighting_error {
                        self.emit(Event::Error(e));
                    }
                    self.restart();
                    return;
                }
                Err(e) => {
                    self.emit(Event::LoadFailed(e.to_string()));
                }
            }
        }
        if p.environment {
            let (scene, error) = lit(self.scene.clone(), &self.config.environment);
            if let Some(e) = error {
                self.emit(Event::Error(e));
            } else {
                self.scene = scene;
                self.emit(Event::EnvironmentChanged {
                    environment: self.scene.environment.clone(),
                    notice: self.scene.lighting_notice.clone(),
                });
                self.restart();
                return;
            }
        }
        // Settings whose build just failed are not tried again until something changes.
        let failed = self.failed.as_ref() == Some(&self.config.settings);
        let rebuild = !failed
            && self
                .renderer
                .as_ref()
                .is_none_or(|r| methods::needs_rebuild(r.settings(), &self.config.settings));
        if p.restart || rebuild {
            self.restart();
            return;
        }
        let Some(r) = self.renderer.as_mut() else {
            return;
        };
        let s = &self.config.settings;
        // What the commands changed, by the settings table: the view's settings make a new
        // view, the re-splat and resolve ones an update (the re-trace ones rebuilt above).
        let changes = if p.settings {
            Changes::between(&self.applied, s)
        } else {
            Changes::default()
        };
        // Once the coarse first image is done, a renderer still on its half batch gets the
        // configured size back with the next change of any kind.
        let half_batch = !self.coarse_start && r.settings().photons != s.photons;
        let changed = changes.any(Effect::Resplat) || changes.any(Effect::Resolve) || half_batch;
        if changed && let Err(e) = r.update(s) {
            self.emit(Event::Error(e.to_string()));
            return;
        }
        // What the method now has, but for a view it may still refuse below.
        let mut applied = s.clone();
        applied.adopt(&self.applied, &[Effect::View]);
        self.applied = applied;
        let view = p.view || changes.any(Effect::View);
        if view {
            // The reference shows the current view at its size only.
            self.reference = None;
            let v = if self.interactive {
                let v = interactive_view(s, self.drag.divisor);
                self.drag.begin(v.width as u64 * v.height as u64, true);
                v
            } else {
                self.drag.begin(s.width as u64 * s.height as u64, false);
                s.clone()
            };
            // The light samples are a `Resolve` setting: the update only adopts them.
            if r.settings().nee_samples != v.nee_samples {
                let mut t = r.settings().clone();
                t.nee_samples = v.nee_samples;
                if let Err(e) = r.update(&t) {
                    self.emit(Event::Error(e.to_string()));
                    return;
                }
            }
            if let Err(e) = r.set_view(self.camera.clone(), v.width, v.height, v.spp) {
                self.drag.cancel();
                self.emit(Event::Error(e.to_string()));
                return;
            }
            self.applied = s.clone();
        }
        if view || changed {
            self.generation += 1;
        }
    }

    /// A view being dragged (or the coarse first image) wants a frame per step: re-splats
    /// whole, eye sides never given up.
    fn sync_interactive(&mut self) {
        let interactive = self.interactive || self.coarse_start;
        if let Some(r) = self.renderer.as_mut() {
            r.set_interactive(interactive);
        }
    }

    /// The split view's reference takes the next turn: it has spent no more time than the
    /// batches since it started, and nothing more urgent waits (a re-splat after a change, a
    /// moving camera's coarse frames, the first image).
    fn reference_turn(&self) -> bool {
        self.split_on
            && !self.reference_on
            && !self.paused
            && !self.interactive
            && !self.coarse_start
            && self.t_reference <= self.t_method
            && self
                .renderer
                .as_ref()
                .is_some_and(|r| !r.catching_up() && !r.mid_step() && r.passes() > 0)
    }

    /// Step the reference (built for the method's view when there is none); true when it
    /// traced a pass (a pass given up for a new view adds nothing).
    fn reference_step(&mut self) -> bool {
        let Some(r) = self.renderer.as_ref() else {
            return false;
        };
        if self.reference.is_none() {
            let settings = RenderSettings {
                method: MethodKind::Pt,
                pt_spp: 1,
                ..r.settings().clone()
            };
            match methods::build_for(self.scene.clone(), settings, r.camera().clone()) {
                Ok(mut pt) => {
                    // A new view gives up the pass under way of a view at rest's reference:
                    // the view drops the reference (`apply`), so a move need not wait for its
                    // paths. A dragged view's passes finish, as its eye sides do: each shows
                    // the moving view.
                    if let Some(stop) = self.stop.as_ref().filter(|_| !self.interactive) {
                        pt.set_stop(stop.clone());
                    }
                    self.reference = Some(pt);
                    self.t_method = 0.0;
                    self.t_reference = 0.0;
                }
                Err(e) => {
                    self.reference_on = false;
                    self.emit(Event::Error(e.to_string()));
                    return false;
                }
            }
        }
        self.reference
            .as_mut()
            .is_some_and(|pt| pt.step() == Step::Traced)
    }

    fn restart(&mut self) {
        self.run_clock = RunClock::new();
        // A new scene, lighting or trace: its costs are measured anew.
        self.drag.reset();
        // The last batch's time belongs to the render before the restart.
        (self.last_splat_ms, self.splat_ms_sum) = (0.0, 0.0);
        // The reference shows the scene and settings of the method it is beside.
        self.reference = None;
        self.coarse_start = self.config.first_divisor > 1;
        let mut settings = if self.interactive {
            interactive_view(&self.config.settings, self.drag.divisor)
        } else if self.coarse_start {
            interactive_view(&self.config.settings, self.config.first_divisor as f32)
        } else {
            self.config.settings.clone()
        };
        if self.coarse_start {
            // The coarse first image traces half a batch: its splat time falls as M^(2/3)
            // (the bandwidth grows as M^(−1/6)), first image 258–267 → 182–191 ms on the
            // embedded scene (docs/benchmarks.md, "The previewer"). The batches after it
            // have the configured size again (`apply`).
            settings.photons = limits::PHOTONS.clamp(settings.photons / 2);
        }
        match methods::build_for(self.scene.clone(), settings, self.camera.clone()) {
            Ok(mut r) => {
                r.set_ray_budget(self.config.max_stored_rays);
                if let Some(stop) = &self.stop {
                    r.set_stop(stop.clone());
                }
                // The window renders by the clock.
                r.pace();
                self.renderer = Some(r);
                self.failed = None;
                self.applied = self.config.settings.clone();
            }
            Err(e) => {
                self.failed = Some(self.config.settings.clone());
                self.emit(Event::Error(e.to_string()));
            }
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
            environment: self.scene.environment.clone(),
            notice: self.scene.lighting_notice.clone(),
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
        // A reference of no paths yet (its first pass given up) is no image.
        let reference = self
            .reference
            .as_mut()
            .filter(|p| p.passes() > 0)
            .map(|p| p.film());
        let reference_rel_mse = reference
            .as_ref()
            .filter(|f| (f.width, f.height) == (film.width, film.height))
            .map(|f| crate::film::rel_mse(&film.rgb, &f.rgb));
        // Pause at the user's threshold, once per crossing (see `pause_armed`).
        if let Some(threshold) = self.pause_below {
            match &film.estimate {
                // Paused by hand, the crossing waits for the resume; an estimate of few passes
                // is not acted on (a black image has none).
                Some(e) if e.rel_mse < threshold && !self.paused && e.trusted() => {
                    if self.pause_armed {
                        self.run_clock.tick(self.paused);
                        self.paused = true;
                        self.paused_below = Some(threshold);
                    }
                    self.pause_armed = false;
                }
                Some(_) if self.paused => {}
                _ => self.pause_armed = true,
            }
        }
        // The time spent rendering: paused spans do not count (a new user read photons/s
        // falling after a pause).
        self.run_clock.tick(self.paused);
        let elapsed = self.run_clock.running.as_secs_f64();
        // The indirect class's rays at the bandwidth bounds (all classes when it is empty).
        let (at_min, at_max, at_floor) = m.bandwidth_clamps.map_or((0.0, 0.0, 0.0), |clamps| {
            let pick = if clamps[1].rays > 0 {
                clamps[1]
            } else {
                let mut all = clamps[0];
                all += clamps[2];
                all
            };
            (
                pick.fraction_min(),
                pick.fraction_max(),
                pick.fraction_floor(),
            )
        });
        let stats = SessionStats {
            photons_per_second: m.photons_traced as f64 / elapsed.max(1e-9),
            method: m,
            last_splat_ms: self.last_splat_ms,
            elapsed_s: elapsed,
            paused: self.paused,
            resplat_pending: r.catching_up(),
            reference_spp: self.reference.as_ref().map_or(0, |p| p.passes() as u32),
            reference_rel_mse,
            reference_noise: reference
                .as_ref()
                .and_then(|f| f.estimate.as_ref())
                .map(|e| e.rel_mse),
            paused_below: self.paused_below,
            indirect_at_h_min: at_min,
            indirect_at_h_max: at_max,
            indirect_at_floor: at_floor,
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
            reference,
        };
        // Keep only the newest frame: drop one the UI has not taken yet.
        while self.stale.try_recv().is_ok() {}
        let _ = self.frame_tx.try_send(frame);
        if let Some(n) = &self.notify {
            n();
        }
    }
}

/// `scene` lit by `env` (itself when it already is: the `Auto` default on a freshly loaded
/// scene), or `scene` unchanged with the one-line reason it cannot be.
fn lit(scene: Arc<Scene>, env: &EnvironmentSettings) -> (Arc<Scene>, Option<String>) {
    // Already lit as asked (as it loaded, or by the command line that loaded it).
    if scene.requested_environment() == env {
        return (scene, None);
    }
    let mut relit = (*scene).clone();
    match relit.set_environment(env) {
        Ok(()) => (Arc::new(relit), None),
        Err(e) => (
            scene,
            Some(format!(
                "environment {}: {e} — the lighting stays",
                env.kind.name()
            )),
        ),
    }
}

/// The settings of an interactive view (a camera being dragged, the coarse first image): the
/// configured size divided by `divisor` (rounded), one eye sample per pixel and one light sample each
/// (the configured 4 cost the first image 60–70 ms and a camera move 25–60 ms,
/// docs/benchmarks.md "The previewer"). The view at rest gets the configured ones back: the
/// size and samples by `set_view`, the light samples by the update that ends the coarse
/// image's half batch or by the view branch of `apply`.
fn interactive_view(s: &RenderSettings, divisor: f32) -> RenderSettings {
    let d = divisor.max(1.0);
    let size = |n: u32| limits::RESOLUTION.clamp((n as f32 / d).round() as u32);
    RenderSettings {
        width: size(s.width),
        height: size(s.height),
        spp: 1,
        nee_samples: 1,
        ..s.clone()
    }
}

/// The time a session spent rendering: paused spans do not count.
struct RunClock {
    /// Unpaused time up to `last`.
    running: Duration,
    last: Instant,
}

impl RunClock {
    fn new() -> Self {
        Self {
            running: Duration::ZERO,
            last: Instant::now(),
        }
    }

    /// Bring the unpaused time up to now; `paused` is the state since the last tick (call
    /// before the pause state changes, and before reading).
    fn tick(&mut self, paused: bool) {
        let now = Instant::now();
        if !paused {
            self.running += now - self.last;
        }
        self.last = now;
    }
}

/// The size of the dragged views (adaptive resolution, as production viewports lower theirs
/// while the camera moves; docs/deviations.md §62): the full size divided by `divisor`, at
/// least the configured interactive divisor and at most [`MAX_DRAG_DIVISOR`], chosen so that
/// a dragged view's first frame with its light (its eye side, then the newest stored batch
/// re-splatted onto it) takes about the budget. Early in a render, or in a scene of wide
/// kernels, a batch splats onto many more targets per ray: a half-size view of CORNELL BOX I
/// took 370 ms a few batches in, 230 ms after fifteen (docs/benchmarks.md, "The previewer").
struct DragSize {
    divisor: f32,
    least: f32,
    most: f32,
    /// Seconds a dragged frame may take.
    budget: f64,
    /// Seconds per pixel of the last dragged frames, each new one weighing half; before the
    /// first drag, a view at rest's.
    per_pixel: Option<f64>,
    /// The view under way: when it was applied, its pixels, and whether it is dragged.
    pending: Option<(Instant, u64, bool)>,
}

impl DragSize {
    fn new(least: u32, budget: Duration) -> Self {
        let least = least.max(1) as f32;
        Self {
            divisor: least,
            least,
            most: MAX_DRAG_DIVISOR.max(least),
            budget: budget.as_secs_f64(),
            per_pixel: None,
            pending: None,
        }
    }

    /// Nothing measured: a new scene, lighting or trace starts at the least divisor.
    fn reset(&mut self) {
        (self.divisor, self.per_pixel, self.pending) = (self.least, None, None);
    }

    /// The view under way will not be measured (its frame comes from elsewhere, or it failed).
    fn cancel(&mut self) {
        self.pending = None;
    }

    /// A view of `pixels` is being applied (its eye side is drawn next), `dragged` or at rest.
    fn begin(&mut self, pixels: u64, dragged: bool) {
        self.pending = Some((Instant::now(), pixels, dragged));
    }

    /// The view's first frame with its light is ready: its cost per pixel sizes the next
    /// dragged views of a view of `full_pixels` at rest. The eye side, the splat tree and
    /// the splat all follow the pixel count, so the divisor whose view costs the budget is
    /// √(cost · full / budget), in quarter steps (a size that changed with every frame would
    /// flicker). A view at rest counts only until the first drag has been measured: it takes
    /// more of its visible domains from the last pass's probes (71–76% against a dragged
    /// view's 24%, docs/deviations.md §40), so it would size the dragged views too large,
    /// but it sizes the first one better than nothing (a half-size first move in the
    /// apartment under the sky took 405–408 ms).
    fn end(&mut self, full_pixels: u64) {
        if let Some((t, ..)) = self.pending {
            self.end_after(t.elapsed(), full_pixels);
        }
    }

    /// [`DragSize::end`] for a frame that took `elapsed`. The divisor goes up at once to the
    /// quarter step at or above the one the cost asks for, and down only once the cost asks
    /// for a divisor a whole step below the current step's lower end (a cost near a step
    /// would otherwise flip the size between frames).
    fn end_after(&mut self, elapsed: Duration, full_pixels: u64) {
        let Some((_, pixels, dragged)) = self.pending.take() else {
            return;
        };
        if !dragged && self.per_pixel.is_some() {
            return;
        }
        let cost = elapsed.as_secs_f64() / pixels.max(1) as f64;
        let c = self.per_pixel.map_or(cost, |p| 0.5 * (p + cost));
        self.per_pixel = Some(c);
        if self.budget > 0.0 {
            let d = (c * full_pixels as f64 / self.budget).sqrt() as f32;
            let step = ((d * 4.0).ceil() / 4.0).clamp(self.least, self.most);
            if step > self.divisor || d <= self.divisor - 0.5 {
                self.divisor = step;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The divisor follows the measured cost per pixel: a frame at the budget keeps the size,
    /// dearer ones make it smaller at once, cheaper ones larger only past a quarter step, and
    /// it never leaves [least, most]; a view at rest sizes only the first drag.
    #[test]
    fn the_dragged_view_is_sized_to_its_budget() {
        let mut d = DragSize::new(2, Duration::from_millis(200));
        let full = 500 * 500;
        let pixels = 250 * 250;
        let measure = |d: &mut DragSize, secs: f64| {
            d.begin(pixels, true);
            d.end_after(Duration::from_secs_f64(secs), full);
        };
        measure(&mut d, 0.199);
        assert_eq!(d.divisor, 2.0);
        // The smoothed cost: (0.199 + 0.8)/2 a view, 2.5× the budget's at half size: √10.
        measure(&mut d, 0.8);
        assert_eq!(d.divisor, 3.25);
        // A little cheaper (smoothed 0.42 s, √8.5 = 2.92, whose step is 3.0): the same size,
        // where a cost near 3.0 would flip it between 3.0 and 3.25.
        measure(&mut d, 0.35);
        assert_eq!(d.divisor, 3.25);
        for _ in 0..8 {
            measure(&mut d, 5.0);
        }
        assert_eq!(d.divisor, MAX_DRAG_DIVISOR);
        for _ in 0..8 {
            measure(&mut d, 0.001);
        }
        assert_eq!(d.divisor, 2.0);
        // Once a drag was measured, a view at rest measures nothing.
        d.begin(full, false);
        d.end_after(Duration::from_secs(5), full);
        assert_eq!(d.divisor, 2.0);
        // Before, it sizes the first drag: a full-size view at just under 9× the budget, a
        // third of each side.
        let mut first = DragSize::new(2, Duration::from_millis(200));
        first.begin(full, false);
        first.end_after(Duration::from_secs_f64(1.79), full);
        assert_eq!(first.divisor, 3.0);
        // A reset forgets it; a cancelled view measures nothing.
        first.reset();
        first.begin(pixels, true);
        first.cancel();
        first.end_after(Duration::from_secs(5), full);
        assert_eq!((first.divisor, first.per_pixel), (2.0, None));
        // A configured least above the most is kept.
        assert_eq!(DragSize::new(8, Duration::from_millis(200)).most, 8.0);
    }
}
