//! `render`: one scene headless to EXR (and PNG), with a progress bar, Table 2's timing row and
//! optional JSON stats.

use super::args::RenderArgs;
use super::error::CliError;
use super::output;
use super::{load_scene, set_threads};
use indicatif::{ProgressBar, ProgressStyle};
use raysplat::choice::Choice;
use raysplat::film::Film;
use raysplat::methods::{self, MethodStats, Timings, peak_rss_mb};
use raysplat::settings::MethodKind;
use serde_json::json;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Renders `args`' scene with its method and writes the files it asks for. Everything the
/// command line says is checked before the scene loads; Ctrl-C ends the render early, writes
/// the image so far (marked partial in the stats) and exits with status 130.
pub fn run(args: RenderArgs) -> Result<(), CliError> {
    let interrupted = super::interrupt_flag();
    let settings = args.settings().map_err(CliError::Usage)?;
    if let Some(png) = &args.output.png
        && output::Format::of(png).map_err(CliError::Output)? == output::Format::Exr
    {
        return Err(CliError::Output(format!(
            "--png {}: a tone-mapped image is .png or .jpg (use --out for an EXR)",
            png.display()
        )));
    }
    let images = args.output.images();
    let mut outputs: Vec<(&Path, bool)> = images.iter().map(|p| (p.as_path(), true)).collect();
    if let Some(stats) = &args.output.stats {
        outputs.push((stats.as_path(), false));
    }
    let scene_file = args
        .settings
        .scene
        .as_deref()
        .filter(|s| !s.starts_with("builtin:"))
        .map(Path::new);
    output::check(&outputs, scene_file.as_slice()).map_err(CliError::Output)?;
    set_threads(args.settings.run.threads)?;
    let t_load = Instant::now();
    let scene = Arc::new(load_scene(
        args.settings.scene.as_deref(),
        &args.settings.environment,
    )?);
    let t_load = t_load.elapsed().as_secs_f64();
    let time_budget = args.settings.run.time_budget;
    let progress = match time_budget {
        Some(b) => ProgressBar::new((b * 1000.0) as u64).with_style(
            ProgressStyle::with_template(
                "{spinner} {msg:24} [{bar:30}] {elapsed_precise} (ETA {eta})",
            )
            .expect("static template")
            .progress_chars("=> "),
        ),
        None => ProgressBar::new_spinner().with_style(
            ProgressStyle::with_template("{spinner} {msg:24} {elapsed_precise}")
                .expect("static template"),
        ),
    };
    progress.enable_steady_tick(Duration::from_millis(100));
    progress.set_message(format!("preparing ({})", settings.method.name()));
    let start = Instant::now();
    let mut m = methods::build(scene.clone(), settings)?;
    progress.set_message("rendering");
    let until = args.until_error;
    // The path tracer stops at a --spp given with its budget, if that comes first.
    let path_cap = (m.kind() == MethodKind::Pt)
        .then(|| args.settings.pt_path_cap())
        .flatten();
    let mut checked = Instant::now();
    let mut reached = false;
    methods::run(m.as_mut(), args.budget(), |m| {
        if let Some(b) = time_budget {
            let spent = start.elapsed().as_secs_f64();
            progress.set_position((spent * 1000.0).min(b * 1000.0) as u64);
        }
        progress.set_message(format!("pass {}", m.passes()));
        if path_cap.is_some_and(|cap| m.passes() >= cap) {
            return false;
        }
        // --until-error: the estimate is read from a film, made at most every
        // UNTIL_ERROR_CHECK (a resolve costs a fraction of a batch).
        if let Some(target) = until
            && checked.elapsed() >= UNTIL_ERROR_CHECK
        {
            checked = Instant::now();
            if let Some(e) = m.film().estimate {
                progress.set_message(format!("pass {}, est. relMSE {:.4}", m.passes(), e.rel_mse));
                // Only an estimate of enough passes to act on, as the window's pause and
                // --c auto (two passes' spread is itself too noisy to stop on).
                if e.trusted() && e.rel_mse < target {
                    reached = true;
                    return false;
                }
            }
        }
        !interrupted.load(Ordering::Relaxed)
    });
    let stopped = interrupted.load(Ordering::Relaxed);
    // A film that holds no complete unit of work: a gathering pass cut by the time budget.
    let partial = stopped || m.passes() == 0;
    progress.set_message("resolving");
    let film = m.final_film();
    progress.finish_and_clear();
    if stopped {
        eprintln!("interrupted: writing the image after {} passes", m.passes());
    } else if partial {
        eprintln!(
            "warning: the time budget ended inside the first pass; rows not gathered yet hold \
             direct light and caustics only (partial in the stats)"
        );
    }
    let stats = m.stats();
    print_table(&scene.name, m.kind(), m.timings(), &stats);
    if let Some(e) = &film.estimate {
        // The path tracer's estimate is its passes' spread; it has no eye passes or C.
        let from = if m.kind() == MethodKind::Pt {
            format!("{} passes", e.passes)
        } else {
            format!(
                "{} eye passes, C {:.3}{}",
                e.passes,
                m.settings().bandwidth.smoothness_c,
                if m.settings().auto_c {
                    " (chosen by --c auto)"
                } else {
                    ""
                }
            )
        };
        println!(
            "estimated error: relMSE {:.5} (bias² {:.5}, variance {:.5}) from {from}{}",
            e.rel_mse,
            e.bias2,
            e.variance,
            match until {
                Some(t) if reached => format!("; below --until-error {t}"),
                Some(t) => format!("; --until-error {t} not reached before the render ended"),
                None => String::new(),
            }
        );
    }
    let invalid = film.invalid_pixels();
    if invalid > 0 {
        eprintln!("warning: {invalid} pixels are NaN or infinite");
    }
    let tone = &args.output.tone;
    let stops = tone.exposure.stops(&film);
    let mut j = args
        .output
        .stats
        .as_ref()
        .map(|_| stats_json(&scene.name, m.as_ref(), &stats, &film, t_load));
    // The images are written without the render's eye side and stores beside them.
    drop(m);
    for path in &images {
        output::write_image(path, &film, stops, tone.tonemap).map_err(CliError::Output)?;
        eprintln!("wrote {}", path.display());
    }
    if let (Some(path), Some(j)) = (&args.output.stats, j.as_mut()) {
        j["partial"] = json!(partial);
        j["until_error"] = json!(until);
        j["until_error_reached"] = json!(until.map(|_| reached));
        j["exposure"] = json!(stops);
        j["environment"] = json!(scene.environment);
        // The peak so far, image writing included.
        j["peak_rss_mb"] = json!(peak_rss_mb());
        let bytes = serde_json::to_vec_pretty(&j).map_err(|e| e.to_string())?;
        raysplat::film::write_atomic(path, &bytes).map_err(CliError::Output)?;
        eprintln!("wrote {}", path.display());
    }
    if stopped {
        std::process::exit(130);
    }
    Ok(())
}

/// How often `--until-error` reads the estimate.
const UNTIL_ERROR_CHECK: Duration = Duration::from_millis(500);

/// Table 2's columns for one render, then the method's counters.
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
        "{}: photons traced {}, photon rays {}, eye samples {}, passes {}, accepted/tested pairs {}/{} ({:.2}), domain-tested/outside {}/{}, rays reaching an eye sample {}/{} ({:.1}%)",
        kind.name(),
        s.photons_traced,
        s.photon_rays,
        s.eye_samples,
        s.passes,
        s.accepted_pairs,
        s.tested_pairs,
        s.accepted_pairs as f64 / s.tested_pairs.max(1) as f64,
        s.domain_tests,
        s.occluded_pairs,
        s.rays_reaching,
        s.splat_rays,
        100.0 * s.rays_reaching as f64 / s.splat_rays.max(1) as f64
    );
}

/// The first `n` characters of `s`.
fn truncate(s: &str, n: usize) -> String {
    s.chars().take(n).collect()
}

/// `--stats`: the settings, timings and counters of a finished render.
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
                "at_floor": clamps[c].fraction_floor(),
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
        "eye_passes": s.eye_passes,
        "splat_targets": s.splat_targets,
        "splat_tree_nodes": s.splat_tree_nodes,
        "batches": s.passes,
        "passes": s.passes,
        "tested_pairs": s.tested_pairs,
        "accepted_pairs": s.accepted_pairs,
        "domain_tests": s.domain_tests,
        "occluded_pairs": s.occluded_pairs,
        "domains_reused": s.domains_reused,
        "domains_probed": s.domains_probed,
        "splat_rays": s.splat_rays,
        "rays_reaching": s.rays_reaching,
        "reaching_fraction": s.rays_reaching as f64 / s.splat_rays.max(1) as f64,
        "guided_emission": settings.guided_emission,
        "guide_batches": s.guide_batches,
        "peak_rss_mb": peak_rss_mb(),
        "memory": s.memory,
        "memory_total_bytes": s.memory.total(),
        "radiance_map": settings.radiance_map,
        "cache_records": s.cache_records,
        "cache_records_per_pass": s.cache_records_per_pass,
        "directional_bytes": s.directional_bytes,
        "glossy_map_samples": s.glossy_map_samples,
        "glossy_traced_samples": s.glossy_traced_samples,
        "glossy_targets": s.glossy_targets,
        "directional_bytes_per_glossy_target": s.directional_bytes as f64 / s.glossy_targets.max(1) as f64,
        "estimated_rel_mse": film.estimate.as_ref().map(|e| e.rel_mse),
        "estimated_bias2": film.estimate.as_ref().map(|e| e.bias2),
        "estimated_bias2_smooth": film.estimate.as_ref().map(|e| e.bias2_smooth),
        "estimated_variance": film.estimate.as_ref().map(|e| e.variance),
        "estimated_variance_splatted": film.estimate.as_ref().map(|e| e.variance_splatted),
        "estimated_variance_photons": film.estimate.as_ref().map(|e| e.variance_photons),
        "estimate_passes": film.estimate.as_ref().map(|e| e.passes),
        "smoothness_c": settings.bandwidth.smoothness_c,
        "invalid_pixels": film.invalid_pixels(),
        "invalid_contributions": film.invalid_contributions,
        "method": m.kind(),
        "pm": s.pm,
        "threads": rayon::current_num_threads(),
        "version": env!("CARGO_PKG_VERSION"),
    })
}
