//! The Khronos glTF-Validator's test files (../shared/gltf-validator, 372 files with the
//! validator's reports): whatever a file holds, loading it returns a scene or one clean line,
//! never a panic, a hang or an abort. (Skipped with a note where the folder is absent.)

use raysplat::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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
    let (mut loaded, mut refused) = (0, 0);
    for path in &all {
        let start = Instant::now();
        // Scene::load turns a dependency's panic into an error; a panic escaping it fails
        // this test with the file's name.
        let result = std::panic::catch_unwind(|| Scene::load(path))
            .unwrap_or_else(|_| panic!("{} panicked", path.display()));
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{} took {:?}",
            path.display(),
            start.elapsed()
        );
        match result {
            Ok(scene) => {
                assert!(scene.triangle_count() > 0);
                loaded += 1;
            }
            Err(e) => {
                let line = e.to_string();
                assert!(!line.contains('\n'), "{}: {line}", path.display());
                // The loader checks what the crate would index unchecked: no file of the set
                // reaches the last line of defence.
                assert!(
                    !line.contains("glTF reader failed"),
                    "{}: {line}",
                    path.display()
                );
                assert!(!line.is_empty());
                refused += 1;
            }
        }
    }
    eprintln!(
        "{} files: {loaded} loaded, {refused} refused with one line",
        all.len()
    );
    assert!(all.len() >= 300, "only {} files found", all.len());
}

/// The two files that crashed inside the `gltf` crate (an empty image object, a POSITION
/// accessor that does not exist): checked before the crate indexes, the command line prints
/// exactly one line and exits 1.
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
        assert_eq!(out.status.code(), Some(1), "{file}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{file}: {stderr}");
        assert!(
            stderr.contains(file.rsplit('/').next().unwrap()),
            "{stderr}"
        );
    }
}
