//! [`App`], the window: it owns the worker session, the newest frame, the displayed image, the
//! viewport and one struct per panel. Each frame it takes what the worker sent, lets the
//! panels draw and emit [`Commands`], and sends those to the worker.

use crate::app::UiSettings;
use crate::app::bandwidth::BandwidthPanel;
use crate::app::cache_filter::CacheFilterPanel;
use crate::app::camera::CameraPanel;
use crate::app::display::{DisplayPanel, set_view_mode};
use crate::app::environment::{EnvironmentPanel, EnvironmentRequest};
use crate::app::error_panel::ErrorPanel;
use crate::app::rendering::{RenderingPanel, toggle_pause};
use crate::app::snapshot_writer::{SnapshotFiles, SnapshotMeta, write_snapshot_in_background};
use crate::app::snapshots::{SnapshotPanel, SnapshotRequest};
use crate::app::stats::{Messages, StatsPanel};
use crate::app::viewport::Viewport;
use crate::app::widgets::Commands;
use crate::film::display::{DisplayImage, ViewMode, display};
use crate::film::error::error_map;
use crate::scene::Scene;
use crate::scene::environment::describe;
use crate::session::{Command, Event, Frame, Session};
use crossbeam_channel::{Receiver, unbounded};
use egui::{Key, Modifiers, RichText};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// A scene loaded before the window opens (by the command line, which reports a failure on
/// stderr instead of opening the window).
#[derive(Clone)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Arc<Scene>,
    /// Its file (none for the built-in scenes).
    pub path: Option<PathBuf>,
}

impl std::fmt::Debug for LoadedScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadedScene")
            .field("scene", &self.scene.name)
            .field("path", &self.path)
            .finish()
    }
}

/// How to start the previewer.
#[derive(Clone, Debug, Default)]
pub struct AppOptions {
    /// A scene file to open; the embedded CORNELL BOX I when absent or unloadable.
    pub scene: Option<PathBuf>,
    /// A scene already loaded (it takes precedence over `scene`).
    pub loaded: Option<LoadedScene>,
    /// Use these settings instead of the persisted ones (tests).
    pub settings: Option<UiSettings>,
}

/// The previewer window (an [`eframe::App`]).
pub struct App {
    session: Session,
    settings: UiSettings,
    frame: Option<Frame>,
    shown: Option<DisplayImage>,
    /// The shown image is out of date (a new frame, or another view mode, exposure or tone map).
    display_dirty: bool,
    scene_name: String,
    /// The worker is paused (as it last reported, or as the pause button just asked).
    paused: bool,
    viewport: Viewport,
    bandwidth: BandwidthPanel,
    error_panel: ErrorPanel,
    cache_filter: CacheFilterPanel,
    rendering: RenderingPanel,
    environment: EnvironmentPanel,
    camera: CameraPanel,
    display: DisplayPanel,
    snapshots: SnapshotPanel,
    stats: StatsPanel,
    messages: Messages,
    snapshot_rx: Option<Receiver<Result<SnapshotFiles, String>>>,
    pick_rx: Option<Receiver<PickResult>>,
}

enum PickResult {
    Scene(Option<PathBuf>),
    Folder(Option<PathBuf>),
    EnvironmentMap(Option<PathBuf>),
}

/// What a file dialog is for.
#[derive(Clone, Copy)]
enum Pick {
    Scene,
    Folder,
    EnvironmentMap,
}

impl App {
    /// Create the app for eframe (or egui_kittest's eframe harness): the settings of
    /// `options`, else the persisted ones, else the defaults.
    pub fn new(cc: &eframe::CreationContext<'_>, options: AppOptions) -> Self {
        let settings = options
            .settings
            .clone()
            .or_else(|| cc.storage.and_then(UiSettings::from_storage))
            .unwrap_or_default();
        let ctx = cc.egui_ctx.clone();
        Self::with_context(&ctx, options, settings)
    }

    /// Create the app on an egui context (no eframe storage) and start the worker.
    pub fn with_context(ctx: &egui::Context, options: AppOptions, settings: UiSettings) -> Self {
        let mut settings = settings.within_limits();
        let mut messages = Messages::default();
        let (scene, path) = match (options.loaded, &options.scene) {
            (Some(l), _) => {
                // The command line lit it (`--environment`): the window's setting takes that
                // instead of the one it kept, which the worker would relight it by.
                if !l.scene.environment_is_auto() {
                    settings.environment = l.scene.requested_environment().clone();
                }
                (l.scene, l.path)
            }
            (None, Some(p)) => match Scene::load(p) {
                Ok(s) => (Arc::new(s), Some(p.clone())),
                Err(e) => {
                    messages.error(format!("{e} — showing the embedded CORNELL BOX I instead"));
                    (Arc::new(Scene::default_scene()), None)
                }
            },
            (None, None) => (Arc::new(Scene::default_scene()), None),
        };
        // The view modes that need the worker (a persisted one included).
        if settings.view_mode == ViewMode::CacheRecords {
            settings.render.cache_on = true;
        }
        let repaint = ctx.clone();
        let session = Session::spawn(
            scene,
            path,
            settings.session_config(),
            Some(Arc::new(move || repaint.request_repaint())),
        );
        if settings.view_mode == ViewMode::Reference {
            session.send(Command::SetReference(true));
        }
        if settings.split {
            session.send(Command::SetSplit(true));
        }
        if let Some(t) = settings.pause_threshold() {
            session.send(Command::SetPauseBelow(Some(t)));
        }
        Self {
            session,
            settings,
            frame: None,
            shown: None,
            display_dirty: false,
            scene_name: String::new(),
            paused: false,
            viewport: Viewport::default(),
            bandwidth: BandwidthPanel,
            error_panel: ErrorPanel,
            cache_filter: CacheFilterPanel,
            rendering: RenderingPanel,
            environment: EnvironmentPanel::default(),
            camera: CameraPanel::default(),
            display: DisplayPanel,
            snapshots: SnapshotPanel,
            stats: StatsPanel::default(),
            messages,
            snapshot_rx: None,
            pick_rx: None,
        }
    }

    /// The newest frame received from the worker.
    pub fn frame(&self) -> Option<&Frame> {
        self.frame.as_ref()
    }

    /// The image on screen (view mode and tone mapping applied).
    pub fn shown(&self) -> Option<&DisplayImage> {
        self.shown.as_ref()
    }

    /// The window's settings as the widgets show them.
    pub fn settings(&self) -> &UiSettings {
        &self.settings
    }

    /// The environment lighting the scene, as the worker last reported it (resolved).
    pub fn lit_by(&self) -> Option<&crate::scene::EnvironmentSettings> {
        self.environment.lit_by.as_ref()
    }

    /// The name of the scene the worker has loaded (empty before it reports one).
    pub fn scene_name(&self) -> &str {
        &self.scene_name
    }

    /// Messages shown in the window, newest last.
    pub fn messages(&self) -> Vec<String> {
        self.messages.texts()
    }

    /// Ask the worker to open a scene (File → Open, drag and drop, tests).
    pub fn open_scene(&mut self, path: PathBuf) {
        self.messages.info(format!("loading {}…", path.display()));
        self.session.send(Command::LoadScene(path));
    }

    /// Light the scene with the environment map at `path` (the Environment panel's "Map
    /// file…", tests); the worker re-traces, or says why it cannot and keeps the lighting.
    pub fn set_environment_map(&mut self, path: PathBuf) {
        self.settings.environment.kind = crate::scene::EnvironmentKind::File(path);
        self.session
            .send(Command::SetEnvironment(self.settings.environment.clone()));
    }

    /// Save the displayed image, the linear film and the metadata into the snapshot folder
    /// (on a helper thread; a message reports the files or the error).
    pub fn snapshot(&mut self) {
        let (Some(frame), Some(shown)) = (&self.frame, &self.shown) else {
            self.messages
                .error("nothing to save yet: no image has arrived".into());
            return;
        };
        let meta = SnapshotMeta::new(frame, &self.settings);
        self.snapshot_rx = Some(write_snapshot_in_background(
            self.settings.snapshot_dir.clone(),
            shown.clone(),
            frame.film.clone(),
            meta,
        ));
    }

    /// Take what the worker and helper threads sent.
    fn poll(&mut self) {
        for e in self.session.try_events() {
            match e {
                Event::SceneLoaded {
                    name,
                    path,
                    cameras,
                    center,
                    warnings,
                    environment,
                    notice,
                } => {
                    self.scene_name = name;
                    self.environment.lit_by = Some(environment);
                    self.viewport.set_scene(center, cameras.first());
                    self.camera = CameraPanel::new(cameras);
                    if let Some(p) = path {
                        self.messages.info(format!("opened {}", p.display()));
                    }
                    for w in warnings {
                        self.messages.error(format!("warning: {w}"));
                    }
                    if let Some(n) = notice {
                        self.messages
                            .info(format!("{n} (the Environment panel chooses another)"));
                    }
                }
                Event::EnvironmentChanged {
                    environment,
                    notice,
                } => {
                    self.messages.info(match notice {
                        Some(n) => format!("{n}: re-tracing"),
                        None => format!("lit by {}: re-tracing", describe(&environment)),
                    });
                    self.environment.lit_by = Some(environment);
                }
                Event::LoadFailed(msg) => {
                    self.messages
                        .error(format!("{msg} — the current scene stays"));
                }
                Event::Error(msg) => self.messages.error(msg),
            }
        }
        if let Some(f) = self.session.try_frame() {
            self.paused = f.stats.paused;
            // A frame rendered under automatic C: the slider shows the C the render chose (and
            // keeps it once Auto is off: the worker keeps it too).
            if f.settings.auto_c {
                self.settings.render.bandwidth.smoothness_c = f.settings.bandwidth.smoothness_c;
            }
            self.frame = Some(f);
            self.display_dirty = true;
        }
        if let Some(rx) = &self.snapshot_rx
            && let Ok(result) = rx.try_recv()
        {
            self.snapshot_rx = None;
            match result {
                Ok(files) => self.messages.info(format!(
                    "saved {}, {}, {}",
                    files.png.display(),
                    files.exr.display(),
                    files.json.display()
                )),
                Err(e) => self.messages.error(format!("snapshot failed: {e}")),
            }
        }
        if let Some(rx) = &self.pick_rx
            && let Ok(result) = rx.try_recv()
        {
            self.pick_rx = None;
            match result {
                PickResult::Scene(Some(p)) => self.open_scene(p),
                PickResult::Folder(Some(p)) => self.settings.snapshot_dir = p,
                PickResult::EnvironmentMap(Some(p)) => self.set_environment_map(p),
                _ => {}
            }
        }
    }

    /// Redraw the shown image when the frame or the display settings changed.
    fn update_texture(&mut self, ctx: &egui::Context) {
        if !self.display_dirty {
            return;
        }
        self.display_dirty = false;
        let Some(f) = &self.frame else { return };
        let mode = self.settings.view_mode;
        // The reference mode shows the path tracer's image once it has one.
        let film = match (&f.reference, mode == ViewMode::Reference) {
            (Some(r), true) => r,
            _ => &f.film,
        };
        let mut img = display(film, mode, self.settings.exposure, self.settings.tone_map);
        if mode == ViewMode::CacheRecords {
            // Records are in the film's pixels (the cache runs at the frame's resolution).
            img.draw_records(&f.cache_records, 7.0);
        }
        // The split view: the reference's final image right of the divider; beside the
        // estimated error, the image's error against the reference in the same colours.
        if let Some(r) = self.split_reference() {
            let right = if mode == ViewMode::EstimatedError {
                DisplayImage::from_rgb(r.width, r.height, &error_map(&f.film.rgb, &r.rgb))
            } else {
                display(
                    r,
                    ViewMode::Final,
                    self.settings.exposure,
                    self.settings.tone_map,
                )
            };
            img.split_with(&right, self.settings.split_at);
        }
        self.viewport.set_image(ctx, &img);
        self.shown = Some(img);
    }

    /// The reference the split view shows beside the image: the split is on, the reference
    /// has the image's size, and the image is not the reference already.
    fn split_reference(&self) -> Option<&crate::film::Film> {
        let f = self.frame.as_ref()?;
        let r = f.reference.as_ref()?;
        (self.settings.split
            && self.settings.view_mode != ViewMode::Reference
            && (r.width, r.height) == (f.film.width, f.film.height))
            .then_some(r)
    }

    fn shortcuts(&mut self, ctx: &egui::Context, out: &mut Commands) {
        let (space, save, dropped) = ctx.input_mut(|i| {
            (
                i.consume_key(Modifiers::NONE, Key::Space),
                i.consume_key(Modifiers::COMMAND, Key::S),
                std::mem::take(&mut i.raw.dropped_files),
            )
        });
        if space && !ctx.egui_wants_keyboard_input() {
            toggle_pause(&mut self.paused, out);
        }
        if save {
            self.snapshot();
        }
        for f in dropped {
            let p = f.path().to_path_buf();
            if is_gltf(&p) {
                self.open_scene(p);
            } else {
                self.messages
                    .error(format!("{}: not a .gltf or .glb file", p.display()));
            }
        }
    }

    /// Open a file dialog on a helper thread: a scene, the snapshot folder, or an
    /// environment map.
    fn pick(&mut self, what: Pick) {
        let (tx, rx) = unbounded();
        let start = self.settings.snapshot_dir.clone();
        std::thread::spawn(move || {
            let r = match what {
                Pick::Folder => {
                    PickResult::Folder(rfd::FileDialog::new().set_directory(&start).pick_folder())
                }
                Pick::Scene => PickResult::Scene(
                    rfd::FileDialog::new()
                        .add_filter("glTF", &["gltf", "glb"])
                        .pick_file(),
                ),
                Pick::EnvironmentMap => PickResult::EnvironmentMap(
                    rfd::FileDialog::new()
                        .add_filter("Environment map", &["hdr", "exr"])
                        .pick_file(),
                ),
            };
            let _ = tx.send(r);
        });
        self.pick_rx = Some(rx);
    }

    fn menu(&mut self, ui: &mut egui::Ui, out: &mut Commands) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    self.pick(Pick::Scene);
                    ui.close();
                }
                if ui.button("Save snapshot (Ctrl+S)").clicked() {
                    self.snapshot();
                    ui.close();
                }
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                for m in ViewMode::ALL {
                    if ui
                        .selectable_label(
                            self.settings.view_mode == m,
                            super::display::view_mode_label(m),
                        )
                        .clicked()
                    {
                        set_view_mode(&mut self.settings, m, out);
                        ui.close();
                    }
                }
            });
            ui.separator();
            ui.label(RichText::new(&self.scene_name).strong());
        });
    }

    /// The side panel: every settings panel, top to bottom.
    fn controls(&mut self, ui: &mut egui::Ui, out: &mut Commands) {
        let stats = self.frame.as_ref().map(|f| &f.stats);
        self.bandwidth.ui(ui, &mut self.settings, stats, out);
        ui.separator();
        self.error_panel
            .ui(ui, &mut self.settings, self.frame.as_ref(), out);
        ui.separator();
        self.cache_filter.ui(ui, &mut self.settings, stats, out);
        ui.separator();
        self.rendering
            .ui(ui, &mut self.settings, &mut self.paused, out);
        ui.separator();
        if let Some(camera) = self.camera.ui(ui, out) {
            self.viewport.reset_orbit(&camera);
        }
        ui.separator();
        self.display.ui(ui, &mut self.settings, out);
        ui.separator();
        match self.snapshots.ui(ui, &mut self.settings) {
            Some(SnapshotRequest::ChooseFolder) => self.pick(Pick::Folder),
            Some(SnapshotRequest::Save) => self.snapshot(),
            None => {}
        }
        ui.separator();
        if let Some(EnvironmentRequest::ChooseMap) =
            self.environment.ui(ui, &mut self.settings, out)
        {
            self.pick(Pick::EnvironmentMap);
        }
    }
}

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let mut out = Commands::new();
        self.poll();
        self.shortcuts(&ctx, &mut out);
        let look = |s: &UiSettings| (s.view_mode, s.exposure, s.tone_map, s.split, s.split_at);
        let before = look(&self.settings);
        egui::Panel::top("menu").show(ui, |ui| self.menu(ui, &mut out));
        let min_height = self.stats.min_height(ctx.content_rect().width());
        let status = egui::Panel::bottom("status")
            .min_size(min_height)
            .show(ui, |ui| {
                self.stats.ui(ui, self.frame.as_ref());
                self.messages.ui(ui);
            });
        self.stats.note_height(status.response.rect.height());
        egui::Panel::left("controls")
            .resizable(true)
            .default_size(300.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui, &mut out));
            });
        if look(&self.settings) != before {
            self.display_dirty = true;
        }
        self.update_texture(&ctx);
        let split = self.split_reference().is_some();
        let split_before = self.settings.split_at;
        egui::CentralPanel::default().show(ui, |ui| {
            self.viewport.ui(
                ui,
                self.frame.as_ref(),
                self.shown.as_ref(),
                self.settings.view_mode,
                split.then_some(&mut self.settings.split_at),
                &mut out,
            );
        });
        if self.settings.split_at != split_before {
            // The divider was dragged: show it where it is now.
            self.display_dirty = true;
            ctx.request_repaint();
        }
        for c in out.take() {
            self.session.send(c);
        }
        if self.snapshot_rx.is_some() || self.pick_rx.is_some() {
            ctx.request_repaint_after(Duration::from_millis(50));
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        self.settings.save(storage);
    }
}

fn is_gltf(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}
