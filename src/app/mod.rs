//! The previewer window (egui/eframe): shows the worker's frames and sends it commands.
//! It only draws and sends messages; all rendering happens on the `session` worker.

pub mod snapshot;

use crate::app::snapshot::{SnapshotFiles, SnapshotMeta, utc_now, write_snapshot};
use crate::choice::Choice;
use crate::film::display::{DisplayImage, ToneMap, ViewMode, display};
use crate::film::false_colour;
use crate::pipeline::cache::CacheParams;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::filter::FilterParams;
use crate::pipeline::photon::BandwidthParams;
use crate::scene::{Camera, Scene};
use crate::session::{Command, Event, Frame, Session, SessionConfig};
use crate::settings::DirectMode;
use crossbeam_channel::{Receiver, unbounded};
use egui::{Color32, Key, Modifiers, RichText, TextureHandle, TextureOptions, Vec2};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Settings that persist between runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct UiSettings {
    pub bandwidth: BandwidthParams,
    pub photons_per_batch: u64,
    pub spp: u32,
    pub width: u32,
    pub height: u32,
    pub direct: DirectMode,
    /// Directional storage at glossy surfaces (§8.1).
    pub radiance_map: DirectionalMode,
    /// Resolve through the radiance cache (§8.3).
    pub cache_on: bool,
    pub cache: CacheParams,
    /// Image-space filter of the indirect light (§8.2).
    pub filter: FilterParams,
    pub view_mode: ViewMode,
    pub exposure: f32,
    pub tone_map: ToneMap,
    pub snapshot_dir: PathBuf,
    /// Photon-ray store budget, in rays.
    pub ray_budget: usize,
}

impl Default for UiSettings {
    fn default() -> Self {
        let s = SessionConfig::default();
        Self {
            bandwidth: BandwidthParams::default(),
            photons_per_batch: s.settings.photons,
            spp: s.settings.spp,
            width: s.settings.width,
            height: s.settings.height,
            direct: s.settings.direct,
            radiance_map: s.settings.radiance_map,
            cache_on: false,
            cache: CacheParams::default(),
            filter: FilterParams::default(),
            view_mode: ViewMode::Final,
            exposure: 0.0,
            tone_map: ToneMap::Aces,
            snapshot_dir: std::env::current_dir().unwrap_or_else(|_| PathBuf::from(".")),
            ray_budget: s.max_stored_rays,
        }
    }
}

/// How to start the previewer.
#[derive(Clone, Debug, Default)]
pub struct AppOptions {
    /// A scene file to open; the embedded CORNELL BOX I when absent or unloadable.
    pub scene: Option<PathBuf>,
    /// Use these settings instead of the persisted ones (tests).
    pub settings: Option<UiSettings>,
}

const STORAGE_KEY: &str = "raysplat-ui";
const MAX_MESSAGES: usize = 6;

struct Message {
    text: String,
    error: bool,
    at: Instant,
}

/// The camera the mouse controls: orbit around `target`.
#[derive(Clone, Debug)]
struct Orbit {
    target: Vec3,
    distance: f32,
    yaw: f32,
    pitch: f32,
    yfov: f32,
}

impl Orbit {
    fn from_camera(c: &Camera, scene_center: Vec3) -> Self {
        let f = c.forward.normalize();
        let distance = (scene_center - c.position).dot(f).max(1e-3);
        Self {
            target: c.position + f * distance,
            distance,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin(),
            yfov: c.yfov,
        }
    }

    fn forward(&self) -> Vec3 {
        Vec3::new(
            self.yaw.sin() * self.pitch.cos(),
            self.pitch.sin(),
            -self.yaw.cos() * self.pitch.cos(),
        )
    }

    fn camera(&self) -> Camera {
        let f = self.forward();
        Camera::look_at(
            "orbit",
            self.target - f * self.distance,
            self.target,
            self.yfov,
        )
    }
}

pub struct App {
    session: Session,
    settings: UiSettings,
    frame: Option<Frame>,
    shown: Option<DisplayImage>,
    texture: Option<TextureHandle>,
    display_dirty: bool,
    scene_name: String,
    scene_center: Vec3,
    cameras: Vec<Camera>,
    selected_camera: usize,
    orbit: Option<Orbit>,
    /// The camera is being moved (interactive frames); when it settles a final view is sent.
    moving_since: Option<Instant>,
    paused: bool,
    /// The worker path-traces the view for the reference mode.
    reference_on: bool,
    messages: Vec<Message>,
    snapshot_rx: Option<Receiver<Result<SnapshotFiles, String>>>,
    pick_rx: Option<Receiver<PickResult>>,
}

enum PickResult {
    Scene(Option<PathBuf>),
    Folder(Option<PathBuf>),
}

impl App {
    /// Create the app for eframe (or egui_kittest's eframe harness).
    pub fn new(cc: &eframe::CreationContext<'_>, options: AppOptions) -> Self {
        let settings = options
            .settings
            .clone()
            .or_else(|| {
                cc.storage
                    .and_then(|s| eframe::get_value::<UiSettings>(s, STORAGE_KEY))
            })
            .unwrap_or_default();
        let ctx = cc.egui_ctx.clone();
        Self::with_context(&ctx, options, settings)
    }

    /// Create the app on an egui context (no eframe storage).
    pub fn with_context(ctx: &egui::Context, options: AppOptions, settings: UiSettings) -> Self {
        let mut messages = Vec::new();
        let (scene, path) = match &options.scene {
            Some(p) => match Scene::load(p) {
                Ok(s) => (s, Some(p.clone())),
                Err(e) => {
                    messages.push(Message {
                        text: format!("{e} — showing the embedded CORNELL BOX I instead"),
                        error: true,
                        at: Instant::now(),
                    });
                    (Scene::default_scene(), None)
                }
            },
            None => (Scene::default_scene(), None),
        };
        let repaint = ctx.clone();
        let session = Session::spawn(
            Arc::new(scene),
            path,
            session_config(&settings),
            Some(Arc::new(move || repaint.request_repaint())),
        );
        Self {
            session,
            settings,
            frame: None,
            shown: None,
            texture: None,
            display_dirty: false,
            scene_name: String::new(),
            scene_center: Vec3::ZERO,
            cameras: Vec::new(),
            selected_camera: 0,
            orbit: None,
            moving_since: None,
            paused: false,
            reference_on: false,
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

    pub fn settings(&self) -> &UiSettings {
        &self.settings
    }

    pub fn scene_name(&self) -> &str {
        &self.scene_name
    }

    /// Messages shown in the window, newest last.
    pub fn messages(&self) -> Vec<String> {
        self.messages.iter().map(|m| m.text.clone()).collect()
    }

    /// Ask the worker to open a scene (File → Open, drag and drop, tests).
    pub fn open_scene(&mut self, path: PathBuf) {
        self.info(format!("loading {}…", path.display()));
        self.session.send(Command::LoadScene(path));
    }

    /// Save the displayed image, the linear film and the metadata into the snapshot folder.
    pub fn snapshot(&mut self) {
        let (Some(frame), Some(shown)) = (&self.frame, &self.shown) else {
            self.error("nothing to save yet: no image has arrived".into());
            return;
        };
        let meta = SnapshotMeta {
            scene_name: frame.scene_name.clone(),
            scene_path: frame.scene_path.clone(),
            camera: frame.camera.clone(),
            settings: frame.settings.clone(),
            photons_traced: frame.stats.photons_traced,
            photon_rays: frame.stats.photon_rays,
            batches: frame.stats.batches,
            elapsed_s: frame.stats.elapsed_s,
            view_mode: self.settings.view_mode,
            exposure: self.settings.exposure,
            tone_map: self.settings.tone_map,
            program_version: env!("CARGO_PKG_VERSION").to_string(),
            created: utc_now().1,
        };
        let (tx, rx) = unbounded();
        let folder = self.settings.snapshot_dir.clone();
        let shown = shown.clone();
        let film = frame.film.clone();
        std::thread::spawn(move || {
            let _ = tx.send(write_snapshot(&folder, &shown, &film, &meta));
        });
        self.snapshot_rx = Some(rx);
    }

    fn info(&mut self, text: String) {
        self.push_message(text, false);
    }

    fn error(&mut self, text: String) {
        self.push_message(text, true);
    }

    fn push_message(&mut self, text: String, error: bool) {
        self.messages.push(Message {
            text,
            error,
            at: Instant::now(),
        });
        if self.messages.len() > MAX_MESSAGES {
            self.messages.remove(0);
        }
    }

    fn send_camera(&mut self, interactive: bool) {
        if let Some(o) = &self.orbit {
            self.session.send(Command::SetCamera {
                camera: o.camera(),
                interactive,
            });
        }
    }

    fn select_camera(&mut self, i: usize) {
        if let Some(c) = self.cameras.get(i) {
            self.selected_camera = i;
            self.orbit = Some(Orbit::from_camera(c, self.scene_center));
            self.session.send(Command::SetCamera {
                camera: c.clone(),
                interactive: false,
            });
        }
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
                } => {
                    self.scene_name = name;
                    self.scene_center = center;
                    self.orbit = cameras.first().map(|c| Orbit::from_camera(c, center));
                    self.cameras = cameras;
                    self.selected_camera = 0;
                    if let Some(p) = path {
                        self.info(format!("opened {}", p.display()));
                    }
                    for w in warnings {
                        self.error(format!("warning: {w}"));
                    }
                }
                Event::LoadFailed(msg) => {
                    self.error(format!("{msg} — the current scene stays"));
                }
                Event::Error(msg) => self.error(msg),
            }
        }
        if let Some(f) = self.session.try_frame() {
            self.paused = f.stats.paused;
            self.frame = Some(f);
            self.display_dirty = true;
        }
        if let Some(rx) = &self.snapshot_rx
            && let Ok(result) = rx.try_recv()
        {
            self.snapshot_rx = None;
            match result {
                Ok(files) => self.info(format!(
                    "saved {}, {}, {}",
                    files.png.display(),
                    files.exr.display(),
                    files.json.display()
                )),
                Err(e) => self.error(format!("snapshot failed: {e}")),
            }
        }
        if let Some(rx) = &self.pick_rx
            && let Ok(result) = rx.try_recv()
        {
            self.pick_rx = None;
            match result {
                PickResult::Scene(Some(p)) => self.open_scene(p),
                PickResult::Folder(Some(p)) => self.settings.snapshot_dir = p,
                _ => {}
            }
        }
    }

    fn update_texture(&mut self, ctx: &egui::Context) {
        let want_reference = self.settings.view_mode == ViewMode::Reference;
        if want_reference != self.reference_on {
            self.reference_on = want_reference;
            self.session.send(Command::SetReference(want_reference));
        }
        if !self.display_dirty {
            return;
        }
        self.display_dirty = false;
        let Some(f) = &self.frame else { return };
        // The reference mode shows the path tracer's image once it has one.
        let film = match (&f.reference, want_reference) {
            (Some(r), true) => r,
            _ => &f.film,
        };
        let mut img = display(
            film,
            self.settings.view_mode,
            self.settings.exposure,
            self.settings.tone_map,
        );
        if self.settings.view_mode == ViewMode::CacheRecords {
            if f.cache_records.is_empty() && !self.settings.cache_on {
                self.settings.cache_on = true;
                self.session.send(Command::SetCache {
                    on: true,
                    params: self.settings.cache,
                });
            }
            // Records are in the film's pixels (the cache runs at the frame's resolution).
            img.draw_records(&f.cache_records, 7.0);
        }
        let color = egui::ColorImage::from_rgba_unmultiplied(
            [img.width as usize, img.height as usize],
            &img.rgba,
        );
        match &mut self.texture {
            Some(t) => t.set(color, TextureOptions::LINEAR),
            None => self.texture = Some(ctx.load_texture("render", color, TextureOptions::LINEAR)),
        }
        self.shown = Some(img);
    }

    fn shortcuts(&mut self, ctx: &egui::Context) {
        let (space, save, dropped) = ctx.input_mut(|i| {
            (
                i.consume_key(Modifiers::NONE, Key::Space),
                i.consume_key(Modifiers::COMMAND, Key::S),
                std::mem::take(&mut i.raw.dropped_files),
            )
        });
        if space && !ctx.egui_wants_keyboard_input() {
            self.toggle_pause();
        }
        if save {
            self.snapshot();
        }
        for f in dropped {
            let p = f.path().to_path_buf();
            if is_gltf(&p) {
                self.open_scene(p);
            } else {
                self.error(format!("{}: not a .gltf or .glb file", p.display()));
            }
        }
    }

    fn toggle_pause(&mut self) {
        self.paused = !self.paused;
        self.session.send(if self.paused {
            Command::Pause
        } else {
            Command::Resume
        });
    }

    fn pick(&mut self, folder: bool) {
        let (tx, rx) = unbounded();
        let start = self.settings.snapshot_dir.clone();
        std::thread::spawn(move || {
            let r = if folder {
                PickResult::Folder(rfd::FileDialog::new().set_directory(&start).pick_folder())
            } else {
                PickResult::Scene(
                    rfd::FileDialog::new()
                        .add_filter("glTF", &["gltf", "glb"])
                        .pick_file(),
                )
            };
            let _ = tx.send(r);
        });
        self.pick_rx = Some(rx);
    }

    fn menu(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    self.pick(false);
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
                        .selectable_label(self.settings.view_mode == m, m.label())
                        .clicked()
                    {
                        self.settings.view_mode = m;
                        self.display_dirty = true;
                        ui.close();
                    }
                }
            });
            ui.separator();
            ui.label(RichText::new(&self.scene_name).strong());
        });
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        let defaults = BandwidthParams::default();
        ui.heading("Bandwidth (eq. 8)");
        let mut b = self.settings.bandwidth;
        param_slider(
            ui,
            &mut b.smoothness_c,
            0.05..=5.0,
            "C",
            "smoothness",
            defaults.smoothness_c,
        );
        param_slider(
            ui,
            &mut b.sensitivity_s,
            0.01..=1.0,
            "S",
            "sensitivity",
            defaults.sensitivity_s,
        );
        param_slider(
            ui,
            &mut b.max_bandwidth_r,
            0.01..=1.0,
            "R",
            "bandwidth range: h within [R·h̄, h̄/R]",
            defaults.max_bandwidth_r,
        );
        if b != self.settings.bandwidth {
            self.settings.bandwidth = b;
            self.session.send(Command::SetBandwidth(b));
        }
        if let Some(f) = &self.frame
            && f.stats.folded_batches > 0
        {
            ui.colored_label(
                Color32::from_rgb(230, 170, 60),
                format!(
                    "Ray store full: {} older batches are folded into the image. Slider and camera \
                     changes re-splat the stored {} rays only; older photons are re-traced.",
                    f.stats.folded_batches, f.stats.photon_rays
                ),
            );
        }

        ui.separator();
        ui.heading("Radiance cache (§8.3)");
        let (mut on, mut cp) = (self.settings.cache_on, self.settings.cache);
        ui.checkbox(&mut on, "Resolve through the radiance cache")
            .on_hover_text(
                "Interpolate the indirect light from sparse cache records in image space. \
                 Moving ε re-runs the cache over the current radiance map (no re-trace, no \
                 re-splat).",
            );
        ui.add_enabled_ui(on, |ui| {
            param_slider(
                ui,
                &mut cp.error,
                0.05..=2.0,
                "ε",
                "cache error: records are valid up to ε × their harmonic mean distance; \
                 smaller ε, more records, more detail",
                CacheParams::default().error,
            );
            ui.horizontal(|ui| {
                ui.label("Min. records per pixel");
                ui.add(egui::DragValue::new(&mut cp.min_records).range(1..=16));
            });
        });
        if (on, cp) != (self.settings.cache_on, self.settings.cache) {
            self.settings.cache_on = on;
            self.settings.cache = cp;
            self.session.send(Command::SetCache { on, params: cp });
        }
        if let Some(f) = &self.frame
            && f.stats.cache_records > 0
        {
            ui.label(format!("{} cache records", f.stats.cache_records));
        }
        ui.heading("Image filter (§8.2)");
        let mut fp = self.settings.filter;
        ui.checkbox(&mut fp.enabled, "Filter the indirect light")
            .on_hover_text(
                "Box-filter the incident light within continuous surfaces (depth, normal and \
                 material discontinuities stop it); the box grows where fewer splats landed.",
            );
        ui.add_enabled_ui(fp.enabled, |ui| {
            param_slider(
                ui,
                &mut fp.strength,
                0.0..=4.0,
                "strength",
                "scales every pixel's filter box",
                FilterParams::default().strength,
            );
        });
        if fp != self.settings.filter {
            self.settings.filter = fp;
            self.session.send(Command::SetFilter(fp));
        }

        ui.separator();
        ui.heading("Rendering");
        let mut photons = self.settings.photons_per_batch;
        ui.horizontal(|ui| {
            ui.label("Photons per batch");
            ui.add(
                egui::DragValue::new(&mut photons)
                    .range(1_000..=2_000_000)
                    .speed(1000),
            );
        });
        if photons != self.settings.photons_per_batch {
            self.settings.photons_per_batch = photons;
            self.session.send(Command::SetPhotonsPerBatch(photons));
        }
        let mut spp = self.settings.spp;
        ui.add(egui::Slider::new(&mut spp, 1..=16).text("Samples per pixel"));
        if spp != self.settings.spp {
            self.settings.spp = spp;
            self.session.send(Command::SetSamplesPerPixel(spp));
        }
        let (mut w, mut h) = (self.settings.width, self.settings.height);
        ui.horizontal(|ui| {
            ui.label("Resolution");
            ui.add(egui::DragValue::new(&mut w).range(16..=4096));
            ui.label("×");
            ui.add(egui::DragValue::new(&mut h).range(16..=4096));
        });
        if (w, h) != (self.settings.width, self.settings.height) {
            self.settings.width = w;
            self.settings.height = h;
            self.session.send(Command::SetResolution {
                width: w,
                height: h,
            });
        }
        let mut direct = self.settings.direct;
        ui.horizontal(|ui| {
            ui.label("Direct light");
            ui.radio_value(&mut direct, DirectMode::Nee, "NEE");
            ui.radio_value(&mut direct, DirectMode::Photons, "photons");
        });
        if direct != self.settings.direct {
            self.settings.direct = direct;
            self.session.send(Command::SetDirect(direct));
        }
        let mut map = self.settings.radiance_map;
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("Glossy radiance map")
                .selected_text(directional_label(map))
                .show_ui(ui, |ui| {
                    for &m in DirectionalMode::ALL {
                        ui.selectable_value(&mut map, m, directional_label(m));
                    }
                })
                .response
                .on_hover_text(
                    "How glossy surfaces store the direction of incident light (§8.1): \
                     irradiance only (matte), 16 spherical-harmonic coefficients or 20 \
                     strata per colour channel. Switching re-splats the stored photon rays.",
                );
        });
        if map != self.settings.radiance_map {
            self.settings.radiance_map = map;
            self.session.send(Command::SetRadianceMap(map));
        }
        let mut budget_m = self.settings.ray_budget as f64 / 1e6;
        ui.horizontal(|ui| {
            ui.label("Ray store budget");
            ui.add(
                egui::DragValue::new(&mut budget_m)
                    .range(0.05..=100.0)
                    .speed(0.05)
                    .suffix(" M rays"),
            );
        });
        let budget = (budget_m * 1e6).round() as usize;
        if budget != self.settings.ray_budget {
            self.settings.ray_budget = budget;
            self.session.send(Command::SetRayBudget(budget));
        }
        ui.horizontal(|ui| {
            let label = if self.paused {
                "Resume (Space)"
            } else {
                "Pause (Space)"
            };
            if ui.button(label).clicked() {
                self.toggle_pause();
            }
            if ui
                .button("Restart")
                .on_hover_text("Drop all photons and trace again")
                .clicked()
            {
                self.session.send(Command::Restart);
            }
        });

        ui.separator();
        ui.heading("Camera");
        ui.label("Drag: orbit · Shift-drag or middle: pan · Wheel: zoom");
        ui.horizontal(|ui| {
            let names: Vec<String> = self.cameras.iter().map(|c| c.name.clone()).collect();
            let mut sel = self.selected_camera;
            egui::ComboBox::from_id_salt("camera")
                .selected_text(names.get(sel).cloned().unwrap_or_default())
                .show_ui(ui, |ui| {
                    for (i, n) in names.iter().enumerate() {
                        ui.selectable_value(&mut sel, i, n);
                    }
                });
            if sel != self.selected_camera {
                self.select_camera(sel);
            }
            if ui.button("Reset").clicked() {
                self.select_camera(self.selected_camera);
            }
        });

        ui.separator();
        ui.heading("Display");
        egui::ComboBox::from_label("View")
            .selected_text(self.settings.view_mode.label())
            .show_ui(ui, |ui| {
                for m in ViewMode::ALL {
                    if ui
                        .selectable_value(&mut self.settings.view_mode, m, m.label())
                        .changed()
                    {
                        self.display_dirty = true;
                    }
                }
            });
        if ui
            .add(
                egui::Slider::new(&mut self.settings.exposure, -8.0..=8.0).text("Exposure (stops)"),
            )
            .changed()
        {
            self.display_dirty = true;
        }
        egui::ComboBox::from_label("Tone mapping")
            .selected_text(self.settings.tone_map.label())
            .show_ui(ui, |ui| {
                for t in ToneMap::ALL {
                    if ui
                        .selectable_value(&mut self.settings.tone_map, t, t.label())
                        .changed()
                    {
                        self.display_dirty = true;
                    }
                }
            });

        ui.separator();
        ui.heading("Snapshots");
        ui.horizontal(|ui| {
            let mut dir = self.settings.snapshot_dir.display().to_string();
            if ui
                .add(egui::TextEdit::singleline(&mut dir).desired_width(170.0))
                .on_hover_text("Snapshot folder")
                .changed()
            {
                self.settings.snapshot_dir = PathBuf::from(dir);
            }
            if ui.button("Choose…").clicked() {
                self.pick(true);
            }
        });
        if ui.button("Save snapshot").clicked() {
            self.snapshot();
        }
    }

    fn stats(&self, ui: &mut egui::Ui) {
        let Some(f) = &self.frame else {
            ui.label("waiting for the first image…");
            return;
        };
        let s = &f.stats;
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("photons traced {}", s.photons_traced));
            ui.separator();
            ui.label(format!(
                "photon rays {} ({:.1} MB)",
                s.photon_rays,
                s.photon_ray_bytes as f64 / 1e6
            ));
            ui.separator();
            ui.label(format!(
                "batches {} ({} stored)",
                s.batches, s.stored_batches
            ));
            ui.separator();
            ui.label(format!("{:.0} photons/s", s.photons_per_second));
            ui.separator();
            ui.label(format!("splat {:.0} ms/batch", s.last_splat_ms));
            ui.separator();
            ui.label(format!(
                "at h_min {:.1}% / h_max {:.1}%",
                100.0 * s.indirect_at_h_min,
                100.0 * s.indirect_at_h_max
            ))
            .on_hover_text("indirect photon rays whose bandwidth sits at eq. 8's bounds");
            ui.separator();
            ui.label(format!(
                "eye samples {} ({} splat targets, {:.1} MB with tree and accumulators)",
                s.eye_samples,
                s.splat_targets,
                s.splat_bytes as f64 / 1e6
            ));
            if s.glossy_targets > 0 {
                ui.separator();
                ui.label(format!(
                    "glossy targets {} ({:.1} MB directional, {:.0} B each)",
                    s.glossy_targets,
                    s.directional_bytes as f64 / 1e6,
                    s.directional_bytes as f64 / s.glossy_targets as f64
                ));
            }
            ui.separator();
            ui.label(format!("{}×{}", f.film.width, f.film.height));
            ui.separator();
            ui.label(format!("elapsed {:.1} s", s.elapsed_s));
            if f.film.invalid_contributions > 0 {
                ui.separator();
                ui.label(
                    RichText::new(format!(
                        "{} NaN/Inf contributions dropped",
                        f.film.invalid_contributions
                    ))
                    .color(egui::Color32::from_rgb(230, 160, 60)),
                )
                .on_hover_text(
                    "Photon rays, light samples or pixels whose value was not finite were \
                     left out of the image (the scene may hold extreme values).",
                );
            }
            if s.paused {
                ui.separator();
                ui.label(RichText::new("paused").strong());
            }
            if s.resplat_pending {
                ui.separator();
                ui.label("re-splatting…");
            }
            if s.reference_spp > 0 {
                ui.separator();
                ui.label(format!("reference {} paths/pixel", s.reference_spp));
            }
        });
    }

    fn message_list(&self, ui: &mut egui::Ui) {
        for m in self.messages.iter().rev() {
            let age = m.at.elapsed().as_secs();
            let text = format!("{} ({age} s ago)", m.text);
            if m.error {
                ui.colored_label(Color32::from_rgb(240, 110, 100), text);
            } else {
                ui.label(text);
            }
        }
    }

    fn viewport(&mut self, ui: &mut egui::Ui) {
        let Some(tex) = &self.texture else {
            ui.centered_and_justified(|ui| ui.spinner());
            return;
        };
        let legend_h = if self.shown.as_ref().is_some_and(|s| s.legend.is_some()) {
            28.0
        } else {
            0.0
        };
        let avail = ui.available_size() - Vec2::new(0.0, legend_h);
        let size = tex.size_vec2();
        let scale = (avail.x / size.x).min(avail.y / size.y).max(0.05);
        let response =
            ui.add(egui::Image::new((tex.id(), size * scale)).sense(egui::Sense::click_and_drag()));
        self.camera_input(ui, &response);
        if let (Some(pos), Some(f)) = (response.hover_pos(), &self.frame) {
            let r = response.rect;
            let px = ((pos.x - r.min.x) / r.width() * f.film.width as f32) as u32;
            let py = ((pos.y - r.min.y) / r.height() * f.film.height as f32) as u32;
            if px < f.film.width && py < f.film.height {
                let i = (py * f.film.width + px) as usize;
                let film = &f.film;
                response.on_hover_ui_at_pointer(|ui| {
                    ui.label(format!("pixel ({px}, {py})"));
                    ui.label(format!("radiance {}", fmt3(film.rgb[i])));
                    ui.label(format!("direct {}", fmt3(film.direct[i])));
                    ui.label(format!("indirect {}", fmt3(film.indirect[i])));
                    ui.label(format!("bandwidth {:.4} m", film.bandwidth[i]));
                    ui.label(format!("kernel weight {:.3}", film.kernel_weight[i]));
                    ui.label(format!("splats per batch {:.0}", film.splats[i]));
                    ui.label(format!(
                        "harmonic mean distance {:.3} m",
                        film.harmonic_distance[i]
                    ));
                });
            }
        }
        if let Some(legend) = self.shown.as_ref().and_then(|s| s.legend.clone()) {
            ui.horizontal(|ui| {
                ui.label(format!("{:.4} {}", legend.min, legend.unit));
                let (rect, _) =
                    ui.allocate_exact_size(Vec2::new(200.0, 14.0), egui::Sense::hover());
                let n = 50;
                for k in 0..n {
                    let c = false_colour(k as f32 / (n - 1) as f32);
                    let x0 = rect.min.x + rect.width() * k as f32 / n as f32;
                    let x1 = rect.min.x + rect.width() * (k + 1) as f32 / n as f32;
                    ui.painter().rect_filled(
                        egui::Rect::from_min_max(
                            egui::pos2(x0, rect.min.y),
                            egui::pos2(x1, rect.max.y),
                        ),
                        0.0,
                        Color32::from_rgb(c[0], c[1], c[2]),
                    );
                }
                ui.label(format!("{:.4} {}", legend.max, legend.unit));
                ui.label(format!(
                    "({}, red = smallest)",
                    self.settings.view_mode.label()
                ));
            });
        }
    }

    fn camera_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
        let Some(orbit) = self.orbit.as_mut() else {
            return;
        };
        let mut moved = false;
        if response.dragged() {
            let d = response.drag_delta();
            let pan =
                ui.input(|i| i.modifiers.shift) || response.dragged_by(egui::PointerButton::Middle);
            if pan {
                let f = orbit.forward();
                let right = f.cross(Vec3::Y).normalize_or(Vec3::X);
                let up = right.cross(f);
                let k = orbit.distance * 2.0 * (0.5 * orbit.yfov).tan()
                    / response.rect.height().max(1.0);
                orbit.target += (-d.x * right + d.y * up) * k;
            } else {
                orbit.yaw += d.x * 0.008;
                orbit.pitch = (orbit.pitch - d.y * 0.008).clamp(-1.5, 1.5);
            }
            moved = d != Vec2::ZERO;
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                orbit.distance = (orbit.distance * (-scroll * 0.002).exp()).max(1e-3);
                moved = true;
            }
        }
        if moved {
            self.moving_since = Some(Instant::now());
            self.send_camera(true);
        } else if let Some(t) = self.moving_since
            && !response.dragged()
            && t.elapsed() > Duration::from_millis(150)
        {
            // The camera came to rest: render the full-resolution view.
            self.moving_since = None;
            self.send_camera(false);
        }
        if self.moving_since.is_some() {
            ui.ctx().request_repaint_after(Duration::from_millis(50));
        }
    }
}

impl eframe::App for App {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.poll();
        self.shortcuts(&ctx);
        self.update_texture(&ctx);
        egui::Panel::top("menu").show(ui, |ui| self.menu(ui));
        egui::Panel::bottom("status").show(ui, |ui| {
            self.stats(ui);
            self.message_list(ui);
        });
        egui::Panel::left("controls")
            .resizable(true)
            .default_size(300.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
            });
        egui::CentralPanel::default().show(ui, |ui| self.viewport(ui));
        if self.snapshot_rx.is_some() || self.pick_rx.is_some() {
            ctx.request_repaint_after(Duration::from_millis(50));
        }
    }

    fn save(&mut self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, STORAGE_KEY, &self.settings);
    }
}

fn session_config(s: &UiSettings) -> SessionConfig {
    let mut c = SessionConfig::default();
    c.settings.bandwidth = s.bandwidth;
    c.settings.photons = s.photons_per_batch;
    c.settings.spp = s.spp;
    c.settings.width = s.width;
    c.settings.height = s.height;
    c.settings.direct = s.direct;
    c.settings.radiance_map = s.radiance_map;
    c.settings.cache_on = s.cache_on;
    c.settings.cache = s.cache;
    c.settings.filter = s.filter;
    c.max_stored_rays = s.ray_budget;
    c
}

/// A labelled slider with numeric entry and a reset button.
fn param_slider(
    ui: &mut egui::Ui,
    value: &mut f32,
    range: std::ops::RangeInclusive<f32>,
    name: &str,
    hint: &str,
    default: f32,
) {
    ui.horizontal(|ui| {
        ui.add(egui::Slider::new(value, range).text(name))
            .on_hover_text(hint);
        if ui
            .small_button("reset")
            .on_hover_text(format!("reset {name} to {default}"))
            .clicked()
        {
            *value = default;
        }
    });
}

/// The window's name for a directional mode (§8.1).
fn directional_label(m: DirectionalMode) -> &'static str {
    match m {
        DirectionalMode::Diffuse => "diffuse (irradiance only)",
        DirectionalMode::Sh => "spherical harmonics (16 per channel)",
        DirectionalMode::Histogram => "histogram (20 strata)",
    }
}

fn fmt3(c: Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", c.x, c.y, c.z)
}

fn is_gltf(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}
