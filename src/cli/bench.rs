//! `bench`: Table 2's CORNELL BOX I rows (rs and rc, with direct photons and with NEE), §8.1's
//! glossy rows (one per directional mode), the previewer's latencies and, with
//! `--quality-references`, quality over time (`super::quality`); one line per row on stdout
//! and, with `--json`, the rows merged into a JSON file (docs/benchmarks.md quotes both).

use super::error::CliError;
use super::quality;
use super::set_threads;
use clap::{Args, ValueEnum};
use glam::Vec3;
use raysplat::choice::Choice;
use raysplat::methods::{Budget, MethodStats, Timings, peak_rss_mb, render_method};
use raysplat::pipeline::cache::CacheParams;
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::pipeline::photon::BandwidthParams;
use raysplat::scene::{BuiltinScene, EnvironmentSettings, Scene};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Args)]
pub struct BenchArgs {
    /// Write (or update) the rows as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Repetitions; the fastest run is reported.
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// A path-traced EXR of builtin:glossy at 500×500 (`raysplat render builtin:glossy
    /// --method pt --spp 1024 --width 500 --height 500`): the glossy rows report relMSE to it.
    #[arg(long)]
    glossy_reference: Option<PathBuf>,
    /// A path-traced EXR of CORNELL BOX I at 500×500 (`raysplat render --method pt --spp 512`):
    /// the Table 2 rows report relMSE to it.
    #[arg(long)]
    cornell_reference: Option<PathBuf>,
    /// A folder of path-traced 500×500 references, classic.exr, cornell1.exr and cornell2.exr
    /// (`raysplat render builtin:classic --method pt --spp 1024 --width 500 --height 500 --out
    /// DIR/classic.exr`, …): adds the quality-over-time rows (the window's image and its
    /// path-traced view against wall time) and their plot.
    #[arg(long)]
    quality_references: Option<PathBuf>,
    /// Wall time of each quality curve in seconds (checkpoints 1, 2, 5, 10, 30 up to it).
    #[arg(long, default_value_t = 30.0)]
    quality_seconds: f64,
    /// Where the quality plot goes (PNG; default DIR/quality.png of --quality-references).
    #[arg(long)]
    quality_plot: Option<PathBuf>,
    /// Quality and previewer rows with the eye samples of the first eye pass kept for every
    /// batch (as the window did before its eye passes, docs/deviations.md §41), for comparison.
    #[arg(long)]
    fixed_eye_samples: bool,
    /// Quality and previewer rows with the window's C fixed at Table 2's value (Auto off), as
    /// the window was before it chose C itself by default (docs/deviations.md §51), for
    /// comparison.
    #[arg(long)]
    fixed_c: bool,
    /// Run only these groups of rows (default: every group; quality needs its references).
    #[arg(long, value_delimiter = ',')]
    only: Vec<Group>,
    /// The previewer's rows on this scene (a .gltf/.glb file or builtin:KEY, seen from its
    /// first camera and lit as --environment says) instead of the embedded CORNELL BOX I; its
    /// rows are named preview_…@NAME, NAME the file's stem or the key.
    #[arg(long, value_name = "SCENE")]
    preview_scene: Option<String>,
    /// The light of --preview-scene.
    #[command(flatten)]
    env: super::args::EnvArgs,
}

/// Groups of rows.
#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum)]
enum Group {
    /// Table 2's CORNELL BOX I rows.
    Table2,
    /// §8.1's glossy rows.
    Glossy,
    /// The previewer's latencies.
    Preview,
    /// Quality over time (needs --quality-references).
    Quality,
}

/// The shortest quality curve: its first checkpoint.
const CHECKPOINT_MIN: f64 = quality::CHECKPOINTS[0];

/// The rows, by name, as they go into the JSON file's `rows`.
type Rows = serde_json::Map<String, serde_json::Value>;

/// The fastest of a Table 2 row's runs.
struct BenchRun {
    timings: Timings,
    stats: MethodStats,
    rel_mse: f64,
}

/// The fastest (in splat and resolve time) of a glossy row's runs, and the directional memory.
struct GlossyRun {
    timings: Timings,
    rel_mse: f64,
    directional_bytes: usize,
    glossy_targets: usize,
}

/// The previewer's latencies, in milliseconds.
struct PreviewLatencies {
    first_image: f64,
    resplat: f64,
    resplat_full: f64,
    camera: f64,
    /// A camera move while batches are traced (not paused): the mean and the largest over
    /// [`RUNNING_MOVES`] moves, without and with the split view's reference beside them.
    running_camera: [f64; 2],
    running_camera_max: [f64; 2],
    /// The scene's name (every row carries it).
    scene: String,
}

/// Camera moves timed while the worker traces.
const RUNNING_MOVES: usize = 6;

/// The previewer rows' scene: the embedded CORNELL BOX I, or `--preview-scene` lit as the
/// `--environment` flags say.
struct PreviewScene {
    scene: Arc<Scene>,
    /// The camera moves' unit: CORNELL BOX I's 0.05 and 0.02 of its length units are scaled
    /// by the scene's diagonal over the box's (a drag in the window moves the camera in
    /// proportion to the scene).
    unit: f32,
    /// Appended to the rows' names: `@NAME`, the file's stem or the built-in key.
    suffix: String,
}

impl PreviewScene {
    fn load(arg: Option<&str>, env: &super::args::EnvArgs) -> Result<Self, CliError> {
        // Built once: the rows' scene, or the yardstick of another scene's camera moves.
        let default = Scene::default_scene();
        let Some(arg) = arg else {
            return Ok(Self {
                scene: Arc::new(default),
                unit: 1.0,
                suffix: String::new(),
            });
        };
        let name = match arg.strip_prefix("builtin:") {
            Some(key) => key.to_string(),
            None => Path::new(arg)
                .file_stem()
                .map_or_else(|| arg.to_string(), |s| s.to_string_lossy().into_owned()),
        };
        let scene = super::load_scene(Some(arg), env)?;
        let unit = scene.diagonal() / default.diagonal();
        Ok(Self {
            scene: Arc::new(scene),
            unit,
            suffix: format!("@{name}"),
        })
    }
}

/// Table 2's CORNELL BOX I settings: 500×500×4, M = 200,000, (0.3, 0.6, 0.1), C = 1, S = 0.4, R = 0.2.
fn cornell1_settings(direct: DirectMode) -> RenderSettings {
    RenderSettings {
        direct,
        ..RenderSettings::default()
    }
}

/// Table 2's RC row: C = 0.6, S = 0.3, ε = 0.7.
fn cornell1_rc_settings(direct: DirectMode) -> RenderSettings {
    RenderSettings {
        method: MethodKind::Rc,
        bandwidth: BandwidthParams {
            smoothness_c: 0.6,
            sensitivity_s: 0.3,
            max_bandwidth_r: 0.2,
            ..Default::default()
        },
        cache: CacheParams {
            error: 0.7,
            ..Default::default()
        },
        ..cornell1_settings(direct)
    }
}

/// Every row, printed and (with `--json`) written.
pub fn run(args: BenchArgs) -> Result<(), CliError> {
    // Everything the command line names is checked before the first row runs.
    if let Some(path) = &args.json {
        let inputs: Vec<&std::path::Path> = [&args.cornell_reference, &args.glossy_reference]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path)
            .collect();
        super::output::check(&[(path.as_path(), false)], &inputs).map_err(CliError::Output)?;
    }
    for (reference, scene) in [
        (&args.cornell_reference, "CORNELL BOX I"),
        (&args.glossy_reference, "builtin:glossy"),
    ] {
        read_reference(reference.as_ref(), scene).map_err(CliError::Input)?;
    }
    let runs = |g: Group| args.only.is_empty() || args.only.contains(&g);
    // The previewer's scene is read (and lit) before any row runs: a scene or an environment
    // that cannot be read is one line, not the end of a long run.
    let environment = args.env.settings();
    if args.preview_scene.is_none() && environment != EnvironmentSettings::default() {
        return Err(CliError::Usage(
            "--environment, --env-strength, --env-rotation and --sun light --preview-scene: \
             give one"
                .into(),
        ));
    }
    if args.preview_scene.is_some() && !runs(Group::Preview) {
        return Err(CliError::Usage(
            "--preview-scene names the preview rows' scene, and --only leaves them out".into(),
        ));
    }
    let preview = PreviewScene::load(args.preview_scene.as_deref(), &args.env)?;
    let quality_refs = match &args.quality_references {
        Some(dir) if runs(Group::Quality) => Some(
            quality::SCENES
                .iter()
                .map(|(stem, _)| {
                    let path = quality::reference_path(dir, stem)?;
                    Ok(read_reference(Some(&path), stem)?.unwrap_or_default())
                })
                .collect::<Result<Vec<_>, String>>()
                .map_err(CliError::Input)?,
        ),
        None if !args.only.is_empty() && runs(Group::Quality) => {
            return Err(CliError::Usage(
                "--only quality needs --quality-references DIR".into(),
            ));
        }
        _ => None,
    };
    let plot = args.quality_plot.clone().or_else(|| {
        args.quality_references
            .as_ref()
            .map(|d| d.join("quality.png"))
    });
    if quality_refs.is_some()
        && let Some(plot) = &plot
    {
        if !plot
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            return Err(CliError::Output(format!(
                "{}: the quality plot is a .png",
                plot.display()
            )));
        }
        let dir = args.quality_references.as_deref().unwrap_or(Path::new("."));
        let refs: Vec<PathBuf> = quality::SCENES
            .iter()
            .map(|(stem, _)| dir.join(format!("{stem}.exr")))
            .collect();
        let mut inputs: Vec<&Path> = refs.iter().map(PathBuf::as_path).collect();
        inputs.extend(args.json.as_deref());
        super::output::check(&[(plot.as_path(), false)], &inputs).map_err(CliError::Output)?;
    }
    if !(args.quality_seconds >= CHECKPOINT_MIN && args.quality_seconds <= 600.0) {
        return Err(CliError::Usage(format!(
            "--quality-seconds {}: must be within {CHECKPOINT_MIN}..600",
            args.quality_seconds
        )));
    }
    set_threads(args.threads)?;
    let mut rows = Rows::new();
    if runs(Group::Table2) {
        cornell_bench(&args, &mut rows)?;
    }
    if runs(Group::Glossy) {
        glossy_bench(&args, &mut rows)?;
    }
    let window = quality::Window {
        progressive_eye: !args.fixed_eye_samples,
        auto_c: !args.fixed_c,
    };
    if runs(Group::Preview) {
        preview_bench(preview.scene, environment.clone(), preview.unit, window)?
            .report(&mut rows, &preview.suffix);
    }
    let mut curves = Vec::new();
    if let Some(references) = quality_refs {
        curves = quality::run_curves(&references, args.quality_seconds, window);
        rows.extend(quality::rows(&curves));
    }
    if let Some(path) = &args.json {
        write_json(path, rows).map_err(CliError::Output)?;
    }
    // After the rows are safe: a plot that cannot be drawn costs only the plot.
    if !curves.is_empty()
        && let Some(plot) = &plot
        && let Err(e) = quality::plot(&curves, plot)
    {
        eprintln!("{e}");
    }
    Ok(())
}

/// `rows` merged into the JSON file at `path`, keeping rows other benchmarks wrote into it.
fn write_json(path: &std::path::Path, rows: Rows) -> Result<(), String> {
    let mut doc: serde_json::Value = std::fs::read(path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .filter(|v: &serde_json::Value| v.is_object())
        .unwrap_or_else(|| json!({}));
    if !doc["rows"].is_object() {
        doc["rows"] = json!({});
    }
    for (k, v) in rows {
        doc["rows"][k] = v;
    }
    doc["threads"] = json!(rayon::current_num_threads());
    doc["version"] = json!(env!("CARGO_PKG_VERSION"));
    let bytes = serde_json::to_vec_pretty(&doc).map_err(|e| e.to_string())?;
    raysplat::film::write_atomic(path, &bytes)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// A reference EXR's pixels; it must have the benchmarks' size (500×500), `what` names it in
/// the error.
fn read_reference(path: Option<&PathBuf>, what: &str) -> Result<Option<Vec<Vec3>>, String> {
    let Some(path) = path else { return Ok(None) };
    let (w, h, px) = raysplat::film::read_exr(path)?;
    let size = RenderSettings::default();
    if (w, h) != (size.width, size.height) {
        return Err(format!(
            "{}: the {what} reference must be {}×{}",
            path.display(),
            size.width,
            size.height
        ));
    }
    Ok(Some(px))
}

/// relMSE to the reference, NaN without one.
fn rel_mse(image: &[Vec3], reference: Option<&[Vec3]>) -> f64 {
    reference.map_or(f64::NAN, |px| raysplat::film::rel_mse(image, px))
}

/// JSON null for a NaN relMSE (no reference).
fn rel_mse_json(err: f64) -> serde_json::Value {
    if err.is_finite() {
        json!(err)
    } else {
        json!(null)
    }
}

/// Table 2's CORNELL BOX I rows: the fastest of `--runs` runs each.
fn cornell_bench(args: &BenchArgs, rows: &mut Rows) -> Result<(), CliError> {
    let scene = Arc::new(Scene::default_scene());
    let reference = read_reference(args.cornell_reference.as_ref(), "CORNELL BOX I")
        .map_err(CliError::Input)?;
    for (name, settings) in [
        ("cornell1_rs", cornell1_settings(DirectMode::Photons)),
        ("cornell1_rs_nee", cornell1_settings(DirectMode::Nee)),
        ("cornell1_rc", cornell1_rc_settings(DirectMode::Photons)),
        ("cornell1_rc_nee", cornell1_rc_settings(DirectMode::Nee)),
    ] {
        let mut best: Option<BenchRun> = None;
        for _ in 0..args.runs.max(1) {
            let r = render_method(&scene, settings.method, &settings, Budget::Fixed)?;
            if r.invalid > 0 {
                return Err(CliError::Failed(format!(
                    "{name}: the image has NaN or infinite pixels"
                )));
            }
            let rel_mse = rel_mse(&r.film.rgb, reference.as_deref());
            if best
                .as_ref()
                .is_none_or(|b| r.timings.total() < b.timings.total())
            {
                best = Some(BenchRun {
                    timings: r.timings,
                    stats: r.stats,
                    rel_mse,
                });
            }
        }
        let best = best.expect("at least one run");
        let (t, stats) = (best.timings, &best.stats);
        let (tested, accepted) = (stats.tested_pairs, stats.accepted_pairs);
        let records = stats.cache_records.unwrap_or(0);
        let ratio = accepted as f64 / tested.max(1) as f64;
        println!(
            "{name:<16} T_E {:.3}  T_D {:.3}  T_L {:.3}  T_S {:.3}  ΣT {:.3} s  peak {:.0} MB  accepted/tested {:.2}  relMSE {:.4}{}",
            t.t_eye,
            t.t_direct,
            t.t_light,
            t.t_splat + t.t_resolve,
            t.total(),
            peak_rss_mb(),
            ratio,
            best.rel_mse,
            if records > 0 {
                format!("  {records} records")
            } else {
                String::new()
            }
        );
        rows.insert(
            name.to_string(),
            json!({
                "t_eye": t.t_eye,
                "t_direct": t.t_direct,
                "t_light": t.t_light,
                "t_splat": t.t_splat + t.t_resolve,
                "t_total": t.total(),
                "peak_rss_mb": peak_rss_mb(),
                "tested_pairs": tested,
                "accepted_pairs": accepted,
                "accepted_ratio": ratio,
                "rel_mse": rel_mse_json(best.rel_mse),
                "cache_records": records,
            }),
        );
    }
    Ok(())
}

/// §8.1 on the glossy Cornell box (500×500×4, M = 200,000, direct photons so that the lights'
/// glossy reflections go through the radiance map too, where a mode resolves the lobe; sharper
/// lobes are traced, docs/deviations.md §37–§38): splat and resolve time and directional
/// memory of the diffuse, SH and histogram modes, and relMSE to a path-traced reference.
fn glossy_bench(args: &BenchArgs, rows: &mut Rows) -> Result<(), CliError> {
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellGlossy));
    let reference =
        read_reference(args.glossy_reference.as_ref(), "glossy").map_err(CliError::Input)?;
    for &mode in DirectionalMode::ALL {
        let settings = RenderSettings {
            direct: DirectMode::Photons,
            radiance_map: mode,
            ..RenderSettings::default()
        };
        let splat_time = |t: &Timings| t.t_splat + t.t_resolve;
        let mut best: Option<GlossyRun> = None;
        for _ in 0..args.runs.max(1) {
            let r = render_method(&scene, settings.method, &settings, Budget::Fixed)?;
            let run = GlossyRun {
                timings: r.timings,
                rel_mse: rel_mse(&r.film.rgb, reference.as_deref()),
                directional_bytes: r.stats.directional_bytes,
                glossy_targets: r.stats.glossy_targets,
            };
            // The memory is the last run's; the times and error the fastest run's.
            best = Some(match best {
                Some(b) if splat_time(&run.timings) >= splat_time(&b.timings) => GlossyRun {
                    directional_bytes: run.directional_bytes,
                    glossy_targets: run.glossy_targets,
                    ..b
                },
                _ => run,
            });
        }
        let best = best.expect("at least one run");
        let t = best.timings;
        let name = format!(
            "glossy_{}",
            serde_json::to_value(mode)
                .map_err(|e| e.to_string())?
                .as_str()
                .unwrap_or("?")
        );
        println!(
            "{name:<16} T_S {:.3}  resolve {:.3}  ΣT {:.3} s  directional {:.1} MB ({} glossy targets)  relMSE {:.4}",
            t.t_splat,
            t.t_resolve,
            t.total(),
            best.directional_bytes as f64 / 1e6,
            best.glossy_targets,
            best.rel_mse
        );
        rows.insert(
            name,
            json!({
                "t_splat": t.t_splat,
                "t_resolve": t.t_resolve,
                "t_total": t.total(),
                "directional_bytes": best.directional_bytes,
                "glossy_targets": best.glossy_targets,
                "rel_mse": rel_mse_json(best.rel_mse),
            }),
        );
    }
    Ok(())
}

/// The previewer's latencies, driving the worker without a window (500×500×1, 20k photons per
/// batch) on `scene` (the embedded CORNELL BOX I unless `--preview-scene`) lit by
/// `environment`, the camera moved sideways by 0.05 and 0.02 times `unit`.
fn preview_bench(
    scene: Arc<Scene>,
    environment: EnvironmentSettings,
    unit: f32,
    window: quality::Window,
) -> Result<PreviewLatencies, String> {
    use raysplat::session::{Command as C, Frame, Session, SessionConfig};
    let timeout = Duration::from_secs(60);
    let wait = |s: &Session, pred: &dyn Fn(&Frame) -> bool| -> Result<Frame, String> {
        let start = Instant::now();
        while start.elapsed() < timeout {
            if let Some(f) = s.wait_frame(Duration::from_millis(20))
                && pred(&f)
            {
                return Ok(f);
            }
        }
        Err("the worker published no frame in time".into())
    };
    let new_config = || {
        let mut config = SessionConfig::default();
        window.apply(&mut config);
        config.environment = environment.clone();
        config
    };
    let t = Instant::now();
    let session = Session::spawn(scene.clone(), None, new_config(), None);
    wait(&session, &|f| f.stats.method.passes >= 1)?;
    let first_image = t.elapsed().as_secs_f64() * 1e3;
    // Store about 200k rays (with NEE, 70% of each batch's M is stored), then stop tracing.
    let f = wait(&session, &|f| f.stats.method.photon_rays >= 200_000)?;
    session.send(C::Pause);
    let f = wait(&session, &|g| g.stats.paused && g.seq > f.seq)?;
    // S, not C: with Auto (the window's default) C is the render's own, and a C sent is
    // only where it starts (`--fixed-c` moves S too, so that the rows compare).
    let mut params = f.settings.bandwidth;
    params.sensitivity_s = 0.35;
    let t = Instant::now();
    session.send(C::SetBandwidth(params));
    let g = wait(&session, &|g| g.generation > f.generation)?;
    let resplat = t.elapsed().as_secs_f64() * 1e3;
    wait(&session, &|h| {
        h.generation == g.generation && !h.stats.resplat_pending
    })?;
    let resplat_full = t.elapsed().as_secs_f64() * 1e3;
    // Move the camera of frame `f` sideways by `dx` (an interactive view): the milliseconds
    // until a frame of the new view with indirect light, and that frame.
    let move_camera = |session: &Session, f: &Frame, dx: f32| -> Result<(f64, Frame), String> {
        let mut camera = f.camera.clone();
        camera.position += camera.right() * dx;
        let t = Instant::now();
        session.send(C::SetCamera {
            camera,
            interactive: true,
        });
        let generation = f.generation;
        let g = wait(session, &|h| {
            h.generation > generation && h.stats.method.passes >= 1
        })?;
        Ok((t.elapsed().as_secs_f64() * 1e3, g))
    };
    let (camera, _) = move_camera(&session, &g, 0.05 * unit)?;
    drop(session);
    // While tracing, a command waits for the step in flight (a batch, or in the split view a
    // reference pass): camera moves at spaced moments, without and with the split view.
    let mut running_camera = [0.0; 2];
    let mut running_camera_max = [0.0; 2];
    for (k, split) in [false, true].into_iter().enumerate() {
        let session = Session::spawn(scene.clone(), None, new_config(), None);
        session.send(C::SetSplit(split));
        let mut f = wait(&session, &|f| {
            f.stats.method.passes >= 3 && !f.interactive && (!split || f.stats.reference_spp >= 2)
        })?;
        let mut times = Vec::new();
        for m in 0..RUNNING_MOVES {
            // Spaced by an odd number of milliseconds, so the moves land at different points
            // of the steps in flight.
            std::thread::sleep(Duration::from_millis(137 + 61 * m as u64));
            let (ms, g) = move_camera(&session, &f, 0.02 * unit)?;
            times.push(ms);
            // The camera comes to rest: full size again, and the reference refining beside.
            session.send(C::SetCamera {
                camera: g.camera.clone(),
                interactive: false,
            });
            f = wait(&session, &|h| {
                h.generation > g.generation
                    && !h.interactive
                    && h.stats.method.passes >= 2
                    && (!split || h.stats.reference_spp >= 1)
            })?;
        }
        running_camera[k] = times.iter().sum::<f64>() / times.len() as f64;
        running_camera_max[k] = times.iter().fold(0.0, |a: f64, &b| a.max(b));
    }
    Ok(PreviewLatencies {
        first_image,
        resplat,
        resplat_full,
        camera,
        running_camera,
        running_camera_max,
        scene: scene.name.clone(),
    })
}

impl PreviewLatencies {
    /// One line and one row (`{"ms": …}`) per latency.
    fn report(&self, rows: &mut Rows, suffix: &str) {
        for (name, ms) in [
            ("preview_first_image_ms", self.first_image),
            ("preview_resplat_ms", self.resplat),
            ("preview_resplat_full_ms", self.resplat_full),
            ("preview_camera_ms", self.camera),
            ("preview_running_camera_ms", self.running_camera[0]),
            ("preview_running_camera_max_ms", self.running_camera_max[0]),
            ("preview_split_camera_ms", self.running_camera[1]),
            ("preview_split_camera_max_ms", self.running_camera_max[1]),
        ] {
            let name = format!("{name}{suffix}");
            println!("{name:<38} {ms:8.0} ms");
            rows.insert(name, json!({ "ms": ms, "scene": self.scene }));
        }
    }
}
