//! The equirectangular map (its conventions are in the notes of `scene::environment`):
//! radiance per texel, its 2D importance-sampling distribution, and the environment's radiance,
//! pdf and sampling, uniform or from a map.

use crate::sampling::{Distribution1D, luminance};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::path::Path;

/// Unit direction of the map coordinates (u, v) ∈ [0, 1]² in the map's own frame (before
/// rotation): θ = πv from +Y, φ = 2π(u − 1/2) from −Z towards +X (the module's convention;
/// `EnvMap::uv` is its inverse).
#[inline]
pub fn direction_of_uv(u: f32, v: f32) -> Vec3 {
    let (theta, phi) = (v * PI, (u - 0.5) * 2.0 * PI);
    let sin = theta.sin();
    Vec3::new(sin * phi.sin(), theta.cos(), -sin * phi.cos())
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
pub(super) fn rotate_y(d: Vec3, (c, s): (f32, f32), inverse: bool) -> Vec3 {
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
    pub(super) fn uv(d: Vec3) -> (f32, f32, f32) {
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

    /// Solid-angle pdf with which [`EnvLight::sample`] picks `d` for a receiver `facing`
    /// that way (`None`: the whole sphere, as photons and receivers lit from both sides take
    /// it).
    #[inline]
    pub fn pdf(&self, d: Vec3, facing: Option<Vec3>) -> f32 {
        match (self, facing) {
            (Self::Uniform(_), None) => 1.0 / (4.0 * PI),
            (Self::Uniform(_), Some(n)) => {
                if d.dot(n) > 0.0 {
                    0.5 / PI
                } else {
                    0.0
                }
            }
            (Self::Map(m), _) => m.pdf(d),
        }
    }

    /// A direction towards the environment for a receiver `facing` that way (`None`: over
    /// the whole sphere), the radiance from it, and its solid-angle pdf ([`EnvLight::pdf`]).
    /// A map is drawn by its own distribution either way; a uniform environment, which has
    /// no direction to importance-sample, over the receiver's hemisphere: over the whole
    /// sphere half the samples fell below the receiver, and the receiver's cosine would
    /// duplicate the BSDF's own samples, which MIS combines with these, and was worse inside
    /// rooms lit through a window (docs/deviations.md §58).
    #[inline]
    pub fn sample(&self, u: Vec2, facing: Option<Vec3>) -> Option<(Vec3, Vec3, f32)> {
        match (self, facing) {
            (Self::Uniform(l), None) => {
                Some((crate::sampling::uniform_sphere(u), *l, 1.0 / (4.0 * PI)))
            }
            (Self::Uniform(l), Some(n)) => {
                let d = crate::sampling::uniform_sphere(u);
                let d = if d.dot(n) < 0.0 { -d } else { d };
                let pdf = self.pdf(d, facing);
                (pdf > 0.0).then_some((d, *l, pdf))
            }
            (Self::Map(m), _) => m.sample(u),
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
