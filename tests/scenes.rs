//! The project's scenes: generated assets match their generator, the embedded default renders
//! cleanly, and glTF features load as documented.

mod common;

use glam::Vec3;
use raysplat::methods;
use raysplat::scene::{BuiltinScene, DEFAULT_SCENE_GLB, GlbBuilder, MaterialKind, Scene};
use raysplat::settings::{DirectMode, RenderSettings};
use serde_json::json;
use std::sync::Arc;

#[test]
fn assets_match_their_generator() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    for s in BuiltinScene::ALL {
        let on_disk = std::fs::read(dir.join(s.file_name())).unwrap();
        assert!(
            on_disk == s.to_glb(),
            "assets/{} is stale: run `raysplat scenes --out assets`",
            s.file_name()
        );
    }
    assert!(DEFAULT_SCENE_GLB == BuiltinScene::CornellBox1.to_glb());
}

/// `builtin:features`' emissive panel reads its texture through TEXCOORD_1 with clamped
/// edges: it glows at its top edge (v below 0, clamped to the bright row), in its middle, and
/// not near its foot. Read through TEXCOORD_0 its lower half would be dark; with a repeating
/// sampler its top would be.
#[test]
fn the_features_panel_glows_where_its_second_uv_set_and_clamp_say() {
    let s = Scene::builtin(BuiltinScene::Features);
    let glow = |y: f32| {
        let hit = s
            .intersect(Vec3::new(1.5, y, 0.0), -Vec3::Z, f32::INFINITY)
            .expect("the panel is behind");
        assert!((hit.position.z + 1.5).abs() < 1e-4, "{:?}", hit.position);
        s.emitted(&hit, Vec3::Z).x
    };
    for (y, lit) in [
        (1.38, true),
        (1.1, true),
        (0.5, true),
        (0.33, true),
        (0.2, false),
    ] {
        assert_eq!(glow(y) > 1.0, lit, "height {y}: {}", glow(y));
    }
}

#[test]
fn cornell_box_1_is_the_papers_scene() {
    let s = Scene::default_scene();
    // About 20k triangles, most of them in the bumpy floor (the paper: 19,635 primitives).
    assert!(
        (19_000..23_000).contains(&s.triangle_count()),
        "{}",
        s.triangle_count()
    );
    let kinds: Vec<MaterialKind> = s.materials.iter().map(|m| m.kind).collect();
    assert!(
        kinds
            .iter()
            .any(|k| matches!(k, MaterialKind::Glossy { .. }))
    );
    assert!(
        kinds
            .iter()
            .any(|k| matches!(k, MaterialKind::Dielectric { ior } if (*ior - 1.5).abs() < 1e-6))
    );
    // Published Cornell box: 0.556 m wide, 0.5488 m high.
    let ext = s.bounds_max - s.bounds_min;
    assert!((ext.x - 0.556).abs() < 1e-3 && (s.bounds_max.y - 0.5488).abs() < 1e-3);
    assert_eq!(s.cameras.len(), 1);
    assert_eq!(s.lights.len(), 2);
    let cb2 = Scene::builtin(BuiltinScene::CornellBox2);
    assert!(cb2.materials.iter().any(|m| m.kind == MaterialKind::Mirror));
}

/// The embedded Cornell box renders without NaN or Inf in both direct-light modes, with the
/// light's colour and the red/green walls where they belong.
#[test]
fn embedded_cornell_box_renders_cleanly() {
    let scene = Arc::new(Scene::default_scene());
    for direct in [DirectMode::Nee, DirectMode::Photons] {
        let mut r = methods::build(
            scene.clone(),
            RenderSettings {
                width: 80,
                height: 80,
                spp: 2,
                photons: 40_000,
                direct,
                ..RenderSettings::default()
            },
        )
        .unwrap();
        r.step();
        let film = r.film();
        assert_eq!(film.invalid_pixels(), 0, "{direct:?}");
        assert!(
            film.indirect
                .iter()
                .all(|c| c.is_finite() && c.min_element() >= 0.0)
        );
        let mean = film.mean();
        assert!(mean.min_element() > 0.0, "{direct:?}: {mean}");
        // The light is (17, 12, 4): warm overall.
        assert!(mean.x > mean.z, "{direct:?}: {mean}");
        // Left third (red wall) is redder than the right third (green wall).
        let (mut left, mut right) = (Vec3::ZERO, Vec3::ZERO);
        for y in 20..60 {
            for x in 0..80 {
                let c = film.rgb[y * 80 + x];
                if x < 15 {
                    left += c;
                } else if x >= 65 {
                    right += c;
                }
            }
        }
        assert!(
            left.x / left.y > right.x / right.y,
            "{direct:?}: {left} vs {right}"
        );
        let s = r.stats();
        assert!(s.accepted_pairs > 0 && s.accepted_pairs <= s.tested_pairs);
    }
}

#[test]
fn gltf_materials_and_lights_load_as_documented() {
    let mut g = GlbBuilder::default();
    let diffuse = common::white(&mut g);
    let mirror = g
        .material(json!({"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.0}}));
    let glossy = g
        .material(json!({"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.4}}));
    let spec_off = g.material(
        json!({"pbrMetallicRoughness": {"roughnessFactor": 0.2, "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}),
    );
    let glass = g.material(
        json!({"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.33}}}),
    );
    let emissive = g.material(json!({"emissiveFactor": [0.5, 0.5, 0.5],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}}));
    // glTF's metallic defaults to 1, and transmission replaces only the dielectric's
    // diffuse layer: without a metallic factor this is a metal (deviations §55).
    let metal_glass = g.material(
        json!({"extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}}),
    );
    for (i, m) in [
        diffuse,
        mirror,
        glossy,
        spec_off,
        glass,
        emissive,
        metal_glass,
    ]
    .into_iter()
    .enumerate()
    {
        let o = Vec3::new(i as f32, 0.0, 0.0);
        g.mesh(
            &format!("m{i}"),
            &[o, o + Vec3::X, o + Vec3::Y],
            &[Vec3::Z; 3],
            &[0, 1, 2],
            m,
        );
    }
    g.point_light("p", Vec3::new(0.0, 2.0, 0.0), Vec3::ONE, 3.0);
    let s = Scene::from_glb_bytes(&g.to_glb(), "materials").unwrap();
    let kind = |i: usize| s.materials[i].kind;
    assert_eq!(kind(0), MaterialKind::Diffuse);
    assert_eq!(kind(1), MaterialKind::Mirror);
    assert!(
        matches!(kind(2), MaterialKind::Glossy { roughness, .. } if (roughness - 0.4).abs() < 1e-6)
    );
    assert_eq!(kind(3), MaterialKind::Diffuse);
    assert!(matches!(kind(4), MaterialKind::Dielectric { ior } if (ior - 1.33).abs() < 1e-6));
    assert!(
        matches!(kind(6), MaterialKind::Glossy { metallic, .. } if metallic == 1.0),
        "{:?}",
        kind(6)
    );
    // glTF emissive is radiance: factor × strength.
    assert_eq!(s.materials[5].emission, Vec3::splat(2.0));
    // One emissive triangle and the point light.
    assert_eq!(s.lights.len(), 2);
    // No camera in the file: one framing the bounds is made.
    assert_eq!(s.cameras.len(), 1);
    assert_eq!(s.cameras[0].name, "framing");
}

/// The test scenes shared beside the project load and render when they are present (they are
/// not part of the repository; on a machine without them this test checks nothing and says so).
#[test]
fn shared_scenes_load_when_present() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!(
            "note: {} not found; shared scenes not checked",
            dir.display()
        );
        return;
    };
    let mut checked = 0;
    for e in entries.flatten() {
        let path = e.path();
        if path.extension().is_some_and(|x| x == "glb") {
            let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                s.triangle_count() > 1000 && !s.lights.is_empty(),
                "{}",
                path.display()
            );
            let mut r = methods::build(
                Arc::new(s),
                RenderSettings {
                    width: 40,
                    height: 30,
                    spp: 1,
                    photons: 5_000,
                    ..RenderSettings::default()
                },
            )
            .unwrap();
            r.step();
            let film = r.film();
            assert_eq!(film.invalid_pixels(), 0, "{}", path.display());
            assert!(
                film.mean().max_element() > 0.0,
                "{} renders black",
                path.display()
            );
            checked += 1;
        }
    }
    eprintln!("checked {checked} shared scenes");
}

/// A ray whose direction has −0 components (`-Vec3::Y` is (−0, −1, −0)) hits what lies
/// ahead: the BVH's traversal missed everything along it.
#[test]
fn a_direction_with_negative_zeros_hits() {
    let mut g = GlbBuilder::default();
    let floor = common::white(&mut g);
    common::plane(&mut g, 2.0, floor);
    let s = Scene::from_glb_bytes(&g.to_glb(), "floor").expect("loads");
    let o = Vec3::new(0.1, 3.0, 0.2);
    for d in [-Vec3::Y, Vec3::new(0.0, -1.0, 0.0)] {
        assert_eq!(
            s.intersect(o, d, f32::INFINITY).map(|h| h.t),
            Some(3.0),
            "{d}"
        );
        assert!(s.occluded(o, d, 4.0), "{d}");
    }
}
