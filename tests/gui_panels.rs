//! Each panel of the window on its own, without a worker thread: draw it in an egui_kittest
//! harness over a settings value, move one widget through its accessibility node, and check
//! the exact worker commands it emitted and the settings it changed — and that a panel whose
//! widgets did not change emits nothing.

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use raysplat::app::UiSettings;
use raysplat::app::bandwidth::BandwidthPanel;
use raysplat::app::cache_filter::CacheFilterPanel;
use raysplat::app::camera::CameraPanel;
use raysplat::app::display::DisplayPanel;
use raysplat::app::environment::{EnvironmentPanel, EnvironmentRequest};
use raysplat::app::error_panel::ErrorPanel;
use raysplat::app::rendering::RenderingPanel;
use raysplat::app::snapshots::{SnapshotPanel, SnapshotRequest};
use raysplat::app::stats::{Messages, StatsPanel};
use raysplat::app::widgets::Commands;
use raysplat::film::Film;
use raysplat::film::display::{ToneMap, ViewMode};
use raysplat::methods::MethodStats;
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::scene::{Camera, EnvironmentKind, EnvironmentSettings};
use raysplat::session::{Command, Frame, SessionStats};
use raysplat::settings::{DirectMode, RenderSettings, limits};
use std::path::PathBuf;

/// A panel, the settings it edits, what it emitted and what it returned.
struct State<P, R = ()> {
    panel: P,
    settings: UiSettings,
    out: Commands,
    returned: Vec<R>,
}

/// The panels' settings: the window's defaults with C set by hand (Auto off, the estimate
/// off), so that the C slider and the estimate's box are live; the tests that need Auto turn
/// it on (the window's default, `gui::the_auto_box_lets_the_render_choose_c_and_the_slider_shows_it`).
fn settings() -> UiSettings {
    let mut s = UiSettings {
        snapshot_dir: PathBuf::from("/tmp/snapshots"),
        ..UiSettings::default()
    };
    s.render.auto_c = false;
    s.render.estimate_error = false;
    s
}

/// A harness drawing `draw` over a fresh [`State`]; it runs a few frames and checks that
/// drawing alone emitted nothing.
fn harness<P: 'static, R: 'static>(
    panel: P,
    settings: UiSettings,
    draw: impl FnMut(&mut egui::Ui, &mut State<P, R>) + 'static,
) -> Harness<'static, State<P, R>> {
    let state = State {
        panel,
        settings: settings.clone(),
        out: Commands::new(),
        returned: Vec::new(),
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(500.0, 700.0))
        .build_ui_state(draw, state);
    h.run_steps(3);
    assert_commands(&mut h.state_mut().out, &[]);
    assert_eq!(
        h.state().settings,
        settings,
        "drawing alone changed settings"
    );
    h
}

/// The emitted commands are exactly `expected` (compared by their debug form: `Command` has no
/// `PartialEq`); clears them.
#[track_caller]
fn assert_commands(out: &mut Commands, expected: &[Command]) {
    assert_eq!(format!("{:?}", out.take()), format!("{expected:?}"));
}

/// Click a combo box, then its entry `entry`.
fn choose<S>(h: &mut Harness<'_, S>, combo: &str, entry: &str) {
    h.get_by_role_and_label(Role::ComboBox, combo).click();
    h.run_steps(3);
    h.get_by_label(entry).click();
    h.run_steps(3);
}

fn bandwidth_harness(stats: Option<SessionStats>) -> Harness<'static, State<BandwidthPanel>> {
    harness(BandwidthPanel, settings(), move |ui, s| {
        s.panel.ui(ui, &mut s.settings, stats.as_ref(), &mut s.out)
    })
}

#[test]
fn bandwidth_panel_emits_set_bandwidth() {
    let mut h = bandwidth_harness(None);
    for (label, value) in [("C", 0.3), ("S", 0.55), ("R", 0.35), ("K", 64.0)] {
        h.get_by_role_and_label(Role::Slider, label)
            .set_value_accesskit(value);
        h.run_steps(2);
    }
    let mut expected = settings();
    let b = &mut expected.render.bandwidth;
    let mut commands = Vec::new();
    b.smoothness_c = 0.3;
    commands.push(Command::SetBandwidth(*b));
    b.sensitivity_s = 0.55;
    commands.push(Command::SetBandwidth(*b));
    b.max_bandwidth_r = 0.35;
    commands.push(Command::SetBandwidth(*b));
    // The floor from the photons stored (docs/deviations.md §63).
    b.floor_neighbours = 64.0;
    commands.push(Command::SetBandwidth(*b));
    assert_commands(&mut h.state_mut().out, &commands);
    assert_eq!(h.state().settings, expected);
    // Beyond the limits table's range the slider stops at its end.
    h.get_by_role_and_label(Role::Slider, "C")
        .set_value_accesskit(100.0);
    h.run_steps(2);
    expected.render.bandwidth.smoothness_c = limits::SMOOTHNESS_C.max;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetBandwidth(expected.render.bandwidth)],
    );
    assert!(h.query_by_label_contains("Ray store full").is_none());
}

/// The Auto box beside C: on, it asks the worker to choose C (the estimate comes on with it)
/// and the C slider is disabled but shows the C it is given (the window writes the chosen one
/// from each frame); off, it asks for nothing more: the worker keeps the C it chose.
#[test]
fn the_auto_box_lets_the_render_choose_c() {
    let mut h = bandwidth_harness(None);
    assert!(
        !h.get_by_role_and_label(Role::Slider, "C")
            .accesskit_node()
            .is_disabled()
    );
    h.get_by_role_and_label(Role::CheckBox, "Auto").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetAutoC(true)]);
    let r = &h.state().settings.render;
    assert!(r.auto_c && r.estimate_error);
    assert!(
        h.get_by_role_and_label(Role::Slider, "C")
            .accesskit_node()
            .is_disabled()
    );
    // The render chose 0.7: the slider shows it.
    h.state_mut().settings.render.bandwidth.smoothness_c = 0.7;
    h.run_steps(2);
    let shown = h
        .get_by_role_and_label(Role::Slider, "C")
        .accesskit_node()
        .numeric_value();
    assert!(shown.is_some_and(|v| (v - 0.7).abs() < 1e-6), "{shown:?}");
    assert_commands(&mut h.state_mut().out, &[]);
    h.get_by_role_and_label(Role::CheckBox, "Auto").click();
    h.run_steps(2);
    assert_eq!(h.state().settings.render.bandwidth.smoothness_c, 0.7);
    assert_commands(&mut h.state_mut().out, &[Command::SetAutoC(false)]);
    assert!(!h.state().settings.render.auto_c);
    assert!(
        !h.get_by_role_and_label(Role::Slider, "C")
            .accesskit_node()
            .is_disabled()
    );
}

fn error_harness(frame: Option<Frame>) -> Harness<'static, State<ErrorPanel>> {
    harness(ErrorPanel, settings(), move |ui, s| {
        s.panel.ui(ui, &mut s.settings, frame.as_ref(), &mut s.out)
    })
}

/// The error panel's boxes: the estimate, the pause (which needs the estimate: on with it) and
/// the split view, whose divider is the window's alone (no command).
#[test]
fn error_panel_turns_the_estimate_the_pause_and_the_split_on() {
    let mut h = error_harness(None);
    h.get_by_label("refines until paused");
    h.get_by_label("Pause below").click();
    h.run_steps(2);
    assert_commands(
        &mut h.state_mut().out,
        &[
            Command::SetErrorEstimate(true),
            Command::SetPauseBelow(Some(0.002)),
        ],
    );
    h.get_by_label("pauses once the estimate is below 0.002");
    h.get_by_label("Estimate the error").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetErrorEstimate(false)]);
    h.get_by_label("Pause below").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetPauseBelow(None)]);
    assert!(h.query_by_label("Divider").is_none());
    h.get_by_label("Split view with the reference").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetSplit(true)]);
    h.get_by_role_and_label(Role::Slider, "Divider")
        .set_value_accesskit(0.3);
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[]);
    let s = &h.state().settings;
    assert!(s.split && (s.split_at - 0.3).abs() < 1e-6 && !s.render.estimate_error);
}

/// With automatic C the estimate cannot be turned off: its box is disabled.
#[test]
fn error_panel_keeps_the_estimate_while_c_is_automatic() {
    let mut s = settings();
    s.render.auto_c = true;
    s.render.estimate_error = true;
    let h = harness(ErrorPanel, s, move |ui, s: &mut State<ErrorPanel>| {
        s.panel.ui(ui, &mut s.settings, None, &mut s.out)
    });
    assert!(
        h.get_by_label("Estimate the error")
            .accesskit_node()
            .is_disabled()
    );
}

/// The panel shows the frame's estimate, the threshold it paused at, and in the split view the
/// relMSE against the reference with the reference's paths.
#[test]
fn error_panel_shows_the_estimate_and_the_error_against_the_reference() {
    let mut film = Film::new(8, 8);
    film.estimate = Some(raysplat::film::estimate::ErrorEstimate {
        rel_mse: 0.00123,
        bias2: 0.0002,
        variance: 0.00103,
        passes: 7,
        ..Default::default()
    });
    let frame = Frame {
        film,
        seq: 3,
        generation: 1,
        scene_name: "box".into(),
        scene_path: None,
        camera: Camera::look_at("c", glam::Vec3::Z, glam::Vec3::ZERO, 0.8),
        settings: RenderSettings::default(),
        interactive: false,
        cache_records: Vec::new(),
        stats: SessionStats {
            paused: true,
            paused_below: Some(0.002),
            reference_spp: 16,
            reference_rel_mse: Some(0.0456),
            reference_noise: Some(0.0400),
            ..SessionStats::default()
        },
        reference: None,
    };
    let mut s = settings();
    s.split = true;
    let h = harness(ErrorPanel, s, move |ui, s: &mut State<ErrorPanel>| {
        s.panel.ui(ui, &mut s.settings, Some(&frame), &mut s.out)
    });
    h.get_by_label("estimated relMSE 0.00123 (bias² 0.00020, variance 0.00103) from 7 eye passes");
    h.get_by_label("paused: estimate below 0.002");
    h.get_by_label("relMSE against the reference: 0.04560 (16 paths per pixel)");
    h.get_by_label("of which the reference's own noise ≈ 0.04000: the image's error ≈ 0.00560");
}

#[test]
fn bandwidth_panel_warns_when_the_ray_store_is_full() {
    let stats = SessionStats {
        method: MethodStats {
            folded_batches: 3,
            photon_rays: 1234,
            ..MethodStats::default()
        },
        ..SessionStats::default()
    };
    let mut h = bandwidth_harness(Some(stats));
    h.get_by_label_contains("Ray store full: 3 older batches");
    assert_commands(&mut h.state_mut().out, &[]);
}

fn cache_filter_harness() -> Harness<'static, State<CacheFilterPanel>> {
    let stats = SessionStats {
        method: MethodStats {
            cache_records: Some(77),
            ..MethodStats::default()
        },
        ..SessionStats::default()
    };
    harness(CacheFilterPanel, settings(), move |ui, s| {
        s.panel.ui(ui, &mut s.settings, Some(&stats), &mut s.out)
    })
}

#[test]
fn cache_panel_emits_set_cache() {
    let mut h = cache_filter_harness();
    h.get_by_label("77 cache records");
    h.get_by_label("Resolve through the radiance cache").click();
    h.run_steps(2);
    let mut expected = settings();
    expected.render.cache_on = true;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetCache {
            on: true,
            params: expected.render.cache,
        }],
    );
    h.get_by_role_and_label(Role::Slider, "ε")
        .set_value_accesskit(0.2);
    h.run_steps(2);
    expected.render.cache.error = 0.2;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetCache {
            on: true,
            params: expected.render.cache,
        }],
    );
    h.get_by_role_and_label(Role::SpinButton, "Min. records per pixel")
        .set_value_accesskit(8.0);
    h.run_steps(2);
    expected.render.cache.min_records = 8;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetCache {
            on: true,
            params: expected.render.cache,
        }],
    );
    assert_eq!(h.state().settings, expected);
}

#[test]
fn filter_panel_emits_set_filter() {
    let mut h = cache_filter_harness();
    h.get_by_label("Filter the indirect light").click();
    h.run_steps(2);
    let mut expected = settings();
    expected.render.filter.enabled = true;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetFilter(expected.render.filter)],
    );
    h.get_by_role_and_label(Role::Slider, "strength")
        .set_value_accesskit(2.5);
    h.run_steps(2);
    expected.render.filter.strength = 2.5;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetFilter(expected.render.filter)],
    );
    assert_eq!(h.state().settings, expected);
}

type RenderingHarness = Harness<'static, State<(RenderingPanel, bool)>>;

/// Set the widget `label` of `role` to `value` and check that it emitted `command` alone.
#[track_caller]
fn step(h: &mut RenderingHarness, role: Role, label: &str, value: f64, command: Command) {
    h.get_by_role_and_label(role, label)
        .set_value_accesskit(value);
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[command]);
}

/// The rendering panel and the `paused` flag it flips.
fn rendering_harness() -> RenderingHarness {
    harness((RenderingPanel, false), settings(), |ui, s| {
        let (panel, paused) = &mut s.panel;
        panel.ui(ui, &mut s.settings, paused, &mut s.out)
    })
}

#[test]
fn rendering_panel_emits_one_command_per_widget() {
    let mut h = rendering_harness();
    let mut expected = settings();
    step(
        &mut h,
        Role::SpinButton,
        "Photons per batch",
        50_000.0,
        Command::SetPhotonsPerBatch(50_000),
    );
    step(
        &mut h,
        Role::Slider,
        "Samples per pixel",
        4.0,
        Command::SetSamplesPerPixel(4),
    );
    let height = expected.render.height;
    step(
        &mut h,
        Role::SpinButton,
        "Width",
        128.0,
        Command::SetResolution { width: 128, height },
    );
    step(
        &mut h,
        Role::SpinButton,
        "Ray store budget",
        1_500_000.0,
        Command::SetRayBudget(1_500_000),
    );
    // The limits table bounds every widget.
    step(
        &mut h,
        Role::Slider,
        "Samples per pixel",
        1000.0,
        Command::SetSamplesPerPixel(limits::SPP.max),
    );
    step(
        &mut h,
        Role::SpinButton,
        "Height",
        1.0,
        Command::SetResolution {
            width: 128,
            height: limits::RESOLUTION.min,
        },
    );
    step(
        &mut h,
        Role::Slider,
        "Light samples",
        8.0,
        Command::SetNeeSamples(8),
    );
    // The window's slider stops at its own end (an eye pass at 256 takes seconds).
    step(
        &mut h,
        Role::Slider,
        "Light samples",
        1000.0,
        Command::SetNeeSamples(limits::WINDOW_NEE_SAMPLES.max),
    );
    expected.render.nee_samples = limits::WINDOW_NEE_SAMPLES.max;
    expected.render.photons = 50_000;
    expected.render.spp = limits::SPP.max;
    expected.render.width = 128;
    expected.render.height = limits::RESOLUTION.min;
    expected.ray_budget = 1_500_000;
    assert_eq!(h.state().settings, expected);

    h.get_by_label("photons").click();
    h.run_steps(2);
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetDirect(DirectMode::Photons)],
    );
    choose(&mut h, "Glossy radiance map", "histogram (20 strata)");
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetRadianceMap(DirectionalMode::Histogram)],
    );
    h.get_by_label("Visibility in the splat footprint").click();
    h.run_steps(2);
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetSplatVisibility(false)],
    );
    h.get_by_label("Photons where the camera looks").click();
    h.run_steps(2);
    // On by default: the click turns it off.
    assert_commands(&mut h.state_mut().out, &[Command::SetGuidedEmission(false)]);
    expected.render.direct = DirectMode::Photons;
    expected.render.radiance_map = DirectionalMode::Histogram;
    expected.render.splat_visibility = false;
    expected.render.guided_emission = false;
    assert_eq!(h.state().settings, expected);
}

#[test]
fn rendering_panel_pauses_restarts_and_path_traces() {
    let mut h = rendering_harness();
    h.get_by_label("Pause (Space)").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::Pause]);
    assert!(h.state().panel.1, "the pause button pauses");
    h.get_by_label("Resume (Space)").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::Resume]);
    assert!(!h.state().panel.1);
    h.get_by_label("Restart").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::Restart]);
    h.get_by_label("Path-trace this view").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetReference(true)]);
    assert_eq!(h.state().settings.view_mode, ViewMode::Reference);
    h.get_by_label("Path-trace this view").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[Command::SetReference(false)]);
    assert_eq!(h.state().settings, settings());
}

#[test]
fn camera_panel_emits_set_camera() {
    let cameras = vec![
        Camera::look_at("front", glam::Vec3::Z * 3.0, glam::Vec3::ZERO, 0.8),
        Camera::look_at("side", glam::Vec3::X * 3.0, glam::Vec3::ZERO, 0.6),
    ];
    let mut h = harness(
        CameraPanel::new(cameras.clone()),
        settings(),
        |ui, s: &mut State<CameraPanel, Camera>| {
            if let Some(c) = s.panel.ui(ui, &mut s.out) {
                s.returned.push(c);
            }
        },
    );
    assert!(h.state().returned.is_empty());
    choose(&mut h, "Camera", "side");
    let chosen = Command::SetCamera {
        camera: cameras[1].clone(),
        interactive: false,
    };
    assert_commands(&mut h.state_mut().out, std::slice::from_ref(&chosen));
    assert_eq!(h.state().panel.selected, 1);
    assert_eq!(h.state().returned, std::slice::from_ref(&cameras[1]));
    h.get_by_label("Reset").click();
    h.run_steps(2);
    assert_commands(&mut h.state_mut().out, &[chosen]);
    assert_eq!(h.state().returned.len(), 2);
}

fn display_harness() -> Harness<'static, State<DisplayPanel>> {
    harness(DisplayPanel, settings(), |ui, s| {
        s.panel.ui(ui, &mut s.settings, &mut s.out)
    })
}

#[test]
fn display_panel_changes_the_look_without_commands() {
    let mut h = display_harness();
    choose(&mut h, "View", "Bandwidth (false colour)");
    h.get_by_role_and_label(Role::Slider, "Exposure (stops)")
        .set_value_accesskit(2.0);
    h.run_steps(2);
    choose(&mut h, "Tone mapping", "Reinhard");
    assert_commands(&mut h.state_mut().out, &[]);
    let expected = UiSettings {
        view_mode: ViewMode::Bandwidth,
        exposure: 2.0,
        tone_map: ToneMap::Reinhard,
        ..settings()
    };
    assert_eq!(h.state().settings, expected);
}

#[test]
fn display_panel_view_modes_that_need_the_worker() {
    let mut h = display_harness();
    choose(&mut h, "View", "Reference (path traced)");
    assert_commands(&mut h.state_mut().out, &[Command::SetReference(true)]);
    // Leaving the reference for the records turns the path tracer off and the cache on.
    choose(&mut h, "View", "Cache records (radii)");
    let params = settings().render.cache;
    assert_commands(
        &mut h.state_mut().out,
        &[
            Command::SetReference(false),
            Command::SetCache { on: true, params },
        ],
    );
    let s = &h.state().settings;
    assert_eq!(s.view_mode, ViewMode::CacheRecords);
    assert!(s.render.cache_on);
}

#[test]
fn snapshot_panel_edits_the_folder_and_asks_to_save() {
    let mut h = harness(
        SnapshotPanel,
        settings(),
        |ui, s: &mut State<SnapshotPanel, SnapshotRequest>| {
            if let Some(r) = s.panel.ui(ui, &mut s.settings) {
                s.returned.push(r);
            }
        },
    );
    assert!(h.state().returned.is_empty());
    h.get_by_label("Save snapshot").click();
    h.run_steps(2);
    h.get_by_label("Choose…").click();
    h.run_steps(2);
    assert_eq!(
        h.state().returned,
        [SnapshotRequest::Save, SnapshotRequest::ChooseFolder]
    );
    let field = h.get_by_role_and_label(Role::TextInput, "Snapshot folder");
    field.focus();
    h.run_steps(1);
    h.get_by_role_and_label(Role::TextInput, "Snapshot folder")
        .type_text("/more");
    h.run_steps(2);
    assert_eq!(
        h.state().settings.snapshot_dir,
        PathBuf::from("/tmp/snapshots/more")
    );
    assert_commands(&mut h.state_mut().out, &[]);
}

#[test]
fn stats_panel_shows_the_frame() {
    let mut h = harness(
        (StatsPanel::default(), None::<Frame>),
        settings(),
        |ui, s: &mut State<(StatsPanel, Option<Frame>)>| {
            let (panel, frame) = &mut s.panel;
            panel.ui(ui, frame.as_ref());
        },
    );
    h.get_by_label("waiting for the first image…");
    let film = Film::new(32, 16);
    h.state_mut().panel.1 = Some(Frame {
        film,
        seq: 3,
        generation: 1,
        scene_name: "box".into(),
        scene_path: None,
        camera: Camera::look_at("c", glam::Vec3::Z, glam::Vec3::ZERO, 0.8),
        settings: RenderSettings::default(),
        interactive: false,
        cache_records: Vec::new(),
        stats: SessionStats {
            method: MethodStats {
                photons_traced: 1234,
                ..MethodStats::default()
            },
            paused: true,
            indirect_at_h_min: 0.011,
            indirect_at_h_max: 0.002,
            indirect_at_floor: 0.123,
            ..SessionStats::default()
        },
        reference: None,
    });
    h.run_steps(2);
    h.get_by_label("photons traced 1234");
    h.get_by_label("32×16");
    h.get_by_label("paused");
    // The rays at eq. 8's bounds and at the floor from the photons stored (deviations §63).
    h.get_by_label("at h_min 1.1% / h_max 0.2% / floor 12.3%");
    assert!(h.query_by_label("waiting for the first image…").is_none());
}

#[test]
fn messages_keep_the_newest_and_show_them_first() {
    let mut m = Messages::default();
    for k in 0..8 {
        if k % 2 == 0 {
            m.info(format!("note {k}"));
        } else {
            m.error(format!("error {k}"));
        }
    }
    let texts = m.texts();
    assert_eq!(texts.len(), Messages::MAX);
    assert_eq!(texts.first().unwrap(), "note 2");
    assert_eq!(texts.last().unwrap(), "error 7");
    let h = Harness::new_ui(move |ui| m.ui(ui));
    h.get_by_label_contains("error 7 (");
    assert!(h.query_by_label_contains("note 0").is_none());
}

#[derive(Default)]
struct MemStorage(std::collections::HashMap<String, String>);

impl eframe::Storage for MemStorage {
    fn get_string(&self, key: &str) -> Option<String> {
        self.0.get(key).cloned()
    }

    fn set_string(&mut self, key: &str, value: String) {
        self.0.insert(key.to_string(), value);
    }

    fn remove_string(&mut self, key: &str) {
        self.0.remove(key);
    }

    fn flush(&mut self) {}
}

/// The settings as the window persisted them before they embedded `RenderSettings`.
#[derive(serde::Serialize)]
struct OldUiSettings {
    photons_per_batch: u64,
    spp: u32,
    width: u32,
    height: u32,
    cache_on: bool,
    exposure: f32,
    ray_budget: usize,
    snapshot_dir: PathBuf,
}

#[test]
fn persisted_settings_load_or_fall_back_to_the_defaults() {
    let mut storage = MemStorage::default();
    assert_eq!(UiSettings::from_storage(&storage), None);
    // A round trip keeps everything.
    let mut s = settings();
    s.render.width = 64;
    s.render.bandwidth.smoothness_c = 0.7;
    s.view_mode = ViewMode::Bandwidth;
    s.save(&mut storage);
    assert_eq!(UiSettings::from_storage(&storage), Some(s));
    // The old flat format: the render settings it held are dropped for the defaults, the
    // display fields it shares are kept.
    let old = OldUiSettings {
        photons_per_batch: 4000,
        spp: 2,
        width: 64,
        height: 64,
        cache_on: true,
        exposure: 1.5,
        ray_budget: 1_000_000,
        snapshot_dir: PathBuf::from("/tmp/old"),
    };
    eframe::set_value(&mut storage, UiSettings::STORAGE_KEY, &old);
    let loaded = UiSettings::from_storage(&storage).expect("the old format loads");
    assert_eq!(loaded.render, UiSettings::default().render);
    assert_eq!(
        (loaded.exposure, loaded.ray_budget, loaded.snapshot_dir),
        (1.5, 1_000_000, PathBuf::from("/tmp/old"))
    );
    // Saved under the first defaults (no `defaults` field): the guide and the light samples
    // take today's defaults, the rest stays as saved.
    let mut first = UiSettings::default();
    first.render.guided_emission = false;
    first.render.nee_samples = 1;
    first.render.photons = 7_000;
    first.defaults = 0;
    first.save(&mut storage);
    let loaded = UiSettings::from_storage(&storage).expect("loads");
    let d = UiSettings::default();
    assert_eq!(
        (loaded.render.guided_emission, loaded.render.nee_samples),
        (d.render.guided_emission, d.render.nee_samples)
    );
    assert_eq!(
        (loaded.render.photons, loaded.defaults),
        (7_000, UiSettings::DEFAULTS)
    );
    // Saved under the second defaults (C by hand): the render chooses C now, with the
    // estimate; a C set by hand after today's defaults stays by hand (the round trip above).
    let mut second = settings();
    second.render.bandwidth.smoothness_c = 0.7;
    second.defaults = 1;
    second.save(&mut storage);
    let loaded = UiSettings::from_storage(&storage).expect("loads");
    assert!(loaded.render.auto_c && loaded.render.estimate_error);
    assert_eq!(loaded.render.bandwidth.smoothness_c, 0.7);
    // Values beyond the limits are moved into them.
    storage.set_string_for_test("(exposure: 100.0, ray_budget: 1)");
    let loaded = UiSettings::from_storage(&storage).expect("loads");
    assert_eq!(loaded.exposure, limits::EXPOSURE.max);
    assert_eq!(loaded.ray_budget, limits::RAY_BUDGET.min);
    // A render block missing fields, or no settings at all, does not parse: the window
    // starts from the defaults.
    for text in [
        "(render: (width: 64))",
        "not ron at all",
        "(exposure: \"x\")",
    ] {
        storage.set_string_for_test(text);
        assert_eq!(UiSettings::from_storage(&storage), None, "{text}");
    }
}

impl MemStorage {
    fn set_string_for_test(&mut self, value: &str) {
        eframe::Storage::set_string(self, UiSettings::STORAGE_KEY, value.to_string());
    }
}

/// The environment panel: each choice and slider sends the whole environment to the worker
/// (one `SetEnvironment` per change); "Map file…" asks the window for a dialog instead; the
/// strength stops at the limits table's bound; the sun appears with its sliders.
#[test]
fn environment_panel_emits_set_environment() {
    let mut h = harness(
        EnvironmentPanel::default(),
        settings(),
        |ui, s: &mut State<EnvironmentPanel, EnvironmentRequest>| {
            if let Some(r) = s.panel.ui(ui, &mut s.settings, &mut s.out) {
                s.returned.push(r);
            }
        },
    );
    let mut env = EnvironmentSettings::default();
    choose(&mut h, "Environment", "Sky");
    env.kind = EnvironmentKind::Sky;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetEnvironment(env.clone())],
    );
    h.get_by_role_and_label(Role::Slider, "Strength")
        .set_value_accesskit(3.0);
    h.run_steps(2);
    env.strength = 3.0;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetEnvironment(env.clone())],
    );
    h.get_by_role_and_label(Role::Slider, "Rotation")
        .set_value_accesskit(-45.0);
    h.run_steps(2);
    env.rotation_deg = -45.0;
    assert_commands(
        &mut h.state_mut().out,
        &[Command::SetEnvironment(env.clone())],
    );
    h.get_by_role_and_label(Role::Slider, "Strength")
        .set_value_accesskit(1e9);
    h.run_steps(2);
    let strength = h.state().settings.environment.strength;
    assert!(strength <= limits::ENV_STRENGTH.max, "{strength}");
    h.state_mut().out.take();
    h.get_by_label("Sun").click();
    h.run_steps(3);
    let sun = h.state().settings.environment.sun.expect("the sun is on");
    assert_eq!(h.state_mut().out.take().len(), 1);
    h.get_by_role_and_label(Role::Slider, "Sun elevation")
        .set_value_accesskit(20.0);
    h.run_steps(2);
    assert_eq!(
        h.state().settings.environment.sun.map(|s| s.elevation_deg),
        Some(20.0)
    );
    assert_ne!(Some(sun), h.state().settings.environment.sun);
    assert_eq!(h.state_mut().out.take().len(), 1);
    assert!(h.state().returned.is_empty());
    choose(&mut h, "Environment", "Map file…");
    assert_eq!(h.state().returned, [EnvironmentRequest::ChooseMap]);
    assert_commands(&mut h.state_mut().out, &[]);
}
