//! The environment light (docs/deviations.md, "Light from afar"): the open furnace, a map with one
//! bright texel, rotation, and files without lights of their own.

mod common;

use glam::Vec3;
use raysplat::methods::{Budget, render_method};
use raysplat::scene::environment::EnvMap;
use raysplat::scene::{EnvironmentKind, EnvironmentSettings, GlbBuilder, Scene, uv_sphere};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::f32::consts::PI;
use std::sync::Arc;

const RHO: f32 = 0.5;
const L: f32 = 2.0;

fn diffuse(g: &mut GlbBuilder, rho: f32) -> u32 {
    g.material(json!({"name": "matte", "pbrMetallicRoughness": {
        "baseColorFactor": [rho, rho, rho, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}))
}

/// A unit sphere of albedo RHO at the origin, seen from +Z by a camera whose whole view lies
/// on it; optionally inside a closed box (camera inside too). No light of its own.
fn furnace(boxed: bool) -> Scene {
    let mut g = GlbBuilder::default();
    let m = diffuse(&mut g, RHO);
    let (p, n, i) = uv_sphere(Vec3::ZERO, 1.0, 96, 48);
    g.mesh("sphere", &p, &n, &i, m);
    if boxed {
        // A closed cube of side 8 around it, faces towards the inside.
        let h = 4.0;
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * h;
        let corners = [
            c(-1., -1., -1.),
            c(1., -1., -1.),
            c(1., 1., -1.),
            c(-1., 1., -1.),
            c(-1., -1., 1.),
            c(1., -1., 1.),
            c(1., 1., 1.),
            c(-1., 1., 1.),
        ];
        // Each face wound counter-clockwise seen from inside.
        let faces: [[usize; 4]; 6] = [
            [0, 1, 2, 3],
            [5, 4, 7, 6],
            [4, 0, 3, 7],
            [1, 5, 6, 2],
            [4, 5, 1, 0],
            [3, 2, 6, 7],
        ];
        let (mut bp, mut bn, mut bi) = (Vec::new(), Vec::new(), Vec::new());
        for f in faces {
            let q: Vec<Vec3> = f.iter().map(|&k| corners[k]).collect();
            let nrm = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
            let base = bp.len() as u32;
            bp.extend(&q);
            bn.extend([nrm; 4]);
            bi.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        g.mesh("box", &bp, &bn, &bi, m);
    }
    g.camera(
        "front",
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        20f32.to_radians(),
    );
    Scene::from_glb_bytes(&g.to_glb(), "furnace").expect("the furnace loads")
}

fn small(method: MethodKind) -> RenderSettings {
    RenderSettings {
        width: 24,
        height: 24,
        spp: 4,
        photons: 200_000,
        nee_samples: 8,
        method,
        ..RenderSettings::default()
    }
}

/// The mean radiance of `small(kind)`'s image of `scene` with `direct` light and 64 paths per
/// pixel for pt.
fn render_mean(scene: &Arc<Scene>, kind: MethodKind, direct: DirectMode, budget: Budget) -> Vec3 {
    render_mean_c(scene, kind, direct, budget, 1.0)
}

/// [`render_mean`] at smoothness C = `c`.
fn render_mean_c(
    scene: &Arc<Scene>,
    kind: MethodKind,
    direct: DirectMode,
    budget: Budget,
    c: f32,
) -> Vec3 {
    let s = RenderSettings {
        direct,
        pt_spp: 64,
        bandwidth: raysplat::pipeline::photon::BandwidthParams {
            smoothness_c: c,
            ..Default::default()
        },
        ..small(kind)
    };
    mean(&render_method(scene, kind, &s, budget).unwrap().film)
}

fn mean(film: &raysplat::film::Film) -> Vec3 {
    film.rgb.iter().sum::<Vec3>() / film.rgb.len() as f32
}

fn uniform(strength: f32) -> EnvironmentSettings {
    EnvironmentSettings {
        kind: EnvironmentKind::Uniform,
        strength,
        ..Default::default()
    }
}

/// A diffuse sphere alone under a uniform environment of radiance L has radiance ρ·L
/// everywhere (a convex body sees only the environment): rs, pm (both with their default
/// direct light, NEE) and pt each within 1% of it on the pixels (all on the sphere).
/// Splatted direct photons (`--direct photons`) are held to 6% at half the default C: the
/// end gain (Fig. 4) assumes a flat surface around the hit, and on a sphere of radius R it
/// over-counts by O(h/R). Measured on seeds 1 and 2: +0.7/+3.4% at C = 0.25, +1.7/+4.6% at
/// C = 0.5, +3.5/+5.7% at C = 1, +4.9/+5.8% at C = 2. Seed 2's offset of about 2% does not
/// shrink with C: it is not this bias and is not explained yet (the pilot's calibration
/// differs between seeds); the bound holds both seeds. Until escaping rays were kept to the
/// far side of the scene's bounds (docs/deviations.md §42), the bounds cut off part of the
/// rays passing beside the sphere from the samples near its outline, which hid about 2% of
/// this (+1.3/+3.1% at C = 1).
#[test]
fn open_furnace_gives_rho_times_l() {
    let mut scene = furnace(false);
    scene.set_environment(&uniform(L)).unwrap();
    let scene = Arc::new(scene);
    let want = RHO * L;
    let cases = [
        (MethodKind::Rs, DirectMode::Nee, Budget::Passes(2), 0.01),
        (MethodKind::Pm, DirectMode::Nee, Budget::Passes(2), 0.01),
        (MethodKind::Pt, DirectMode::Nee, Budget::Fixed, 0.01),
        (MethodKind::Rs, DirectMode::Photons, Budget::Passes(4), 0.06),
    ];
    for (kind, direct, budget, tolerance) in cases {
        let c = if direct == DirectMode::Photons {
            0.5
        } else {
            1.0
        };
        let m = render_mean_c(&scene, kind, direct, budget, c);
        for c in 0..3 {
            assert!(
                (m[c] - want).abs() <= tolerance * want,
                "{kind:?} with {direct:?}: mean radiance {m} against ρ·L = {want}"
            );
        }
    }
}

/// The same sphere inside a closed box sees none of the environment: black in every method.
#[test]
fn closed_box_keeps_the_environment_out() {
    let mut scene = furnace(true);
    scene.set_environment(&uniform(L)).unwrap();
    let scene = Arc::new(scene);
    for kind in [MethodKind::Rs, MethodKind::Pm, MethodKind::Pt] {
        let s = RenderSettings {
            pt_spp: 16,
            ..small(kind)
        };
        let film = render_method(&scene, kind, &s, Budget::Passes(1))
            .unwrap()
            .film;
        let m = mean(&film).max_element();
        assert!(m <= 1e-4 * L, "{kind:?}: mean {m} inside a closed box");
    }
}

/// An environment map dark but for one bright texel, written as an EXR and read back.
fn one_texel_map(dir: &std::path::Path) -> (std::path::PathBuf, f32) {
    let (w, h) = (32usize, 16usize);
    let (tx, ty) = (20usize, 5usize); // θ from 56.25° to 67.5°, so it lights an upward plane
    let radiance = 500.0f32;
    let mut film = raysplat::film::Film::new(w as u32, h as u32);
    film.rgb[ty * w + tx] = Vec3::splat(radiance);
    let path = dir.join("one_texel.exr");
    film.write_exr(&path).unwrap();
    // E = L ∫ cos θ dω over the texel = L·Δφ·(sin²θ1 − sin²θ0)/2.
    let (t0, t1) = (PI * ty as f32 / h as f32, PI * (ty + 1) as f32 / h as f32);
    let irradiance = radiance * (2.0 * PI / w as f32) * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
    (path, irradiance)
}

fn tempdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("raysplat-env-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A diffuse plane (albedo RHO, half size `half`) and a camera at `eye` looking at `target`.
fn plane_scene(half: f32, eye: Vec3, target: Vec3, yfov_deg: f32) -> Scene {
    let mut g = GlbBuilder::default();
    let m = diffuse(&mut g, RHO);
    common::plane(&mut g, half, m);
    g.camera("view", eye, target, yfov_deg.to_radians());
    Scene::from_glb_bytes(&g.to_glb(), "plane").unwrap()
}

/// A plane under a map with one bright texel: splatted photons, NEE and the path tracer give
/// the analytic irradiance E = L·∫cos θ dω (radiance ρE/π) within 2% on the plane.
#[test]
fn one_bright_texel_photons_nee_and_pt_agree() {
    let dir = tempdir("texel");
    let (map, irradiance) = one_texel_map(&dir);
    let mut scene = plane_scene(4.0, Vec3::new(0.0, 4.0, 0.001), Vec3::ZERO, 20.0);
    scene
        .set_environment(&EnvironmentSettings {
            kind: EnvironmentKind::File(map),
            strength: 1.0,
            ..Default::default()
        })
        .unwrap();
    let scene = Arc::new(scene);
    let want = RHO * irradiance / PI;
    let cases = [
        (MethodKind::Rs, DirectMode::Photons, Budget::Passes(3)),
        (MethodKind::Rs, DirectMode::Nee, Budget::Passes(1)),
        (MethodKind::Pt, DirectMode::Nee, Budget::Fixed),
    ];
    for (kind, direct, budget) in cases {
        let m = render_mean(&scene, kind, direct, budget);
        for c in 0..3 {
            assert!(
                (m[c] - want).abs() <= 0.02 * want,
                "{kind:?} with {direct:?}: {m} against ρE/π = {want}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// Rotating the environment turns what the camera sees of it: the brightest background
/// pixel looks towards the bright texel's direction turned by the rotation.
#[test]
fn rotation_turns_the_image() {
    let dir = tempdir("rotation");
    let (map, _) = one_texel_map(&dir);
    // Looking up towards the texel (θ ≈ 62°, u ≈ 0.64: azimuth ≈ 51° from −Z towards +X).
    let eye = Vec3::new(0.0, 0.1, 0.0);
    let towards = raysplat::scene::environment::direction_from_angles(28.0, 30.0);
    let base = plane_scene(1.0, eye, eye + towards, 80.0);
    // The texel's centre: u = 20.5/32, v = 5.5/16.
    let texel_dir = raysplat::scene::environment::direction_of_uv(20.5 / 32.0, 5.5 / 16.0);
    for rotation in [0.0f32, 25.0, -20.0] {
        let mut scene = base.clone();
        scene
            .set_environment(&EnvironmentSettings {
                kind: EnvironmentKind::File(map.clone()),
                rotation_deg: rotation,
                ..Default::default()
            })
            .unwrap();
        let camera = scene.cameras[0].clone();
        let s = RenderSettings {
            width: 64,
            height: 64,
            spp: 1,
            pt_spp: 1,
            ..RenderSettings::default()
        };
        let film = render_method(&Arc::new(scene), MethodKind::Pt, &s, Budget::Fixed)
            .unwrap()
            .film;
        let (best, _) = film
            .rgb
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.x.total_cmp(&b.1.x))
            .unwrap();
        let (x, y) = ((best % 64) as f32 + 0.5, (best / 64) as f32 + 0.5);
        let seen = camera.direction(x / 64.0, y / 64.0, 1.0);
        let r = rotation.to_radians();
        let turned = Vec3::new(
            r.cos() * texel_dir.x + r.sin() * texel_dir.z,
            texel_dir.y,
            r.cos() * texel_dir.z - r.sin() * texel_dir.x,
        );
        // Within the texel's angular size (11.25°) of its centre.
        let angle = seen.dot(turned).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(
            angle < 8.0,
            "rotation {rotation}: brightest pixel {angle}° off"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// A file with no light of its own opens lit by the uniform environment at strength 1, with
/// one line saying so; asking for no environment then is refused and changes nothing; a
/// missing map is one line too.
#[test]
fn a_file_without_lights_is_lit_by_the_uniform_environment() {
    let mut scene = furnace(false);
    assert_eq!(scene.environment.kind, EnvironmentKind::Uniform);
    assert_eq!(scene.environment.strength, 1.0);
    let notice = scene.lighting_notice.clone().expect("a notice");
    assert!(
        notice.contains("no light") && !notice.contains('\n'),
        "{notice}"
    );
    assert_eq!(scene.background(Vec3::Y), Vec3::ONE);
    let err = scene
        .set_environment(&EnvironmentSettings {
            kind: EnvironmentKind::None,
            ..Default::default()
        })
        .unwrap_err();
    assert!(err.contains("no light"), "{err}");
    assert_eq!(scene.environment.kind, EnvironmentKind::Uniform);
    let err = scene
        .set_environment(&EnvironmentSettings {
            kind: EnvironmentKind::File("/nonexistent/sky.hdr".into()),
            ..Default::default()
        })
        .unwrap_err();
    assert!(!err.contains('\n') && err.contains("sky.hdr"), "{err}");
    assert_eq!(scene.environment.kind, EnvironmentKind::Uniform);
    // A scene with lights keeps `none` unless asked.
    let lit = Scene::builtin(raysplat::scene::BuiltinScene::CornellClassic);
    assert_eq!(lit.environment.kind, EnvironmentKind::None);
    assert!(lit.lighting_notice.is_none());
    assert_eq!(lit.background(Vec3::Y), Vec3::ZERO);
    // A Radiance .hdr is read as well as an EXR (written here with the image crate).
    let dir = tempdir("hdr");
    let path = dir.join("sky.hdr");
    let img = image::Rgb32FImage::from_pixel(8, 4, image::Rgb([0.25f32, 0.5, 1.0]));
    image::DynamicImage::ImageRgb32F(img).save(&path).unwrap();
    let map = EnvMap::read(&path, 2.0, 0.0).unwrap();
    let env = raysplat::scene::environment::EnvLight::Map(Box::new(map));
    let got = env.radiance(Vec3::new(0.3, 0.5, -0.2).normalize());
    assert!((got - Vec3::new(0.5, 1.0, 2.0)).length() < 1e-2, "{got}");
    let _ = std::fs::remove_dir_all(dir);
}

/// A uniform environment's light samples cover the receiver's hemisphere (deviations §58):
/// for a receiver facing n every sample lies above it, its density is 1/(2π) (times the
/// environment's selection, here 1) as `pdf_escaped` gives it for MIS, and its value is
/// 2π·L; over many samples the mean of value·cos θ is the unoccluded irradiance π·L, and
/// the samples fill the hemisphere evenly (as many above cos θ = 0.5 as below). A receiver
/// lit from both sides (rough glass, no normal) draws the whole sphere at 1/(4π). The open
/// furnace above checks that every method stays unbiased with it.
#[test]
fn a_uniform_environment_is_drawn_over_the_receivers_hemisphere() {
    let mut scene = furnace(false);
    scene.set_environment(&uniform(L)).unwrap();
    let lights = &scene.lights;
    let mut rng = raysplat::sampling::Rng::new(5, 0);
    let p = Vec3::new(0.0, 3.0, 0.0);
    let count = 20_000;
    let (mut irradiance, mut steep) = (0.0f64, 0usize);
    for k in 0..count {
        let n = raysplat::sampling::uniform_sphere(rng.next_2d());
        let s = lights
            .sample_direct(p, Some(n), rng.next_f32(), rng.next_2d())
            .expect("the environment is the only light");
        let cos = s.wi.dot(n);
        assert!(cos >= 0.0, "sample {k}: below the receiver ({cos})");
        assert!(
            (s.value.x - 2.0 * PI * L).abs() < 1e-3 * L,
            "sample {k}: value {}",
            s.value
        );
        let pdf = lights.pdf_escaped(s.wi, Some(n));
        assert!((pdf - 0.5 / PI).abs() < 1e-6, "sample {k}: pdf {pdf}");
        assert!(
            (s.pdf - pdf).abs() < 1e-6,
            "sample {k}: the sample's pdf {}",
            s.pdf
        );
        assert_eq!(
            lights.pdf_escaped(-s.wi, Some(n)),
            0.0,
            "nothing is drawn below"
        );
        irradiance += (s.value.x * cos) as f64;
        steep += usize::from(cos > 0.5);
        let both = lights
            .sample_direct(p, None, rng.next_f32(), rng.next_2d())
            .expect("the environment is the only light");
        assert!(
            (both.pdf - 1.0 / (4.0 * PI)).abs() < 1e-6,
            "two-sided pdf {}",
            both.pdf
        );
        assert!((lights.pdf_escaped(both.wi, None) - both.pdf).abs() < 1e-6);
    }
    // value·cos θ is uniform on [0, 2πL]: σ/mean = 1/√3, so 4σ of the mean is 1.6%.
    let e = irradiance / count as f64;
    let want = (PI * L) as f64;
    assert!(
        (e / want - 1.0).abs() < 0.016,
        "irradiance {e} against π·L = {want}"
    );
    let share = steep as f64 / count as f64;
    assert!(
        (share - 0.5).abs() < 0.015,
        "share above cos θ = 0.5: {share}"
    );
}
