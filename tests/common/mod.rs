//! Scenes built in tests.
#![allow(dead_code)]

pub mod chi2;
pub mod glb;

use glam::Vec3;
use raysplat::film::Film;
use raysplat::methods::{Budget, render_method};
use raysplat::scene::{GlbBuilder, Scene};
use raysplat::settings::{MethodKind, RenderSettings};
use serde_json::json;
use std::sync::Arc;

/// A square diffuse plane at y = 0 (half size `half`), front face up.
pub fn plane(g: &mut GlbBuilder, half: f32, material: u32) {
    let p = [
        Vec3::new(-half, 0.0, -half),
        Vec3::new(half, 0.0, -half),
        Vec3::new(half, 0.0, half),
        Vec3::new(-half, 0.0, half),
    ];
    // Counter-clockwise seen from +Y.
    g.mesh("plane", &p, &[Vec3::Y; 4], &[0, 2, 1, 0, 3, 2], material);
}

pub fn white(g: &mut GlbBuilder) -> u32 {
    g.material(json!({"name": "white", "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}))
}

/// A plane under a point light of intensity `intensity` W/sr at height `height`, seen from
/// straight above by a camera covering ±`view` around the foot of the light.
pub fn point_light_over_plane(intensity: f32, height: f32, view: f32) -> Scene {
    let mut g = GlbBuilder::default();
    let m = white(&mut g);
    plane(&mut g, 4.0, m);
    g.point_light("lamp", Vec3::new(0.0, height, 0.0), Vec3::ONE, intensity);
    let cam_h = 2.0 * height;
    g.camera(
        "top",
        Vec3::new(0.0, cam_h, 0.0),
        Vec3::ZERO,
        2.0 * (view / cam_h).atan(),
    );
    Scene::from_glb_bytes(&g.to_glb(), "point light over plane").expect("test scene loads")
}

/// A white square area light facing down (mesh "light"): centre `center`, half side `half`,
/// radiance `radiance`.
pub fn ceiling_light(g: &mut GlbBuilder, center: Vec3, half: f32, radiance: f32) {
    let light = g.material(json!({"name": "light", "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": radiance}}}));
    let p = [
        center + Vec3::new(-half, 0.0, -half),
        center + Vec3::new(half, 0.0, -half),
        center + Vec3::new(half, 0.0, half),
        center + Vec3::new(-half, 0.0, half),
    ];
    // Counter-clockwise seen from below (front face down).
    g.mesh("light", &p, &[-Vec3::Y; 4], &[0, 1, 2, 0, 2, 3], light);
}

/// A downward-facing square area light (side `side`, radiance `radiance`) at height `height`
/// over the plane.
pub fn area_light_over_plane(side: f32, radiance: f32, height: f32) -> Scene {
    let mut g = GlbBuilder::default();
    let m = white(&mut g);
    plane(&mut g, 4.0, m);
    ceiling_light(&mut g, Vec3::Y * height, 0.5 * side, radiance);
    g.camera("top", Vec3::new(0.0, 2.0 * height, 0.01), Vec3::ZERO, 0.6);
    Scene::from_glb_bytes(&g.to_glb(), "area light over plane").expect("test scene loads")
}

/// The built-in path tracer's image of `scene` with `settings` at `spp` paths per pixel (the
/// transport the settings' photon fractions carry).
pub fn path_traced(scene: &Arc<Scene>, settings: &RenderSettings, spp: u32) -> Film {
    let s = RenderSettings {
        pt_spp: spp,
        ..settings.clone()
    };
    render_method(scene, MethodKind::Pt, &s, Budget::Fixed)
        .expect("the path tracer renders")
        .film
}

/// The tiny photon-splatting render the loader tests give every scene that loads: 8 × 8, one
/// eye sample per pixel, 500 photon rays.
pub fn tiny_settings() -> RenderSettings {
    RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        photons: 500,
        pm_k: 10,
        ..RenderSettings::default()
    }
}

/// One pass of [`tiny_settings`]' render of `scene`: Err when it fails or gives a NaN or
/// infinite pixel.
pub fn renders_cleanly(scene: Arc<Scene>) -> Result<(), String> {
    let mut r = raysplat::methods::build(scene, tiny_settings()).map_err(|e| e.to_string())?;
    r.step();
    match r.film().invalid_pixels() {
        0 => Ok(()),
        n => Err(format!("{n} NaN or infinite pixels (rs)")),
    }
}
