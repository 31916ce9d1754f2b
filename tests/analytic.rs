//! Analytic checks of the pipeline: irradiance from a point light, eq. 7 on a known geometry,
//! emitted power, and reproducibility.

mod common;

use glam::Vec3;
use raysplat::choice::Choice;
use raysplat::methods::Method;
use raysplat::methods::rs::RsResolver;
use raysplat::methods::testing::{self, run_batch};
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::pipeline::photon::{
    ClassBudgets, D_TILDE_FRACTION, LightPassSettings, PathUnits, PhotonClass, light_pass,
};
use raysplat::sampling::Rng;
use raysplat::scene::Scene;
use raysplat::settings::{DirectMode, RenderSettings};
use std::f32::consts::PI;
use std::sync::Arc;

/// Direct photons from a point light of intensity 2 at height 1 over a plane, seen from above
/// over ±`view`: per ring of width `ring_width` around the light's foot, the summed
/// splatted irradiance, the summed analytic E = I·cos θ/d² and the sample count.
fn point_light_rings(
    view: f32,
    ring_width: f32,
    rings: usize,
    seed: u64,
) -> Vec<(f64, f64, usize)> {
    let (intensity, height) = (2.0, 1.0);
    let scene = Arc::new(common::point_light_over_plane(intensity, height, view));
    let settings = RenderSettings {
        width: 96,
        height: 96,
        spp: 1,
        photons: 1_000_000,
        fractions: [1.0, 0.0, 0.0],
        direct: DirectMode::Photons,
        seed,
        // Half the default smoothness: the kernel's blur of the 1/d³ falloff grows with h²
        // (at C = 1 it adds +3.7% at 54°), and these tests measure the splat's energy.
        bandwidth: raysplat::pipeline::photon::BandwidthParams {
            smoothness_c: 0.5,
            ..Default::default()
        },
        ..RenderSettings::default()
    };
    let mut r = testing::open::<RsResolver>(scene, settings).unwrap();
    run_batch(&mut r);
    let e = testing::target_irradiance(&r, true);
    let light = Vec3::new(0.0, height, 0.0);
    let mut out = vec![(0.0f64, 0.0f64, 0usize); rings];
    for (p, e) in testing::target_positions(&r).iter().zip(&e) {
        let ring = ((p.x * p.x + p.z * p.z).sqrt() / ring_width) as usize;
        if ring < rings {
            let d = light - *p;
            out[ring].0 += e.x as f64;
            out[ring].1 += (intensity * d.y / d.length().powi(3)) as f64;
            out[ring].2 += 1;
        }
    }
    out
}

/// Splatted direct photons on a diffuse plane reproduce E = I·cos θ / d² (§4, eq. 5).
///
/// Tolerance 3%: with 10⁶ photons each ring below averages well over 10⁴
/// photon splats (statistical error < 1%); the kernel blur of the smooth 1/d³ falloff adds
/// < 0.5%, in the region tested ("away from the edges", below 22° incidence).
#[test]
fn point_light_irradiance_on_a_plane() {
    for (i, (est, ana, n)) in point_light_rings(0.5, 0.1, 4, 7).iter().enumerate() {
        assert!(*n > 50, "ring {i} has only {n} samples");
        let rel = est / ana - 1.0;
        assert!(
            rel.abs() < 0.03,
            "ring {i}: splatted {:.4} vs analytic {:.4} ({:+.2}%)",
            est / *n as f64,
            ana / *n as f64,
            100.0 * rel
        );
    }
}

/// The hemisphere rule beyond the hit point (Fig. 4) cuts off kernel mass on the hit surface
/// at oblique incidence (measured without correction: −6% at 45°, −17% at 61°, −26% at 69°);
/// the splat restores it on the hit plane (docs/deviations.md). Out to 66° incidence the
/// irradiance stays within 3% (statistical error < 1% per ring with 10⁶ photons).
#[test]
fn oblique_incidence_keeps_its_energy() {
    for (i, (est, ana, _)) in point_light_rings(2.6, 0.4, 6, 11).iter().enumerate() {
        assert!(
            (est / ana - 1.0).abs() < 0.03,
            "ring {i} (about {:.0}°): ratio {:.3}",
            ((i as f32 + 0.5) * 0.4).atan().to_degrees(),
            est / ana
        );
    }
}

/// A streamed light pass (`plan_light_pass`, then `LightPassPlan::stream`, for a render that
/// never keeps its batches) hands on exactly the rays `light_pass` stores, in the same order,
/// with the same counts: over several waves, with classes that fill in different waves and
/// one that never fills (no specular surface: no caustic photon), and on the default scene.
#[test]
fn a_streamed_light_pass_hands_on_the_rays_of_a_stored_one() {
    use raysplat::pipeline::photon::plan_light_pass;
    let plane = common::area_light_over_plane(0.5, 5.0, 1.0);
    let cornell = Scene::default_scene();
    let cases = [
        (&plane, ClassBudgets([3000, 9000, 500]), 2),
        (&cornell, ClassBudgets([4000, 12000, 2000]), 50),
    ];
    // One thread: waves of 8,192 photons, so each case spans several.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (scene, budgets, max_emitted_factor) in cases {
        let s = LightPassSettings {
            budgets,
            max_emitted_factor,
            seed: 9,
            first_photon: 1234,
            units: PathUnits { length: 0.7 },
            guide: None,
        };
        let (stored, plan, streamed, waves) = pool.install(|| {
            let stored = light_pass(scene, &s);
            let plan = plan_light_pass(scene, &s, None);
            let (mut streamed, mut waves) = (Vec::new(), 0);
            plan.stream(scene, &s, |rays| {
                streamed.extend_from_slice(rays);
                waves += 1;
            });
            (stored, plan, streamed, waves)
        });
        assert!(waves >= 2, "{waves} waves");
        assert!(stored.rays.len() > 10_000);
        assert_eq!(plan.batch.emitted, stored.emitted);
        assert_eq!(plan.batch.stored, stored.stored);
        assert_eq!(plan.batch.traced, stored.traced);
        assert_eq!(plan.batch.invalid, stored.invalid);
        assert_eq!(streamed.len(), stored.rays.len());
        for (a, b) in streamed.iter().zip(&stored.rays) {
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
        }
    }
    // The plane's caustic class never filled: it took every photon the cap allowed.
    let s = LightPassSettings {
        budgets: ClassBudgets([3000, 9000, 500]),
        max_emitted_factor: 2,
        seed: 9,
        first_photon: 1234,
        units: PathUnits { length: 0.7 },
        guide: None,
    };
    let plan = pool.install(|| plan_light_pass(&plane, &s, None));
    assert_eq!(plan.batch.stored[2], 0);
    assert_eq!(plan.batch.emitted[2], plan.batch.traced);
}

/// eq. 7 on a known path, without units (lengths in the pilot's ⟨D⟩ = L, areas in L²): for a
/// downward area light over a plane, every direct ray has p̃(x1|x0) = p_e / D(x0, x1) with
/// p_e = (L²/A)·cos θ/π, and every ray leaving the plane after one diffuse bounce multiplies
/// p̃ by (cos θ'/π) / D, with D = max(D̃², (length/L)²) and D̃ a fraction of L.
#[test]
fn eq7_clamped_path_pdf_on_a_known_geometry() {
    let side = 0.5;
    let scene = common::area_light_over_plane(side, 5.0, 1.0);
    let unit = 0.7f32;
    let batch = light_pass(
        &scene,
        &LightPassSettings {
            budgets: ClassBudgets([2000, 2000, 0]),
            max_emitted_factor: 4,
            seed: 3,
            first_photon: 0,
            units: PathUnits { length: unit },
            guide: None,
        },
    );
    let area = side * side / (unit * unit);
    let (mut direct, mut bounced) = (0, 0);
    for r in &batch.rays {
        let d = (r.length * r.length / (unit * unit)).max(D_TILDE_FRACTION * D_TILDE_FRACTION);
        match (r.class(), r.bounce()) {
            (PhotonClass::Direct, 0) => {
                let cos = r.dir.dot(-Vec3::Y);
                let expect = (1.0 / area) * (cos / PI) / d;
                assert!(
                    (r.pdf_end / expect - 1.0).abs() < 1e-3,
                    "direct: {} vs {expect}",
                    r.pdf_end
                );
                direct += 1;
            }
            (PhotonClass::Indirect, 1) => {
                let cos = r.dir.dot(Vec3::Y);
                let expect = r.pdf_start * (cos / PI) / d;
                assert!(
                    (r.pdf_end / expect - 1.0).abs() < 1e-3,
                    "bounce: {} vs {expect}",
                    r.pdf_end
                );
                bounced += 1;
            }
            _ => {}
        }
    }
    assert!(
        direct >= 2000 && bounced > 500,
        "{direct} direct, {bounced} bounced"
    );
}

/// Photons leave the lights carrying, on average, exactly the lights' power.
#[test]
fn emitted_photon_power_equals_light_power() {
    // Mixed lights: an area light, a point light and a spot light.
    let mut g = raysplat::scene::GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 2.0, m);
    let light =
        g.material(serde_json::json!({"name": "light", "emissiveFactor": [1.0, 0.5, 0.25]}));
    let p = [
        Vec3::new(-0.2, 1.0, -0.2),
        Vec3::new(0.2, 1.0, -0.2),
        Vec3::new(0.2, 1.0, 0.2),
        Vec3::new(-0.2, 1.0, 0.2),
    ];
    g.mesh("light", &p, &[-Vec3::Y; 4], &[0, 1, 2, 0, 2, 3], light);
    g.point_light("p", Vec3::new(0.5, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.5), 0.3);
    g.spot_light(
        "s",
        Vec3::new(-0.5, 1.0, 0.0),
        -Vec3::Y,
        Vec3::ONE,
        0.8,
        (0.2, 0.6),
    );
    let scene = Scene::from_glb_bytes(&g.to_glb(), "mixed lights").unwrap();
    assert_eq!(scene.lights.len(), 4);
    let n = 400_000;
    let mut rng = Rng::new(11, 0);
    let mut sum = glam::DVec3::ZERO;
    for _ in 0..n {
        sum += scene
            .lights
            .sample_emission(&mut rng)
            .unwrap()
            .power
            .as_dvec3();
    }
    let mean = (sum / n as f64).as_vec3();
    let total = scene.lights.total_power;
    // Spot photons vary in power with the falloff; 4×10⁵ photons bound the error well below 1%.
    for c in 0..3 {
        assert!(
            (mean[c] / total[c] - 1.0).abs() < 0.01,
            "channel {c}: {} vs {}",
            mean[c],
            total[c]
        );
    }
    // A single uniform area light gives every photon exactly the light's power.
    let cornell = Scene::default_scene();
    let mut rng = Rng::new(1, 1);
    for _ in 0..1000 {
        let p = cornell.lights.sample_emission(&mut rng).unwrap().power;
        assert!(
            (p / cornell.lights.total_power - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-4
        );
    }
}

/// Photons leave a two-sided emitter from both faces without hitting the emitter itself: every
/// direct ray has a real length, and both sides' light bounces on (the Sibenik panel is such a
/// light; photons used to die on it at t = 0).
#[test]
fn photons_leave_a_two_sided_light() {
    let mut g = raysplat::scene::GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 3.0, m);
    let light = g.material(serde_json::json!({"doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
        "emissiveFactor": [1.0, 1.0, 1.0]}));
    // Tilted, so that rounding puts photon origins on either side of its plane.
    let p = [
        Vec3::new(-0.5, 0.9, -0.5),
        Vec3::new(0.5, 0.9, -0.5),
        Vec3::new(0.5, 1.17, 0.5),
        Vec3::new(-0.5, 1.17, 0.5),
    ];
    // Wound to face up: only its back face looks at the plane.
    g.mesh("panel", &p, &[Vec3::Y; 4], &[0, 2, 1, 0, 3, 2], light);
    g.mesh(
        "ceiling",
        &p.map(|v| v + Vec3::Y),
        &[-Vec3::Y; 4],
        &[0, 1, 2, 0, 2, 3],
        m,
    );
    let scene = Scene::from_glb_bytes(&g.to_glb(), "two-sided light").unwrap();
    let batch = light_pass(
        &scene,
        &LightPassSettings {
            budgets: ClassBudgets([5_000, 5_000, 0]),
            max_emitted_factor: 4,
            seed: 2,
            first_photon: 0,
            units: PathUnits { length: 1.0 },
            guide: None,
        },
    );
    let direct: Vec<_> = batch
        .rays
        .iter()
        .filter(|r| r.class() == PhotonClass::Direct)
        .collect();
    assert!(
        direct.iter().all(|r| r.length > 0.5),
        "a photon hit its own light"
    );
    let up = direct.iter().filter(|r| r.dir.y > 0.0).count();
    assert!(
        (2_000..3_000).contains(&up),
        "{up} of {} leave upwards",
        direct.len()
    );
    assert!(batch.stored[PhotonClass::Indirect as usize] >= 5_000);
}

/// Everything the direct class carries is the emitted power: in the stored light pass the
/// direct rays' powers sum to the lights' power (each photon's first segment, every photon).
#[test]
fn direct_rays_carry_the_light_power() {
    let scene = Scene::default_scene();
    let batch = light_pass(
        &scene,
        &LightPassSettings {
            budgets: ClassBudgets([20_000, 0, 0]),
            max_emitted_factor: 4,
            seed: 5,
            first_photon: 0,
            units: PathUnits { length: 1.0 },
            guide: None,
        },
    );
    let sum: Vec3 = batch
        .rays
        .iter()
        .filter(|r| r.class() == PhotonClass::Direct)
        .map(|r| r.power)
        .sum();
    let total = scene.lights.total_power;
    assert!(
        (sum / total - Vec3::ONE).abs().max_element() < 1e-3,
        "{sum} vs {total}"
    );
}

fn small_settings() -> RenderSettings {
    RenderSettings {
        width: 64,
        height: 64,
        spp: 2,
        photons: 20_000,
        seed: 3,
        ..RenderSettings::default()
    }
}

/// The same seed and settings give the same image bit for bit, on 1 or 3 threads: photons and
/// pixels draw from per-index random streams, and each splat target sums its splats in ray
/// order inside one task.
#[test]
fn same_seed_same_image_on_any_thread_count() {
    let scene = Arc::new(Scene::default_scene());
    let render = |threads: usize, direct: DirectMode, map: DirectionalMode| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut r = testing::open::<RsResolver>(
                scene.clone(),
                RenderSettings {
                    direct,
                    radiance_map: map,
                    ..small_settings()
                },
            )
            .unwrap();
            run_batch(&mut r);
            run_batch(&mut r);
            r.film().rgb
        })
    };
    for direct in [DirectMode::Nee, DirectMode::Photons] {
        for &map in DirectionalMode::ALL {
            let a = render(1, direct, map);
            let b = render(3, direct, map);
            assert!(
                a == b,
                "{direct:?} {map:?}: images differ between 1 and 3 threads"
            );
        }
    }
}

/// Bandwidth is recomputed from stored rays: re-splatting with the same parameters gives the
/// same image, with other parameters a different one, and the photon count does not change.
/// Only pixels seen through traced glossy lobes (the brass icosahedron) change, since every
/// re-splat draws their directions anew (docs/deviations.md §38).
#[test]
fn resplat_uses_stored_rays() {
    let scene = Arc::new(Scene::default_scene());
    let mut r = testing::open::<RsResolver>(scene, small_settings()).unwrap();
    run_batch(&mut r);
    let before = r.film();
    let traced = r.stats().photons_traced;
    let params = r.settings().bandwidth;
    testing::resplat(&mut r, params);
    let again = r.film();
    let (mut same, mut lobes) = (0, 0);
    for (i, src) in before.glossy_source.iter().enumerate() {
        if src[1] == 0.0 {
            assert_eq!(
                again.rgb[i], before.rgb[i],
                "pixel {i} without a traced lobe"
            );
            same += 1;
        } else {
            lobes += 1;
        }
    }
    assert!(lobes > 0 && same > 10 * lobes, "{lobes} traced, {same} not");
    let before = before.rgb;
    testing::resplat(
        &mut r,
        raysplat::pipeline::photon::BandwidthParams {
            smoothness_c: 0.5,
            ..params
        },
    );
    let after = r.film().rgb;
    assert!(after != before);
    assert_eq!(r.stats().photons_traced, traced);
}

/// Progressive batches: each adds its photons to M, so bandwidths shrink (h ∝ M^(−1/6)) and the
/// image keeps its brightness while noise falls. The reference (2 × 10⁶ photons) has the same
/// seed, hence the same eye samples and pilot: with other eye samples the comparison has a
/// floor of its own (CORNELL BOX I's bumpy floor and glass make two seeds' pixels differ by
/// relMSE 0.005 whatever the photons), which hid the photons' convergence. Its first
/// 10⁶-photon batch shares the 8 batches' photons (160k of them). Both keep the first eye
/// pass (`progressive_eye` off), for the same reason: this is the photons' convergence alone
/// (the eye passes have `eye_passes_make_the_whole_image_converge`).
#[test]
fn progressive_batches_converge() {
    let scene = Arc::new(Scene::default_scene());
    let small_settings = || RenderSettings {
        progressive_eye: false,
        ..small_settings()
    };
    let mut reference = testing::open::<RsResolver>(
        scene.clone(),
        RenderSettings {
            photons: 1_000_000,
            ..small_settings()
        },
    )
    .unwrap();
    for _ in 0..2 {
        run_batch(&mut reference);
    }
    let reference = reference.film();
    let mut r = testing::open::<RsResolver>(scene, small_settings()).unwrap();
    run_batch(&mut r);
    let one = raysplat::film::rel_mse(&r.film().indirect, &reference.indirect);
    for _ in 0..7 {
        run_batch(&mut r);
    }
    let eight = raysplat::film::rel_mse(&r.film().indirect, &reference.indirect);
    assert_eq!(r.passes(), 8);
    // Measured 0.30 (0.00214 → 0.00064).
    assert!(
        eight < 0.5 * one,
        "relMSE after 8 batches {eight} vs after 1 {one}"
    );
    let (m1, m8) = (reference.mean(), r.film().mean());
    assert!(
        (m8 / m1 - Vec3::ONE).abs().max_element() < 0.05,
        "{m8} vs {m1}"
    );
}

/// docs/deviations.md §41: with progressive eye passes the whole image converges with the batches —
/// pixel edges, NEE and the splatted light at new sample positions — where eye samples kept from
/// the first pass stay at one draw of anti-aliasing and NEE forever. Against 512 paths, after 24
/// batches the progressive image's relMSE is at most half the fixed one's; one batch is the same
/// image either way (the first pass draws from the settings' seed).
#[test]
fn eye_passes_make_the_whole_image_converge() {
    let scene = Arc::new(Scene::default_scene());
    let base = RenderSettings {
        width: 32,
        height: 32,
        spp: 1,
        photons: 4_000,
        seed: 5,
        ..RenderSettings::default()
    };
    let reference = common::path_traced(&scene, &base, 512).rgb;
    let run = |progressive_eye: bool, batches: usize| {
        let mut r = testing::open::<RsResolver>(
            scene.clone(),
            RenderSettings {
                progressive_eye,
                ..base.clone()
            },
        )
        .unwrap();
        for _ in 0..batches {
            run_batch(&mut r);
        }
        (r.film().rgb, r.stats().eye_passes)
    };
    let (one_fixed, _) = run(false, 1);
    let (one_prog, passes) = run(true, 1);
    assert!(one_fixed == one_prog && passes == 1, "one batch differs");
    let (fixed, fixed_passes) = run(false, 24);
    let (prog, prog_passes) = run(true, 24);
    assert_eq!(fixed_passes, 1);
    assert!(prog_passes > 4, "{prog_passes} eye passes");
    let (e_fixed, e_prog) = (
        raysplat::film::rel_mse(&fixed, &reference),
        raysplat::film::rel_mse(&prog, &reference),
    );
    println!("relMSE after 24 batches: fixed eye samples {e_fixed:.5}, eye passes {e_prog:.5}");
    assert!(e_prog < 0.5 * e_fixed, "{e_prog} vs {e_fixed}");
}

/// Photon rays that pass a surface's open edge and escape still splat onto the samples within
/// their radius of it (docs/deviations.md §42): a 2 × 2 plane under a square light, seen near
/// one edge, gets the same direct light from splatted photons as from NEE in the band of
/// pixels next to the edge, within 4% (measured 0.995). Before, the band got 0.59 of it, for
/// two reasons: escaping rays were cut where they left the scene's bounds, so samples that
/// project past the cut were missed, and a ray leaving the light that escapes had a
/// cylinder of radius h(x_0) = 0. Mending only the first gives 0.59 (those rays have no
/// radius), only the second 0.65.
#[test]
fn an_open_edge_keeps_the_light_of_the_rays_that_pass_it() {
    let mut g = raysplat::scene::GlbBuilder::default();
    let m = common::white(&mut g);
    common::plane(&mut g, 1.0, m);
    common::ceiling_light(&mut g, Vec3::Y, 0.5, 5.0);
    g.camera(
        "edge",
        Vec3::new(0.9, 1.2, 0.01),
        Vec3::new(0.9, 0.0, 0.0),
        0.3,
    );
    let scene = Arc::new(Scene::from_glb_bytes(&g.to_glb(), "open edge").unwrap());
    let (w, h) = (64usize, 64usize);
    let render = |direct: DirectMode| {
        let s = RenderSettings {
            width: w as u32,
            height: h as u32,
            spp: 4,
            photons: 400_000,
            fractions: [1.0, 0.0, 0.0],
            direct,
            nee_samples: 4,
            ..RenderSettings::default()
        };
        raysplat::methods::render_method(
            &scene,
            raysplat::settings::MethodKind::Rs,
            &s,
            raysplat::methods::Budget::Fixed,
        )
        .unwrap()
        .film
    };
    let nee = render(DirectMode::Nee);
    let photons = render(DirectMode::Photons);
    // The band: plane pixels within 6 pixels of one that sees past the edge.
    let on_plane = |x: usize, y: usize| nee.direct[y * w + x].x > 0.0;
    let (mut sum_p, mut sum_n, mut n) = (0.0f64, 0.0f64, 0);
    for y in 0..h {
        for x in 0..w {
            let near_edge = (x.saturating_sub(6)..(x + 7).min(w)).any(|xx| !on_plane(xx, y))
                || (y.saturating_sub(6)..(y + 7).min(h)).any(|yy| !on_plane(x, yy));
            if on_plane(x, y) && near_edge {
                sum_p += photons.direct[y * w + x].x as f64;
                sum_n += nee.direct[y * w + x].x as f64;
                n += 1;
            }
        }
    }
    assert!(n > 100, "{n} pixels in the band");
    let ratio = sum_p / sum_n;
    assert!(
        (ratio - 1.0).abs() < 0.04,
        "splatted / NEE direct light next to the edge: {ratio:.3} over {n} pixels"
    );
}

/// A headless rs render (`methods::run`) frees each photon batch once it is splatted: the
/// same image as a render that keeps every batch, no stored rays at the end while its stats
/// still count them; pm, whose film gathers the stored rays, keeps them (docs/benchmarks.md,
/// "Memory": a 30 s render of the classic box peaked at 391 MB with every batch kept, 117 MB
/// without).
#[test]
fn a_headless_rs_render_frees_its_rays_and_pm_keeps_them() {
    use raysplat::methods::{Budget, build, render_method};
    use raysplat::settings::MethodKind;
    let scene = Arc::new(Scene::default_scene());
    let s = RenderSettings {
        width: 32,
        height: 32,
        spp: 1,
        photons: 3_000,
        ..RenderSettings::default()
    };
    let headless = render_method(&scene, MethodKind::Rs, &s, Budget::Passes(3)).unwrap();
    assert_eq!(headless.stats.memory.photon_rays, 0);
    let traced: u64 = headless.stats.photon_rays_per_class.iter().sum();
    assert!(traced > 0);
    assert_eq!(headless.stats.photon_rays as u64, traced);
    // Every batch is released once splatted: none stays in the store, each counts as folded.
    assert_eq!(headless.stats.stored_batches, 0);
    assert_eq!(headless.stats.folded_batches, 3);
    // Stepped by hand, the store keeps every batch; the image is the same.
    let mut kept = build(scene.clone(), s.clone()).unwrap();
    for _ in 0..3 {
        kept.step();
    }
    assert!(kept.stats().memory.photon_rays > 0);
    // The floor from the photons stored acts here (docs/deviations.md §63), so the streamed
    // render, which counts its landings in the light pass's first trace, must give its rays
    // the φ the store gives them for the images to agree.
    let clamps = kept.stats().bandwidth_clamps.unwrap();
    assert!(clamps.iter().map(|c| c.at_floor).sum::<u64>() > 0);
    assert!(kept.film().rgb == headless.film.rgb);
    // More photons than one wave, direct photons splatted too: the headless render streams
    // each batch a wave at a time and is the stepped render's image up to the order of float
    // additions (one thread: waves of 8,192 photons).
    let s = RenderSettings {
        photons: 30_000,
        direct: DirectMode::Photons,
        ..s
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (streamed, stepped) = pool.install(|| {
        let streamed = render_method(&scene, MethodKind::Rs, &s, Budget::Passes(2)).unwrap();
        let mut kept = build(scene.clone(), s.clone()).unwrap();
        for _ in 0..2 {
            kept.step();
        }
        (streamed, kept.film())
    });
    assert_eq!(streamed.stats.memory.photon_rays, 0);
    assert!(streamed.stats.photon_rays > 2 * 30_000 - 100);
    let mut lit = 0;
    for (a, b) in streamed.film.rgb.iter().zip(&stepped.rgb) {
        assert!(
            (*a - *b).abs().max_element() <= 1e-5 * b.max_element() + 1e-7,
            "{a} vs {b}"
        );
        lit += usize::from(b.max_element() > 0.0);
    }
    assert!(lit > stepped.rgb.len() / 2);
    // pm keeps every batch it gathers from, not only the newest.
    let pm = render_method(&scene, MethodKind::Pm, &s, Budget::Passes(2)).unwrap();
    let pm_traced: u64 = pm.stats.photon_rays_per_class.iter().sum();
    assert_eq!(pm.stats.photon_rays as u64, pm_traced);
    assert_eq!(
        pm.stats.memory.photon_rays,
        pm.stats.photon_rays * std::mem::size_of::<raysplat::pipeline::photon::PhotonRay>()
    );
}
