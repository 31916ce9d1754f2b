//! The previewer window, headless with egui_kittest (wgpu on a software device where one is
//! needed): sliders reach the worker, snapshots write their files, bad scenes show an error.

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};
use raysplat::app::snapshot_writer::SnapshotMeta;
use raysplat::app::{App, AppOptions, UiSettings};
use raysplat::scene::BuiltinScene;
use raysplat::settings::RenderSettings;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("gui")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn harness(snapshot_dir: PathBuf) -> Harness<'static, App> {
    harness_on(None, snapshot_dir)
}

/// The tests' window settings: a 64×64 view of one eye sample a pixel, 4,000 photons a
/// batch, snapshots into `snapshot_dir`.
fn small_settings(snapshot_dir: PathBuf) -> UiSettings {
    let defaults = UiSettings::default();
    UiSettings {
        render: RenderSettings {
            width: 64,
            height: 64,
            spp: 1,
            photons: 4_000,
            ..defaults.render.clone()
        },
        snapshot_dir,
        ..defaults
    }
}

/// [`harness`] opening `scene` (a .glb) instead of the embedded default.
fn harness_on(scene: Option<PathBuf>, snapshot_dir: PathBuf) -> Harness<'static, App> {
    let settings = small_settings(snapshot_dir);
    Harness::builder()
        .with_size(egui::vec2(1100.0, 800.0))
        .build_eframe(move |cc| {
            App::new(
                cc,
                AppOptions {
                    scene,
                    settings: Some(settings),
                    ..AppOptions::default()
                },
            )
        })
}

/// Step the UI until `pred` holds; panics after `secs`.
fn run_until(h: &mut Harness<'static, App>, secs: u64, what: &str, pred: impl Fn(&App) -> bool) {
    let start = Instant::now();
    loop {
        h.step();
        if pred(h.state()) {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(secs),
            "timed out waiting for {what}; messages: {:?}",
            h.state().messages()
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Step until the control panel's scroll animation has settled: the rect `rect_of` reads
/// stays put.
fn settle(h: &mut Harness<'static, App>, rect_of: impl Fn(&Harness<'static, App>) -> egui::Rect) {
    let mut rect = rect_of(h);
    for k in 0..120 {
        h.step();
        let now = rect_of(h);
        if k >= 5 && now == rect {
            break;
        }
        rect = now;
    }
}

/// Scroll the control panel to the widget labelled `label` and click it.
fn click(h: &mut Harness<'static, App>, label: &str) {
    h.get_by_label(label).scroll_to_me();
    settle(h, |h| h.get_by_label(label).rect());
    h.get_by_label(label).click();
}

/// Scroll the control panel to the Display panel's "View" box and choose `mode` in it.
fn choose_view(h: &mut Harness<'static, App>, mode: &str) {
    let view = |h: &Harness<'static, App>| h.get_by_role_and_label(Role::ComboBox, "View").rect();
    h.get_by_role_and_label(Role::ComboBox, "View")
        .scroll_to_me();
    settle(h, view);
    h.get_by_role_and_label(Role::ComboBox, "View").click();
    h.run_steps(3);
    h.get_by_label(mode).click();
}

/// Step until the worker, restarted with the visibility test off, shows a frame without it.
fn until_a_frame_without_domain_tests(h: &mut Harness<'static, App>) {
    run_until(h, 60, "a frame without domain tests", |a| {
        a.frame().is_some_and(|f| {
            !f.settings.splat_visibility
                && f.stats.method.passes >= 1
                && f.stats.method.domain_tests == 0
        })
    });
}

fn pause(h: &mut Harness<'static, App>) {
    click(h, "Pause (Space)");
    run_until(h, 30, "a paused frame", |a| {
        a.frame()
            .is_some_and(|f| f.stats.paused && !f.stats.resplat_pending)
    });
}

#[test]
fn moving_the_c_slider_reaches_the_worker_and_changes_the_image() {
    let mut h = harness(tmp("slider"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 2) && a.shown().is_some()
    });
    pause(&mut h);
    // The render chooses C by default (the Auto box); a user who sets it by hand turns
    // that off first, and the slider comes alive.
    assert!(h.state().settings().render.auto_c);
    click(&mut h, "Auto");
    h.step();
    let before = h.state().shown().unwrap().rgba.clone();
    let generation = h.state().frame().unwrap().generation;
    h.get_by_role_and_label(Role::Slider, "C")
        .set_value_accesskit(0.3);
    run_until(&mut h, 60, "the re-splatted frame", |a| {
        a.frame().is_some_and(|f| {
            f.generation > generation
                && !f.stats.resplat_pending
                && (f.settings.bandwidth.smoothness_c - 0.3).abs() < 1e-6
        })
    });
    h.step();
    let app = h.state();
    assert!((app.settings().render.bandwidth.smoothness_c - 0.3).abs() < 1e-6);
    let after = &app.shown().unwrap().rgba;
    let changed = before.iter().zip(after).filter(|(a, b)| a != b).count();
    assert!(changed > before.len() / 20, "only {changed} bytes changed");
    // Re-splatting did not trace: the photon count is unchanged while paused.
    assert!(app.frame().unwrap().stats.paused);
}

#[test]
fn snapshot_button_writes_png_exr_and_json() {
    let dir = tmp("snapshot");
    let mut h = harness(dir.clone());
    run_until(&mut h, 60, "the first image", |a| a.shown().is_some());
    h.get_by_role_and_label(Role::Slider, "S")
        .set_value_accesskit(0.55);
    run_until(&mut h, 60, "S to reach the worker", |a| {
        a.frame()
            .is_some_and(|f| (f.settings.bandwidth.sensitivity_s - 0.55).abs() < 1e-6)
    });
    click(&mut h, "Save snapshot");
    run_until(&mut h, 60, "the snapshot", |a| {
        a.messages().iter().any(|m| m.starts_with("saved "))
    });
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 3, "{files:?}");
    let stems: Vec<_> = files
        .iter()
        .map(|p| p.file_stem().unwrap().to_owned())
        .collect();
    assert!(stems.iter().all(|s| *s == stems[0]), "{files:?}");
    let ext: Vec<_> = files
        .iter()
        .map(|p| p.extension().unwrap().to_str().unwrap().to_string())
        .collect();
    assert_eq!(ext, ["exr", "json", "png"]);
    let meta: SnapshotMeta = serde_json::from_slice(&std::fs::read(&files[1]).unwrap()).unwrap();
    let app = h.state();
    // With Auto (the default) C moves with the render: the snapshot holds its frame's C,
    // which a later frame may have moved in the window.
    let (m, a) = (&meta.settings.bandwidth, &app.settings().render.bandwidth);
    assert_eq!(
        (m.sensitivity_s, m.max_bandwidth_r),
        (a.sensitivity_s, a.max_bandwidth_r)
    );
    assert!(meta.settings.auto_c && m.smoothness_c > 0.0);
    assert!((meta.settings.bandwidth.sensitivity_s - 0.55).abs() < 1e-6);
    assert_eq!(meta.settings.width, 64);
    assert_eq!(meta.view_mode, app.settings().view_mode);
    assert_eq!(meta.program_version, env!("CARGO_PKG_VERSION"));
    let png = image::open(&files[2]).unwrap();
    assert_eq!((png.width(), png.height()), (64, 64));
    let (w, _, px) = raysplat::film::read_exr(&files[0]).unwrap();
    assert_eq!(w, 64);
    assert!(px.iter().any(|c| c.max_element() > 0.0));
}

#[test]
fn snapshot_into_a_missing_folder_shows_an_error_and_goes_on() {
    let missing = tmp("gone").join("does-not-exist");
    let mut h = harness(missing);
    run_until(&mut h, 60, "the first image", |a| a.shown().is_some());
    let seq = h.state().frame().unwrap().seq;
    click(&mut h, "Save snapshot");
    run_until(&mut h, 30, "the error", |a| {
        a.messages().iter().any(|m| m.contains("snapshot failed"))
    });
    h.get_by_label_contains("snapshot failed");
    run_until(&mut h, 30, "more frames", |a| {
        a.frame().is_some_and(|f| f.seq > seq + 1)
    });
}

#[test]
fn a_malformed_glb_shows_an_error_and_keeps_the_scene() {
    let dir = tmp("malformed");
    let bad = dir.join("broken.glb");
    std::fs::write(&bad, &BuiltinScene::CornellBox2.to_glb()[..1000]).unwrap();
    let mut h = harness(dir);
    run_until(&mut h, 60, "the first image", |a| a.shown().is_some());
    let scene = h.state().scene_name().to_string();
    assert!(scene.contains("CORNELL BOX I"), "{scene}");
    h.state_mut().open_scene(bad);
    run_until(&mut h, 60, "the load error", |a| {
        a.messages()
            .iter()
            .any(|m| m.contains("truncated or corrupt"))
    });
    // The error is on screen and the old scene stays.
    h.get_by_label_contains("truncated or corrupt");
    assert_eq!(h.state().scene_name(), scene);
    let seq = h.state().frame().unwrap().seq;
    run_until(&mut h, 30, "frames of the old scene", |a| {
        a.frame()
            .is_some_and(|f| f.seq > seq && f.scene_name == scene)
    });
}

#[test]
fn bandwidth_view_shows_a_legend() {
    let mut h = harness(tmp("legend"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 1)
    });
    choose_view(&mut h, "Bandwidth (false colour)");
    run_until(&mut h, 10, "the legend", |a| {
        a.shown().is_some_and(|s| s.legend.is_some())
    });
    let legend = h.state().shown().unwrap().legend.clone().unwrap();
    assert!(legend.min > 0.0 && legend.max > legend.min && legend.unit == "m");
    h.get_by_label_contains("red = smallest");
}

/// The whole window renders through wgpu (lavapipe here), with the false-colour image in it.
#[test]
fn window_renders_through_wgpu() {
    let mut h = harness(tmp("wgpu"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 2)
    });
    choose_view(&mut h, "Bandwidth (false colour)");
    run_until(&mut h, 10, "the false-colour image", |a| {
        a.shown().is_some_and(|s| s.legend.is_some())
    });
    h.run_steps(2);
    let shot = h.render().expect("wgpu renders the window");
    assert!(shot.width() >= 1100 && shot.height() >= 800);
    let (mut reddish, mut bluish) = (0, 0);
    for p in shot.pixels() {
        let [r, g, b, _] = p.0;
        if r > 200 && g < 90 && b < 90 {
            reddish += 1;
        }
        if b > 200 && r < 90 && g < 150 {
            bluish += 1;
        }
    }
    assert!(
        reddish > 100 && bluish > 100,
        "red {reddish}, blue {bluish}"
    );
    shot.save(Path::new(env!("CARGO_TARGET_TMPDIR")).join("gui/window.png"))
        .unwrap();
}

#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

/// Dropping a .glb onto the window opens it; dropping another file says why it is refused.
#[test]
fn dropping_a_scene_opens_it() {
    let dir = tmp("drop");
    let good = dir.join("cornell_box_2.glb");
    std::fs::write(&good, BuiltinScene::CornellBox2.to_glb()).unwrap();
    let text = dir.join("notes.txt");
    std::fs::write(&text, "not a scene").unwrap();
    let mut h = harness(dir);
    run_until(&mut h, 60, "the first image", |a| a.shown().is_some());
    h.input_mut()
        .dropped_files
        .push(std::sync::Arc::new(Dropped(text)));
    h.input_mut()
        .dropped_files
        .push(std::sync::Arc::new(Dropped(good)));
    run_until(&mut h, 60, "the dropped scene", |a| {
        a.frame()
            .is_some_and(|f| f.scene_name == "cornell_box_2" && f.stats.method.passes >= 1)
    });
    assert!(
        h.state()
            .messages()
            .iter()
            .any(|m| m.contains("notes.txt: not a .gltf or .glb file")),
        "{:?}",
        h.state().messages()
    );
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

/// The last parameters persist: what `save` stores reads back as the same settings.
#[test]
fn settings_persist_through_eframe_storage() {
    use eframe::App as _;
    let mut h = harness(tmp("persist"));
    run_until(&mut h, 60, "the first image", |a| a.shown().is_some());
    h.get_by_role_and_label(Role::Slider, "R")
        .set_value_accesskit(0.35);
    h.run_steps(2);
    let mut storage = MemStorage::default();
    h.state_mut().save(&mut storage);
    let keys: Vec<&String> = storage.0.keys().collect();
    let key = keys.first().expect("save stored something").to_string();
    let restored: UiSettings = eframe::get_value(&storage, &key).expect("settings read back");
    assert_eq!(&restored, h.state().settings());
    assert!((restored.render.bandwidth.max_bandwidth_r - 0.35).abs() < 1e-6);
}

/// The reference view mode makes the worker path-trace the same view progressively and shows it.
#[test]
fn reference_view_mode_path_traces_the_view() {
    let mut h = harness(tmp("reference"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame()
            .is_some_and(|f| f.stats.method.passes >= 1 && !f.interactive)
    });
    choose_view(&mut h, "Reference (path traced)");
    run_until(&mut h, 60, "a reference with a few paths per pixel", |a| {
        a.frame()
            .is_some_and(|f| f.stats.reference_spp >= 4 && f.reference.is_some())
    });
    h.run_steps(2);
    let app = h.state();
    let f = app.frame().unwrap();
    let reference = f.reference.as_ref().unwrap();
    assert_eq!(
        (reference.width, reference.height),
        (f.film.width, f.film.height)
    );
    assert_eq!(reference.invalid_pixels(), 0);
    // The shown image is the reference's (brightness within reach of the splatted film's).
    let (m_ref, m_rs) = (reference.mean(), f.film.mean());
    assert!((m_ref.x / m_rs.x - 1.0).abs() < 0.5, "{m_ref} vs {m_rs}");
    let s = app.settings();
    let expected = raysplat::film::display::display(
        reference,
        raysplat::film::display::ViewMode::Reference,
        s.exposure,
        s.tone_map,
    );
    assert_eq!(app.shown().unwrap().rgba, expected.rgba, "the shown image");
}

/// The glossy radiance-map mode (§8.1) reaches the worker, re-splats the stored rays without
/// tracing (paused), changes the glossy spheres, and the stats report the directional memory.
/// On the glossy box, whose copper sphere (roughness 0.95, a GGX lobe as wide as Phong's e = 1)
/// SH records carry.
#[test]
fn radiance_map_mode_switches_and_reports_memory() {
    let dir = tmp("radiance_map");
    let scene = dir.join("glossy.glb");
    std::fs::write(&scene, BuiltinScene::CornellGlossy.to_glb()).unwrap();
    let mut h = harness_on(Some(scene), dir);
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 2) && a.shown().is_some()
    });
    pause(&mut h);
    h.step();
    let f = h.state().frame().unwrap().clone();
    assert!(
        f.stats.method.glossy_targets > 0,
        "the copper sphere has SH records"
    );
    assert!(f.stats.method.directional_bytes >= f.stats.method.glossy_targets * 48 * 4);
    let before = h.state().shown().unwrap().rgba.clone();
    let photons = f.stats.method.photons_traced;
    for (label, mode, floats) in [
        (
            "histogram (20 strata)",
            raysplat::pipeline::directional::DirectionalMode::Histogram,
            60usize,
        ),
        (
            "diffuse (irradiance only)",
            raysplat::pipeline::directional::DirectionalMode::Diffuse,
            0,
        ),
    ] {
        let generation = h.state().frame().unwrap().generation;
        let combo = |h: &Harness<'static, App>| {
            h.get_by_role_and_label(Role::ComboBox, "Glossy radiance map")
                .rect()
        };
        h.get_by_role_and_label(Role::ComboBox, "Glossy radiance map")
            .scroll_to_me();
        settle(&mut h, combo);
        h.get_by_role_and_label(Role::ComboBox, "Glossy radiance map")
            .click();
        h.run_steps(3);
        h.get_by_label(label).click();
        run_until(&mut h, 60, label, |a| {
            a.frame().is_some_and(|f| {
                f.generation > generation
                    && !f.stats.resplat_pending
                    && f.settings.radiance_map == mode
            })
        });
        h.step();
        let f = h.state().frame().unwrap();
        assert_eq!(
            f.stats.method.photons_traced, photons,
            "switching must not trace"
        );
        if floats == 0 {
            assert_eq!(f.stats.method.directional_bytes, 0);
        } else {
            assert!(f.stats.method.directional_bytes >= f.stats.method.glossy_targets * floats * 4);
        }
    }
    let after = &h.state().shown().unwrap().rgba;
    let changed = before.iter().zip(after).filter(|(a, b)| a != b).count();
    assert!(
        changed > 0,
        "the matte spheres look the same as the glossy ones"
    );
}

/// The radiance cache in the window (§8.3): turning it on and moving ε re-runs the cache over
/// the current radiance map without tracing (paused) — a smaller ε gives more records — and
/// the records view mode draws them; the filter toggle reaches the worker.
#[test]
fn epsilon_slider_reruns_the_cache_live() {
    let mut h = harness(tmp("cache"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 2) && a.shown().is_some()
    });
    pause(&mut h);
    let photons = h.state().frame().unwrap().stats.method.photons_traced;
    click(&mut h, "Resolve through the radiance cache");
    run_until(&mut h, 60, "a cached frame", |a| {
        a.frame()
            .is_some_and(|f| f.settings.cache_on && f.stats.method.cache_records.unwrap_or(0) > 0)
    });
    let coarse = h
        .state()
        .frame()
        .unwrap()
        .stats
        .method
        .cache_records
        .unwrap_or(0);
    h.get_by_role_and_label(Role::Slider, "ε")
        .set_value_accesskit(0.1);
    run_until(&mut h, 60, "a frame with ε = 0.1", |a| {
        a.frame().is_some_and(|f| {
            (f.settings.cache.error - 0.1).abs() < 1e-6
                && f.stats.method.cache_records.unwrap_or(0) > 0
        })
    });
    let f = h.state().frame().unwrap().clone();
    assert!(
        f.stats.method.cache_records.unwrap_or(0) > coarse,
        "{} records at ε 0.1, {coarse} at 0.5",
        f.stats.method.cache_records.unwrap_or(0)
    );
    assert_eq!(
        f.stats.method.photons_traced, photons,
        "moving ε must not trace"
    );
    assert_eq!(
        f.cache_records.len(),
        f.stats.method.cache_records.unwrap_or(0)
    );
    // The records view mode draws the records over the image.
    h.run_steps(2);
    let count_white = |rgba: &[u8]| {
        rgba.chunks_exact(4)
            .filter(|p| p[..3] == [255, 255, 255])
            .count()
    };
    let before = count_white(&h.state().shown().unwrap().rgba);
    choose_view(&mut h, "Cache records (radii)");
    h.run_steps(3);
    let white = count_white(&h.state().shown().unwrap().rgba);
    assert!(
        white > before + f.stats.method.cache_records.unwrap_or(0).min(200) / 2,
        "record centres not drawn: {white} white pixels, {before} before"
    );
    // The side panel scrolls: a user scrolls the checkbox into view before clicking it.
    h.get_by_label("Filter the indirect light").scroll_to_me();
    h.run_steps(3);
    h.get_by_label("Filter the indirect light").click();
    run_until(&mut h, 60, "a filtered frame", |a| {
        a.frame().is_some_and(|f| f.settings.filter.enabled)
    });
}

/// docs/deviations.md §38: hovering a pixel tells whether its glossy part came from the radiance
/// map or from reflections traced by the eye path, and the stats count both kinds of glossy eye
/// sample. On the mirror-to-matte box with SH records, the floor (roughness 0.25, e ≈ 510) is
/// traced and the copper sphere (roughness 0.95) goes through the map.
#[test]
fn the_probe_shows_where_the_glossy_part_came_from() {
    let dir = tmp("glossy_probe");
    let scene = dir.join("glossy_sharp.glb");
    std::fs::write(&scene, BuiltinScene::CornellGlossySharp.to_glb()).unwrap();
    let mut h = harness_on(Some(scene), dir);
    run_until(&mut h, 60, "the first full-size image", |a| {
        a.frame()
            .is_some_and(|f| f.stats.method.passes >= 1 && f.film.width == 64)
            && a.shown().is_some()
    });
    pause(&mut h);
    h.step();
    let f = h.state().frame().unwrap().clone();
    assert!(
        f.stats.method.glossy_map_samples > 0 && f.stats.method.glossy_traced_samples > 0,
        "map {} traced {}",
        f.stats.method.glossy_map_samples,
        f.stats.method.glossy_traced_samples
    );
    let src = &f.film.glossy_source;
    let traced = src.iter().position(|s| s[0] == 0.0 && s[1] > 0.9).unwrap();
    let map = src.iter().position(|s| s[0] > 0.9 && s[1] == 0.0).unwrap();
    let rect = h.get_by_role(Role::Image).rect();
    for (pixel, text) in [
        (traced, "glossy: traced reflections"),
        (map, "glossy: from the radiance map"),
    ] {
        let (x, y) = ((pixel % 64) as f32 + 0.5, (pixel / 64) as f32 + 0.5);
        let pos = rect.min + egui::vec2(x / 64.0 * rect.width(), y / 64.0 * rect.height());
        hover_until(&mut h, pos, text);
    }
}

/// Move the pointer to `pos` and keep still until a label containing `text` shows (egui
/// waits for the pointer to rest before a tooltip).
fn hover_until(h: &mut Harness<'static, App>, pos: egui::Pos2, text: &str) {
    h.hover_at(pos);
    let start = Instant::now();
    loop {
        h.step();
        if h.query_by_label_contains(text).is_some() {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no \"{text}\" in the probe at {pos:?}"
        );
    }
}

/// The visibility test (docs/deviations.md §40), on by default in the window: the stats count
/// the pairs tested against the visible domains; switched off, the worker restarts without.
#[test]
fn visibility_checkbox_restarts_without_domain_tests() {
    let mut h = harness(tmp("visibility"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 1)
    });
    assert!(h.state().frame().unwrap().stats.method.domain_tests > 0);
    h.get_by_label_contains("pairs tested");
    click(&mut h, "Visibility in the splat footprint");
    until_a_frame_without_domain_tests(&mut h);
    h.run_steps(2);
    assert!(h.query_by_label_contains("pairs tested").is_none());
}

/// The status bar keeps its height while its counters change: a line that wraps less (here
/// the visibility counters leave it, in a window narrowed so that they take a line of their
/// own) does not move the image, and the bar does not creep taller frame by frame.
#[test]
fn the_status_bar_does_not_move_the_image() {
    let mut h = harness(tmp("status_height"));
    h.set_size(egui::vec2(700.0, 800.0));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| f.stats.method.passes >= 1)
    });
    h.run_steps(3);
    let top = |h: &Harness<'static, App>| h.get_by_label_contains("photons traced").rect().top();
    let before = top(&h);
    click(&mut h, "Visibility in the splat footprint");
    until_a_frame_without_domain_tests(&mut h);
    let mut tops = Vec::new();
    for _ in 0..60 {
        h.step();
        tops.push(top(&h));
    }
    assert!(h.query_by_label_contains("pairs tested").is_none());
    // Screen y grows downwards: the bar's first line never lies lower than it did.
    for t in &tops {
        assert!(*t <= before + 0.5, "the status bar shrank: {before} -> {t}");
    }
    // Nor does it creep: the last frames all agree.
    let last = tops[tops.len() - 20..].to_vec();
    assert!(
        last.iter().all(|t| (t - last[0]).abs() < 0.5),
        "the status bar moves: {last:?}"
    );
}

/// docs/deviations.md §41 in the window: the worker draws new eye passes as batches go on, and the
/// stats line says which pass the image has reached and how much memory the render holds.
#[test]
fn the_stats_line_counts_eye_passes() {
    let mut h = harness(tmp("eye_passes"));
    run_until(&mut h, 60, "a second eye pass", |a| {
        a.frame().is_some_and(|f| f.stats.method.eye_passes >= 2)
    });
    pause(&mut h);
    h.step();
    let f = h.state().frame().unwrap().clone();
    h.get_by_label_contains(&format!("eye pass {}", f.stats.method.eye_passes));
    // The memory breakdown (docs/benchmarks.md, "Memory") reaches the window: every part the
    // view has.
    let m = f.stats.method.memory;
    assert!(m.eye_samples > 0 && m.splat_tree > 0 && m.photon_rays > 0 && m.film > 0);
    assert!(m.scene > 0 && m.accumulators > 0 && m.pixel_sums > 0);
    h.get_by_label(&format!("memory {:.0} MB", m.total() as f64 / 1e6));
}

/// The Auto box beside the C slider, on by default, reaches the worker: the render chooses C
/// from its own error estimate, and the disabled slider shows the C it chose.
#[test]
fn the_auto_box_lets_the_render_choose_c_and_the_slider_shows_it() {
    let mut h = harness(tmp("auto_c"));
    run_until(&mut h, 60, "the first image", |a| a.frame().is_some());
    assert!(h.state().settings().render.auto_c, "Auto is the default");
    // Off and on again: the box reaches the worker both ways.
    click(&mut h, "Auto");
    run_until(&mut h, 60, "a frame with C of the slider", |a| {
        a.frame().is_some_and(|f| !f.settings.auto_c)
    });
    // C back to 1 by hand, so that a C other than 1 below is one chosen after Auto is on
    // again.
    h.get_by_role_and_label(Role::Slider, "C")
        .set_value_accesskit(1.0);
    run_until(&mut h, 60, "C = 1 at the worker", |a| {
        a.frame()
            .is_some_and(|f| !f.settings.auto_c && f.settings.bandwidth.smoothness_c == 1.0)
    });
    click(&mut h, "Auto");
    run_until(&mut h, 150, "a C of the render's own", |a| {
        a.frame().is_some_and(|f| {
            f.settings.auto_c && (f.settings.bandwidth.smoothness_c - 1.0).abs() > 1e-3
        })
    });
    h.step();
    let app = h.state();
    let chosen = app.frame().unwrap().settings.bandwidth.smoothness_c;
    assert_eq!(app.settings().render.bandwidth.smoothness_c, chosen);
    let slider = h.get_by_role_and_label(Role::Slider, "C");
    assert!(slider.accesskit_node().is_disabled());
    let shown = slider.accesskit_node().numeric_value().unwrap();
    assert!((shown - chosen as f64).abs() < 1e-6, "{shown} vs {chosen}");
}

/// The split view: the path-traced reference refines beside the batches, the image right of
/// the divider is the reference's, the panel shows their relMSE, and dragging the divider in
/// the image moves it without moving the camera.
#[test]
fn the_split_view_shows_the_reference_right_of_a_draggable_divider() {
    use raysplat::film::display::{ViewMode, display};
    let mut h = harness(tmp("split"));
    run_until(&mut h, 60, "the first image", |a| {
        a.frame().is_some_and(|f| !f.interactive)
    });
    click(&mut h, "Split view with the reference");
    run_until(&mut h, 120, "the reference beside the batches", |a| {
        a.frame().is_some_and(|f| {
            f.stats.reference_spp >= 3 && f.stats.method.passes >= 3 && f.reference.is_some()
        }) && a.shown().is_some()
    });
    h.step();
    h.step();
    let app = h.state();
    let f = app.frame().unwrap();
    let s = app.settings();
    let shown = app.shown().unwrap();
    let r = f.reference.as_ref().unwrap();
    let right = display(r, ViewMode::Final, s.exposure, s.tone_map);
    let left = display(&f.film, ViewMode::Final, s.exposure, s.tone_map);
    let w = shown.width as usize;
    let x0 = (0.5 * w as f32).round() as usize;
    for y in 0..shown.height as usize {
        let row = |img: &[u8]| img[4 * y * w..4 * (y + 1) * w].to_vec();
        let (got, l, rr) = (row(&shown.rgba), row(&left.rgba), row(&right.rgba));
        assert_eq!(got[..4 * x0], l[..4 * x0], "row {y}: left of the divider");
        assert_eq!(got[4 * x0..], rr[4 * x0..], "row {y}: right of the divider");
    }
    h.get_by_label_contains("relMSE against the reference:");
    // The probe reads the reference right of the divider and the image left of it.
    let image = h.get_by_role(Role::Image).rect();
    let at = |fx: f32| egui::pos2(image.min.x + fx * image.width(), image.center().y);
    hover_until(&mut h, at(0.75), "of the path-traced reference");
    hover_until(&mut h, at(0.25), "kernel weight");
    assert!(
        h.query_by_label_contains("of the path-traced reference")
            .is_none()
    );
    // Drag the divider from the middle of the image to a quarter of its width.
    let from = egui::pos2(image.center().x, image.center().y);
    let to = egui::pos2(image.min.x + 0.25 * image.width(), image.center().y);
    h.hover_at(from);
    h.step();
    h.drag_at(from);
    h.step();
    for k in 1..=5 {
        h.hover_at(from + (to - from) * (k as f32 / 5.0));
        h.step();
    }
    h.drop_at(to);
    h.run_steps(3);
    let at = h.state().settings().split_at;
    assert!((at - 0.25).abs() < 0.03, "divider at {at}");
    run_until(&mut h, 30, "a frame after the drag", |a| {
        a.frame().is_some()
    });
    assert_ne!(
        h.state().frame().unwrap().camera.name,
        "orbit",
        "the drag moved the camera"
    );
}

/// A scene the command line lit (`raysplat view FILE --environment uniform --env-strength 2`)
/// opens lit that way: the window's environment setting takes the scene's (a persisted
/// "Automatic" had the worker relight a file with lights of its own by none), and the
/// worker reports it so.
#[test]
fn a_scene_lit_on_the_command_line_stays_lit_so() {
    use raysplat::app::LoadedScene;
    use raysplat::scene::{EnvironmentKind, EnvironmentSettings, Scene};
    let mut scene = Scene::builtin(BuiltinScene::CornellClassic);
    let asked = EnvironmentSettings {
        kind: EnvironmentKind::Uniform,
        strength: 2.0,
        ..EnvironmentSettings::default()
    };
    scene.set_environment(&asked).unwrap();
    let settings = small_settings(tmp("lit_on_the_command_line"));
    let mut h = Harness::builder()
        .with_size(egui::vec2(1100.0, 800.0))
        .build_eframe(move |cc| {
            App::new(
                cc,
                AppOptions {
                    loaded: Some(LoadedScene {
                        scene: std::sync::Arc::new(scene),
                        path: None,
                    }),
                    settings: Some(settings),
                    ..AppOptions::default()
                },
            )
        });
    assert_eq!(h.state().settings().environment, asked);
    run_until(&mut h, 60, "the worker's report", |app| {
        app.lit_by().is_some()
    });
    assert_eq!(
        h.state().lit_by().map(|e| e.kind.clone()),
        Some(EnvironmentKind::Uniform)
    );
}
