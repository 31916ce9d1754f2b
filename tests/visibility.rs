//! Visibility inside the splat footprint (docs/deviations.md §40): a closed shed of
//! zero-thickness walls standing on a sunlit ground sees none of the light outside, however
//! close to a wall its floor is; the probes find walls, not a sphere.

use glam::Vec3;
use raysplat::methods::{Budget, render_method};
use raysplat::pipeline::splat_tree::probe;
use raysplat::scene::{EnvironmentKind, EnvironmentSettings, GlbBuilder, Scene, uv_sphere};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings};
use serde_json::json;
use std::sync::Arc;

fn quad(bp: &mut Vec<Vec3>, bn: &mut Vec<Vec3>, bi: &mut Vec<u32>, q: [Vec3; 4]) {
    let nrm = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
    let base = bp.len() as u32;
    bp.extend(q);
    bn.extend([nrm; 4]);
    bi.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// A ground of half-size 6 at y = 0, and on it a 2 × 2 × 2 shed with walls and a roof 0.1
/// thick (no floor of its own: the ground runs on under the walls), a sphere of radius
/// 0.3 inside; the camera inside looks down at the floor along a wall. No light of its own.
fn shed() -> Scene {
    let mut g = GlbBuilder::default();
    let m = g.material(json!({"name": "matte", "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let (mut bp, mut bn, mut bi) = (Vec::new(), Vec::new(), Vec::new());
    let v = Vec3::new;
    let s = 6.0;
    quad(
        &mut bp,
        &mut bn,
        &mut bi,
        [v(-s, 0., s), v(s, 0., s), v(s, 0., -s), v(-s, 0., -s)],
    );
    // Two shells: the inner faces of the walls and roof (2 × 2 × 2), and their outer faces
    // 0.1 further out.
    for (a, hgt) in [(1.0f32, 2.0f32), (1.1, 2.1)] {
        let c = |x: f32, y: f32, z: f32| v(x * a, y * hgt, z * a);
        let walls = [
            [
                c(-1., 0., -1.),
                c(1., 0., -1.),
                c(1., 1., -1.),
                c(-1., 1., -1.),
            ],
            [c(1., 0., 1.), c(-1., 0., 1.), c(-1., 1., 1.), c(1., 1., 1.)],
            [
                c(-1., 0., 1.),
                c(-1., 0., -1.),
                c(-1., 1., -1.),
                c(-1., 1., 1.),
            ],
            [c(1., 0., -1.), c(1., 0., 1.), c(1., 1., 1.), c(1., 1., -1.)],
            [
                c(-1., 1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
        ];
        for q in walls {
            quad(&mut bp, &mut bn, &mut bi, q);
        }
    }
    g.mesh("shed", &bp, &bn, &bi, m);
    let (p, n, i) = uv_sphere(Vec3::new(0.3, 0.3, 0.3), 0.3, 32, 16);
    g.mesh("ball", &p, &n, &i, m);
    g.camera(
        "inside",
        v(0.0, 1.6, 0.6),
        v(-0.6, 0.0, -0.9),
        60f32.to_radians(),
    );
    let mut scene = Scene::from_glb_bytes(&g.to_glb(), "shed").expect("the shed loads");
    scene
        .set_environment(&EnvironmentSettings {
            kind: EnvironmentKind::Uniform,
            strength: 1.0,
            ..Default::default()
        })
        .unwrap();
    scene
}

fn mean_inside(scene: &Arc<Scene>, visibility: bool) -> f32 {
    let s = RenderSettings {
        width: 32,
        height: 32,
        spp: 2,
        photons: 200_000,
        direct: DirectMode::Photons,
        splat_visibility: visibility,
        ..RenderSettings::default()
    };
    let film = render_method(scene, MethodKind::Rs, &s, Budget::Passes(1))
        .unwrap()
        .film;
    film.rgb.iter().map(|c| c.element_sum() / 3.0).sum::<f32>() / film.rgb.len() as f32
}

/// Outside, the ground has radiance ρ·L = 0.5; inside the shed everything is black. Without
/// the visibility test the floor and walls within a splat radius of the wall bases pick up the
/// light of the ground just outside (measured 0.052, 10% of the outside radiance); with it,
/// 0.019: the test holds it below 0.4× the leak. (0.054 and 0.017 while escaping rays were
/// cut at the scene's bounds, which at the roof's height is where rays rising past the
/// walls were cut: docs/deviations.md §42.) What is left reaches the walls' inner faces
/// from rays just outside them, and the floor from rays landing on the walls' outer faces
/// (the hemisphere beyond a hit, Fig. 4); docs/deviations.md §40 has why neither is tested.
#[test]
fn a_closed_shed_on_a_sunlit_ground_stays_dark() {
    let scene = Arc::new(shed());
    let outside = 0.5;
    let leaky = mean_inside(&scene, false);
    let tight = mean_inside(&scene, true);
    eprintln!("interior: {leaky} without the visibility test, {tight} with it");
    assert!(
        leaky > 1e-2 * outside,
        "without visibility the shed should leak: {leaky}"
    );
    assert!(
        tight < 0.4 * leaky,
        "with visibility the shed should leak far less: {tight} (without: {leaky})"
    );
}

/// The probes find a wall beside a floor point (the wall's plane, facing the point) and no
/// blocker beside the sphere, whose tangent planes differ between the two elevations.
#[test]
fn probes_find_walls_not_spheres() {
    let scene = shed();
    // On the floor 0.1 from the wall at z = −1.
    let b = probe(&scene, Vec3::new(0.0, 0.0, -0.9), Vec3::Y);
    assert!(
        b.iter()
            .any(|p| p.m.dot(Vec3::Z) > 0.999 && (p.d - -1.0).abs() < 1e-4),
        "{b:?}"
    );
    // On the floor beside the sphere, far from every wall but the roof's height: the sphere
    // gives no plane.
    let b = probe(&scene, Vec3::new(0.3, 0.0, -0.05), Vec3::Y);
    assert!(
        b.iter().all(|p| p.m == Vec3::ZERO
            || p.m.dot(Vec3::Y).abs() > 0.999
            || p.m.dot(Vec3::Y).abs() < 1e-3),
        "a sphere's tangent plane was taken for a blocker: {b:?}"
    );
}
