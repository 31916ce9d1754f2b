//! What the user chooses about the environment: which one, its strength and rotation, and an
//! optional sun; parsed from the command line, checked against their ranges, described in one
//! line.

use super::{ANGLE_RANGE, ELEVATION_RANGE, STRENGTH_RANGE};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;
use std::path::PathBuf;

/// Which environment lights the scene.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum EnvironmentKind {
    /// `none` when the file has lights of its own, `uniform` when it has none.
    #[default]
    Auto,
    /// No environment: escaping rays see black.
    None,
    /// The same radiance (strength, strength, strength) from every direction.
    Uniform,
    /// An analytic clear daylight sky ([`sky_radiance`](super::sky_radiance)).
    Sky,
    /// An equirectangular map read from a Radiance `.hdr` or OpenEXR `.exr` file.
    File(PathBuf),
}

impl EnvironmentKind {
    /// `auto`, `none`, `uniform`, `sky`, or anything else as a file path.
    pub fn parse(s: &str) -> Self {
        match s.trim() {
            "auto" => Self::Auto,
            "none" => Self::None,
            "uniform" => Self::Uniform,
            "sky" => Self::Sky,
            path => Self::File(PathBuf::from(path)),
        }
    }

    /// The name `parse` reads back (a file's path for a file).
    pub fn name(&self) -> String {
        match self {
            Self::Auto => "auto".into(),
            Self::None => "none".into(),
            Self::Uniform => "uniform".into(),
            Self::Sky => "sky".into(),
            Self::File(p) => p.display().to_string(),
        }
    }
}

/// A sun: a disc of angular radius [`SUN_ANGULAR_RADIUS_DEG`](super::SUN_ANGULAR_RADIUS_DEG) at
/// an elevation and azimuth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sun {
    /// Degrees above the horizon (−90 to 90).
    pub elevation_deg: f32,
    /// Degrees from −Z towards +X (the map's convention, see the module notes).
    pub azimuth_deg: f32,
    /// Irradiance on a surface facing the sun (W/m², before the environment's strength).
    pub strength: f32,
}

impl Sun {
    /// A sun's strength when `--sun` names none: five times the irradiance that a uniform
    /// environment of radiance 1 gives a horizontal surface (π), about a clear day's ratio
    /// of direct sun to sky light.
    pub const DEFAULT_STRENGTH: f32 = 5.0 * PI;

    /// `ELEVATION,AZIMUTH[,STRENGTH]` in degrees (and W/m²).
    pub fn parse(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if !(2..=3).contains(&parts.len()) {
            return Err(format!(
                "{s:?}: expected ELEVATION,AZIMUTH[,STRENGTH] (degrees, degrees, W/m²)"
            ));
        }
        let num = |i: usize, what: &str| -> Result<f32, String> {
            parts[i]
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{s:?}: the {what} {:?} is not a number", parts[i]))
        };
        let sun = Sun {
            elevation_deg: num(0, "elevation")?,
            azimuth_deg: num(1, "azimuth")?,
            strength: if parts.len() == 3 {
                num(2, "strength")?
            } else {
                Self::DEFAULT_STRENGTH
            },
        };
        sun.check()?;
        Ok(sun)
    }

    /// An error when a value is outside its range.
    pub fn check(&self) -> Result<(), String> {
        if !ELEVATION_RANGE.contains(&self.elevation_deg) {
            return Err(format!(
                "sun elevation {} outside {ELEVATION_RANGE:?} degrees",
                self.elevation_deg
            ));
        }
        if !ANGLE_RANGE.contains(&self.azimuth_deg) {
            return Err(format!(
                "sun azimuth {} outside {ANGLE_RANGE:?} degrees",
                self.azimuth_deg
            ));
        }
        if !STRENGTH_RANGE.contains(&self.strength) {
            return Err(format!(
                "sun strength {} outside {STRENGTH_RANGE:?}",
                self.strength
            ));
        }
        Ok(())
    }

    /// Unit direction towards the sun, before the environment's rotation.
    pub fn direction(&self) -> Vec3 {
        direction_from_angles(self.elevation_deg, self.azimuth_deg)
    }
}

/// Unit direction at `elevation` degrees above the horizon and `azimuth` degrees from −Z
/// towards +X.
pub fn direction_from_angles(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos())
}

/// Everything the user chose about the environment (the CLI's `--environment`,
/// `--env-strength`, `--env-rotation`, `--sun`; the window's Environment section).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EnvironmentSettings {
    /// Which environment.
    pub kind: EnvironmentKind,
    /// Multiplier of the environment's radiance (and the sun's).
    pub strength: f32,
    /// Rotation of the environment (and the sun) about +Y, degrees.
    pub rotation_deg: f32,
    /// An optional sun.
    pub sun: Option<Sun>,
}

impl Default for EnvironmentSettings {
    fn default() -> Self {
        Self {
            kind: EnvironmentKind::Auto,
            strength: 1.0,
            rotation_deg: 0.0,
            sun: None,
        }
    }
}

impl EnvironmentSettings {
    /// An error when a value is outside its range.
    pub fn check(&self) -> Result<(), String> {
        if !STRENGTH_RANGE.contains(&self.strength) {
            return Err(format!(
                "environment strength {} outside {STRENGTH_RANGE:?}",
                self.strength
            ));
        }
        if !ANGLE_RANGE.contains(&self.rotation_deg) {
            return Err(format!(
                "environment rotation {} outside {ANGLE_RANGE:?} degrees",
                self.rotation_deg
            ));
        }
        match &self.sun {
            Some(s) => s.check(),
            None => Ok(()),
        }
    }
}

/// A one-line description of a resolved environment ("uniform × 1", "sky × 2, sun", …).
pub fn describe(env: &EnvironmentSettings) -> String {
    let kind = match &env.kind {
        EnvironmentKind::Auto => "automatic".to_string(),
        EnvironmentKind::None => "none".to_string(),
        EnvironmentKind::Uniform => "uniform".to_string(),
        EnvironmentKind::Sky => "sky".to_string(),
        EnvironmentKind::File(p) => p
            .file_name()
            .map_or_else(|| p.display().to_string(), |f| f.to_string_lossy().into()),
    };
    let mut s = if env.kind == EnvironmentKind::None {
        kind
    } else {
        format!("{kind} × {}", env.strength)
    };
    if env.rotation_deg != 0.0 && env.kind != EnvironmentKind::None {
        s += &format!(", turned {}°", env.rotation_deg);
    }
    if env.sun.is_some() {
        s += ", sun";
    }
    s
}
