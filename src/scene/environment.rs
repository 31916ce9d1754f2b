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

use crate::sampling::{Distribution1D, luminance};
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

/// The sun's angular radius: half of its mean apparent diameter, 0.53°.
pub const SUN_ANGULAR_RADIUS_DEG: f32 = 0.265;

/// Accepted environment (and sun) strengths; `settings::limits` reads these ranges.
pub const STRENGTH_RANGE: RangeInclusive<f32> = 0.0..=1e6;
/// Accepted rotations and sun azimuths, degrees.
pub const ANGLE_RANGE: RangeInclusive<f32> = -360.0..=360.0;
/// Accepted sun elevations, degrees.
pub const ELEVATION_RANGE: RangeInclusive<f32> = -90.0..=90.0;

/// Width and height of the tabulated analytic sky.
const SKY_SIZE: (usize, usize) = (512, 256);

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
    /// An analytic clear daylight sky ([`sky_radiance`]).
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

/// A sun: a disc of angular radius [`SUN_ANGULAR_RADIUS_DEG`] at an elevation and azimuth.
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

/// Unit direction of the map coordinates (u, v) ∈ [0, 1]² in the map's own frame (before
/// rotation): θ = πv from +Y, φ = 2π(u − 1/2) from −Z towards +X (the module's convention;
/// `EnvMap::uv` is its inverse).
#[inline]
pub fn direction_of_uv(u: f32, v: f32) -> Vec3 {
    let (theta, phi) = (v * PI, (u - 0.5) * 2.0 * PI);
    let sin = theta.sin();
    Vec3::new(sin * phi.sin(), theta.cos(), -sin * phi.cos())
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

/// Radiance arriving from infinitely far away: uniform, or a map (the sky is tabulated as one).
#[derive(Clone, Debug)]
pub enum EnvLight {
    /// The same radiance from every direction.
    Uniform(Vec3),
    /// An equirectangular map.
    Map(Box<EnvMap>),
}

/// An equirectangular radiance map with its sampling distribution (module notes).
#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Radiance per texel, row 0 at the zenith, strength applied.
    texels: Vec<Vec3>,
    /// Rows by their summed weight.
    rows: Distribution1D,
    /// Each row's texels by weight (`None` for a row without light).
    columns: Vec<Option<Distribution1D>>,
    /// cos and sin of the rotation about +Y.
    rotation: (f32, f32),
    /// ∫ L dω over the sphere (RGB).
    integral: Vec3,
}

/// Turn `d` by the rotation (cos, sin) about +Y; `inverse` turns it back.
#[inline]
fn rotate_y(d: Vec3, (c, s): (f32, f32), inverse: bool) -> Vec3 {
    let s = if inverse { -s } else { s };
    Vec3::new(c * d.x + s * d.z, d.y, c * d.z - s * d.x)
}

impl EnvMap {
    /// A map of `width` × `height` texels (row 0 at the zenith) turned by `rotation_deg`
    /// about +Y. `None` when no texel is bright (nothing to light with) or a value is
    /// negative or not finite.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>, rotation_deg: f32) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return None;
        }
        if texels
            .iter()
            .any(|t| !t.is_finite() || t.min_element() < 0.0)
        {
            return None;
        }
        let mut row_weights = Vec::with_capacity(height);
        let mut columns = Vec::with_capacity(height);
        let mut integral = Vec3::ZERO;
        for y in 0..height {
            let (t0, t1) = (
                PI * y as f32 / height as f32,
                PI * (y + 1) as f32 / height as f32,
            );
            let sin_mid = (0.5 * (t0 + t1)).sin() as f64;
            // A texel's solid angle: (2π/w)(cos θ0 − cos θ1).
            let omega = 2.0 * PI / width as f32 * (t0.cos() - t1.cos());
            let row = &texels[y * width..(y + 1) * width];
            let weights: Vec<f64> = row.iter().map(|t| luminance(*t) as f64 * sin_mid).collect();
            integral += row.iter().sum::<Vec3>() * omega;
            row_weights.push(weights.iter().sum::<f64>());
            columns.push(Distribution1D::new(&weights));
        }
        let rows = Distribution1D::new(&row_weights)?;
        let r = rotation_deg.to_radians();
        Some(Self {
            width,
            height,
            texels,
            rows,
            columns,
            rotation: (r.cos(), r.sin()),
            integral,
        })
    }

    /// Read an equirectangular `.hdr` (Radiance RGBE) or `.exr` map, scaled by `strength`.
    pub fn read(path: &Path, strength: f32, rotation_deg: f32) -> Result<Self, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let (w, h, px) = match ext.as_str() {
            "exr" => crate::film::read_exr(path)?,
            "hdr" => {
                let img = image::ImageReader::open(path)
                    .map_err(|e| format!("cannot open {}: {e}", path.display()))?
                    .with_guessed_format()
                    .map_err(|e| format!("cannot read {}: {e}", path.display()))?
                    .decode()
                    .map_err(|e| format!("cannot read {}: {e}", path.display()))?
                    .into_rgb32f();
                let (w, h) = img.dimensions();
                let px = img.pixels().map(|p| Vec3::from(p.0)).collect();
                (w, h, px)
            }
            _ => {
                return Err(format!(
                    "{}: an environment map must be a Radiance .hdr or an OpenEXR .exr file",
                    path.display()
                ));
            }
        };
        // Negative or non-finite texels (an EXR may hold them) give no light.
        let px: Vec<Vec3> = px
            .into_iter()
            .map(|t| {
                let t = t * strength;
                if t.is_finite() {
                    t.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        Self::new(w as usize, h as usize, px, rotation_deg)
            .ok_or_else(|| format!("{}: the environment map has no light", path.display()))
    }

    /// (u, v) in [0, 1)² of a direction in the map's own frame, and sin θ.
    #[inline]
    fn uv(d: Vec3) -> (f32, f32, f32) {
        let y = d.y.clamp(-1.0, 1.0);
        let u = 0.5 + d.x.atan2(-d.z) / (2.0 * PI);
        (
            u.rem_euclid(1.0),
            y.acos() / PI,
            (1.0 - y * y).max(0.0).sqrt(),
        )
    }

    #[inline]
    fn texel_index(&self, u: f32, v: f32) -> (usize, usize) {
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }

    fn radiance(&self, d: Vec3) -> Vec3 {
        let (u, v, _) = Self::uv(rotate_y(d, self.rotation, true));
        let (x, y) = self.texel_index(u, v);
        self.texels[y * self.width + x]
    }

    fn pdf(&self, d: Vec3) -> f32 {
        let (u, v, sin) = Self::uv(rotate_y(d, self.rotation, true));
        if sin <= 0.0 {
            return 0.0;
        }
        let (x, y) = self.texel_index(u, v);
        let Some(col) = &self.columns[y] else {
            return 0.0;
        };
        let p_uv = self.rows.pmf(y) * col.pmf(x) * (self.width * self.height) as f32;
        p_uv / (2.0 * PI * PI * sin)
    }

    fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let (y, _, dv) = self.rows.sample_continuous(u.y);
        let col = self.columns[y].as_ref()?;
        let (x, _, du) = col.sample_continuous(u.x);
        let uu = (x as f32 + du) / self.width as f32;
        let vv = (y as f32 + dv) / self.height as f32;
        let d = rotate_y(direction_of_uv(uu, vv), self.rotation, false);
        // Radiance and pdf of the texel the direction maps back to, so that a sample on a
        // texel's edge (rounding) gets the very values `radiance` and `pdf` give it.
        let (pdf, l) = (self.pdf(d), self.radiance(d));
        (pdf > 0.0).then_some((d, l, pdf))
    }
}

impl EnvLight {
    /// Radiance arriving from direction `d` (unit, pointing away from the scene).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match self {
            Self::Uniform(l) => *l,
            Self::Map(m) => m.radiance(d),
        }
    }

    /// Solid-angle pdf with which [`EnvLight::sample`] picks `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match self {
            Self::Uniform(_) => 1.0 / (4.0 * PI),
            Self::Map(m) => m.pdf(d),
        }
    }

    /// A direction towards the environment, the radiance from it, and its solid-angle pdf.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        match self {
            Self::Uniform(l) => Some((crate::sampling::uniform_sphere(u), *l, 1.0 / (4.0 * PI))),
            Self::Map(m) => m.sample(u),
        }
    }

    /// ∫ L dω over the sphere (RGB).
    pub fn integral(&self) -> Vec3 {
        match self {
            Self::Uniform(l) => *l * (4.0 * PI),
            Self::Map(m) => m.integral,
        }
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

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
            let Some((d, l, pdf)) = env.sample(rng.next_2d()) else {
                continue;
            };
            assert!(
                (env.pdf(d) - pdf).abs() <= 2e-3 * pdf,
                "{} vs {pdf}",
                env.pdf(d)
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
            total += env.pdf(d) as f64 * 4.0 * std::f64::consts::PI;
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
}
