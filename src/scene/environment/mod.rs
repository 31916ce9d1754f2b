//! The environment: light arriving from infinitely far away in every direction (a uniform
//! white, an analytic daylight sky, or an equirectangular `.hdr`/`.exr` map), and the sun.
//!
//! Directions use the scene's frame (glTF: +Y up). An equirectangular map's row 0 is the
//! zenith (+Y) and its last row the nadir; its centre column looks along −Z (the way a glTF
//! camera without rotation looks) and u grows towards +X: for a unit direction d,
//! u = 1/2 + atan2(d.x, −d.z)/2π, v = acos(d.y)/π. `rotation` turns the whole environment,
//! the sun included, about +Y (right-handed: +90° takes −Z to −X).
//!
//! A map is piecewise constant over its texels (nearest texel), and is importance-sampled
//! with a piecewise-constant 2D distribution over the image whose texel weights are
//! luminance × sin θ (the equirectangular texel's solid angle), as pbrt-v4's image infinite
//! light does (it uses an equal-area octahedral map instead). The solid-angle pdf of a
//! direction is p(u, v)/(2π² sin θ).
//!
//! The user's choices ([`EnvironmentSettings`]: parsing, ranges, the one-line description) are
//! in `settings`, the equirectangular map and its sampling distribution in `map`, the analytic
//! sky and the sun's light in `sky`; [`Environment`], what a scene's lights hold, is here. Unit
//! tests are in `tests`.

mod map;
mod settings;
mod sky;
#[cfg(test)]
mod tests;

pub use map::{EnvLight, EnvMap, direction_of_uv};
pub use settings::{EnvironmentKind, EnvironmentSettings, Sun, describe, direction_from_angles};
pub use sky::{SunLight, cie_clear_sky, sky_map, sky_radiance};

use glam::Vec3;
use map::rotate_y;
use std::ops::RangeInclusive;

/// The sun's angular radius: half of its mean apparent diameter, 0.53°.
pub const SUN_ANGULAR_RADIUS_DEG: f32 = 0.265;

/// Accepted environment (and sun) strengths; `crate::settings::limits` reads these ranges.
pub const STRENGTH_RANGE: RangeInclusive<f32> = 0.0..=1e6;
/// Accepted rotations and sun azimuths, degrees.
pub const ANGLE_RANGE: RangeInclusive<f32> = -360.0..=360.0;
/// Accepted sun elevations, degrees.
pub const ELEVATION_RANGE: RangeInclusive<f32> = -90.0..=90.0;

/// The built environment of a scene: what [`EnvironmentSettings`] resolved to.
#[derive(Clone, Debug, Default)]
pub struct Environment {
    /// The environment's radiance, when there is one.
    pub light: Option<EnvLight>,
    /// The sun, when there is one.
    pub sun: Option<SunLight>,
}

impl Environment {
    /// Build what `settings` asks for (`Auto` must have been resolved: it builds nothing).
    /// A file's path is taken as given (relative to the working directory).
    pub fn build(settings: &EnvironmentSettings) -> Result<Self, String> {
        settings.check()?;
        let strength = settings.strength;
        let sun_dir = settings.sun.map(|s| s.direction());
        let light = match &settings.kind {
            EnvironmentKind::Auto | EnvironmentKind::None => None,
            EnvironmentKind::Uniform => Some(EnvLight::Uniform(Vec3::splat(strength))),
            EnvironmentKind::Sky => {
                // Without --sun the sky's brightness follows a sun at 45°, azimuth 0.
                let sun = sun_dir.unwrap_or_else(|| direction_from_angles(45.0, 0.0));
                sky_map(sun, strength, settings.rotation_deg).map(|m| EnvLight::Map(Box::new(m)))
            }
            EnvironmentKind::File(path) => Some(EnvLight::Map(Box::new(EnvMap::read(
                path,
                strength,
                settings.rotation_deg,
            )?))),
        };
        let r = settings.rotation_deg.to_radians();
        let sun = settings.sun.map(|s| {
            SunLight::new(
                rotate_y(s.direction(), (r.cos(), r.sin()), false),
                s.strength * strength,
            )
        });
        Ok(Self { light, sun })
    }

    /// Nothing lights from far away.
    pub fn is_empty(&self) -> bool {
        self.light.is_none() && self.sun.is_none()
    }

    /// Radiance arriving along a ray that escapes the scene in direction `d`.
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let mut l = Vec3::ZERO;
        if let Some(e) = &self.light {
            l += e.radiance(d);
        }
        if let Some(s) = &self.sun {
            l += s.radiance(d);
        }
        l
    }
}
