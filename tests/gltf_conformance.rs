//! The Khronos glTF-Validator's test files (../shared/gltf-validator, 372 files, each with the
//! validator's report): every file the validator finds valid (`"numErrors": 0`) loads and
//! renders, or is refused only for a reason a valid file can have (see
//! [`ACCEPTED_REFUSALS_OF_VALID`]); every invalid file loads or gives one clean line; none
//! panics, hangs or aborts. (Skipped with a note where the folder is absent.)

mod common;

use raysplat::scene::{Scene, SceneError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Why a file the validator finds valid may still be refused: it has nothing to render (a file
/// without lights opens under the uniform environment).
const ACCEPTED_REFUSALS_OF_VALID: [&str; 1] = ["no triangles"];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "gltf" || x == "glb") {
            out.push(p);
        }
    }
}

/// The validator's error count for `path`, from the report next to it.
fn validator_errors(path: &Path) -> u64 {
    let mut report = path.as_os_str().to_owned();
    report.push(".report.json");
    let report = PathBuf::from(report);
    let text =
        std::fs::read_to_string(&report).unwrap_or_else(|e| panic!("{}: {e}", report.display()));
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["issues"]["numErrors"]
        .as_u64()
        .unwrap_or_else(|| panic!("{}: no issues.numErrors", report.display()))
}

#[test]
fn every_validator_file_loads_or_gives_one_clean_line() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-validator/test");
    let mut all = Vec::new();
    files(&root, &mut all);
    if all.is_empty() {
        eprintln!("note: {} not found; skipped", root.display());
        return;
    }
    all.sort();
    let mut valid_loaded = 0;
    let mut valid_refused: BTreeMap<&str, usize> = BTreeMap::new();
    let mut wrongly_refused = Vec::new();
    let (mut invalid_loaded, mut invalid_refused) = (0, 0);
    for path in &all {
        let name = path
            .strip_prefix(&root)
            .unwrap_or(path)
            .display()
            .to_string();
        let valid = validator_errors(path) == 0;
        let start = Instant::now();
        // Scene::load turns a dependency's panic into an error; a panic escaping it fails
        // this test with the file's name.
        let result = std::panic::catch_unwind(|| Scene::load(path))
            .unwrap_or_else(|_| panic!("{name} panicked"));
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{name} took {:?}",
            start.elapsed()
        );
        match result {
            Ok(scene) => {
                assert!(scene.triangle_count() > 0, "{name}");
                if valid {
                    if let Err(e) = common::renders_cleanly(Arc::new(scene)) {
                        panic!("{name} loads but does not render cleanly: {e}");
                    }
                    valid_loaded += 1;
                } else {
                    invalid_loaded += 1;
                }
            }
            Err(e) => {
                let line = e.to_string();
                assert!(!line.is_empty() && !line.contains('\n'), "{name}: {line}");
                // The loader checks what it follows: no file of the set reaches the last line
                // of defence.
                assert!(!line.contains("glTF reader failed"), "{name}: {line}");
                if !valid {
                    invalid_refused += 1;
                } else if let Some(reason) = ACCEPTED_REFUSALS_OF_VALID
                    .iter()
                    .find(|r| line.contains(*r))
                {
                    *valid_refused.entry(reason).or_default() += 1;
                } else {
                    wrongly_refused.push(format!("{name}: {line}"));
                }
            }
        }
    }
    let valid_total = valid_loaded + valid_refused.values().sum::<usize>() + wrongly_refused.len();
    eprintln!(
        "{} files; {valid_total} valid: {valid_loaded} loaded and rendered, refused {valid_refused:?}; {} invalid: {invalid_loaded} loaded, {invalid_refused} refused with one line",
        all.len(),
        all.len() - valid_total
    );
    assert!(
        wrongly_refused.is_empty(),
        "valid files refused:\n{}",
        wrongly_refused.join("\n")
    );
    assert!(all.len() >= 300, "only {} files found", all.len());
    assert!(valid_total >= 100, "only {valid_total} valid files found");
}

/// The two files that crashed inside the `gltf` crate (an empty image object, a POSITION
/// accessor that does not exist): the command line prints exactly one line and exits 3.
#[test]
fn files_that_crashed_the_gltf_crate_are_one_line() {
    let root =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-validator/test/base/data");
    for file in ["image/empty_object.gltf", "mesh/unresolved_positions.gltf"] {
        let path = root.join(file);
        if !path.exists() {
            eprintln!("note: {} not found; skipped", path.display());
            continue;
        }
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_raysplat"))
            .arg("render")
            .arg(&path)
            .arg("--out")
            .arg(Path::new(env!("CARGO_TARGET_TMPDIR")).join("never.exr"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        // Status 3: the input is at fault (README, "Exit status").
        assert_eq!(out.status.code(), Some(3), "{file}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{file}: {stderr}");
        assert!(
            stderr.contains(file.rsplit('/').next().unwrap()),
            "{stderr}"
        );
    }
}

/// The error's kind is what a caller branches on: a file that cannot be read, one that holds
/// no renderable scene, and (in-memory) bytes that are not glTF at all. Each names its file.
#[test]
fn a_load_error_says_which_kind() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scene_error_kinds");
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing.glb");
    let e = Scene::load(&missing).err().expect("a missing file loads");
    assert!(matches!(e, SceneError::Unreadable { .. }), "{e:?}");
    assert_eq!(e.file(), missing.display().to_string());
    // A folder is not a file either.
    let e = Scene::load(&dir).err().expect("a folder loads");
    assert!(matches!(e, SceneError::Unreadable { .. }), "{e:?}");
    let junk = dir.join("junk.glb");
    std::fs::write(&junk, b"not a scene").unwrap();
    let e = Scene::load(&junk).err().expect("junk loads");
    assert!(matches!(e, SceneError::Invalid { .. }), "{e:?}");
    assert!(
        e.to_string().starts_with(&junk.display().to_string()),
        "{e}"
    );
    let e = Scene::from_glb_bytes(b"glTF", "bytes")
        .err()
        .expect("4 bytes load");
    assert!(matches!(e, SceneError::Invalid { .. }), "{e:?}");
    assert_eq!(e.file(), "bytes");
}
