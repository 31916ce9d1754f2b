//! Bad input never takes raysplat down: hand-written malformed scenes (truncated files, missing
//! and wrong-sized buffers, bad accessors, out-of-range indices, NaN/Inf positions and normals,
//! degenerate triangles, zero-area and negative-strength lights, no lights (lit by the uniform
//! environment), no geometry, a
//! zero field of view, a million triangles) each give a clear one-line error or a sane render,
//! never a panic and never NaN in the output; NaN/Inf contributions are dropped and counted;
//! outputs are written atomically.

mod common;

use common::glb::{accessor_offset, join, put_f32, small_scene, split};
use glam::Vec3;
use raysplat::methods;
use raysplat::methods::{Budget, render_method};
use raysplat::scene::{GlbBuilder, Scene};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;

/// What loading and rendering a file gave.
#[derive(Debug)]
enum Outcome {
    /// A clear error (one line).
    Refused(String),
    /// Loaded and rendered without NaN; the load warnings.
    Rendered(Vec<String>),
}

/// Tiny renders with every method family: rs (both direct modes), pm, pt.
fn render_all(scene: Scene) {
    let scene = Arc::new(scene);
    let base = RenderSettings {
        width: 12,
        height: 12,
        spp: 1,
        photons: 3_000,
        pm_k: 20,
        pm_caustic_k: 10,
        ..RenderSettings::default()
    };
    for direct in [DirectMode::Nee, DirectMode::Photons] {
        let s = RenderSettings {
            direct,
            ..base.clone()
        };
        let mut r = methods::build(scene.clone(), s).expect("a loaded scene has a camera");
        r.step();
        let film = r.film();
        assert_eq!(film.invalid_pixels(), 0, "NaN/Inf pixels ({direct:?})");
    }
    for method in [MethodKind::Pm, MethodKind::Pt] {
        let r = render_method(
            &scene,
            method,
            &RenderSettings {
                pt_spp: 2,
                ..base.clone()
            },
            Budget::Fixed,
        )
        .unwrap();
        assert_eq!(r.film.invalid_pixels(), 0, "NaN/Inf pixels ({method:?})");
    }
}

/// Load `bytes` and render what loads; panics (failing the test) only on a panic inside.
fn outcome(bytes: &[u8]) -> Outcome {
    let loaded = catch_unwind(AssertUnwindSafe(|| {
        Scene::from_glb_bytes(bytes, "case.glb")
    }));
    match loaded {
        Err(_) => panic!("loading panicked"),
        Ok(Err(e)) => {
            let msg = e.to_string();
            assert!(
                !msg.is_empty() && !msg.contains('\n'),
                "unclear error: {msg:?}"
            );
            Outcome::Refused(msg)
        }
        Ok(Ok(scene)) => {
            let mut warnings = scene.warnings.clone();
            warnings.extend(scene.lighting_notice.clone());
            if catch_unwind(AssertUnwindSafe(|| render_all(scene))).is_err() {
                panic!("rendering a loaded scene panicked or produced NaN");
            }
            Outcome::Rendered(warnings)
        }
    }
}

/// A file left without a light of its own renders under the uniform environment and says so.
fn lit_by_environment(bytes: &[u8]) {
    match outcome(bytes) {
        Outcome::Rendered(w) => assert!(
            w.iter().any(|w| w.contains("no light of its own")),
            "no notice: {w:?}"
        ),
        Outcome::Refused(m) => panic!("expected a render under the environment, got: {m}"),
    }
}

fn refused(bytes: &[u8], needle: &str) {
    match outcome(bytes) {
        Outcome::Refused(m) => assert!(m.contains(needle), "expected '{needle}' in: {m}"),
        Outcome::Rendered(w) => panic!("expected a refusal with '{needle}', got a render ({w:?})"),
    }
}

fn edited(f: impl FnOnce(&mut serde_json::Value, &mut Vec<u8>)) -> Vec<u8> {
    let (mut json, mut bin) = split(&small_scene());
    f(&mut json, &mut bin);
    join(&json, &bin)
}

#[test]
fn the_small_scene_renders() {
    assert!(matches!(outcome(&small_scene()), Outcome::Rendered(_)));
}

#[test]
fn truncated_files_are_refused_at_every_length() {
    let glb = small_scene();
    for len in (0..glb.len()).step_by(37) {
        match outcome(&glb[..len]) {
            Outcome::Refused(_) => {}
            // A cut inside trailing padding can still be a whole file.
            Outcome::Rendered(_) => assert!(len + 4 >= glb.len(), "{len} of {}", glb.len()),
        }
    }
}

#[test]
fn buffers_missing_or_of_the_wrong_size_are_refused() {
    // The BIN chunk shorter than the buffer claims.
    let (json, bin) = split(&small_scene());
    refused(&join(&json, &bin[..bin.len() / 2]), "buffer");
    // A buffer view reaching past its buffer.
    refused(
        &edited(|j, _| j["bufferViews"][0]["byteLength"] = json!(1 << 30)),
        "",
    );
    // An external buffer that is not there.
    let dir = std::env::temp_dir().join(format!("raysplat-missing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (mut json, bin) = split(&small_scene());
    json["buffers"][0] = json!({"byteLength": bin.len(), "uri": "missing.bin"});
    let path = dir.join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    let e = Scene::load(&path)
        .err()
        .expect("a missing buffer is an error");
    assert!(e.to_string().contains("buffer"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_accessors_are_refused_or_skipped() {
    // More elements than the view holds.
    refused(
        &edited(|j, _| j["accessors"][0]["count"] = json!(1_000_000)),
        "",
    );
    // An offset past the end of the view.
    refused(
        &edited(|j, _| j["accessors"][2]["byteOffset"] = json!(4096)),
        "",
    );
    // Positions as bytes (not allowed by glTF), a type that does not exist, no buffer view.
    for edit in [
        json!({"componentType": 5121}),
        json!({"type": "MAT4"}),
        json!({"bufferView": null}),
    ] {
        let bytes = edited(|j, _| {
            for (k, v) in edit.as_object().unwrap() {
                if v.is_null() {
                    j["accessors"][0].as_object_mut().unwrap().remove(k);
                } else {
                    j["accessors"][0][k] = v.clone();
                }
            }
        });
        // Either refused, or the floor is unusable and the light alone renders.
        let _ = outcome(&bytes);
    }
}

#[test]
fn out_of_range_indices_are_refused() {
    let bytes = edited(|j, bin| {
        let at = accessor_offset(j, 2);
        bin[at..at + 4].copy_from_slice(&999u32.to_le_bytes());
    });
    refused(&bytes, "out of range");
}

#[test]
fn nan_and_infinite_positions_are_refused_and_normals_are_repaired() {
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let bytes = edited(|j, bin| put_f32(bin, accessor_offset(j, 0) + 4, v));
        refused(&bytes, "NaN or infinite position");
        // A bad normal falls back to the geometric normal.
        let bytes = edited(|j, bin| put_f32(bin, accessor_offset(j, 1), v));
        assert!(matches!(outcome(&bytes), Outcome::Rendered(_)));
    }
    // Positions so large that a cross product overflows f32.
    let bytes = edited(|j, bin| {
        let at = accessor_offset(j, 0);
        for k in 0..12 {
            let x = f32::from_le_bytes(bin[at + 4 * k..at + 4 * k + 4].try_into().unwrap());
            put_f32(bin, at + 4 * k, x * 1e25);
        }
    });
    let _ = outcome(&bytes);
}

#[test]
fn degenerate_triangles_are_skipped_with_a_warning() {
    let mut g = GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 1.0, m);
    let p = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Y];
    // Collinear, repeated-vertex and a good triangle.
    g.mesh("bad", &p, &[Vec3::Y; 4], &[0, 1, 2, 3, 3, 3, 0, 1, 3], m);
    g.point_light("lamp", Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, 5.0);
    match outcome(&g.to_glb()) {
        Outcome::Rendered(w) => assert!(w.iter().any(|w| w.contains("degenerate")), "{w:?}"),
        o => panic!("{o:?}"),
    }
}

#[test]
fn lights_of_zero_area_or_negative_strength_do_not_emit() {
    // The light's quad collapsed to a line: no light left (the uniform environment lights it).
    let bytes = edited(|j, bin| {
        let at = accessor_offset(j, 3);
        for k in 0..4 {
            put_f32(bin, at + 12 * k, 0.0);
        }
    });
    lit_by_environment(&bytes);
    // Negative strength: said, and not a light.
    let bytes = edited(|j, _| {
        j["materials"][1]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] =
            json!(-10.0)
    });
    lit_by_environment(&bytes);
    // With a second, good light the scene renders and warns about the bad one.
    let mut g = GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 1.0, m);
    let bad = g.material(json!({"name": "bad", "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": -3.0}}}));
    let q = [
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.1, 0.5, 0.0),
        Vec3::new(0.0, 0.5, 0.1),
    ];
    g.mesh("bad_light", &q, &[-Vec3::Y; 3], &[0, 1, 2], bad);
    g.point_light("lamp", Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, 5.0);
    match outcome(&g.to_glb()) {
        Outcome::Rendered(w) => assert!(w.iter().any(|w| w.contains("emissive strength")), "{w:?}"),
        o => panic!("{o:?}"),
    }
    // A negative punctual intensity is skipped with a warning.
    let mut g = GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 1.0, m);
    g.point_light("negative", Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, -5.0);
    lit_by_environment(&g.to_glb());
}

#[test]
fn no_lights_are_lit_by_the_environment_and_no_geometry_is_refused() {
    let bytes = edited(|j, _| {
        j["materials"][1]
            .as_object_mut()
            .unwrap()
            .remove("emissiveFactor");
    });
    lit_by_environment(&bytes);
    let bytes = edited(|j, _| {
        j["nodes"] = json!([{"name": "lamp", "extensions": {"KHR_lights_punctual": {"light": 0}}}]);
        j["scenes"] = json!([{"nodes": [0]}]);
        j["extensions"] = json!({"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 1, 1], "intensity": 5.0}]}});
        j["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    });
    refused(&bytes, "no triangles");
}

#[test]
fn a_camera_with_zero_field_of_view_is_replaced() {
    let bytes = edited(|j, _| j["cameras"][0]["perspective"]["yfov"] = json!(0.0));
    match outcome(&bytes) {
        Outcome::Rendered(w) => assert!(w.iter().any(|w| w.contains("field of view")), "{w:?}"),
        o => panic!("{o:?}"),
    }
}

/// Extreme light strength (radiance 10³⁸, a hair under f32's limit once multiplied by π): the
/// film stays finite in both direct modes (the guards themselves are unit-tested in
/// `radiance_map` and `photon`).
#[test]
fn extreme_light_strength_keeps_the_film_finite() {
    let bytes = edited(|j, _| {
        j["materials"][1]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] =
            json!(1.0e38)
    });
    let scene = Arc::new(Scene::from_glb_bytes(&bytes, "hot").unwrap());
    for direct in [DirectMode::Nee, DirectMode::Photons] {
        let s = RenderSettings {
            width: 16,
            height: 16,
            spp: 1,
            photons: 5_000,
            direct,
            ..RenderSettings::default()
        };
        let mut r = methods::build(scene.clone(), s).unwrap();
        r.step();
        let film = r.film();
        assert_eq!(film.invalid_pixels(), 0, "{direct:?}");
        assert!(
            film.mean().max_element() > 1e30,
            "{direct:?}: the light is not that bright"
        );
    }
}

/// A million triangles (a 708×708 grid of quads) load, build their BVH and render.
#[test]
fn a_million_triangles_load_and_render() {
    let n = 708usize;
    let mut p = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 2.0 - 1.0,
                j as f32 / n as f32 * 2.0 - 1.0,
            );
            p.push(Vec3::new(x, 0.02 * (7.0 * x).sin() * (5.0 * z).cos(), z));
        }
    }
    let mut idx = Vec::with_capacity(n * n * 6);
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * (n as u32 + 1) + i;
            let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
            idx.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    assert!(idx.len() / 3 >= 1_000_000);
    let mut g = GlbBuilder::default();
    let m = common::white(&mut g);
    g.mesh("grid", &p, &vec![Vec3::Y; p.len()], &idx, m);
    g.point_light("lamp", Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, 5.0);
    g.camera("top", Vec3::new(0.0, 2.0, 0.01), Vec3::ZERO, 0.8);
    let scene = Scene::from_glb_bytes(&g.to_glb(), "million").unwrap();
    assert!(scene.triangle_count() >= 1_000_000);
    let mut r = methods::build(
        Arc::new(scene),
        RenderSettings {
            width: 24,
            height: 24,
            spp: 1,
            photons: 5_000,
            ..RenderSettings::default()
        },
    )
    .unwrap();
    r.step();
    let film = r.film();
    assert_eq!(film.invalid_pixels(), 0);
    assert!(film.mean().x > 0.0);
}

/// A reader never sees a partial file under the final name: while a large file replaces a
/// small one, every read finds the whole old content or the whole new content.
#[test]
fn atomic_writes_never_expose_a_partial_file() {
    use raysplat::film::write_atomic;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("atomic");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("image.exr");
    let old = vec![b'a'; 1 << 20];
    write_atomic(&path, &old).unwrap();
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let reader = {
        let (path, done) = (path.clone(), done.clone());
        std::thread::spawn(move || {
            let mut reads = 0u32;
            while !done.load(std::sync::atomic::Ordering::SeqCst) || reads < 10 {
                let b = std::fs::read(&path).unwrap();
                let whole_old = b.len() == 1 << 20 && b.iter().all(|&c| c == b'a');
                let whole_new = b.len() == 8 << 20 && b.iter().all(|&c| c == b'b');
                assert!(whole_old || whole_new, "partial file: {} bytes", b.len());
                reads += 1;
            }
            reads
        })
    };
    for _ in 0..5 {
        write_atomic(&path, &vec![b'b'; 8 << 20]).unwrap();
        write_atomic(&path, &old).unwrap();
    }
    write_atomic(&path, &vec![b'b'; 8 << 20]).unwrap();
    done.store(true, std::sync::atomic::Ordering::SeqCst);
    assert!(reader.join().unwrap() >= 10);
    // Nothing but the file itself is left in the folder.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

/// A failing write (the folder is missing, or is a file, or the name is taken by a folder)
/// gives a message and leaves no file and no temporary behind.
#[test]
fn failing_writes_say_why_and_leave_nothing_behind() {
    use raysplat::film::write_atomic;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("failing");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let taken = dir.join("taken.png");
    std::fs::create_dir_all(taken.join("inside")).unwrap();
    for target in [
        dir.join("missing").join("out.exr"),
        file.join("out.exr"),
        taken.clone(),
    ] {
        let e = write_atomic(&target, b"data").unwrap_err();
        assert!(e.contains("cannot write"), "{e}");
    }
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["a_file", "taken.png"], "temporaries left behind");
    assert!(taken.join("inside").is_dir());
    // A read-only folder: refused with a message (root ignores permission bits, so only
    // checked where they apply).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.join("read_only");
        std::fs::create_dir_all(&ro).unwrap();
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
        let probe = ro.join("probe");
        let writable = std::fs::write(&probe, b"x").is_ok();
        let _ = std::fs::remove_file(&probe);
        if !writable {
            let e = write_atomic(&ro.join("out.png"), b"data").unwrap_err();
            assert!(e.contains("cannot write"), "{e}");
            assert_eq!(std::fs::read_dir(&ro).unwrap().count(), 0);
        } else {
            eprintln!("running as root: permission bits are not enforced, read-only case skipped");
        }
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
}

/// Regression (seen in the previewer as "NaN/Inf contributions dropped"): photons trapped in
/// CORNELL BOX I's glass sphere multiply eq. 7's p̃ past f32's range. p̃ saturates instead, so
/// no ray is dropped, and the saturated rays splat with the smallest bandwidth. A length unit
/// of 10⁶ m (areas of 10¹² m²) drives the caustic chain past f32's range within a few bounces;
/// with the pilot's unit it takes a dozen and is rare.
#[test]
fn long_specular_chains_saturate_the_path_pdf() {
    use raysplat::pipeline::photon::{ClassBudgets, LightPassSettings, PathUnits, light_pass};
    let scene = Scene::default_scene();
    let batch = light_pass(
        &scene,
        &LightPassSettings {
            budgets: ClassBudgets::from_fractions(400_000, [0.3, 0.6, 0.1], true),
            max_emitted_factor: 4,
            seed: 3,
            first_photon: 0,
            units: PathUnits { length: 1e6 },
            guide: None,
        },
    );
    assert_eq!(batch.invalid, 0, "photon rays dropped as non-finite");
    assert!(
        batch.rays.iter().any(|r| r.pdf_end == f32::MAX),
        "no chain saturated p̃: the case is not exercised"
    );
}
