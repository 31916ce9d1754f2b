//! Glossy transport through the directional radiance map (§8.1): a rough metal plate lit by a
//! small area light, rendered with direct photons (so that the reflection of the light itself
//! goes through the map), against the built-in path tracer.

mod common;

use glam::Vec3;
use raysplat::film::rel_mse;
use raysplat::methods::{Budget, render_method};
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::scene::{GlbBuilder, Scene, uv_sphere};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::sync::Arc;

/// A 2 m rough-metal plate (roughness 0.75: Phong exponent 4.3) under a 0.3 m square light at
/// 1 m, seen from the side of the mirror direction so the glossy highlight is in view.
fn glossy_plate() -> Scene {
    plate(1.0, 0.75)
}

/// The plate of [`glossy_plate`] with any metallic factor and roughness.
fn plate(metallic: f32, roughness: f32) -> Scene {
    let mut g = GlbBuilder::default();
    let metal = g.material(json!({"name": "plate", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.8, 0.7, 1.0], "metallicFactor": metallic,
        "roughnessFactor": roughness}}));
    common::plane(&mut g, 1.0, metal);
    common::ceiling_light(&mut g, Vec3::new(-0.5, 1.0, 0.0), 0.15, 20.0);
    g.camera(
        "side",
        Vec3::new(1.2, 0.9, 0.0),
        Vec3::new(0.0, 0.0, 0.0),
        0.9,
    );
    Scene::from_glb_bytes(&g.to_glb(), "glossy plate").expect("test scene loads")
}

#[test]
fn glossy_plate_matches_the_path_tracer_in_both_directional_modes() {
    let scene = Arc::new(glossy_plate());
    let base = RenderSettings {
        width: 48,
        height: 48,
        spp: 4,
        photons: 400_000,
        fractions: [1.0, 0.0, 0.0],
        direct: DirectMode::Photons,
        seed: 7,
        ..RenderSettings::default()
    };
    let reference = common::path_traced(&scene, &base, 1024);
    let err_of = |method: MethodKind, mode: DirectionalMode| {
        let s = RenderSettings {
            radiance_map: mode,
            pm_k: 200,
            ..base.clone()
        };
        let r = render_method(
            &scene,
            method,
            &RenderSettings { ..s.clone() },
            Budget::Fixed,
        )
        .unwrap();
        assert_eq!(r.invalid, 0);
        rel_mse(&r.film.rgb, &reference.rgb)
    };
    let err = |mode| err_of(MethodKind::Rs, mode);
    let (diffuse, sh, hist) = (
        err(DirectionalMode::Diffuse),
        err(DirectionalMode::Sh),
        err(DirectionalMode::Histogram),
    );
    // Measured (48×48×4, 400k direct photons, 1,024-path reference; glTF's GGX model,
    // deviations §49): diffuse 0.058, SH 0.0028, histogram 0.0028. This lobe (roughness 0.75)
    // is traced in both modes: GGX lobes narrower than roughness 0.9 do not go through the
    // map (`GGX_MAP_EXPONENT`; through 16 SH coefficients it was 0.048, 7–33% too bright).
    // Shading the plate as matte is twenty times worse.
    println!("relMSE: diffuse {diffuse:.4}, sh {sh:.4}, histogram {hist:.4}");
    assert!(sh < 0.02, "SH relMSE {sh}");
    assert!(hist < 0.02, "histogram relMSE {hist}");
    assert!(
        diffuse > 5.0 * hist.max(sh),
        "diffuse {diffuse} is not worse than sh/histogram"
    );
    // Photon mapping fills the same directional records from its K nearest photons.
    let pm_sh = err_of(MethodKind::Pm, DirectionalMode::Sh);
    println!("pm sh {pm_sh:.4}");
    // Measured 0.0030.
    assert!(pm_sh < 0.03, "photon mapping with SH: relMSE {pm_sh}");
}

/// Relative MSE of `mode`'s rs image of `scene` against `reference`.
fn rs_error(
    scene: &Arc<Scene>,
    base: &RenderSettings,
    mode: DirectionalMode,
    reference: &[Vec3],
) -> f64 {
    let s = RenderSettings {
        radiance_map: mode,
        ..base.clone()
    };
    let r = render_method(scene, MethodKind::Rs, &s, Budget::Fixed).unwrap();
    assert_eq!(r.invalid, 0);
    rel_mse(&r.film.rgb, reference)
}

/// docs/deviations.md §37: from mirror to matte, metal and plastic, no directional mode is worse
/// than shading the plate matte (diffuse mode) against the path tracer, and SH, within its
/// resolution limit, is not much worse than tracing the lobe. Lobes sharper than a mode's
/// resolution limit are traced by the eye path, the others go through its records. Direct photons,
/// so that the light's reflection is the glossy part under test.
#[test]
fn no_mode_is_worse_than_matte_at_any_roughness() {
    let base = RenderSettings {
        width: 32,
        height: 32,
        spp: 4,
        photons: 200_000,
        fractions: [1.0, 0.0, 0.0],
        direct: DirectMode::Photons,
        seed: 3,
        ..RenderSettings::default()
    };
    for (metallic, name) in [(1.0, "metal"), (0.0, "plastic")] {
        for roughness in [0.05f32, 0.15, 0.3, 0.5, 0.65, 0.7, 0.75, 0.8, 0.9] {
            let scene = Arc::new(plate(metallic, roughness));
            let reference = common::path_traced(&scene, &base, 1024).rgb;
            let matte = rs_error(&scene, &base, DirectionalMode::Diffuse, &reference);
            let sh = rs_error(&scene, &base, DirectionalMode::Sh, &reference);
            let hist = rs_error(&scene, &base, DirectionalMode::Histogram, &reference);
            println!(
                "{name} roughness {roughness}: matte {matte:.4}, sh {sh:.4}, histogram {hist:.4}"
            );
            for (mode, err) in [("sh", sh), ("histogram", hist)] {
                assert!(
                    err <= matte * 1.05 + 2e-3,
                    "{name} roughness {roughness}: {mode} relMSE {err} > matte {matte}"
                );
            }
            // Within its limit SH keeps at least 80% of a highlight (deviations §37), so its
            // error stays near that of tracing the lobe, which histogram mode does for every
            // lobe here (its limit is e = 1). At the old half-peak limit SH's highlight at
            // roughness 0.65 was 40% low: relMSE 0.168 against 0.010 traced.
            assert!(
                sh <= 2.0 * hist + 2e-3,
                "{name} roughness {roughness}: SH relMSE {sh} against {hist} traced"
            );
        }
    }
}

/// A smooth metal sphere (roughness 0.3: Phong exponent 245) on a white floor between a red
/// and a blue wall, under a square area light, seen from the front.
fn smooth_metal_sphere() -> Scene {
    let mut g = GlbBuilder::default();
    let white = common::white(&mut g);
    common::plane(&mut g, 2.0, white);
    for (name, color, x) in [
        ("red", [0.8, 0.1, 0.1], -1.0f32),
        ("blue", [0.1, 0.1, 0.8], 1.0),
    ] {
        let m = g.material(json!({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [color[0], color[1], color[2], 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 1.0}}));
        let p = [
            Vec3::new(x, 0.0, -2.0),
            Vec3::new(x, 0.0, 2.0),
            Vec3::new(x, 2.0, 2.0),
            Vec3::new(x, 2.0, -2.0),
        ];
        g.mesh(
            name,
            &p,
            &[Vec3::X * -x.signum(); 4],
            &[0, 1, 2, 0, 2, 3],
            m,
        );
    }
    let metal = g.material(json!({"name": "smooth_metal", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.9, 0.9, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.3}}));
    let (p, n, i) = uv_sphere(Vec3::new(0.0, 0.5, 0.0), 0.5, 64, 32);
    g.mesh("sphere", &p, &n, &i, metal);
    common::ceiling_light(&mut g, Vec3::Y * 2.0, 0.3, 10.0);
    g.camera(
        "front",
        Vec3::new(0.0, 0.6, 2.2),
        Vec3::new(0.0, 0.5, 0.0),
        0.55,
    );
    Scene::from_glb_bytes(&g.to_glb(), "smooth metal sphere").expect("test scene loads")
}

/// Isolated highlights: pixels whose 3×3 mean luminance is more than three times the
/// reference's 3×3 mean there, plus a tenth of the reference's image mean (so that noise in the
/// dark and in the traced reflection, averaged over 36 eye samples, does not count): a
/// stratum's dot, not a reflection the reference shows.
fn isolated_highlights(image: &[Vec3], reference: &[Vec3], w: usize, h: usize) -> usize {
    let lum = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
    let floor = 0.1 * reference.iter().map(|c| lum(*c)).sum::<f32>() / reference.len() as f32;
    let mean3 = |img: &[Vec3], x: usize, y: usize| {
        (0..9)
            .map(|k| lum(img[(y + k / 3 - 1) * w + x + k % 3 - 1]))
            .sum::<f32>()
            / 9.0
    };
    let mut n = 0;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            if mean3(image, x, y) > 3.0 * mean3(reference, x, y) + floor {
                n += 1;
            }
        }
    }
    n
}

/// docs/deviations.md §27: the histogram never shows its strata as dots. Point evaluation of a
/// sharp lobe at the 20 strata lit the sphere at one spot per stratum whose direction carried
/// light; now such a lobe is traced (and any lobe the histogram does carry is integrated over the
/// strata's footprints). The sphere's image has no isolated highlight, and is closer to the path
/// tracer than the matte sphere of diffuse mode.
#[test]
fn a_smooth_metal_sphere_shows_no_dot_per_stratum() {
    let scene = Arc::new(smooth_metal_sphere());
    let base = RenderSettings {
        width: 48,
        height: 48,
        spp: 4,
        photons: 200_000,
        direct: DirectMode::Photons,
        seed: 5,
        ..RenderSettings::default()
    };
    let reference = common::path_traced(&scene, &base, 512).rgb;
    let s = RenderSettings {
        radiance_map: DirectionalMode::Histogram,
        ..base.clone()
    };
    let r = render_method(&scene, MethodKind::Rs, &s, Budget::Fixed).unwrap();
    let dots = isolated_highlights(&r.film.rgb, &reference, 48, 48);
    let ref_dots = isolated_highlights(&reference, &reference, 48, 48);
    let hist = rel_mse(&r.film.rgb, &reference);
    let matte = rs_error(&scene, &base, DirectionalMode::Diffuse, &reference);
    println!(
        "isolated highlights: histogram {dots}, reference {ref_dots}; relMSE histogram {hist:.4}, matte {matte:.4}"
    );
    // Measured: 0 (3 with other directions: an eye sample at the silhouette catching the
    // light's reflection, which the reference resolves with 512 paths; one sample lights at
    // most the 9 windows around it); point evaluation at the strata, untraced: 220, relMSE 11.
    assert!(dots <= 9, "{dots} isolated highlights");
    assert!(hist < matte, "histogram relMSE {hist} ≥ matte {matte}");
}

/// docs/deviations.md §38: rs draws new directions for the traced lobes with every photon batch, so
/// a traced reflection converges with the batches as the previewer runs. NEE and no photon light
/// splatted (all photons direct, not splatted with NEE), so the image changes between batches only
/// through the lobes' directions: its squared distance to a 32-batch render falls as 1/B − 1/32
/// (theory: 0.097 of the one-batch distance at 8 batches). Directions drawn once per view would
/// leave every batch's image the same (distance 0).
#[test]
fn traced_reflections_converge_with_the_batches() {
    let scene = Arc::new(smooth_metal_sphere());
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 1,
        photons: 1_000,
        fractions: [1.0, 0.0, 0.0],
        direct: DirectMode::Nee,
        seed: 9,
        // The first eye pass for every batch: only the lobes' directions change (the eye
        // passes of docs/deviations.md §41 would redraw sample positions and NEE too).
        progressive_eye: false,
        ..RenderSettings::default()
    };
    let film_after = |batches: usize| {
        let mut r = raysplat::methods::testing::open::<raysplat::methods::rs::RsResolver>(
            scene.clone(),
            settings.clone(),
        )
        .unwrap();
        for _ in 0..batches {
            raysplat::methods::testing::run_batch(&mut r);
        }
        raysplat::methods::Method::film(&mut r).rgb
    };
    let long = film_after(32);
    let (one, eight) = (
        rel_mse(&film_after(1), &long),
        rel_mse(&film_after(8), &long),
    );
    println!("relMSE to 32 batches: 1 batch {one:.5}, 8 batches {eight:.5}");
    assert!(one > 1e-4, "the reflection does not change between batches");
    // 0.3: three times the theory's 0.097, for the spread of a 1,024-pixel estimate.
    assert!(eight < 0.3 * one, "8 batches {eight} vs 1 batch {one}");
}
