//! Command-line entry points: `view` (the default: the interactive previewer), `render`,
//! `bench`, `scenes`.

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::choice::Choice;
use raysplat::film::Film;
use raysplat::film::error::{error_map, mean_bias, rmse};
use raysplat::methods::{self, Budget, MethodStats, Timings, peak_rss_mb, render_method};
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::pipeline::photon::BandwidthParams;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "raysplat",
    version,
    about = "Global illumination previews by photon ray splatting"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Open the interactive previewer (the default when no command is given).
    View {
        /// A .gltf/.glb file; without it, the embedded CORNELL BOX I.
        scene: Option<PathBuf>,
    },
    /// Render a scene headless to EXR (and PNG).
    Render(RenderArgs),
    /// Reproduce Table 2's CORNELL BOX I row and report timings and memory.
    Bench(BenchArgs),
    /// Render several methods with the same photons and eye samples and compare them with a
    /// reference (the path tracer at high spp unless --reference is given).
    Compare(CompareArgs),
    /// Tone-map a linear EXR to an sRGB PNG (exposure in stops, ACES filmic or clamp).
    Tonemap {
        input: PathBuf,
        output: PathBuf,
        #[arg(long, default_value_t = 0.0)]
        exposure: f32,
        /// Clamp instead of the ACES filmic curve.
        #[arg(long)]
        clamp: bool,
    },
    /// Write the project's generated scenes (.glb) into a folder.
    Scenes {
        #[arg(long, default_value = "assets")]
        out: PathBuf,
    },
}

#[derive(Args, Clone)]
struct RenderArgs {
    /// A .gltf/.glb file, or builtin:cornell1 | builtin:cornell2 | builtin:classic |
    /// builtin:glossy.
    /// Without it, the embedded CORNELL BOX I.
    scene: Option<String>,
    #[arg(long, default_value_t = 500)]
    width: u32,
    #[arg(long, default_value_t = 500)]
    height: u32,
    /// Eye samples per pixel (paths per pixel for --method pt).
    #[arg(long, default_value_t = 4)]
    spp: u32,
    /// M: stored photon rays per batch.
    #[arg(long, default_value_t = 200_000)]
    photons: u64,
    /// Fractions of M for direct, indirect-diffuse and caustic photons (Table 2).
    #[arg(long, value_delimiter = ',', default_values_t = [0.3, 0.6, 0.1])]
    fractions: Vec<f32>,
    /// C: smoothness (eq. 8).
    #[arg(long, default_value_t = 1.0)]
    c: f32,
    /// S: bandwidth sensitivity in (0, 1] (eq. 8).
    #[arg(long, default_value_t = 0.4)]
    s: f32,
    /// R in (0, 1]: bandwidth range; every h lies within [R·h̄, h̄/R] of the typical bandwidth.
    #[arg(long, default_value_t = 0.2)]
    r: f32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Direct light: nee (light and BSDF samples at eye samples) or photons (splatted).
    #[arg(long, default_value = "nee", value_parser = choice::<DirectMode>())]
    direct: DirectMode,
    /// Light samples per eye sample for --direct nee.
    #[arg(long, default_value_t = 1)]
    nee_samples: u32,
    #[arg(long, default_value = "out.exr")]
    out: PathBuf,
    /// Also write a tone-mapped sRGB PNG.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Exposure for the PNG (and for `compare`'s montage), in stops.
    #[arg(long, default_value_t = 0.0)]
    exposure: f32,
    /// Write timings and counters as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Render progressively in batches of --photons until this many seconds are spent.
    #[arg(long)]
    time_budget: Option<f64>,
    /// Camera by name (default: the scene's first).
    #[arg(long)]
    camera: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// rs, rc, pm, pt, rs-fg or pm-fg.
    #[arg(long, default_value = "rs", value_parser = choice::<MethodKind>())]
    method: MethodKind,
    /// K of the global photon map (--method pm).
    #[arg(long, default_value_t = 400)]
    pm_k: usize,
    /// K of the caustic photon map (--method pm).
    #[arg(long, default_value_t = 250)]
    pm_caustic_k: usize,
    /// Gather rays per eye sample (--method rs-fg, pm-fg).
    #[arg(long, default_value_t = 64)]
    fg_rays: u32,
    /// Splat onto every eye sample instead of sharing one splat target among the samples of
    /// a pixel that lie on the same surface.
    #[arg(long)]
    no_merge: bool,
    /// Directional storage at glossy surfaces (§8.1): diffuse (irradiance only), sh
    /// (16 spherical-harmonic coefficients per channel) or histogram (20 strata).
    #[arg(long, default_value = "sh", value_parser = choice::<DirectionalMode>())]
    radiance_map: DirectionalMode,
    /// ε, the radiance cache error (§8.3): records are valid up to ε × their harmonic mean
    /// distance. Used by --method rc, and by rs with --cache.
    #[arg(long, default_value_t = 0.5)]
    cache_error: f32,
    /// Every pixel is covered by at least this many cache records.
    #[arg(long, default_value_t = 4)]
    min_records: u32,
    /// rs: resolve the full radiance map through the radiance cache (as the previewer does).
    #[arg(long)]
    cache: bool,
    /// Filter the indirect light in image space within continuous regions (§8.2).
    #[arg(long)]
    filter: bool,
    /// Scale of the filter's box radius (1 = as the splat statistics ask).
    #[arg(long, default_value_t = 1.0)]
    filter_strength: f32,
}

#[derive(Args)]
struct CompareArgs {
    #[command(flatten)]
    render: RenderArgs,
    /// Methods to compare.
    #[arg(long, value_delimiter = ',', default_value = "rs,pm,pt", value_parser = choice::<MethodKind>())]
    methods: Vec<MethodKind>,
    /// Reference image (linear EXR of the same size); without it the path tracer renders one.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Paths per pixel of the path-traced reference.
    #[arg(long, default_value_t = 512)]
    ref_spp: u32,
    /// Paths per pixel of the pt method in the comparison (without --time-budget).
    #[arg(long, default_value_t = 16)]
    pt_spp: u32,
    #[arg(long, default_value = "compare")]
    out_dir: PathBuf,
}

#[derive(Args)]
struct BenchArgs {
    /// Write (or update) the rows as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Repetitions; the fastest run is reported.
    #[arg(long, default_value_t = 3)]
    runs: u32,
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
}

/// A clap value parser for a closed set of named choices.
fn choice<T: Choice>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(T::ALL.iter().map(|c| c.name()))
        .map(|s| T::from_name(&s).expect("clap checked the name"))
}

/// One row of `compare`'s table (Table 2's phases plus errors).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct CompareRow {
    t_eye: f64,
    t_light: f64,
    t_splat: f64,
    t_total: f64,
    rmse: f64,
    relmse: f64,
    /// Image mean over reference mean, minus 1 (luminance): the method's overall bias.
    mean_bias: f64,
    photons: u64,
    passes: u64,
}

pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        None => view(None),
        Some(Command::View { scene }) => view(scene),
        Some(Command::Render(args)) => render(args),
        Some(Command::Bench(args)) => bench(args),
        Some(Command::Compare(args)) => compare(args),
        Some(Command::Scenes { out }) => write_scenes(&out),
        Some(Command::Tonemap {
            input,
            output,
            exposure,
            clamp,
        }) => tonemap_file(&input, &output, exposure, clamp),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            1
        }
    }
}

impl RenderArgs {
    fn settings(&self) -> Result<RenderSettings, String> {
        let positive = |x: f32| x.is_finite() && x > 0.0;
        if !positive(self.s) || self.s > 1.0 {
            return Err(format!("--s must be in (0, 1], got {}", self.s));
        }
        if !positive(self.c) {
            return Err(format!("--c must be positive, got {}", self.c));
        }
        if !positive(self.r) || self.r > 1.0 {
            return Err(format!(
                "--r must be in (0, 1] (every bandwidth within [R·h̄, h̄/R] of the typical one), got {}",
                self.r
            ));
        }
        let [f0, f1, f2] = self.fractions[..] else {
            return Err(format!(
                "--fractions takes three numbers (direct, indirect, caustic), got {}",
                self.fractions.len()
            ));
        };
        let f = [f0, f1, f2];
        if f.iter().any(|x| x.is_nan() || *x < 0.0) || f.iter().sum::<f32>() <= 0.0 {
            return Err("--fractions must be three non-negative numbers, not all zero".into());
        }
        Ok(RenderSettings {
            width: self.width,
            height: self.height,
            spp: self.spp,
            photons: self.photons,
            fractions: f,
            bandwidth: BandwidthParams {
                smoothness_c: self.c,
                sensitivity_s: self.s,
                max_bandwidth_r: self.r,
            },
            seed: self.seed,
            direct: self.direct,
            nee_samples: self.nee_samples,
            camera: self.camera.clone(),
            merge_targets: !self.no_merge,
            method: self.method,
            pm_k: self.pm_k,
            pm_caustic_k: self.pm_caustic_k,
            fg_rays: self.fg_rays,
            radiance_map: self.radiance_map,
            pt_spp: self.spp,
            cache: raysplat::pipeline::cache::CacheParams {
                error: self.cache_error,
                min_records: self.min_records.max(1),
            },
            cache_on: self.cache,
            filter: raysplat::pipeline::filter::FilterParams {
                enabled: self.filter,
                strength: self.filter_strength,
            },
            ..RenderSettings::default()
        })
    }
}

/// The previewer window.
fn view(scene: Option<PathBuf>) -> Result<(), String> {
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("raysplat")
            .with_inner_size([1280.0, 860.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    let app_options = raysplat::app::AppOptions {
        scene,
        settings: None,
    };
    eframe::run_native(
        "raysplat",
        options,
        Box::new(move |cc| Ok(Box::new(raysplat::app::App::new(cc, app_options)))),
    )
    .map_err(|e| {
        format!("cannot open the previewer window ({e}); without a display, use `raysplat render`")
    })
}

fn load_scene(arg: Option<&str>) -> Result<Scene, String> {
    match arg {
        None => Ok(Scene::default_scene()),
        Some(name) if name.starts_with("builtin:") => {
            let key = &name["builtin:".len()..];
            let Some(which) = BuiltinScene::from_key(key) else {
                let keys: Vec<&str> = BuiltinScene::ALL.iter().map(|s| s.key()).collect();
                return Err(format!(
                    "unknown built-in scene '{key}' ({})",
                    keys.join(", ")
                ));
            };
            Ok(Scene::builtin(which))
        }
        Some(path) => Scene::load(Path::new(path)).map_err(|e| e.to_string()),
    }
}

fn set_threads(threads: Option<usize>) -> Result<(), String> {
    if let Some(n) = threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .map_err(|e| format!("cannot set up {n} threads: {e}"))?;
    }
    Ok(())
}

fn render(args: RenderArgs) -> Result<(), String> {
    set_threads(args.threads)?;
    let settings = args.settings()?;
    let t_load = Instant::now();
    let scene = Arc::new(load_scene(args.scene.as_deref())?);
    let t_load = t_load.elapsed().as_secs_f64();
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let progress = ProgressBar::new(match args.time_budget {
        Some(b) => (b * 1000.0) as u64,
        None => 1,
    });
    progress.set_style(
        ProgressStyle::with_template("{spinner} {msg:24} [{bar:30}] {elapsed_precise}")
            .expect("static template")
            .progress_chars("=> "),
    );
    progress.enable_steady_tick(Duration::from_millis(100));
    progress.set_message(format!("preparing ({})", args.method.name()));
    let start = Instant::now();
    let mut m = methods::build(scene.clone(), settings)?;
    progress.set_message("rendering");
    let budget = match args.time_budget {
        Some(b) => Budget::Seconds(b),
        None => Budget::Fixed,
    };
    methods::run(m.as_mut(), budget, |m| {
        let spent = start.elapsed().as_secs_f64();
        progress.set_position(match args.time_budget {
            Some(b) => (spent * 1000.0).min(b * 1000.0) as u64,
            None => 1,
        });
        progress.set_message(format!("pass {}", m.passes()));
    });
    progress.set_message("resolving");
    let film = m.film();
    progress.finish_and_clear();
    let stats = m.stats();
    print_table(&scene.name, m.kind(), m.timings(), &stats);
    write_outputs(&args, &film)?;
    if let Some(path) = &args.stats {
        let j = stats_json(&scene.name, m.as_ref(), &stats, &film, t_load);
        let bytes = serde_json::to_vec_pretty(&j).map_err(|e| e.to_string())?;
        raysplat::film::write_atomic(path, &bytes)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn write_outputs(args: &RenderArgs, film: &Film) -> Result<(), String> {
    let invalid = film.invalid_pixels();
    if invalid > 0 {
        eprintln!("warning: {invalid} pixels are NaN or infinite");
    }
    film.write_exr(&args.out)?;
    eprintln!("wrote {}", args.out.display());
    if let Some(png) = &args.png {
        film.write_png(png, args.exposure)?;
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}

/// `compare`: every method with the same settings, against a reference.
fn compare(args: CompareArgs) -> Result<(), String> {
    set_threads(args.render.threads)?;
    let settings = args.render.settings()?;
    let scene = Arc::new(load_scene(args.render.scene.as_deref())?);
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("cannot create {}: {e}", args.out_dir.display()))?;
    let reference = match &args.reference {
        Some(path) => {
            let (w, h, px) = raysplat::film::read_exr(path)?;
            if (w, h) != (settings.width, settings.height) {
                return Err(format!(
                    "{}: the reference is {w}×{h}, the comparison {}×{}",
                    path.display(),
                    settings.width,
                    settings.height
                ));
            }
            px
        }
        None => {
            eprintln!(
                "rendering the reference: path tracing at {} spp…",
                args.ref_spp
            );
            let reference_settings = RenderSettings {
                seed: settings.seed ^ 0x5eed,
                pt_spp: args.ref_spp,
                ..settings.clone()
            };
            let r = render_method(&scene, MethodKind::Pt, &reference_settings, Budget::Fixed)?;
            let path = args.out_dir.join("reference.exr");
            r.film.write_exr(&path)?;
            eprintln!("wrote {} ({:.1} s)", path.display(), r.timings.total());
            r.film.rgb
        }
    };
    let budget = match args.render.time_budget {
        Some(b) => Budget::Seconds(b),
        None => Budget::Fixed,
    };
    let settings = RenderSettings {
        pt_spp: args.pt_spp,
        ..settings
    };
    let mut rows = serde_json::Map::new();
    // Fig. 10's montage: each method's image above its relative-error map, the reference last.
    let mut montage: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
    println!(
        "{:<6} {:>8} {:>8} {:>8} {:>8} {:>10} {:>10} {:>8}",
        "method", "T_E", "T_L", "T_S", "ΣT", "RMSE", "relMSE", "bias"
    );
    for &m in &args.methods {
        let r = render_method(&scene, m, &settings, budget)?;
        let t = r.timings;
        let row = CompareRow {
            t_eye: t.t_eye + t.t_direct,
            t_light: t.t_light,
            t_splat: t.t_splat + t.t_resolve,
            t_total: t.total(),
            rmse: rmse(&r.film.rgb, &reference),
            relmse: raysplat::film::rel_mse(&r.film.rgb, &reference),
            mean_bias: mean_bias(&r.film.rgb, &reference),
            photons: r.photons,
            passes: r.passes,
        };
        println!(
            "{:<6} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>10.5} {:>10.5} {:>+7.2}%",
            m.name(),
            row.t_eye,
            row.t_light,
            row.t_splat,
            row.t_total,
            row.rmse,
            row.relmse,
            row.mean_bias * 100.0
        );
        r.film
            .write_exr(&args.out_dir.join(format!("{}.exr", m.name())))?;
        raysplat::film::write_png(
            &args.out_dir.join(format!("{}_error.png", m.name())),
            settings.width,
            settings.height,
            &error_map(&r.film.rgb, &reference),
        )?;
        rows.insert(
            m.name().to_string(),
            serde_json::to_value(&row).map_err(|e| e.to_string())?,
        );
        montage.push((
            raysplat::film::tonemap(&r.film.rgb, args.render.exposure),
            error_map(&r.film.rgb, &reference),
        ));
    }
    montage.push((
        raysplat::film::tonemap(&reference, args.render.exposure),
        vec![255; (settings.width * settings.height * 3) as usize],
    ));
    write_montage(
        &args.out_dir.join("montage.jpg"),
        settings.width,
        settings.height,
        &montage,
    )?;
    let doc = json!({
        "scene": scene.name,
        "settings": settings,
        "reference": args.reference.as_ref().map(|p| p.display().to_string())
            .unwrap_or_else(|| format!("path tracer, {} spp", args.ref_spp)),
        "methods": rows,
    });
    let path = args.out_dir.join("compare.json");
    raysplat::film::write_atomic(
        &path,
        &serde_json::to_vec_pretty(&doc).map_err(|e| e.to_string())?,
    )?;
    eprintln!("wrote {} and the images beside it", path.display());
    Ok(())
}

/// Images side by side (top row) over their error maps (bottom row), as a JPEG.
fn write_montage(
    path: &Path,
    width: u32,
    height: u32,
    columns: &[(Vec<u8>, Vec<u8>)],
) -> Result<(), String> {
    let gap = 4;
    let cols = columns.len() as u32;
    let mut img = image::RgbImage::from_pixel(
        cols * width + (cols - 1) * gap,
        2 * height + gap,
        image::Rgb([255, 255, 255]),
    );
    for (c, (top, bottom)) in columns.iter().enumerate() {
        for (row, px) in [top, bottom].into_iter().enumerate() {
            let tile = image::RgbImage::from_raw(width, height, px.clone())
                .ok_or("montage: a tile has the wrong size")?;
            image::imageops::replace(
                &mut img,
                &tile,
                (c as u32 * (width + gap)) as i64,
                (row as u32 * (height + gap)) as i64,
            );
        }
    }
    let mut buf = std::io::Cursor::new(Vec::new());
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 85)
        .encode_image(&img)
        .map_err(|e| format!("cannot encode JPEG for {}: {e}", path.display()))?;
    raysplat::film::write_atomic(path, buf.get_ref())
}

fn print_table(scene: &str, kind: MethodKind, t: Timings, s: &MethodStats) {
    println!(
        "{:<18} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "scene", "T_E", "T_D", "T_L", "T_S", "ΣT"
    );
    println!(
        "{:<18} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3}",
        truncate(scene, 18),
        t.t_eye,
        t.t_direct,
        t.t_light,
        t.t_splat + t.t_resolve,
        t.total()
    );
    if let Some(pm) = &s.pm {
        println!(
            "photon mapping: {} global photons (K avg/max {:.0}/{}), {} caustic photons (K avg/max {:.0}/{})",
            pm.global_photons,
            pm.mean_k_global,
            pm.max_k_global,
            pm.caustic_photons,
            pm.mean_k_caustic,
            pm.max_k_caustic
        );
    }
    println!(
        "{}: photons traced {}, photon rays {}, eye samples {}, passes {}, accepted/tested pairs {}/{} ({:.2})",
        kind.name(),
        s.photons_traced,
        s.photon_rays,
        s.eye_samples,
        s.passes,
        s.accepted_pairs,
        s.tested_pairs,
        s.accepted_pairs as f64 / s.tested_pairs.max(1) as f64
    );
}

fn truncate(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}

fn stats_json(
    scene: &str,
    m: &dyn methods::Method,
    s: &MethodStats,
    film: &Film,
    t_load: f64,
) -> serde_json::Value {
    let t = m.timings();
    let class_clamps = |c: usize| {
        s.bandwidth_clamps.map(|clamps| {
            json!({
                "rays": clamps[c].rays,
                "at_h_min": clamps[c].fraction_min(),
                "at_h_max": clamps[c].fraction_max(),
            })
        })
    };
    let settings = m.settings();
    json!({
        "scene": scene,
        "camera": m.camera().name,
        "settings": settings,
        "t_load": t_load,
        "t_eye": t.t_eye,
        "t_direct": t.t_direct,
        "t_light": t.t_light,
        "t_splat": t.t_splat,
        "t_resolve": t.t_resolve,
        "t_total": t.total(),
        "photons": s.photons_traced,
        "photon_rays": s.photon_rays,
        "photon_rays_direct": s.photon_rays_per_class[0],
        "photon_rays_indirect": s.photon_rays_per_class[1],
        "photon_rays_caustic": s.photon_rays_per_class[2],
        "photon_ray_bytes": s.photon_ray_bytes,
        "pilot_mean_length": s.pilot_mean_length,
        "bandwidth_clamps": {
            "direct": class_clamps(0),
            "indirect": class_clamps(1),
            "caustic": class_clamps(2),
        },
        "eye_samples": s.eye_samples,
        "splat_targets": s.splat_targets,
        "splat_tree_nodes": s.splat_tree_nodes,
        "batches": s.passes,
        "passes": s.passes,
        "tested_pairs": s.tested_pairs,
        "accepted_pairs": s.accepted_pairs,
        "peak_rss_mb": peak_rss_mb(),
        "radiance_map": settings.radiance_map,
        "cache_records": s.cache_records,
        "cache_records_per_pass": s.cache_records_per_pass,
        "directional_bytes": s.directional_bytes,
        "glossy_targets": s.glossy_targets,
        "directional_bytes_per_glossy_target": s.directional_bytes as f64 / s.glossy_targets.max(1) as f64,
        "invalid_pixels": film.invalid_pixels(),
        "invalid_contributions": film.invalid_contributions,
        "method": m.kind(),
        "pm": s.pm,
        "threads": rayon::current_num_threads(),
        "version": env!("CARGO_PKG_VERSION"),
    })
}

/// The fastest of a bench row's runs.
struct BenchRun {
    timings: Timings,
    stats: MethodStats,
    rel_mse: f64,
}

/// Table 2's CORNELL BOX I settings: 500×500×4, M = 200,000, (0.3, 0.6, 0.1), C = 1, S = 0.4, R = 0.2.
fn cornell1_settings(direct: DirectMode) -> RenderSettings {
    RenderSettings {
        direct,
        ..RenderSettings::default()
    }
}

fn bench(args: BenchArgs) -> Result<(), String> {
    set_threads(args.threads)?;
    let scene = Arc::new(Scene::default_scene());
    let mut rows = serde_json::Map::new();
    let reference = match &args.cornell_reference {
        Some(p) => Some(raysplat::film::read_exr(p)?.2),
        None => None,
    };
    // Table 2's RC row: C = 0.6, S = 0.3, ε = 0.7.
    let rc = |direct| RenderSettings {
        method: MethodKind::Rc,
        bandwidth: BandwidthParams {
            smoothness_c: 0.6,
            sensitivity_s: 0.3,
            max_bandwidth_r: 0.2,
        },
        cache: raysplat::pipeline::cache::CacheParams {
            error: 0.7,
            ..Default::default()
        },
        ..cornell1_settings(direct)
    };
    for (name, settings) in [
        ("cornell1_rs", cornell1_settings(DirectMode::Photons)),
        ("cornell1_rs_nee", cornell1_settings(DirectMode::Nee)),
        ("cornell1_rc", rc(DirectMode::Photons)),
        ("cornell1_rc_nee", rc(DirectMode::Nee)),
    ] {
        let mut best: Option<BenchRun> = None;
        for _ in 0..args.runs.max(1) {
            let r = render_method(&scene, settings.method, &settings, Budget::Fixed)?;
            if r.invalid > 0 {
                return Err(format!("{name}: the image has NaN or infinite pixels"));
            }
            let err = reference
                .as_ref()
                .map_or(f64::NAN, |px| raysplat::film::rel_mse(&r.film.rgb, px));
            if best
                .as_ref()
                .is_none_or(|b| r.timings.total() < b.timings.total())
            {
                best = Some(BenchRun {
                    timings: r.timings,
                    stats: r.stats,
                    rel_mse: err,
                });
            }
        }
        let BenchRun {
            timings: t,
            stats,
            rel_mse: err,
        } = best.expect("at least one run");
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
            err,
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
                "rel_mse": if err.is_finite() { json!(err) } else { json!(null) },
                "cache_records": records,
            }),
        );
    }
    glossy_bench(&args, &mut rows)?;
    for (name, ms) in preview_bench()? {
        println!("{name:<24} {ms:8.0} ms");
        rows.insert(name.to_string(), json!({ "ms": ms }));
    }
    if let Some(path) = &args.json {
        // Keep rows other benchmarks wrote into the same file.
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
    }
    Ok(())
}

/// §8.1 on the glossy Cornell box (500×500×4, M = 200,000, direct photons so that every
/// glossy reflection goes through the radiance map): splat and resolve time and directional
/// memory of the diffuse, SH and histogram modes, and relMSE to a path-traced reference.
fn glossy_bench(
    args: &BenchArgs,
    rows: &mut serde_json::Map<String, serde_json::Value>,
) -> Result<(), String> {
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellGlossy));
    let reference = match &args.glossy_reference {
        Some(p) => {
            let (w, h, px) = raysplat::film::read_exr(p)?;
            if (w, h) != (500, 500) {
                return Err(format!(
                    "{}: the glossy reference must be 500×500",
                    p.display()
                ));
            }
            Some(px)
        }
        None => None,
    };
    for &mode in DirectionalMode::ALL {
        let settings = RenderSettings {
            direct: DirectMode::Photons,
            radiance_map: mode,
            ..RenderSettings::default()
        };
        let mut best: Option<(Timings, f64)> = None;
        let mut memory = (0, 0);
        for _ in 0..args.runs.max(1) {
            let r = render_method(&scene, settings.method, &settings, Budget::Fixed)?;
            let err = reference
                .as_ref()
                .map_or(f64::NAN, |px| raysplat::film::rel_mse(&r.film.rgb, px));
            let t = r.timings;
            memory = (r.stats.directional_bytes, r.stats.glossy_targets);
            if best.is_none_or(|b| t.t_splat + t.t_resolve < b.0.t_splat + b.0.t_resolve) {
                best = Some((t, err));
            }
        }
        let (t, err) = best.expect("at least one run");
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
            memory.0 as f64 / 1e6,
            memory.1,
            err
        );
        rows.insert(
            name,
            json!({
                "t_splat": t.t_splat,
                "t_resolve": t.t_resolve,
                "t_total": t.total(),
                "directional_bytes": memory.0,
                "glossy_targets": memory.1,
                "rel_mse": if err.is_finite() { json!(err) } else { json!(null) },
            }),
        );
    }
    Ok(())
}

/// The previewer's latencies, driving the worker without a window (500×500×1, 20k photons per
/// batch, the embedded CORNELL BOX I).
fn preview_bench() -> Result<Vec<(&'static str, f64)>, String> {
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
    let config = SessionConfig::default();
    let t = Instant::now();
    let session = Session::spawn(Arc::new(Scene::default_scene()), None, config, None);
    wait(&session, &|f| f.stats.batches >= 1)?;
    let first = t.elapsed().as_secs_f64() * 1e3;
    // Store about 200k rays (with NEE, 70% of each batch's M is stored), then stop tracing.
    let f = wait(&session, &|f| f.stats.photon_rays >= 200_000)?;
    session.send(C::Pause);
    let f = wait(&session, &|g| g.stats.paused && g.seq > f.seq)?;
    let mut params = f.settings.bandwidth;
    params.smoothness_c = 0.7;
    let t = Instant::now();
    session.send(C::SetBandwidth(params));
    let g = wait(&session, &|g| g.generation > f.generation)?;
    let resplat = t.elapsed().as_secs_f64() * 1e3;
    wait(&session, &|h| {
        h.generation == g.generation && !h.stats.resplat_pending
    })?;
    let resplat_full = t.elapsed().as_secs_f64() * 1e3;
    let mut camera = g.camera.clone();
    camera.position += camera.right() * 0.05;
    let t = Instant::now();
    session.send(C::SetCamera {
        camera,
        interactive: true,
    });
    wait(&session, &|h| {
        h.generation > g.generation && h.stats.batches >= 1
    })?;
    let camera_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok(vec![
        ("preview_first_image_ms", first),
        ("preview_resplat_ms", resplat),
        ("preview_resplat_full_ms", resplat_full),
        ("preview_camera_ms", camera_ms),
    ])
}

fn tonemap_file(input: &Path, output: &Path, exposure: f32, clamp: bool) -> Result<(), String> {
    use raysplat::film::display::{ToneMap, ViewMode, display};
    let (w, h, rgb) = raysplat::film::read_exr(input)?;
    let mut film = Film::new(w, h);
    film.rgb = rgb;
    let tone = if clamp { ToneMap::Clamp } else { ToneMap::Aces };
    let img = display(&film, ViewMode::Final, exposure, tone);
    raysplat::film::write_png(output, w, h, &img.rgb())?;
    eprintln!("wrote {}", output.display());
    Ok(())
}

fn write_scenes(out: &Path) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    for s in BuiltinScene::ALL {
        let path = out.join(s.file_name());
        raysplat::film::write_atomic(&path, &s.to_glb())?;
        println!("wrote {} ({})", path.display(), s.title());
    }
    Ok(())
}
