//! Glossy transport through the directional radiance map (§8.1): a rough metal plate lit by a
//! small area light, rendered with direct photons (so that the reflection of the light itself
//! goes through the map), against the built-in path tracer.

mod common;

use glam::Vec3;
use raysplat::film::rel_mse;
use raysplat::methods::{Budget, render_method};
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::scene::{GlbBuilder, Scene};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::sync::Arc;

/// A 2 m rough-metal plate (roughness 0.75: Phong exponent 4.3) under a 0.3 m square light at
/// 1 m, seen from the side of the mirror direction so the glossy highlight is in view.
fn glossy_plate() -> Scene {
    let mut g = GlbBuilder::default();
    let metal = g.material(json!({"name": "rough_metal", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.8, 0.7, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.75}}));
    common::plane(&mut g, 1.0, metal);
    let light = g.material(json!({"name": "light", "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20.0}}}));
    let (c, h) = (Vec3::new(-0.5, 1.0, 0.0), 0.15);
    let p = [
        c + Vec3::new(-h, 0.0, -h),
        c + Vec3::new(h, 0.0, -h),
        c + Vec3::new(h, 0.0, h),
        c + Vec3::new(-h, 0.0, h),
    ];
    g.mesh("light", &p, &[-Vec3::Y; 4], &[0, 1, 2, 0, 2, 3], light);
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
    // Measured (48×48×4, 400k direct photons, 1,024-path reference): diffuse 1.26, SH 0.012,
    // histogram 0.116. SH's 16 coefficients carry this e ≈ 4 lobe well; 20 strata 42° apart
    // blur it (the highlight peaks 25% low, docs/deviations.md). Shading the plate as matte is
    // a hundred times worse than SH.
    println!("relMSE: diffuse {diffuse:.4}, sh {sh:.4}, histogram {hist:.4}");
    assert!(sh < 0.02, "SH relMSE {sh}");
    assert!(hist < 0.15, "histogram relMSE {hist}");
    assert!(
        diffuse > 5.0 * hist.max(sh),
        "diffuse {diffuse} is not worse than sh/histogram"
    );
    // Photon mapping fills the same directional records from its K nearest photons.
    let pm_sh = err_of(MethodKind::Pm, DirectionalMode::Sh);
    println!("pm sh {pm_sh:.4}");
    // Measured 0.014.
    assert!(pm_sh < 0.03, "photon mapping with SH: relMSE {pm_sh}");
}
