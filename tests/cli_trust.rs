//! The command line a user can trust: one test per promise (docs/testing.md, `cli_trust::*`). Each
//! asserts the exit status, the one-line message, and that no input or unrelated file changed.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raysplat"))
}

/// A fresh folder for one test.
fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli_trust")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str], cwd: &Path) -> Output {
    bin().args(args).current_dir(cwd).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The `--stats s.json` a run wrote into `d`.
fn stats(d: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap()
}

/// Refused before any work: a non-zero exit, no panic, the first line names `flag` (and
/// `also`), nothing rendered (no timing table) and nothing written into `cwd`.
fn refused(args: &[&str], flag: &str, also: &str) {
    let d = dir(&format!(
        "refused_{}",
        flag.trim_start_matches('-').replace(['/', '.', ' '], "_")
    ));
    let o = run(args, &d);
    let e = stderr(&o);
    assert!(!o.status.success(), "{args:?} succeeded: {e}");
    assert!(!e.contains("panicked"), "{args:?} panicked: {e}");
    let first = e.lines().next().unwrap_or("");
    assert!(
        first.contains(flag) && first.contains(also),
        "{args:?}: the first line does not name {flag} and {also}: {e}"
    );
    assert!(
        !String::from_utf8_lossy(&o.stdout).contains("T_E"),
        "{args:?} rendered before refusing"
    );
    assert_eq!(
        std::fs::read_dir(&d).unwrap().count(),
        0,
        "{args:?} wrote files"
    );
}

/// A small linear EXR to tone-map.
fn small_exr(path: &Path) {
    let o = bin()
        .args(["render", "builtin:classic"])
        .args(SMALL)
        .arg("--out")
        .arg(path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

const SMALL: [&str; 8] = [
    "--width",
    "24",
    "--height",
    "24",
    "--spp",
    "1",
    "--photons",
    "2000",
];

/// The exit status tells a script what failed: 2 the flags, 3 an input, 4 an output (README,
/// "Exit status"). Each case fails before any work and prints one line.
#[test]
fn the_exit_status_says_what_failed() {
    let d = dir("status");
    std::fs::write(d.join("junk.glb"), b"not a scene").unwrap();
    let cases: [(&[&str], i32); 8] = [
        // The flags: clap's own refusals and the settings' checks alike.
        (&["render", "--c", "99"], 2),
        (&["render", "--fractions", "0,0,0"], 2),
        (&["render", "--spp", "100000"], 2),
        // An input: a missing or broken scene, an unknown built-in, a missing EXR.
        (&["render", "missing.glb"], 3),
        (&["render", "junk.glb"], 3),
        (&["render", "builtin:nope"], 3),
        (&["tonemap", "missing.exr", "out.png"], 3),
        // An output: a folder that cannot be made (a file stands in its way).
        (&["render", "builtin:classic", "--out", "junk.glb/x.exr"], 4),
    ];
    for (args, status) in cases {
        let o = run(args, &d);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(status), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        // One line of error (clap adds its pointer to --help below its own).
        assert!(e.starts_with("error: "), "{args:?}: {e}");
        let errors = e.lines().filter(|l| l.starts_with("error")).count();
        assert_eq!(errors, 1, "{args:?}: {e}");
    }
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
    assert_eq!(left.len(), 1, "only junk.glb stays: {left:?}");
}

#[test]
fn negative_numbers_are_values() {
    refused(
        &["render", "--exposure", "-2", "--c", "-1"],
        "--c",
        "0.05..=5",
    );
    let d = dir("negative");
    small_exr(&d.join("in.exr"));
    let o = run(&["tonemap", "in.exr", "o.png", "--exposure", "-2"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("o.png").exists());
    assert!(!d.join("-2").exists(), "wrote a file named -2");
}

#[test]
fn an_input_is_never_overwritten() {
    let d = dir("overwrite");
    small_exr(&d.join("a.exr"));
    let before = std::fs::read(d.join("a.exr")).unwrap();
    for args in [
        vec!["tonemap", "a.exr", "a.exr"],
        vec!["tonemap", "a.exr", "./a.png", "--exposure", "0"],
    ] {
        let o = run(&args, &d);
        if args[2] == "a.exr" {
            assert!(!o.status.success(), "{args:?}");
            assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
        }
        assert_eq!(std::fs::read(d.join("a.exr")).unwrap(), before);
    }
    // A render never writes over its scene file.
    std::fs::write(d.join("scene.glb"), b"not a scene").unwrap();
    let o = run(&["render", "scene.glb", "--out", "scene.glb"], &d);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("input"), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.join("scene.glb")).unwrap(), b"not a scene");
}

#[test]
fn the_format_follows_the_extension() {
    let d = dir("formats");
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--out", "o.png"]);
    let o = run(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(&std::fs::read(d.join("o.png")).unwrap()[..4], b"\x89PNG");
    assert!(
        !d.join("out.exr").exists(),
        "--out o.png also wrote out.exr"
    );
    // --png alone writes no EXR.
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--png", "p.png"]);
    let o = run(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("p.png").exists() && !d.join("out.exr").exists());
    small_exr(&d.join("x.exr"));
    let o = run(&["tonemap", "x.exr", "t.jpg"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(&std::fs::read(d.join("t.jpg")).unwrap()[..2], b"\xff\xd8");
    refused(
        &["render", "--out", "a.png", "--png", "a.png"],
        "a.png",
        "two outputs",
    );
    refused(&["render", "--png", "y.exr"], "--png y.exr", ".png or .jpg");
    refused(&["render", "--out", "o.tif"], "o.tif", "format");
}

#[test]
fn output_folders_are_checked_first() {
    refused(&["render", "--out", "/proc/x.exr"], "/proc", "");
    refused(&["render", "--stats", "/proc/x.json"], "/proc", "");
    // A missing folder is made.
    let d = dir("folders");
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--out", "missing/x.exr"]);
    let o = run(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("missing/x.exr").exists());
}

#[test]
fn a_mis_sized_reference_is_one_line() {
    let d = dir("bench_reference");
    small_exr(&d.join("small.exr"));
    let o = run(
        &["bench", "--runs", "1", "--cornell-reference", "small.exr"],
        &d,
    );
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.contains("small.exr") && e.contains("500"), "{e}");
}

/// With a budget far below one gathering pass, final gathering stops within the budget's
/// step (a band of rows): the stats show no completed pass, and the image is written.
#[test]
fn the_time_budget_bounds_final_gathering() {
    let d = dir("fg_budget");
    let o = run(
        &[
            "render",
            "--method",
            "pm-fg",
            "--width",
            "64",
            "--height",
            "64",
            "--spp",
            "2",
            "--photons",
            "20000",
            "--time-budget",
            "0.001",
            "--stats",
            "s.json",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j = stats(&d);
    assert_eq!(j["passes"], 0, "{j}");
    assert_eq!(j["partial"], true, "an unfinished pass must say so: {j}");
    assert!(stderr(&o).contains("partial"), "{}", stderr(&o));
    assert!(d.join("out.exr").exists());
}

#[test]
fn view_takes_what_render_takes() {
    for args in [
        vec!["view", "missing.glb"],
        vec!["missing.glb"],
        vec!["view", "builtin:nope"],
    ] {
        let d = dir("view");
        let o = run(&args, &d);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(3), "{args:?}: {e}");
        assert_eq!(e.lines().count(), 1, "{args:?}: {e}");
        assert!(e.contains(args[args.len() - 1].trim_start_matches("builtin:")));
    }
}

#[test]
fn fractions_are_normalised_and_the_help_shows_what_the_parser_takes() {
    let d = dir("fractions");
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--fractions", "3,6,1", "--stats", "s.json"]);
    let o = run(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = stats(&d);
    let f: Vec<f64> = j["settings"]["fractions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!((f[0] - 0.3).abs() < 1e-6 && (f[1] - 0.6).abs() < 1e-6 && (f[2] - 0.1).abs() < 1e-6);
    let total = j["photon_rays"].as_u64().unwrap();
    assert!(total <= 2000, "{total} photon rays for M = 2000");
    let help = String::from_utf8_lossy(&run(&["render", "--help"], &d).stdout).into_owned();
    assert!(help.contains("[default: 0.3,0.6,0.1]"), "{help}");
    let mut args = vec!["render"];
    args.extend(SMALL);
    args.extend(["--fractions", "0.3,0.6,0.1", "--out", "o.exr"]);
    assert!(run(&args, &d).status.success());
}

#[test]
fn every_numeric_flag_has_a_range() {
    for (args, flag) in [
        (vec!["render", "--threads", "0"], "--threads"),
        (vec!["render", "--nee-samples", "0"], "--nee-samples"),
        (vec!["render", "--pm-k", "0"], "--pm-k"),
        (vec!["render", "--cache-error=-1"], "--cache-error"),
        (vec!["render", "--filter-strength=-1"], "--filter-strength"),
        (vec!["render", "--time-budget=-1"], "--time-budget"),
        (vec!["render", "--time-budget", "nan"], "--time-budget"),
        (vec!["render", "--batches", "0"], "--batches"),
        (vec!["bench", "--runs", "0"], "--runs"),
        (
            vec!["tonemap", "a.exr", "b.png", "--exposure", "NaN"],
            "--exposure",
        ),
        (
            vec!["render", "--width", "4294967295", "--height", "2"],
            "--width",
        ),
        (vec!["render", "--spp", "4294967295"], "--spp"),
        (vec!["render", "--spp", "100"], "--spp"),
        (vec!["compare", "--ref-spp", "0"], "--ref-spp"),
        (vec!["render", "--width", "-5"], "--width"),
        (vec!["render", "--photons", "2.5"], "--photons"),
    ] {
        refused(&args, flag, "..=");
    }
}

/// `--batches N` renders exactly N batches (or path-tracing passes, within a --spp given
/// to the path tracer, here 4), and cannot be given with a time budget.
#[test]
fn batches_renders_exactly_that_many() {
    for (method, passes) in [("rs", 3), ("pt", 2)] {
        let d = dir(&format!("batches_{method}"));
        let n = passes.to_string();
        let args = [
            "render",
            "builtin:classic",
            "--method",
            method,
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            if method == "pt" { "4" } else { "1" },
            "--photons",
            "2000",
            "--batches",
            &n,
            "--out",
            "o.exr",
            "--stats",
            "s.json",
        ];
        let o = run(&args, &d);
        assert!(o.status.success(), "{}", stderr(&o));
        let j = stats(&d);
        assert_eq!(j["passes"], passes, "{method}: {j}");
    }
    let d = dir("batches_budget");
    let o = run(
        &[
            "render",
            "builtin:classic",
            "--batches",
            "2",
            "--time-budget",
            "1",
        ],
        &d,
    );
    assert!(
        !o.status.success(),
        "--batches with --time-budget must be refused"
    );
}

/// The path tracer under a time budget or a count of passes stops at a --spp given with it,
/// whichever comes first (it used to ignore --spp there), and its error estimate names no C
/// or eye passes, which it does not have.
#[test]
fn a_path_tracer_stops_at_the_given_spp_within_its_budget() {
    for budget in [["--time-budget", "120"], ["--batches", "9"]] {
        let d = dir(&format!("pt_cap{}", budget[0]));
        let mut args = vec![
            "render",
            "builtin:classic",
            "--method",
            "pt",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "3",
            "--out",
            "o.exr",
            "--stats",
            "s.json",
        ];
        args.extend(budget);
        let o = run(&args, &d);
        assert!(o.status.success(), "{}", stderr(&o));
        let j = stats(&d);
        assert_eq!(j["passes"], 3, "{budget:?}: {j}");
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains("estimated error"), "{out}");
        assert!(
            !out.contains("C 1.000") && !out.contains("eye passes"),
            "{out}"
        );
    }
    // Without --spp the budget alone decides: more than 3 passes in 9 batches.
    let d = dir("pt_uncapped");
    let o = run(
        &[
            "render",
            "builtin:classic",
            "--method",
            "pt",
            "--width",
            "16",
            "--height",
            "16",
            "--batches",
            "9",
            "--out",
            "o.exr",
            "--stats",
            "s.json",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let j = stats(&d);
    assert_eq!(j["passes"], 9, "{j}");
}

/// The help documents each numeric flag's range, the same range the parser holds it to.
#[test]
fn the_help_shows_every_range() {
    let d = dir("help_ranges");
    let help = String::from_utf8_lossy(&run(&["render", "--help"], &d).stdout).into_owned();
    for (flag, range) in [
        ("--width", "8..=4096"),
        ("--spp", "1..=1048576"),
        ("--photons", "100..=100000000"),
        ("--c", "0.05..=5"),
        ("--s", "0.01..=1"),
        ("--r", "0.01..=1"),
        ("--nee-samples", "1..=256"),
        ("--pm-k", "1..=100000"),
        ("--cache-error", "0.05..=2"),
        ("--time-budget", "0.001..=1000000"),
        ("--batches", "1..=1000000"),
        ("--threads", "1..=1024"),
    ] {
        let at = help
            .find(&format!("{flag} <"))
            .unwrap_or_else(|| panic!("{flag} missing from the help"));
        let entry = &help[at..];
        let end = entry[2..].find("\n      -").map_or(entry.len(), |e| e + 2);
        assert!(
            entry[..end].contains(&format!("[range: {range}]")),
            "{flag}: {}",
            &entry[..end]
        );
    }
}

#[test]
fn compare_lists_only_the_flags_it_uses() {
    let d = dir("compare_help");
    let help = String::from_utf8_lossy(&run(&["compare", "--help"], &d).stdout).into_owned();
    // The flags it defines: help lines that start with one.
    let flags: Vec<&str> = help
        .lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with("--"))
        .filter_map(|l| l.split([' ', '=']).next())
        .collect();
    for unused in ["--out", "--png", "--stats", "--method"] {
        assert!(!flags.contains(&unused), "compare --help lists {unused}");
    }
    for used in ["--methods", "--exposure", "--tonemap", "--out-dir"] {
        assert!(
            flags.contains(&used),
            "compare --help lacks {used}: {flags:?}"
        );
    }
}

/// `render --png` and `tonemap` of the same render's EXR give the same pixels: one curve and
/// one exposure meaning.
#[test]
fn one_tone_curve() {
    let d = dir("tone");
    for tone in ["aces", "clamp", "reinhard"] {
        let mut args = vec!["render"];
        args.extend(SMALL);
        args.extend([
            "--out",
            "r.exr",
            "--png",
            "r.png",
            "--exposure",
            "1",
            "--tonemap",
            tone,
        ]);
        let o = run(&args, &d);
        assert!(o.status.success(), "{}", stderr(&o));
        let o = run(
            &[
                "tonemap",
                "r.exr",
                "t.png",
                "--exposure",
                "1",
                "--tonemap",
                tone,
            ],
            &d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let a = image::open(d.join("r.png")).unwrap().to_rgb8();
        let b = image::open(d.join("t.png")).unwrap().to_rgb8();
        assert_eq!(a.as_raw(), b.as_raw(), "{tone}: two tone curves");
    }
}

/// Ctrl-C during a long render writes the image so far, marks the stats partial, exits 130.
#[test]
fn ctrl_c_writes_the_image_so_far() {
    let d = dir("ctrl_c");
    let mut child = bin()
        .args([
            "render",
            "--width",
            "48",
            "--height",
            "48",
            "--spp",
            "1",
            "--photons",
            "5000",
            "--time-budget",
            "60",
            "--out",
            "o.exr",
            "--stats",
            "s.json",
        ])
        .current_dir(&d)
        .spawn()
        .unwrap();
    // Wait until it renders (the progress bar is not a file: poll for a while, then signal).
    std::thread::sleep(std::time::Duration::from_millis(2500));
    // The shell's own `kill`, so that no procps package is needed.
    let killed = Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(d.join("o.exr").exists());
    let j = stats(&d);
    assert_eq!(j["partial"], true);
    assert!(j["passes"].as_u64().unwrap() >= 1);
}

/// The default camera is the file's first, as the help says (SIBENIK and Sponza list their
/// classic view first); before, the node traversal made it the last.
#[test]
fn the_default_camera_is_the_first() {
    use glam::Vec3;
    use raysplat::scene::{GlbBuilder, Scene};
    let mut g = GlbBuilder::default();
    let m = g.material(serde_json::json!({"emissiveFactor": [1.0, 1.0, 1.0]}));
    g.mesh(
        "light",
        &[Vec3::ZERO, Vec3::X, Vec3::Y],
        &[Vec3::Z; 3],
        &[0, 1, 2],
        m,
    );
    for (i, name) in ["first", "second", "third"].iter().enumerate() {
        g.camera(name, Vec3::new(i as f32, 0.5, 3.0), Vec3::ZERO, 0.8);
    }
    let d = dir("cameras");
    let path = d.join("cameras.glb");
    std::fs::write(&path, g.to_glb()).unwrap();
    let scene = Scene::load(&path).unwrap();
    let names: Vec<&str> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["first", "second", "third"]);
    assert_eq!(scene.camera_or_error(None).unwrap().name, "first");
}
