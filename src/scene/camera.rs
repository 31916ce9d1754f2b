//! The pinhole camera.

use glam::Vec3;

/// A pinhole camera (glTF perspective camera: looks down its local −Z, +Y up).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// Name (the glTF node's or camera's; `cameraN` or `framing` when it has none).
    pub name: String,
    /// Eye point (world space).
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up vector, perpendicular to `forward`.
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl Camera {
    /// A camera at `position` looking at `target` with +Y up (vertical field of view `yfov`,
    /// radians).
    pub fn look_at(name: &str, position: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - position).normalize();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        Self {
            name: name.to_string(),
            position,
            forward,
            up: right.cross(forward),
            yfov,
        }
    }

    /// Unit right vector, forward × up.
    pub fn right(&self) -> Vec3 {
        self.forward.cross(self.up).normalize()
    }

    /// Direction through film point (`sx`, `sy`) ∈ \[0, 1\]², y down, for an image of
    /// `aspect` = w/h.
    #[inline]
    pub fn direction(&self, sx: f32, sy: f32, aspect: f32) -> Vec3 {
        let th = (0.5 * self.yfov).tan();
        let x = (2.0 * sx - 1.0) * th * aspect;
        let y = (1.0 - 2.0 * sy) * th;
        (self.forward + x * self.right() + y * self.up).normalize()
    }
}

/// A camera looking at the bounding box from +Z, for scenes without one.
pub(super) fn framing_camera(min: Vec3, max: Vec3) -> Camera {
    let center = 0.5 * (min + max);
    let radius = 0.5 * (max - min).length();
    let yfov = 45f32.to_radians();
    let dist = radius / (0.5 * yfov).sin();
    Camera::look_at("framing", center + Vec3::new(0.0, 0.0, dist), center, yfov)
}
