//! `compare`: several methods with the same settings, photons and eye samples, against a
//! reference (a given EXR, or the path tracer at high spp): a table, each image and its error
//! map, Fig. 10's montage and compare.json.

use super::args::{SettingsArgs, ToneArgs};
use super::error::CliError;
use super::{choice, load_scene, output, set_threads};
use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::choice::Choice;
use raysplat::film::Film;
use raysplat::film::display::{ViewMode, display};
use raysplat::film::error::{bright_dots, error_map, mean_bias, rmse};
use raysplat::methods::{self, Budget, render_method};
use raysplat::scene::Scene;
use raysplat::settings::{MethodKind, RenderSettings};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Args)]
pub struct CompareArgs {
    #[command(flatten)]
    settings: SettingsArgs,
    /// Methods to compare.
    #[arg(long, value_delimiter = ',', default_value = "rs,pm,pt", value_parser = choice::<MethodKind>())]
    methods: Vec<MethodKind>,
    /// Reference image (linear EXR of the same size); without it the path tracer renders one.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Paths per pixel of the path-traced reference.
    #[arg(long, default_value_t = 512)]
    ref_spp: u32,
    /// Paths per pixel of the pt method in the comparison. With --time-budget or --batches it
    /// traces one path per pixel a step instead (the settings then record 1), as many steps as
    /// the budget or the batches give.
    #[arg(long, default_value_t = 16)]
    pt_spp: u32,
    /// The folder for every method's EXR and error map, the reference, the montage and
    /// compare.json.
    #[arg(long, default_value = "compare")]
    out_dir: PathBuf,
    #[command(flatten)]
    tone: ToneArgs,
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
    /// Isolated bright pixels the reference lacks ([`bright_dots`]).
    dots: usize,
    photons: u64,
    passes: u64,
    /// rs with `--estimate-error`: the relMSE the render estimated from its own passes
    /// (docs/deviations.md §51).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    estimated_relmse: Option<f64>,
    /// The C the last batch was splatted with (under `--c auto`, the chosen one).
    smoothness_c: f32,
}

/// One column of the montage: a tone-mapped image over its error map (8-bit sRGB).
struct MontageColumn {
    image: Vec<u8>,
    error: Vec<u8>,
}

/// Every method with the same settings, against a reference.
pub fn run(args: CompareArgs) -> Result<(), CliError> {
    // The eye-sample checks of the first method that takes eye samples.
    let kind = args
        .methods
        .iter()
        .copied()
        .find(|&m| m != MethodKind::Pt)
        .unwrap_or(MethodKind::Pt);
    let settings = args.settings.settings(kind).map_err(CliError::Usage)?;
    // Every file compare writes, checked before any work; the reference is never overwritten.
    let mut files: Vec<PathBuf> = vec![
        args.out_dir.join("montage.jpg"),
        args.out_dir.join("compare.json"),
    ];
    if args.reference.is_none() {
        files.push(args.out_dir.join("reference.exr"));
    }
    for m in &args.methods {
        files.push(args.out_dir.join(format!("{}.exr", m.name())));
        files.push(args.out_dir.join(format!("{}_error.png", m.name())));
    }
    let outputs: Vec<(&Path, bool)> = files.iter().map(|p| (p.as_path(), false)).collect();
    let mut inputs: Vec<&Path> = args.reference.iter().map(PathBuf::as_path).collect();
    if let Some(s) = args
        .settings
        .scene
        .as_deref()
        .filter(|s| !s.starts_with("builtin:"))
    {
        inputs.push(Path::new(s));
    }
    output::check(&outputs, &inputs).map_err(CliError::Output)?;
    set_threads(args.settings.run.threads)?;
    let scene = Arc::new(load_scene(
        args.settings.scene.as_deref(),
        &args.settings.environment,
    )?);
    let reference = reference(&args, &scene, &settings)?;
    let budget = args.settings.run.budget();
    let settings = RenderSettings {
        // With a time budget the path tracer adds one path per pixel per step.
        pt_spp: if args.settings.run.stepped() {
            1
        } else {
            args.pt_spp
        },
        ..settings
    };
    let tone = args.tone.tonemap;
    let mut reference_film = Film::new(settings.width, settings.height);
    reference_film.rgb = reference.clone();
    // One exposure for every column: the reference's, so that the images compare.
    let exposure = args.tone.exposure.stops(&reference_film);
    let tonemapped = |rgb: &[Vec3]| {
        let mut f = Film::new(settings.width, settings.height);
        f.rgb = rgb.to_vec();
        display(&f, ViewMode::Final, exposure, tone).rgb()
    };
    let mut rows = serde_json::Map::new();
    // Fig. 10's montage: each method's image above its relative-error map, the reference last.
    let mut montage: Vec<MontageColumn> = Vec::new();
    println!(
        "{:<6} {:>8} {:>8} {:>8} {:>8} {:>10} {:>10} {:>8} {:>6}",
        "method", "T_E", "T_L", "T_S", "ΣT", "RMSE", "relMSE", "bias", "dots"
    );
    for (i, &m) in args.methods.iter().enumerate() {
        let spinner = ProgressBar::new_spinner().with_message(format!(
            "rendering {} ({} of {})",
            m.name(),
            i + 1,
            args.methods.len()
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(100));
        let r = render_method(&scene, m, &settings, budget)?;
        spinner.finish_and_clear();
        let t = r.timings;
        let row = CompareRow {
            t_eye: t.t_eye + t.t_direct,
            t_light: t.t_light,
            t_splat: t.t_splat + t.t_resolve,
            t_total: t.total(),
            rmse: rmse(&r.film.rgb, &reference),
            relmse: raysplat::film::rel_mse(&r.film.rgb, &reference),
            mean_bias: mean_bias(&r.film.rgb, &reference),
            dots: bright_dots(&r.film.rgb, &reference, settings.width, settings.height),
            photons: r.photons,
            passes: r.passes,
            estimated_relmse: r.film.estimate.as_ref().map(|e| e.rel_mse),
            smoothness_c: r.smoothness_c,
        };
        println!(
            "{:<6} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>10.5} {:>10.5} {:>+7.2}% {:>6}",
            m.name(),
            row.t_eye,
            row.t_light,
            row.t_splat,
            row.t_total,
            row.rmse,
            row.relmse,
            row.mean_bias * 100.0,
            row.dots
        );
        if let Some(e) = row.estimated_relmse {
            // The method's name: the line follows its row, and pt has no C.
            let c = if m == MethodKind::Pt {
                String::new()
            } else {
                format!(", C {:.3}", row.smoothness_c)
            };
            println!(
                "{:<6} estimated relMSE {e:.5} from its own passes{c}",
                m.name()
            );
        }
        r.film
            .write_exr(&args.out_dir.join(format!("{}.exr", m.name())))
            .map_err(CliError::Output)?;
        raysplat::film::write_png(
            &args.out_dir.join(format!("{}_error.png", m.name())),
            settings.width,
            settings.height,
            &error_map(&r.film.rgb, &reference),
        )
        .map_err(CliError::Output)?;
        rows.insert(
            m.name().to_string(),
            serde_json::to_value(&row).map_err(|e| e.to_string())?,
        );
        montage.push(MontageColumn {
            image: tonemapped(&r.film.rgb),
            error: error_map(&r.film.rgb, &reference),
        });
    }
    montage.push(MontageColumn {
        image: tonemapped(&reference),
        error: vec![255; (settings.width * settings.height * 3) as usize],
    });
    write_montage(
        &args.out_dir.join("montage.jpg"),
        settings.width,
        settings.height,
        &montage,
    )
    .map_err(CliError::Output)?;
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
    )
    .map_err(CliError::Output)?;
    eprintln!("wrote {} and the images beside it", path.display());
    Ok(())
}

/// The reference's pixels: `--reference` (which must have the comparison's size), or the path
/// tracer at `--ref-spp` with its own seed, written to reference.exr.
fn reference(
    args: &CompareArgs,
    scene: &Arc<Scene>,
    settings: &RenderSettings,
) -> Result<Vec<Vec3>, CliError> {
    if let Some(path) = &args.reference {
        let (w, h, px) = raysplat::film::read_exr(path).map_err(CliError::Input)?;
        if (w, h) != (settings.width, settings.height) {
            return Err(CliError::Input(format!(
                "{}: the reference is {w}×{h}, the comparison {}×{}",
                path.display(),
                settings.width,
                settings.height
            )));
        }
        return Ok(px);
    }
    // One path per pixel per step (the same paths as one call of ref_spp), so that the bar
    // can show progress and an ETA.
    let reference_settings = RenderSettings {
        seed: settings.seed ^ 0x5eed,
        pt_spp: 1,
        method: MethodKind::Pt,
        ..settings.clone()
    };
    let bar = ProgressBar::new(args.ref_spp as u64).with_style(
        ProgressStyle::with_template(
            "{spinner} reference: path tracing [{bar:30}] {pos}/{len} spp {elapsed_precise} (ETA {eta})",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    let mut pt = methods::build(scene.clone(), reference_settings)?;
    methods::run(pt.as_mut(), Budget::Passes(args.ref_spp as u64), |m| {
        bar.set_position(m.passes());
        !super::interrupt_flag().load(std::sync::atomic::Ordering::Relaxed)
    });
    bar.finish_and_clear();
    if super::interrupt_flag().load(std::sync::atomic::Ordering::Relaxed) {
        eprintln!("interrupted while rendering the reference; nothing written");
        std::process::exit(130);
    }
    let r = methods::finish(pt.as_mut());
    let path = args.out_dir.join("reference.exr");
    r.film.write_exr(&path).map_err(CliError::Output)?;
    eprintln!("wrote {} ({:.1} s)", path.display(), r.timings.total());
    Ok(r.film.rgb)
}

/// Images side by side (top row) over their error maps (bottom row), as a JPEG.
fn write_montage(
    path: &Path,
    width: u32,
    height: u32,
    columns: &[MontageColumn],
) -> Result<(), String> {
    let gap = 4;
    let cols = columns.len() as u32;
    let mut img = image::RgbImage::from_pixel(
        cols * width + (cols - 1) * gap,
        2 * height + gap,
        image::Rgb([255, 255, 255]),
    );
    for (c, column) in columns.iter().enumerate() {
        for (row, px) in [&column.image, &column.error].into_iter().enumerate() {
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
