//! The analytic `sky` environment (the CIE standard clear sky, tabulated as a map) and the sun
//! as a light.

use super::{EnvMap, SUN_ANGULAR_RADIUS_DEG, direction_of_uv};
use crate::sampling::luminance;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Width and height of the tabulated analytic sky.
const SKY_SIZE: (usize, usize) = (512, 256);

/// Relative luminance of the CIE standard clear sky (ISO 15469:2004 / CIE S 011, sky type 12:
/// gradation a = −1, b = −0.32; indicatrix c = 10, d = −3, e = 0.45) at zenith angle `theta`
/// and angle `gamma` from the sun whose zenith angle is `sun_theta`, relative to the zenith's.
pub fn cie_clear_sky(theta: f32, gamma: f32, sun_theta: f32) -> f32 {
    let (a, b, c, d, e) = (-1.0f32, -0.32f32, 10.0f32, -3.0f32, 0.45f32);
    let gradation = |t: f32| 1.0 + a * (b / t.cos().max(1e-4)).exp();
    let indicatrix =
        |g: f32| 1.0 + c * ((d * g).exp() - (d * PI / 2.0).exp()) + e * g.cos().powi(2);
    indicatrix(gamma) * gradation(theta) / (indicatrix(sun_theta) * gradation(0.0))
}

/// Radiance of the `sky` environment towards direction `d` (before normalisation): the CIE
/// clear sky's luminance ([`cie_clear_sky`]) for a sun towards `sun` (unit), tinted from a
/// blue zenith to a white horizon; below the horizon a grey ground of 0.3× the zenith
/// luminance.
pub fn sky_radiance(d: Vec3, sun: Vec3) -> Vec3 {
    const ZENITH_TINT: Vec3 = Vec3::new(0.50, 0.70, 1.0);
    const HORIZON_TINT: Vec3 = Vec3::new(1.0, 1.0, 1.0);
    if d.y <= 0.0 {
        return Vec3::splat(0.3);
    }
    let theta = d.y.clamp(-1.0, 1.0).acos();
    // The sky's own sun stays above the horizon (its brightness pattern needs one).
    let sun_theta = sun.y.clamp(0.02, 1.0).acos();
    let gamma = d.dot(sun).clamp(-1.0, 1.0).acos();
    let t = theta / (0.5 * PI);
    let tint = ZENITH_TINT.lerp(HORIZON_TINT, t * t);
    tint * cie_clear_sky(theta, gamma, sun_theta)
}

/// The `sky` environment as a map: [`sky_radiance`] for a sun at `sun` (before rotation),
/// normalised so that its mean luminance over the upper hemisphere (per solid angle) is
/// `strength`.
pub fn sky_map(sun: Vec3, strength: f32, rotation_deg: f32) -> Option<EnvMap> {
    let (w, h) = SKY_SIZE;
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let d = direction_of_uv((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            texels.push(sky_radiance(d, sun));
        }
    }
    // Mean luminance over the upper hemisphere, by solid angle.
    let (mut sum, mut omega) = (0.0f64, 0.0f64);
    for y in 0..h / 2 {
        let theta = PI * (y as f32 + 0.5) / h as f32;
        let s = theta.sin() as f64;
        for x in 0..w {
            sum += luminance(texels[y * w + x]) as f64 * s;
            omega += s;
        }
    }
    let scale = if sum > 0.0 {
        (strength as f64 * omega / sum) as f32
    } else {
        0.0
    };
    for t in &mut texels {
        *t *= scale;
    }
    EnvMap::new(w, h, texels, rotation_deg)
}

/// The sun as a light: radiance inside a cone of half-angle [`SUN_ANGULAR_RADIUS_DEG`].
#[derive(Clone, Copy, Debug)]
pub struct SunLight {
    /// Unit direction towards the sun (rotation applied).
    pub towards: Vec3,
    /// Radiance of the sun's disc.
    pub radiance: Vec3,
    /// cos of the angular radius.
    pub cos_max: f32,
    /// Solid angle of the disc, 2π(1 − cos), worked out in f64.
    pub solid_angle: f32,
}

impl SunLight {
    /// A sun giving `irradiance` on a surface facing it: L = E/(π sin²α) (∫ L cos θ dω over
    /// the cone of half-angle α), a slightly warm white.
    pub fn new(towards: Vec3, irradiance: f32) -> Self {
        const COLOUR: Vec3 = Vec3::new(1.0, 0.96, 0.90);
        let a = (SUN_ANGULAR_RADIUS_DEG as f64).to_radians();
        let radiance = irradiance as f64 / (std::f64::consts::PI * a.sin() * a.sin());
        Self {
            towards: towards.normalize(),
            radiance: COLOUR / luminance(COLOUR) * radiance as f32,
            cos_max: a.cos() as f32,
            solid_angle: (2.0 * std::f64::consts::PI * (1.0 - a.cos())) as f32,
        }
    }

    /// Radiance from direction `d` (the disc's inside the cone, zero outside).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        if d.dot(self.towards) >= self.cos_max {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }

    /// Solid-angle pdf of [`SunLight::sample`] for `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        if d.dot(self.towards) >= self.cos_max {
            1.0 / self.solid_angle
        } else {
            0.0
        }
    }

    /// A direction towards the sun's disc, uniformly over its solid angle.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        // 1 − cos_max is tiny (1.1·10⁻⁵): sample z from the solid angle, not from cos_max.
        let z = 1.0 - u.x * self.solid_angle / (2.0 * PI);
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        crate::sampling::to_world(Vec3::new(r * phi.cos(), r * phi.sin(), z), self.towards)
    }
}
