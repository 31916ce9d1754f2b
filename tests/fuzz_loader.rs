//! An in-tree mutation fuzzer for glTF/GLB loading (cargo-fuzz needs a nightly toolchain, which
//! this project's machines cannot fetch). Seeds: the project's generated scenes, a small test
//! scene, and the same as glTF JSON with an embedded buffer. Mutations: bit flips, interesting
//! bytes and words (0, ~0, NaN, ±Inf, huge floats), truncation, insertion, duplication, and
//! JSON-aware edits (a number replaced by an extreme value, a key removed). Every mutant is
//! loaded under `catch_unwind`; what loads is rendered tiny with splatting and path tracing and
//! must have no NaN pixel. Runs for `RAYSPLAT_FUZZ_SECONDS` (default 60 s; `.ci/run` keeps the
//! default) from seed `RAYSPLAT_FUZZ_SEED`; failures are written to
//! `target/tmp/fuzz-failures/` for turning into regression tests.

mod common;

use common::glb::{base64, join, small_scene, split};
use raysplat::methods::{Budget, render_method};
use raysplat::sampling::Rng;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::settings::{MethodKind, RenderSettings};
use serde_json::{Value, json};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn seeds() -> Vec<Vec<u8>> {
    let mut s = vec![small_scene()];
    for b in BuiltinScene::ALL {
        s.push(b.to_glb());
    }
    // glTF JSON with the buffer as a base64 data URI.
    let (mut json, bin) = split(&small_scene());
    json["buffers"][0] = json!({
        "byteLength": bin.len(),
        "uri": format!("data:application/octet-stream;base64,{}", base64(&bin)),
    });
    s.push(serde_json::to_vec(&json).unwrap());
    s
}

const WORDS: [u32; 9] = [
    0,
    u32::MAX,
    0x7fc0_0000, // NaN
    0x7f80_0000, // +Inf
    0xff80_0000, // −Inf
    0x7149_f2ca, // 1e30
    0x8000_0000,
    0x0000_ffff,
    0x0010_0000,
];

fn extreme_number(rng: &mut Rng) -> Value {
    match rng.next_u32() % 10 {
        0 => json!(0),
        1 => json!(-1),
        2 => json!(1e9),
        3 => json!(4294967296u64),
        4 => json!(-1e30),
        5 => json!(1e38),
        6 => json!(0.5),
        7 => json!(7),
        8 => json!(65535),
        _ => json!(1e-30),
    }
}

/// Visit every node of a JSON value; `f` may replace the one at the chosen index.
fn mutate_json(v: &mut Value, target: &mut i64, rng: &mut Rng) {
    if *target < 0 {
        return;
    }
    *target -= 1;
    if *target < 0 {
        match v {
            Value::Number(_) | Value::Bool(_) | Value::Null => *v = extreme_number(rng),
            Value::Array(a) if !a.is_empty() => {
                let i = rng.next_u32() as usize % a.len();
                if rng.next_u32().is_multiple_of(2) {
                    a.remove(i);
                } else {
                    let dup = a[i].clone();
                    a.push(dup);
                }
            }
            Value::Object(o) if !o.is_empty() => {
                let k = o
                    .keys()
                    .nth(rng.next_u32() as usize % o.len())
                    .unwrap()
                    .clone();
                o.remove(&k);
            }
            _ => *v = extreme_number(rng),
        }
        return;
    }
    match v {
        Value::Array(a) => {
            for x in a {
                mutate_json(x, target, rng);
            }
        }
        Value::Object(o) => {
            for (_, x) in o.iter_mut() {
                mutate_json(x, target, rng);
            }
        }
        _ => {}
    }
}

fn count_nodes(v: &Value) -> i64 {
    1 + match v {
        Value::Array(a) => a.iter().map(count_nodes).sum(),
        Value::Object(o) => o.values().map(count_nodes).sum(),
        _ => 0,
    }
}

fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    let rounds = 1 + rng.next_u32() % 3;
    for _ in 0..rounds {
        if b.is_empty() {
            break;
        }
        let at = rng.next_u32() as usize % b.len();
        match rng.next_u32() % 8 {
            0 => {
                for _ in 0..1 + rng.next_u32() % 8 {
                    let i = rng.next_u32() as usize % b.len();
                    b[i] ^= 1 << (rng.next_u32() % 8);
                }
            }
            1 => b[at] = [0u8, 0xff, 0x7f, 0x80][rng.next_u32() as usize % 4],
            2 if at + 4 <= b.len() => {
                let w = WORDS[rng.next_u32() as usize % WORDS.len()];
                b[at..at + 4].copy_from_slice(&w.to_le_bytes());
            }
            3 => b.truncate(at),
            4 => {
                let n = rng.next_u32() as usize % 16;
                let ins: Vec<u8> = (0..n).map(|_| rng.next_u32() as u8).collect();
                b.splice(at..at, ins);
            }
            5 => {
                let n = (rng.next_u32() as usize % 64).min(b.len() - at);
                let dup = b[at..at + n].to_vec();
                b.splice(at..at, dup);
            }
            _ => {
                // JSON-aware: on a GLB edit the JSON chunk; on JSON edit the text.
                let is_glb = b.starts_with(b"glTF") && b.len() >= 20;
                let parsed = if is_glb {
                    catch_unwind(|| split(&b)).ok()
                } else {
                    serde_json::from_slice::<Value>(&b)
                        .ok()
                        .map(|j| (j, Vec::new()))
                };
                if let Some((mut j, bin)) = parsed {
                    let mut target = (rng.next_u32() as i64) % count_nodes(&j);
                    mutate_json(&mut j, &mut target, rng);
                    b = if is_glb {
                        join(&j, &bin)
                    } else {
                        serde_json::to_vec(&j).unwrap()
                    };
                }
            }
        }
    }
    b
}

/// Load and, if it loads and is small, render; Err describes a failure.
fn check(bytes: &[u8]) -> Result<bool, String> {
    let loaded = catch_unwind(AssertUnwindSafe(|| Scene::from_glb_bytes(bytes, "mutant")))
        .map_err(|_| "loading panicked".to_string())?;
    let Ok(scene) = loaded else {
        return Ok(false);
    };
    if scene.triangle_count() > 5_000 {
        return Ok(true);
    }
    let scene = Arc::new(scene);
    catch_unwind(AssertUnwindSafe(|| -> Result<(), String> {
        common::renders_cleanly(scene.clone())?;
        let pt = render_method(
            &scene,
            MethodKind::Pt,
            &RenderSettings {
                pt_spp: 1,
                ..common::tiny_settings()
            },
            Budget::Fixed,
        )
        .map_err(|e| e.to_string())?;
        if pt.film.invalid_pixels() > 0 {
            return Err("NaN or infinite pixels (pt)".into());
        }
        Ok(())
    }))
    .map_err(|_| "rendering panicked".to_string())?
    .map(|_| true)
}

#[test]
fn fuzz_the_loader() {
    let secs: u64 = std::env::var("RAYSPLAT_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let seed: u64 = std::env::var("RAYSPLAT_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    // Panics inside are caught and reported; keep their messages off the test output.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let corpus = seeds();
    let start = Instant::now();
    let (mut runs, mut loaded) = (0u64, 0u64);
    let mut failures = Vec::new();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
    while start.elapsed() < Duration::from_secs(secs) && failures.len() < 10 {
        let mut rng = Rng::new(seed, runs);
        let base = &corpus[rng.next_u32() as usize % corpus.len()];
        let mutant = mutate(base, &mut rng);
        match check(&mutant) {
            Ok(true) => loaded += 1,
            Ok(false) => {}
            Err(e) => {
                std::fs::create_dir_all(&dir).unwrap();
                let path = dir.join(format!("seed{seed}-run{runs}.glb"));
                std::fs::write(&path, &mutant).unwrap();
                failures.push(format!("run {runs}: {e} ({})", path.display()));
            }
        }
        runs += 1;
    }
    std::panic::set_hook(hook);
    eprintln!(
        "fuzz: {runs} mutants in {secs} s, {loaded} loaded, {} failures",
        failures.len()
    );
    assert!(runs > 100, "only {runs} mutants in {secs} s");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
