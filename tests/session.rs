//! The progressive worker on its own: random command storms, convergence, the ray budget.

use raysplat::film::rel_mse;
use raysplat::methods;
use raysplat::pipeline::photon::BandwidthParams;
use raysplat::sampling::Rng;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::session::{Command, Event, Frame, Session, SessionConfig};
use raysplat::settings::{DirectMode, RenderSettings};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

fn small_config() -> SessionConfig {
    SessionConfig {
        settings: RenderSettings {
            width: 48,
            height: 48,
            spp: 1,
            photons: 3_000,
            ..RenderSettings::default()
        },
        max_stored_rays: 200_000,
        ..SessionConfig::default()
    }
}

/// Wait for a frame satisfying `pred`; panics after `secs` (a deadlock shows up as this).
fn wait(s: &Session, secs: u64, pred: impl Fn(&Frame) -> bool) -> Frame {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(secs) {
        if let Some(f) = s.wait_frame(Duration::from_millis(20))
            && pred(&f)
        {
            return f;
        }
        assert!(
            s.is_alive(),
            "the worker thread ended: {:?}",
            s.try_events()
        );
    }
    panic!("no matching frame within {secs} s");
}

/// Aborts the test process if a test hangs (e.g. a deadlock in `Session::drop`).
struct Watchdog(Arc<AtomicBool>);

impl Watchdog {
    fn new(secs: u64) -> Self {
        let done = Arc::new(AtomicBool::new(false));
        let d = done.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs(secs));
            if !d.load(Ordering::SeqCst) {
                eprintln!("watchdog: test still running after {secs} s (deadlock?)");
                std::process::abort();
            }
        });
        Self(done)
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

fn scene_files() -> (PathBuf, PathBuf) {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("session");
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("classic.glb");
    std::fs::write(&good, BuiltinScene::CornellClassic.to_glb()).unwrap();
    let bad = dir.join("broken.glb");
    std::fs::write(&bad, &BuiltinScene::CornellClassic.to_glb()[..500]).unwrap();
    (good, bad)
}

/// The ray store never holds more than the largest budget set plus one batch (the newest is
/// always kept): budgets in the storm are at most 52,000 rays, batches at most 5,500 photons'
/// rays (M is the number of stored rays per batch).
const STORM_RAY_LIMIT: usize = 52_000 + 5_500;

/// Check a frame against the invariants of the storm: finite image, bounded ray store.
fn check_frame(f: &Frame) {
    assert_eq!(
        f.film.invalid_pixels(),
        0,
        "NaN/Inf pixels in frame {}",
        f.seq
    );
    assert!(
        f.stats.method.photon_rays <= STORM_RAY_LIMIT,
        "frame {}: {} stored rays over the budget",
        f.seq,
        f.stats.method.photon_rays
    );
}

/// Thousands of seeded random commands (sliders, camera moves, pause/resume, resolution, spp,
/// direct mode, radiance-map mode, radiance cache and ε, image filter, ray budget, loads of good, truncated and missing files,
/// restarts) interleaved with snapshots of the frames (into a good folder and a missing one):
/// no panic, no deadlock (watchdog), frames keep coming through the storm, never a NaN pixel,
/// the ray store within its budget, every snapshot either complete or refused with a message.
#[test]
fn thousands_of_random_commands_neither_panic_nor_deadlock() {
    use raysplat::app::snapshot_writer::{SnapshotMeta, write_snapshot};
    use raysplat::film::display::{ToneMap, ViewMode, display};
    let _watchdog = Watchdog::new(400);
    let (good, bad) = scene_files();
    let snap_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("storm-snapshots");
    let _ = std::fs::remove_dir_all(&snap_dir);
    std::fs::create_dir_all(&snap_dir).unwrap();
    let scene = Arc::new(Scene::default_scene());
    let base_camera = scene.cameras[0].clone();
    let config = SessionConfig {
        max_stored_rays: 50_000,
        ..small_config()
    };
    let session = Session::spawn(scene, None, config, None);
    wait(&session, 30, |f| f.stats.method.passes >= 1);
    let mut rng = Rng::new(2024, 0);
    let (mut frames_seen, mut snapshots) = (0u64, 0u32);
    let mut last_seq = 0;
    for i in 0..5000 {
        let u = rng.next_f32();
        // Frames keep coming during the storm: every 250 commands wait for a new one, check
        // it and snapshot it; check whatever other frame is ready in between.
        let checkpoint = i % 250 == 249;
        let frame = if checkpoint {
            Some(wait(&session, 60, |f| f.seq > last_seq))
        } else {
            session.try_frame()
        };
        if let Some(f) = frame {
            last_seq = last_seq.max(f.seq);
            check_frame(&f);
            frames_seen += 1;
            if checkpoint {
                let shown = display(&f.film, ViewMode::Final, 0.0, ToneMap::Aces);
                let meta = SnapshotMeta {
                    scene_name: f.scene_name.clone(),
                    scene_path: f.scene_path.clone(),
                    camera: f.camera.clone(),
                    settings: f.settings.clone(),
                    photons_traced: f.stats.method.photons_traced,
                    photon_rays: f.stats.method.photon_rays,
                    batches: f.stats.method.passes as usize,
                    elapsed_s: f.stats.elapsed_s,
                    view_mode: ViewMode::Final,
                    exposure: 0.0,
                    tone_map: ToneMap::Aces,
                    program_version: "test".into(),
                    created: "now".into(),
                };
                let files = write_snapshot(&snap_dir, &shown, &f.film, &meta)
                    .unwrap_or_else(|e| panic!("snapshot into a good folder failed: {e}"));
                snapshots += 1;
                for p in [&files.png, &files.exr, &files.json] {
                    assert!(std::fs::metadata(p).unwrap().len() > 0, "{}", p.display());
                }
                let missing = snap_dir.join("missing");
                let e = write_snapshot(&missing, &shown, &f.film, &meta).unwrap_err();
                assert!(e.contains("does not exist"), "{e}");
            }
        }
        let c = match (rng.next_f32() * 16.0) as u32 {
            0..=2 => Command::SetBandwidth(BandwidthParams {
                smoothness_c: 0.1 + 2.0 * u,
                sensitivity_s: (rng.next_f32()).max(0.01),
                max_bandwidth_r: 0.02 + 0.5 * rng.next_f32(),
                ..Default::default()
            }),
            3 | 4 => {
                let mut camera = base_camera.clone();
                camera.position += glam::Vec3::new(u - 0.5, 0.2 * rng.next_f32(), 0.3 * u) * 0.2;
                Command::SetCamera {
                    camera,
                    interactive: rng.next_f32() < 0.7,
                }
            }
            5 => Command::Pause,
            6 => Command::Resume,
            7 => Command::SetPhotonsPerBatch(500 + (u * 5000.0) as u64),
            8 => Command::SetSamplesPerPixel(1 + (u * 3.0) as u32),
            9 => Command::SetResolution {
                width: 24 + (u * 40.0) as u32,
                height: 24 + (rng.next_f32() * 40.0) as u32,
            },
            10 => Command::SetDirect(if u < 0.5 {
                DirectMode::Nee
            } else {
                DirectMode::Photons
            }),
            11 => Command::SetRayBudget(2_000 + (u * 50_000.0) as usize),
            12 => Command::SetRadianceMap(
                <raysplat::pipeline::directional::DirectionalMode as raysplat::choice::Choice>::ALL
                    [(u * 2.99) as usize],
            ),
            13 => Command::SetCache {
                on: rng.next_f32() < 0.6,
                params: raysplat::pipeline::cache::CacheParams {
                    error: 0.05 + 2.0 * u,
                    min_records: 1 + (rng.next_f32() * 7.0) as u32,
                },
            },
            14 => Command::SetFilter(raysplat::pipeline::filter::FilterParams {
                enabled: rng.next_f32() < 0.6,
                strength: 3.0 * u,
            }),
            _ => match (rng.next_f32() * 7.0) as u32 {
                0 => Command::SetSplatVisibility(u < 0.5),
                1 => Command::SetGuidedEmission(u < 0.5),
                // Past the limits too (0, 10,000): the worker clamps them.
                2 => Command::SetNeeSamples([0, 1, 4, 10_000][(u * 3.99) as usize]),
                3 => Command::LoadScene(good.clone()),
                4 => Command::LoadScene(bad.clone()),
                5 => Command::LoadScene(PathBuf::from("/nonexistent/scene.glb")),
                _ => Command::Restart,
            },
        };
        session.send(c);
        if i % 25 == 0 {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    // Loads that arrive together are coalesced (the last wins); a bad one on its own is refused.
    session.send(Command::LoadScene(bad.clone()));
    session.send(Command::Resume);
    // The worker keeps publishing after the storm, with new batches.
    let f = wait(&session, 120, |_| true);
    let g = wait(&session, 60, |g| {
        g.seq > f.seq + 2 && g.stats.method.passes > 0
    });
    check_frame(&g);
    assert!(session.is_alive());
    assert!(
        frames_seen >= 20 && snapshots == 20,
        "{frames_seen} frames, {snapshots} snapshots"
    );
    // No temporary or partial files are left beside the snapshots.
    for e in std::fs::read_dir(&snap_dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            name.ends_with(".png") || name.ends_with(".exr") || name.ends_with(".json"),
            "stray file {name}"
        );
    }
    let events = session.try_events();
    assert!(
        events.iter().any(|e| matches!(e, Event::LoadFailed(_))),
        "bad files were loaded without an error"
    );
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, Event::Error(m) if m.contains("stopped"))),
        "{events:?}"
    );
    drop(session);
}

/// The progressive image converges: its relMSE against a long render falls as batches
/// accumulate (consistency of the h ∝ M^(−1/6) schedule). On the classic Lambertian box: in
/// CORNELL BOX I the focus of the glass sphere's caustic, a few pixels, carries 97% of the
/// relMSE at 48×48 and converges far more slowly than the rest of the image. The long render
/// has the session's seed, hence its eye samples and pilot: another seed's eye samples differ
/// at every edge, a floor that no number of photons lowers. (Its photons include the
/// session's, which flatters the last checkpoint a little.)
#[test]
fn progressive_image_converges_to_a_long_render() {
    let _watchdog = Watchdog::new(240);
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
    // Both keep their first eye pass, so that they share eye samples (the eye passes of
    // docs/deviations.md §41 have `analytic::eye_passes_make_the_whole_image_converge`).
    let mut config = small_config();
    config.settings.progressive_eye = false;
    let mut long = methods::build(
        scene.clone(),
        RenderSettings {
            photons: 400_000,
            ..config.settings.clone()
        },
    )
    .unwrap();
    for _ in 0..10 {
        long.step();
    }
    let reference = long.film();
    // Publish after every batch so the checkpoints below are met closely.
    let config = SessionConfig {
        publish_interval: Duration::ZERO,
        ..config
    };
    let session = Session::spawn(scene, None, config, None);
    let errors: Vec<(usize, f64)> = [2usize, 16, 64]
        .iter()
        .map(|&b| {
            let f = wait(&session, 120, |f| f.stats.method.passes as usize >= b);
            (
                f.stats.method.passes as usize,
                rel_mse(&f.film.indirect, &reference.indirect),
            )
        })
        .collect();
    // Variance and squared bias both fall about as M^(−2/3): 32× the photons should cut the
    // error about tenfold; ask for half, and for a fall at every checkpoint.
    eprintln!("relMSE by batches: {errors:?}");
    assert!(
        errors[1].1 < errors[0].1 && errors[2].1 < errors[1].1 && errors[2].1 < 0.5 * errors[0].1,
        "relMSE by batches: {errors:?}"
    );
}

/// Over the ray budget, old batches fold into the image; a slider change then re-splats the
/// stored rays only.
#[test]
fn ray_budget_folds_old_batches() {
    let _watchdog = Watchdog::new(120);
    let config = SessionConfig {
        max_stored_rays: 5_000,
        ..small_config()
    };
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    let f = wait(&session, 60, |f| f.stats.method.folded_batches >= 3);
    // At most one batch beyond the budget is ever kept.
    assert!(
        f.stats.method.photon_rays <= 5_000 + 3_000,
        "{} rays",
        f.stats.method.photon_rays
    );
    assert!(f.stats.method.passes as usize > f.stats.method.folded_batches);
    // Every batch whose light the image holds is either stored or folded.
    if !f.stats.resplat_pending {
        assert_eq!(
            f.stats.method.stored_batches + f.stats.method.folded_batches,
            f.stats.method.passes as usize
        );
    }
    assert!(f.stats.method.splat_bytes > 0);
    session.send(Command::Pause);
    let p = wait(&session, 30, |g| g.stats.paused);
    session.send(Command::SetBandwidth(BandwidthParams {
        smoothness_c: 0.5,
        ..p.settings.bandwidth
    }));
    let g = wait(&session, 30, |g| {
        g.generation > p.generation && !g.stats.resplat_pending
    });
    assert_eq!(g.stats.method.folded_batches, 0);
    assert!(g.stats.method.passes >= 1 && g.stats.method.photon_rays <= 8_000);
}

/// A view too large for the machine's memory (4096×4096×64 eye samples, hundreds of GB) is
/// refused by the worker with the memory estimate, before anything is allocated; the old view
/// keeps rendering. Settings whose method cannot be built are not retried in a loop.
#[test]
fn a_view_too_large_for_memory_is_refused_and_the_old_one_stays() {
    let _watchdog = Watchdog::new(120);
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
    let session = Session::spawn(scene, None, small_config(), None);
    let first = wait(&session, 60, |f| f.stats.method.passes >= 1);
    session.send(Command::SetResolution {
        width: 4096,
        height: 4096,
    });
    session.send(Command::SetSamplesPerPixel(64));
    let start = Instant::now();
    let mut refused = None;
    while refused.is_none() && start.elapsed() < Duration::from_secs(60) {
        refused = session.try_events().into_iter().find_map(|e| match e {
            Event::Error(m) if m.contains("needs about") => Some(m),
            _ => None,
        });
        std::thread::sleep(Duration::from_millis(20));
    }
    let message = refused.expect("the worker refused the view with its memory estimate");
    assert!(message.contains("4096×4096"), "{message}");
    // Frames keep coming at the old size (the configured 48×48, or its coarse first frame).
    let f = wait(&session, 60, |f| f.seq > first.seq + 2);
    let s = small_config().settings;
    assert!(
        f.film.width <= s.width && f.film.height <= s.height,
        "{}×{}",
        f.film.width,
        f.film.height
    );
}

/// Commands beyond the limits table are clamped by the worker to the table's bounds (the
/// window's sliders already stop there; a script or a persisted file might not).
#[test]
fn the_worker_clamps_commands_to_the_limits_table() {
    let _watchdog = Watchdog::new(120);
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
    let session = Session::spawn(scene, None, small_config(), None);
    let first = wait(&session, 60, |f| f.stats.method.passes >= 1);
    session.send(Command::SetSamplesPerPixel(1000));
    session.send(Command::SetBandwidth(BandwidthParams {
        smoothness_c: 100.0,
        sensitivity_s: f32::NAN,
        max_bandwidth_r: 0.5,
        ..Default::default()
    }));
    session.send(Command::SetPhotonsPerBatch(1));
    session.send(Command::SetNeeSamples(10_000));
    let f = wait(&session, 60, |f| {
        f.generation > first.generation && !f.interactive && f.settings.spp != 1
    });
    assert_eq!(
        f.settings.nee_samples,
        raysplat::settings::limits::NEE_SAMPLES.max
    );
    let l = raysplat::settings::limits::SPP;
    assert_eq!(f.settings.spp, l.max);
    assert_eq!(f.settings.bandwidth.smoothness_c, 5.0);
    assert_eq!(f.settings.bandwidth.sensitivity_s, 0.01);
    assert_eq!(f.settings.bandwidth.max_bandwidth_r, 0.5);
    assert_eq!(f.settings.photons, 100);
}

/// Wait for the first event `pick` accepts; panics after `secs`.
fn wait_event<T>(s: &Session, secs: u64, mut pick: impl FnMut(Event) -> Option<T>) -> T {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(secs) {
        if let Some(t) = s.try_events().into_iter().find_map(&mut pick) {
            return t;
        }
        let _ = s.wait_frame(Duration::from_millis(20));
    }
    panic!("no matching event within {secs} s");
}

/// A scene without lights opens lit by the uniform environment and says so; the window's
/// environment change re-traces under the sky (frames after it are lit differently); a map
/// that cannot be read is one line and the lighting stays.
#[test]
fn the_environment_changes_under_the_worker() {
    use raysplat::scene::{EnvironmentKind, EnvironmentSettings};
    let _watchdog = Watchdog::new(120);
    let scene = Arc::new(Scene::builtin(BuiltinScene::Outdoor));
    let session = Session::spawn(scene, None, small_config(), None);
    let (env, notice) = wait_event(&session, 30, |e| match e {
        Event::SceneLoaded {
            environment,
            notice,
            ..
        } => Some((environment, notice)),
        _ => None,
    });
    assert_eq!(env.kind, EnvironmentKind::Uniform);
    assert!(notice.expect("a notice").contains("no light of its own"));
    let first = wait(&session, 60, |f| f.stats.method.passes >= 1);
    let sky = EnvironmentSettings {
        kind: EnvironmentKind::Sky,
        strength: 3.0,
        ..Default::default()
    };
    session.send(Command::SetEnvironment(sky.clone()));
    let changed = wait_event(&session, 30, |e| match e {
        Event::EnvironmentChanged { environment, .. } => Some(environment),
        _ => None,
    });
    assert_eq!(changed, sky);
    let after = wait(&session, 60, |f| {
        f.generation > first.generation && f.stats.method.passes >= 1
    });
    assert!(
        (after.film.mean() - first.film.mean()).length() > 0.1 * first.film.mean().length(),
        "the image did not change: {} then {}",
        first.film.mean(),
        after.film.mean()
    );
    session.send(Command::SetEnvironment(EnvironmentSettings {
        kind: EnvironmentKind::File("/nonexistent/map.exr".into()),
        ..Default::default()
    }));
    let err = wait_event(&session, 30, |e| match e {
        Event::Error(m) => Some(m),
        _ => None,
    });
    assert!(
        err.contains("map.exr") && err.contains("stays") && !err.contains('\n'),
        "{err}"
    );
    wait(&session, 60, |f| f.seq > after.seq + 2);
}

/// The reference view mode asked for before the first image (as `bench`'s quality rows do)
/// reaches full resolution: the worker leaves its coarse start although the splatting method
/// never steps (it stayed at half size before), and the path tracer adds paths there.
#[test]
fn the_reference_mode_from_the_start_renders_at_full_size() {
    let config = small_config();
    let (w, h) = (config.settings.width, config.settings.height);
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    session.send(Command::SetReference(true));
    let f = wait(&session, 60, |f| {
        f.reference
            .as_ref()
            .is_some_and(|r| (r.width, r.height) == (w, h))
            && f.stats.reference_spp >= 2
    });
    assert_eq!(
        f.stats.method.passes, 0,
        "no photon batch is traced in the reference mode"
    );
}

/// The coarse first image, at a quarter of the size, traces half a batch (a faster first
/// image, docs/benchmarks.md "The previewer"); the batches after it, at full size, have the
/// configured size again.
#[test]
fn the_first_coarse_image_traces_half_a_batch_and_the_next_ones_a_whole() {
    let _w = Watchdog::new(120);
    let mut config = small_config();
    config.settings.nee_samples = 4;
    let (w, m) = (config.settings.width, config.settings.photons);
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    let first = wait(&session, 60, |f| f.stats.method.passes >= 1);
    assert!(first.interactive, "the first image is coarse");
    assert_eq!(
        first.settings.width,
        w / SessionConfig::default().first_divisor,
        "at a quarter of the size"
    );
    assert_eq!(first.settings.photons, m / 2);
    assert_eq!(
        first.settings.nee_samples, 1,
        "the coarse image draws one light sample"
    );
    let later = wait(&session, 60, |f| {
        f.settings.width == w && f.stats.method.passes >= 3
    });
    assert_eq!(later.settings.photons, m);
    assert_eq!(later.settings.nee_samples, 4);
    // A camera being dragged: one light sample per eye sample, the count again at rest.
    let camera = Scene::default_scene().cameras[0].clone();
    session.send(Command::SetCamera {
        camera: camera.clone(),
        interactive: true,
    });
    let dragged = wait(&session, 60, |f| {
        f.interactive && f.generation > later.generation
    });
    assert_eq!(dragged.settings.nee_samples, 1);
    session.send(Command::SetCamera {
        camera,
        interactive: false,
    });
    let rest = wait(&session, 60, |f| {
        !f.interactive && f.generation > dragged.generation
    });
    assert_eq!(rest.settings.nee_samples, 4);
}

/// The split view: the path tracer refines the same view beside the photon batches, both
/// advancing, and each frame carries their relMSE against each other.
#[test]
fn the_split_view_refines_the_reference_beside_the_batches() {
    let _w = Watchdog::new(180);
    let config = small_config();
    let (w, h) = (config.settings.width, config.settings.height);
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    session.send(Command::SetSplit(true));
    let first = wait(&session, 60, |f| {
        f.reference
            .as_ref()
            .is_some_and(|r| (r.width, r.height) == (w, h))
            && f.stats.reference_spp >= 1
    });
    let later = wait(&session, 120, |f| {
        f.stats.reference_spp >= first.stats.reference_spp + 4
            && f.stats.method.passes >= first.stats.method.passes + 4
    });
    let r = later.reference.as_ref().unwrap();
    let expected = rel_mse(&later.film.rgb, &r.rgb);
    let shown = later
        .stats
        .reference_rel_mse
        .expect("the relMSE between the two");
    assert!(
        (shown - expected).abs() <= 1e-9 * expected.max(1.0),
        "{shown} vs {expected}"
    );
    // Both images of one box: a relMSE of noise, not of different scenes or sizes.
    assert!(shown < 0.5, "relMSE {shown}");
    // The reference's own noise is part of it, and known from its paths' spread.
    let noise = later
        .stats
        .reference_noise
        .expect("the reference's own noise");
    assert!(noise > 0.0 && noise < shown, "noise {noise} of {shown}");
    // A new size: the reference starts again at it.
    session.send(Command::SetResolution {
        width: 40,
        height: 32,
    });
    wait(&session, 120, |f| {
        f.reference
            .as_ref()
            .is_some_and(|r| (r.width, r.height) == (40, 32))
            && (f.film.width, f.film.height) == (40, 32)
            && f.stats.reference_rel_mse.is_some()
    });
    // Leaving the split view drops the reference.
    session.send(Command::SetSplit(false));
    wait(&session, 60, |f| {
        f.reference.is_none() && f.stats.reference_spp == 0
    });
}

/// The pause at an estimated error: with a threshold the estimate is soon below, the worker
/// pauses itself and says at which threshold; a resume refines on without pausing again.
#[test]
fn the_worker_pauses_itself_below_the_error_threshold() {
    let _w = Watchdog::new(180);
    let mut config = small_config();
    config.settings.estimate_error = true;
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    session.send(Command::SetPauseBelow(Some(0.5)));
    let paused = wait(&session, 120, |f| f.stats.paused);
    let e = paused.film.estimate.as_ref().expect("an estimate");
    assert!(e.rel_mse < 0.5, "{e:?}");
    // Not on the word of two or three passes.
    assert!(
        e.passes >= raysplat::film::estimate::TRUSTED_PASSES,
        "{e:?}"
    );
    assert_eq!(paused.stats.paused_below, Some(0.5));
    session.send(Command::Resume);
    let resumed = wait(&session, 60, |f| {
        !f.stats.paused && f.stats.method.passes >= paused.stats.method.passes + 3
    });
    assert_eq!(resumed.stats.paused_below, None);
}

/// Automatic C from the window's command: the estimate comes on with it (the worker's
/// settings say so), and after a few eye passes the batches use a C of the render's own.
#[test]
fn auto_c_from_a_command_turns_the_estimate_on_and_moves_c() {
    let _w = Watchdog::new(180);
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, small_config(), None);
    session.send(Command::SetAutoC(true));
    let f = wait(&session, 150, |f| {
        f.settings.auto_c && (f.settings.bandwidth.smoothness_c - 1.0).abs() > 1e-3
    });
    assert!(f.settings.estimate_error);
    assert!(f.film.estimate.is_some());
    // Off, the batches keep the C it chose (no return to the slider's old 1).
    let chosen = f.settings.bandwidth.smoothness_c;
    session.send(Command::SetAutoC(false));
    let g = wait(&session, 60, |g| !g.settings.auto_c);
    let kept = g.settings.bandwidth.smoothness_c;
    assert!((kept - 1.0).abs() > 1e-3, "C went back to 1");
    // It may have moved once more before the command arrived.
    assert!((kept / chosen - 1.0).abs() <= 0.11, "{chosen} -> {kept}");
}

/// A camera dragged across the window sends a new interactive view every frame: the worker
/// keeps answering with frames of the views (each view's re-splat goes whole while the camera
/// moves; in pieces, every new view would cut the last one short and none would be shown).
#[test]
fn a_dragged_camera_keeps_getting_frames() {
    let _w = Watchdog::new(180);
    // Large enough that a re-splat takes longer than the 16 ms between two views.
    let mut config = small_config();
    config.settings.width = 240;
    config.settings.height = 240;
    config.settings.photons = 20_000;
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    let f = wait(&session, 60, |f| {
        f.stats.method.passes >= 3 && !f.interactive
    });
    let mut frames = 0;
    let start = Instant::now();
    let mut k = 0;
    while start.elapsed() < Duration::from_secs(4) {
        let mut camera = f.camera.clone();
        camera.position += camera.right() * (0.002 * k as f32);
        k += 1;
        session.send(Command::SetCamera {
            camera,
            interactive: true,
        });
        std::thread::sleep(Duration::from_millis(16));
        if let Some(g) = session.try_frame()
            && g.interactive
            && g.generation > f.generation
        {
            frames += 1;
        }
    }
    assert!(frames >= 4, "{frames} frames in 4 s of dragging");
}

/// "elapsed" (and photons per second) count the time spent rendering, not a pause: a frame
/// after a pause of 1.5 s reads at least a second less than the wall clock since the start.
#[test]
fn a_pause_does_not_count_as_elapsed_time() {
    let _w = Watchdog::new(120);
    let start = Instant::now();
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, small_config(), None);
    let first = wait(&session, 60, |f| f.stats.method.passes >= 1);
    session.send(Command::Pause);
    std::thread::sleep(Duration::from_millis(1500));
    session.send(Command::Resume);
    let later = wait(&session, 60, |f| {
        !f.stats.paused && f.stats.method.passes > first.stats.method.passes
    });
    let wall = start.elapsed().as_secs_f64();
    assert!(
        later.stats.elapsed_s < wall - 1.0,
        "elapsed {} s against {wall} s of wall time with 1.5 s paused",
        later.stats.elapsed_s
    );
    assert!(later.stats.elapsed_s > first.stats.elapsed_s);
}

/// The dragged views are sized to the drag budget from what the views before them cost
/// (adaptive resolution, docs/deviations.md §62), end to end through the worker: with a
/// budget no frame can meet they go to the smallest size, a quarter (the view at rest sizes
/// the first drag, the drags the next: either way a quarter here); with one every frame
/// meets they keep the configured half. The averaging and the steps in between are
/// `session::worker::tests::the_dragged_view_is_sized_to_its_budget`'s.
#[test]
fn dragged_views_are_sized_to_their_budget() {
    let _w = Watchdog::new(180);
    for (budget, divisor) in [
        (Duration::from_micros(1), 4),
        (Duration::from_secs(1000), 2),
    ] {
        let mut config = small_config();
        config.settings.width = 96;
        config.settings.height = 64;
        config.drag_frame_budget = budget;
        let w = config.settings.width;
        let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
        let mut f = wait(&session, 60, |f| {
            f.stats.method.passes >= 2 && !f.interactive
        });
        // The first drag may be sized by the view at rest; the second by the first drag.
        for k in 1..=2 {
            let mut camera = f.camera.clone();
            camera.position += camera.right() * (0.01 * k as f32);
            session.send(Command::SetCamera {
                camera,
                interactive: true,
            });
            let generation = f.generation;
            f = wait(&session, 60, |g| {
                g.interactive && g.generation > generation && g.stats.method.passes >= 1
            });
        }
        assert_eq!(
            f.settings.width,
            w / divisor,
            "budget {budget:?}: a dragged view of {}",
            f.settings.width
        );
    }
    assert_eq!(raysplat::session::MAX_DRAG_DIVISOR, 4.0);
}

/// Automatic C holds through a camera move: the move re-splats every stored batch onto one
/// eye pass, whose estimate pulled C down at every move (CORNELL BOX I in the window, four
/// moves: 0.70 → 0.57 → 0.52 → 0.48 → 0.37, docs/deviations.md §51), so C stays until the
/// passes drawn after it hold as many batches; and it moves again after that.
#[test]
fn auto_c_holds_through_a_camera_move() {
    let _w = Watchdog::new(300);
    // Auto, as the window's default, at the window's batches on a smaller view.
    let mut config = SessionConfig::default();
    config.settings.width = 160;
    config.settings.height = 160;
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    // Many stored batches, so that the re-splatted pass outweighs the trusted estimate's
    // first four passes by far.
    let f = wait(&session, 150, |f| {
        f.settings.auto_c
            && (f.settings.bandwidth.smoothness_c - 1.0).abs() > 1e-3
            && f.stats.method.stored_batches >= 20
    });
    let mut camera = f.camera.clone();
    camera.position += camera.right() * 0.1;
    session.send(Command::SetCamera {
        camera,
        interactive: false,
    });
    let moved = wait(&session, 60, |g| {
        g.generation > f.generation && !g.interactive
    });
    // New batches since the move, from the photons traced (the frames' batch count holds
    // the re-splatted ones too).
    let (c, traced, per_batch, stored) = (
        moved.settings.bandwidth.smoothness_c,
        moved.stats.method.photons_traced,
        moved.settings.photons,
        moved.stats.method.stored_batches as u64,
    );
    assert!(stored >= 20);
    let new = |g: &Frame| g.stats.method.photons_traced.saturating_sub(traced) / per_batch;
    // Every frame until C moves again: C held while fewer new batches than were re-splatted.
    let later = wait(&session, 200, |g| {
        let c_now = g.settings.bandwidth.smoothness_c;
        assert!(
            c_now == c || new(g) + 1 >= stored,
            "C {c} -> {c_now} after {} new batches, {stored} re-splatted",
            new(g)
        );
        c_now != c
    });
    assert!(new(&later) + 1 >= stored);
}
