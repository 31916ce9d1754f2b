//! Unit tests of the environment: the map's conventions and sampling, the sun, the sky, the
//! parsers and the one-line descriptions.

use super::*;
use crate::sampling::{Rng, luminance};

#[test]
fn map_directions_follow_the_documented_convention() {
    // Centre column looks along −Z; u grows towards +X; row 0 is the zenith.
    assert!((EnvMap::uv(Vec3::NEG_Z).0 - 0.5).abs() < 1e-6);
    assert!((EnvMap::uv(Vec3::X).0 - 0.75).abs() < 1e-6);
    assert!(EnvMap::uv(Vec3::Y).1 < 1e-6);
    // direction_of_uv is uv's inverse.
    for (u, v) in [(0.1f32, 0.3f32), (0.64, 0.34), (0.9, 0.8)] {
        let (u2, v2, _) = EnvMap::uv(direction_of_uv(u, v));
        assert!((u2 - u).abs() < 1e-5 && (v2 - v).abs() < 1e-5, "({u}, {v})");
    }
    assert!((direction_from_angles(0.0, 90.0) - Vec3::X).length() < 1e-6);
    assert!((direction_from_angles(90.0, 0.0) - Vec3::Y).length() < 1e-6);
    // +90° about +Y takes −Z to −X.
    let r = 90f32.to_radians();
    assert!((rotate_y(Vec3::NEG_Z, (r.cos(), r.sin()), false) - Vec3::NEG_X).length() < 1e-6);
}

#[test]
fn map_sampling_pdf_matches_pdf_and_integrates_to_one() {
    // A map with one bright texel and a dim rest, turned by 30°.
    let (w, h) = (16, 8);
    let mut texels = vec![Vec3::splat(0.1); w * h];
    texels[3 * w + 5] = Vec3::new(40.0, 30.0, 20.0);
    let m = EnvMap::new(w, h, texels, 30.0).unwrap();
    let env = EnvLight::Map(Box::new(m));
    let mut rng = Rng::new(1, 2);
    // E[L/pdf] = ∫ L dω (importance sampling is unbiased).
    let n = 200_000;
    let mut est = Vec3::ZERO;
    for _ in 0..n {
        // None only on a pole (sin θ = 0): a set of measure zero, counted as zero.
        let Some((d, l, pdf)) = env.sample(rng.next_2d(), None) else {
            continue;
        };
        assert!(
            (env.pdf(d, None) - pdf).abs() <= 2e-3 * pdf,
            "{} vs {pdf}",
            env.pdf(d, None)
        );
        assert_eq!(env.radiance(d), l);
        est += l / pdf;
    }
    est /= n as f32;
    let exact = env.integral();
    assert!(
        ((est - exact) / exact).abs().max_element() < 0.01,
        "{est} vs {exact}"
    );
    // ∫ pdf dω = 1 by uniform sphere sampling.
    let mut total = 0.0f64;
    for _ in 0..n {
        let d = crate::sampling::uniform_sphere(rng.next_2d());
        total += env.pdf(d, None) as f64 * 4.0 * std::f64::consts::PI;
    }
    assert!(
        (total / n as f64 - 1.0).abs() < 0.02,
        "{}",
        total / n as f64
    );
}

#[test]
fn sun_gives_its_irradiance_and_samples_its_disc() {
    let towards = direction_from_angles(30.0, 40.0);
    let sun = SunLight::new(towards, 7.0);
    // E = L · solid angle · cos ≈ L·Ω on a facing surface (α tiny).
    let e = luminance(sun.radiance) * sun.solid_angle;
    assert!((e - 7.0).abs() < 7.0 * 1e-3, "{e}");
    let mut rng = Rng::new(3, 4);
    for _ in 0..1000 {
        let d = sun.sample(rng.next_2d());
        assert!(d.dot(towards) >= sun.cos_max - 1e-6);
    }
}

#[test]
fn sky_is_normalised_brighter_near_the_sun_and_parses() {
    let sun = direction_from_angles(40.0, 0.0);
    let m = sky_map(sun, 2.0, 0.0).unwrap();
    // Mean radiance over the upper hemisphere is the strength: ∫ over it = 2·2π.
    let upper = EnvLight::Map(Box::new(m));
    let mut rng = Rng::new(5, 6);
    let n = 100_000;
    let mut sum = 0.0;
    for _ in 0..n {
        let mut d = crate::sampling::uniform_sphere(rng.next_2d());
        d.y = d.y.abs();
        sum += luminance(upper.radiance(d));
    }
    assert!((sum / n as f32 - 2.0).abs() < 0.05, "{}", sum / n as f32);
    let near = upper.radiance(direction_from_angles(35.0, 5.0));
    let far = upper.radiance(direction_from_angles(35.0, 180.0));
    assert!(luminance(near) > 2.0 * luminance(far));
    assert_eq!(Sun::parse("30,90").unwrap().strength, Sun::DEFAULT_STRENGTH);
    assert!(Sun::parse("100,0").is_err());
    assert!(Sun::parse("30").is_err());
    assert_eq!(EnvironmentKind::parse("sky"), EnvironmentKind::Sky);
    assert_eq!(
        EnvironmentKind::parse("a.hdr"),
        EnvironmentKind::File("a.hdr".into())
    );
}

#[test]
fn descriptions_name_what_lights() {
    let mut env = EnvironmentSettings {
        kind: EnvironmentKind::Uniform,
        ..Default::default()
    };
    assert_eq!(describe(&env), "uniform × 1");
    env.kind = EnvironmentKind::File("/maps/studio.hdr".into());
    env.strength = 2.0;
    env.rotation_deg = 90.0;
    assert_eq!(describe(&env), "studio.hdr × 2, turned 90°");
    env.kind = EnvironmentKind::None;
    env.sun = Some(Sun::parse("30,0").unwrap());
    assert_eq!(describe(&env), "none, sun");
}
