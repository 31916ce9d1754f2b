//! The command line: a render writes its files and stats; bad scenes give one clear line and a
//! non-zero exit, never a panic.

mod common;

use glam::Vec3;
use raysplat::scene::{BuiltinScene, GlbBuilder};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raysplat"))
}

/// Run `bench` with `args` and `--json` into `dir`, assert that it succeeded, and return the
/// JSON it wrote.
fn bench_json(args: &[&str], dir: &Path) -> serde_json::Value {
    let json = dir.join("bench.json");
    let out = bin()
        .arg("bench")
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    succeeded(&out);
    serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
}

/// Assert that a run of the binary succeeded, showing its stderr if not.
fn succeeded(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Run `render` on a bad file: it must fail with exactly one line naming the file.
fn expect_clean_error(path: &Path, keyword: &str) {
    let out = bin()
        .args(["render", path.to_str().unwrap(), "--out"])
        .arg(tmp("never.exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "{}: exit status {:?}",
        path.display(),
        out.status
    );
    assert!(
        !stderr.contains("panicked"),
        "{}: panicked: {stderr}",
        path.display()
    );
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "{}: expected one line, got: {stderr}",
        path.display()
    );
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(
        lines[0].contains(name),
        "error does not name the file: {stderr}"
    );
    assert!(
        lines[0].to_lowercase().contains(keyword),
        "error for {name} does not mention '{keyword}': {stderr}"
    );
}

#[test]
fn truncated_glb_is_a_clean_error() {
    let bytes = BuiltinScene::CornellClassic.to_glb();
    let path = tmp("truncated.glb");
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    expect_clean_error(&path, "truncated or corrupt");
}

#[test]
fn out_of_range_indices_are_a_clean_error() {
    let mut g = GlbBuilder::default();
    let m = g.material(json!({"emissiveFactor": [1.0, 1.0, 1.0]}));
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
    g.mesh("bad", &p, &[Vec3::Z; 3], &[0, 1, 999], m);
    let path = tmp("bad_indices.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    expect_clean_error(&path, "index 999 is out of range");
}

#[test]
fn nan_positions_are_a_clean_error() {
    let mut g = GlbBuilder::default();
    let m = g.material(json!({"emissiveFactor": [1.0, 1.0, 1.0]}));
    let p = [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y];
    g.mesh("nan", &p, &[Vec3::Z; 3], &[0, 1, 2], m);
    let path = tmp("nan_positions.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    expect_clean_error(&path, "nan");
}

/// A file with no light of its own renders under the uniform environment, and stderr says
/// so in one line; the environment flags are checked before anything is rendered.
#[test]
fn scene_without_lights_renders_under_the_uniform_environment() {
    let mut g = GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 1.0, m);
    let path = tmp("no_lights.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    let exr = tmp("no_lights.exr");
    let small = ["--width", "16", "--height", "16", "--photons", "2000"];
    let out = bin()
        .args(["render", path.to_str().unwrap(), "--out"])
        .arg(&exr)
        .args(small)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let notes: Vec<&str> = stderr.lines().filter(|l| l.contains("no light")).collect();
    assert_eq!(notes.len(), 1, "{stderr}");
    assert!(notes[0].contains("uniform environment"), "{stderr}");
    assert!(exr.exists());
    // Asked for, a sky and a sun: no note.
    let out = bin()
        .args(["render", path.to_str().unwrap(), "--out"])
        .arg(&exr)
        .args(small)
        .args([
            "--environment",
            "sky",
            "--sun",
            "30,40",
            "--env-rotation",
            "-90",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("no light"), "{stderr}");
    // Out of range or unreadable: one line, nothing rendered.
    for (args, keyword) in [
        (vec!["--env-strength", "-1"], "env-strength"),
        (vec!["--env-rotation", "400"], "env-rotation"),
        (vec!["--sun", "100,0"], "elevation"),
        (vec!["--sun", "30"], "elevation,azimuth"),
        (vec!["--environment", "/nonexistent/sky.hdr"], "sky.hdr"),
        (vec!["--environment", "none"], "no light"),
    ] {
        let out = bin()
            .args(["render", path.to_str().unwrap(), "--out"])
            .arg(tmp("never.exr"))
            .args(small)
            .args(&args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            stderr.to_lowercase().contains(keyword),
            "{args:?}: {stderr}"
        );
        assert!(!tmp("never.exr").exists());
    }
}

#[test]
fn missing_file_is_a_clean_error() {
    expect_clean_error(&tmp("does_not_exist.glb"), "cannot read");
}

#[test]
fn render_writes_images_and_stats() {
    let (exr, png, stats) = (tmp("r.exr"), tmp("r.png"), tmp("r.json"));
    for p in [&exr, &png, &stats] {
        let _ = std::fs::remove_file(p);
    }
    let out = bin()
        .args([
            "render",
            "--width",
            "48",
            "--height",
            "40",
            "--spp",
            "1",
            "--photons",
            "5000",
        ])
        .arg("--out")
        .arg(&exr)
        .arg("--png")
        .arg(&png)
        .arg("--stats")
        .arg(&stats)
        .output()
        .unwrap();
    succeeded(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("T_E") && stdout.contains("T_S"), "{stdout}");
    let (w, h, px) = raysplat::film::read_exr(&exr).unwrap();
    assert_eq!((w, h), (48, 40));
    assert!(px.iter().all(|c| c.is_finite()));
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (48, 40));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    // The memory breakdown (docs/benchmarks.md, "Memory"): every part present, the total their
    // sum.
    let mem = &j["memory"];
    let parts = [
        "eye_samples",
        "splat_targets",
        "splat_tree",
        "accumulators",
        "pixel_sums",
        "film",
        "scene",
    ];
    for part in parts {
        assert!(mem[part].as_u64().unwrap_or(0) > 0, "{part}: {mem}");
    }
    // A headless rs render frees its photon rays once splatted: the part is there, and 0.
    assert_eq!(mem["photon_rays"].as_u64(), Some(0), "{mem}");
    let sum: u64 = mem
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(j["memory_total_bytes"].as_u64(), Some(sum));
    for key in [
        "t_eye",
        "t_light",
        "t_splat",
        "t_total",
        "photons",
        "photon_rays",
        "eye_samples",
        "peak_rss_mb",
        "tested_pairs",
        "accepted_pairs",
        "glossy_map_samples",
        "glossy_traced_samples",
    ] {
        assert!(j[key].is_number(), "stats lack {key}: {j}");
    }
    // Eye samples exist where camera rays reach a diffuse surface (most of the 48×40 pixels).
    let eye = j["eye_samples"].as_u64().unwrap();
    assert!((1000..=2 * 48 * 40).contains(&eye), "{eye} eye samples");
    assert!(j["accepted_pairs"].as_u64().unwrap() <= j["tested_pairs"].as_u64().unwrap());
    assert!(j["photon_rays"].as_u64().unwrap() > 0);
}

#[test]
fn bad_parameters_are_refused() {
    let out = bin().args(["render", "--s", "1.5"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--s"));
}

/// A small render with `extra` arguments; asserts success and returns its stats.
fn render_stats(name: &str, extra: &[&str]) -> serde_json::Value {
    let stats = tmp(&format!("{name}.json"));
    let out = bin()
        .args([
            "render",
            "--width",
            "32",
            "--height",
            "32",
            "--spp",
            "1",
            "--photons",
            "4000",
        ])
        .args(extra)
        .arg("--out")
        .arg(tmp(&format!("{name}.exr")))
        .arg("--stats")
        .arg(&stats)
        .output()
        .unwrap();
    succeeded(&out);
    serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap()
}

#[test]
fn time_budget_renders_progressive_batches() {
    let j = render_stats("budget", &["--time-budget", "1.0", "--threads", "2"]);
    // Batches of 4,000 photons at 32×32 take milliseconds: a one-second budget runs many.
    assert!(j["batches"].as_u64().unwrap() >= 3, "{j}");
    assert_eq!(j["threads"], 2);
    let per_batch = 4000 * 7 / 10; // indirect + caustic fractions with NEE
    assert!(j["photon_rays"].as_u64().unwrap() >= 3 * per_batch as u64 - 3);
}

#[test]
fn compare_writes_table_images_and_json() {
    let dir = tmp("compare_out");
    let _ = std::fs::remove_dir_all(&dir);
    let out = bin()
        .args([
            "compare",
            "builtin:classic",
            "--width",
            "24",
            "--height",
            "24",
            "--spp",
            "1",
        ])
        .args([
            "--photons",
            "5000",
            "--ref-spp",
            "16",
            "--pt-spp",
            "2",
            "--methods",
            "rs,pm,pt",
        ])
        .arg("--out-dir")
        .arg(&dir)
        .output()
        .unwrap();
    succeeded(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("relMSE") && stdout.contains("pm"),
        "{stdout}"
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("compare.json")).unwrap()).unwrap();
    for m in ["rs", "pm", "pt"] {
        for key in ["t_eye", "t_light", "t_splat", "t_total", "rmse", "relmse"] {
            assert!(j["methods"][m][key].is_number(), "{m}.{key} missing: {j}");
        }
        assert!(dir.join(format!("{m}.exr")).exists());
        let err = image::open(dir.join(format!("{m}_error.png"))).unwrap();
        assert_eq!((err.width(), err.height()), (24, 24));
    }
    assert!(dir.join("reference.exr").exists());
    // Fig. 10's montage: three methods and the reference side by side (4 px gaps), images
    // over error maps.
    let montage = image::open(dir.join("montage.jpg")).unwrap();
    assert_eq!(
        (montage.width(), montage.height()),
        (4 * 24 + 3 * 4, 2 * 24 + 4)
    );
}

#[test]
fn fractions_take_three_comma_separated_numbers() {
    let j = render_stats(
        "fractions",
        &["--fractions", "0.5,0.5,0.0", "--direct", "photons"],
    );
    assert_eq!(j["photon_rays_caustic"], 0);
    assert!(j["photon_rays_direct"].as_u64().unwrap() >= 2000);
    let bad = bin()
        .args(["render", "--fractions", "0.5,0.5"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("three numbers"));
}

/// `bench --preview-scene`: the previewer's rows on another scene, lit as `--environment`
/// says, named `preview_…@NAME` and carrying the scene's name (here the room lit through a
/// window under the uniform sky: every latency row, each a positive time, none under the
/// default names). Read before any row runs: a scene or an environment that cannot be read is
/// one `error:` line and exit status 3; environment flags without the scene, or the scene
/// with `--only` leaving the preview rows out, are refused (exit 2).
#[test]
fn bench_preview_rows_on_another_scene() {
    let dir = tmp("bench_preview_scene");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let refused = |args: &[&str], code: i32| {
        let out = bin().arg("bench").args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
        assert_eq!(
            err.lines().filter(|l| l.starts_with("error:")).count(),
            1,
            "{args:?}: {err}"
        );
        assert!(out.stdout.is_empty(), "{args:?}: a row ran");
    };
    refused(&["--preview-scene", "no/such/scene.glb"], 3);
    let no_map = [
        "--preview-scene",
        "builtin:room",
        "--environment",
        "no/such.hdr",
    ];
    refused(&no_map, 3);
    refused(&["--only", "preview", "--environment", "sky"], 2);
    refused(&["--only", "glossy", "--preview-scene", "builtin:room"], 2);
    let doc = bench_json(
        &[
            "--only",
            "preview",
            "--runs",
            "1",
            "--preview-scene",
            "builtin:room",
            "--environment",
            "uniform",
        ],
        &dir,
    );
    let room = raysplat::scene::Scene::builtin(raysplat::scene::BuiltinScene::WindowRoom).name;
    for row in [
        "first_image",
        "resplat",
        "resplat_full",
        "camera",
        "running_camera",
        "running_camera_max",
        "split_camera",
        "split_camera_max",
    ] {
        let r = &doc["rows"][format!("preview_{row}_ms@room")];
        assert!(r["ms"].as_f64().is_some_and(|ms| ms > 0.0), "{row}: {r}");
        assert_eq!(r["scene"], json!(room), "{row}: {r}");
        assert!(
            doc["rows"].get(format!("preview_{row}_ms")).is_none(),
            "{row} without @room"
        );
    }
}

/// `bench`'s quality-over-time rows (docs/benchmarks.md): without references `--only quality` is
/// one clean line, a missing reference says how to make it, and with three (here constant) 500×500
/// references a one-second run writes one row per scene and view (window and path-traced view, each
/// with a relMSE at 1 s) and the plot as a PNG.
#[test]
fn bench_quality_rows_and_plot() {
    let dir = tmp("bench_quality");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = bin().args(["bench", "--only", "quality"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--quality-references"), "{err}");
    let out = bin()
        .args(["bench", "--only", "quality", "--quality-references"])
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("raysplat render builtin:classic"),
        "{err}"
    );
    for stem in ["classic", "cornell1", "cornell2"] {
        raysplat::film::write_exr(
            &dir.join(format!("{stem}.exr")),
            500,
            500,
            &vec![Vec3::splat(0.5); 500 * 500],
        )
        .unwrap();
    }
    let refs = dir.to_str().unwrap();
    let quality = ["--only", "quality", "--quality-seconds", "1"];
    let doc = bench_json(
        &[&quality[..], &["--quality-references", refs]].concat(),
        &dir,
    );
    for stem in ["classic", "cornell1", "cornell2"] {
        for view in ["window", "pt_view"] {
            let row = &doc["rows"][format!("quality_{stem}_{view}")];
            assert_eq!(row["seconds"], json!([1.0]), "{stem} {view}: {row}");
            assert_eq!(row["rel_mse"].as_array().map(Vec::len), Some(1), "{row}");
        }
    }
    assert!(
        doc["rows"].get("cornell1_rs").is_none(),
        "--only ran other rows"
    );
    let png = image::open(dir.join("quality.png")).unwrap();
    assert_eq!((png.width(), png.height()), (900, 560));
}

/// `--until-error` stops once the estimate from the render's own eye passes falls below the
/// threshold: exit status 0, the estimate (below it) and the flag in the stats JSON; and it
/// is refused for a method that has no eye passes to estimate from.
#[test]
fn until_error_stops_when_the_estimate_is_below_it() {
    let (out_path, stats) = (tmp("until_error.exr"), tmp("until_error.json"));
    let out = bin()
        .args([
            "render",
            "builtin:classic",
            "--width",
            "32",
            "--height",
            "32",
        ])
        .args(["--spp", "1", "--photons", "2000", "--until-error", "0.02"])
        .args(["--time-budget", "120", "--out"])
        .arg(&out_path)
        .arg("--stats")
        .arg(&stats)
        .output()
        .unwrap();
    succeeded(&out);
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(j["until_error_reached"], json!(true), "{j}");
    let e = j["estimated_rel_mse"].as_f64().unwrap();
    assert!(e > 0.0 && e < 0.02, "estimate {e}");
    // It stops only on an estimate of enough passes to act on.
    assert!(
        j["estimate_passes"].as_u64().unwrap() >= raysplat::film::estimate::TRUSTED_PASSES as u64
    );
    let out = bin()
        .args([
            "render",
            "builtin:classic",
            "--method",
            "pt",
            "--until-error",
            "0.02",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("need --method rs"), "{err}");
    // compare runs its methods to a budget: the threshold is render's argument alone (it ran
    // until interrupted without --time-budget, and ignored it with one), refused by the
    // argument parser.
    let out = bin()
        .args(["compare", "builtin:classic", "--until-error", "0.02"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unexpected argument '--until-error'"), "{err}");
    // A negative or infinite threshold is a value out of range, named as one (a negative
    // one was taken for a flag: "unexpected argument '-0'").
    for bad in ["-0.5", "inf"] {
        let out = bin()
            .args(["render", "builtin:classic", "--until-error", bad])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--until-error must be a finite relMSE above 0"),
            "{bad}: {err}"
        );
    }
}

/// Every built-in scene is named in the help of the commands that open one (the window's
/// help listed five of the eight).
#[test]
fn help_names_every_builtin_scene() {
    for args in [&["--help"][..], &["view", "--help"], &["render", "--help"]] {
        let out = bin().args(args).output().unwrap();
        succeeded(&out);
        let text = String::from_utf8_lossy(&out.stdout);
        for scene in raysplat::scene::BuiltinScene::ALL {
            let name = format!("builtin:{}", scene.key());
            assert!(text.contains(&name), "{args:?} lacks {name}");
        }
    }
}
