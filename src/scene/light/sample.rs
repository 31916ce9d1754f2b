//! Drawing from the lights: photons leaving them for the light pass (chosen by power), and
//! points on them for next-event estimation at eye samples.

use super::{EmittedPhoton, Light, LightSample, Lights, NO_TEXTURE};
use crate::sampling::{
    Rng, cosine_hemisphere, to_world, uniform_cone, uniform_sphere, uniform_triangle,
};
use crate::scene::environment::EnvLight;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

impl Lights {
    /// A point on an area light from `u`: its barycentrics, its radiance there and its area
    /// density relative to the uniform one (uniform without a texture, by the texture with
    /// one: `textured`).
    #[inline]
    fn area_point(
        &self,
        triangle: u32,
        texture: u32,
        radiance: Vec3,
        u: Vec2,
    ) -> (f32, f32, Vec3, f32) {
        let (b1, b2, radiance, relative) = if texture == NO_TEXTURE {
            let (b1, b2) = uniform_triangle(u);
            (b1, b2, radiance, 1.0)
        } else {
            let (b1, b2, relative) = self.textured.sample(texture, u);
            (
                b1,
                b2,
                self.textured.radiance(&self.textures, texture, b1, b2),
                relative,
            )
        };
        // An alpha-tested emitter sends nothing through its holes (MASK) and α of its light
        // elsewhere (BLEND), as the rays that meet it see.
        (b1, b2, radiance * self.coverage(triangle, b1, b2), relative)
    }

    /// Sample a photon leaving a light, chosen by power.
    pub fn sample_emission(&self, rng: &mut Rng) -> Option<EmittedPhoton> {
        let (i, p_sel) = self.select(rng.next_f32())?;
        let u_pos = rng.next_2d();
        let u_dir = rng.next_2d();
        let u_side = rng.next_f32();
        self.emit(i, p_sel, u_pos, u_dir, u_side)
    }

    /// The light `u` ∈ [0, 1) chooses in proportion to power, with its probability.
    #[inline]
    pub fn select(&self, u: f32) -> Option<(usize, f32)> {
        Some(self.dist.as_ref()?.sample(u))
    }

    /// The probability that [`Lights::select`] chooses light `i`.
    pub fn selection_pmf(&self, i: usize) -> f32 {
        self.dist.as_ref().map_or(0.0, |d| d.pmf(i))
    }

    /// The photon that leaves light `i` from the primary sample (`u_pos`, `u_dir`, `u_side`),
    /// drawn with density `p_sel` in that sample space (the light's selection probability
    /// when the sample is uniform; an emission guide's density otherwise): its power is
    /// divided by `p_sel` and its eq. 7 density multiplied by it.
    pub fn emit(
        &self,
        i: usize,
        p_sel: f32,
        u_pos: Vec2,
        u_dir: Vec2,
        u_side: f32,
    ) -> Option<EmittedPhoton> {
        if p_sel.is_nan() || p_sel <= 0.0 {
            return None;
        }
        let photon = match *self.lights.get(i)? {
            Light::Area {
                v0,
                e1,
                e2,
                normal,
                area,
                radiance,
                two_sided,
                triangle,
                texture,
            } => {
                let (b1, b2, radiance, relative) =
                    self.area_point(triangle, texture, radiance, u_pos);
                // A dark texel of an emissive texture sends nothing (the photon still counts).
                if relative <= 0.0 || radiance.max_element() <= 0.0 {
                    return None;
                }
                let (n, p_side) = if two_sided {
                    (if u_side < 0.5 { normal } else { -normal }, 0.5)
                } else {
                    (normal, 1.0)
                };
                let local = cosine_hemisphere(u_dir);
                let dir = to_world(local, n);
                let cos = local.z.max(1e-6);
                let pdf = p_sel * p_side * relative / area * cos / PI;
                EmittedPhoton {
                    origin: v0 + b1 * e1 + b2 * e2,
                    direction: dir,
                    normal: n,
                    // Le · cos / (p_sel · p_side · (relative/A) · cos/π)
                    power: radiance * (PI * area / (p_sel * p_side * relative)),
                    pdf,
                    pdf_per_area: true,
                    offset: crate::scene::surface_offset(
                        v0.abs()
                            .max((v0 + e1).abs())
                            .max((v0 + e2).abs())
                            .max_element(),
                    ),
                    triangle,
                    parallel: false,
                }
            }
            Light::Point {
                position,
                intensity,
            } => EmittedPhoton {
                origin: position,
                direction: uniform_sphere(u_dir),
                normal: Vec3::ZERO,
                power: intensity * (4.0 * PI / p_sel),
                pdf: p_sel / (4.0 * PI),
                pdf_per_area: false,
                offset: 0.0,
                triangle: u32::MAX,
                parallel: false,
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let local = uniform_cone(u_dir, cos_outer);
                let pdf_dir = 1.0 / (2.0 * PI * (1.0 - cos_outer));
                EmittedPhoton {
                    origin: position,
                    direction: to_world(local, direction),
                    normal: Vec3::ZERO,
                    power: intensity
                        * (spot_falloff(local.z, cos_inner, cos_outer) / (p_sel * pdf_dir)),
                    pdf: p_sel * pdf_dir,
                    pdf_per_area: false,
                    offset: 0.0,
                    triangle: u32::MAX,
                    parallel: false,
                }
            }
            Light::Environment { .. } => {
                let (towards, radiance, pdf_dir) =
                    self.environment.light.as_ref()?.sample(u_dir, None)?;
                self.photon_from_afar(towards, radiance, pdf_dir, p_sel, u_pos)?
            }
            Light::Sun(sun) => {
                let towards = sun.sample(u_dir);
                self.photon_from_afar(towards, sun.radiance, 1.0 / sun.solid_angle, p_sel, u_pos)?
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let r = self.scene_radius;
                let d = crate::sampling::concentric_disk(u_pos) * r;
                let (t, b) = crate::sampling::onb(direction);
                let area = PI * r * r;
                EmittedPhoton {
                    origin: self.scene_center - direction * r + t * d.x + b * d.y,
                    direction,
                    normal: direction,
                    power: irradiance * (area / p_sel),
                    pdf: p_sel / area,
                    pdf_per_area: true,
                    offset: 0.0,
                    triangle: u32::MAX,
                    parallel: true,
                }
            }
        };
        Some(photon)
    }

    /// A photon arriving from infinitely far away along −`towards` with radiance `radiance`
    /// (direction sampled with solid-angle pdf `pdf_dir`, the light with `p_sel`): it starts
    /// on the disc of radius r facing `towards` on the scene's bounding sphere, so its power is
    /// L·πr²/(p_sel·pdf_dir). Its eq. 7 density is the disc's, p_sel/(πr²), as a directional
    /// light's: the direction's density is left out (docs/deviations.md, "Light from afar").
    fn photon_from_afar(
        &self,
        towards: Vec3,
        radiance: Vec3,
        pdf_dir: f32,
        p_sel: f32,
        u_pos: Vec2,
    ) -> Option<EmittedPhoton> {
        if pdf_dir.is_nan() || pdf_dir <= 0.0 || radiance == Vec3::ZERO {
            return None;
        }
        let r = self.scene_radius;
        let d = crate::sampling::concentric_disk(u_pos) * r;
        let (t, b) = crate::sampling::onb(towards);
        let area = PI * r * r;
        Some(EmittedPhoton {
            origin: self.scene_center + towards * r + t * d.x + b * d.y,
            direction: -towards,
            normal: -towards,
            power: radiance * (area / (p_sel * pdf_dir)),
            pdf: p_sel / area,
            pdf_per_area: true,
            offset: 0.0,
            triangle: u32::MAX,
            parallel: true,
        })
    }

    /// Sample a point on a light as seen from `p` for next-event estimation. `facing`: the
    /// normal of the hemisphere the receiver takes light from, or `None` for one lit from
    /// both sides (rough glass); a uniform environment is drawn uniformly over its hemisphere
    /// ([`EnvLight::sample`]), everything else ignores it.
    pub fn sample_direct(
        &self,
        p: Vec3,
        facing: Option<Vec3>,
        u_light: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let (i, p_sel) = self.select(u_light)?;
        match self.lights[i] {
            Light::Area {
                v0,
                e1,
                e2,
                normal,
                area,
                radiance,
                two_sided,
                triangle,
                texture,
            } => {
                let (b1, b2, radiance, relative) = self.area_point(triangle, texture, radiance, u);
                if relative <= 0.0 || radiance.max_element() <= 0.0 {
                    return None;
                }
                let q = v0 + b1 * e1 + b2 * e2;
                let d = q - p;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let distance = dist2.sqrt();
                let wi = d / distance;
                let mut cos_l = -wi.dot(normal);
                if two_sided {
                    cos_l = cos_l.abs();
                }
                if cos_l <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    wi,
                    distance,
                    value: radiance * (cos_l * area / (dist2 * p_sel * relative)),
                    pdf: p_sel * relative * dist2 / (area * cos_l),
                    triangle,
                })
            }
            Light::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                Some(LightSample {
                    wi: d / distance,
                    distance,
                    value: intensity / (dist2 * p_sel),
                    pdf: f32::INFINITY,
                    triangle: u32::MAX,
                })
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                let distance = dist2.sqrt();
                let wi = d / distance;
                let fall = spot_falloff(-wi.dot(direction), cos_inner, cos_outer);
                if fall <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    wi,
                    distance,
                    value: intensity * (fall / (dist2 * p_sel)),
                    pdf: f32::INFINITY,
                    triangle: u32::MAX,
                })
            }
            Light::Environment { .. } => {
                let env: &EnvLight = self.environment.light.as_ref()?;
                let (wi, radiance, pdf) = env.sample(u, facing)?;
                (pdf > 0.0).then(|| LightSample {
                    wi,
                    distance: f32::INFINITY,
                    value: radiance / (p_sel * pdf),
                    pdf: p_sel * pdf,
                    triangle: u32::MAX,
                })
            }
            Light::Sun(sun) => {
                let pdf = 1.0 / sun.solid_angle;
                Some(LightSample {
                    wi: sun.sample(u),
                    distance: f32::INFINITY,
                    value: sun.radiance / (p_sel * pdf),
                    pdf: p_sel * pdf,
                    triangle: u32::MAX,
                })
            }
            Light::Directional {
                direction,
                irradiance,
            } => Some(LightSample {
                wi: -direction,
                distance: 4.0 * self.scene_radius,
                value: irradiance / p_sel,
                pdf: f32::INFINITY,
                triangle: u32::MAX,
            }),
        }
    }
}

/// glTF spot attenuation: smooth between the outer and inner cone (KHR_lights_punctual notes).
#[inline]
pub fn spot_falloff(cos: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    if cos <= cos_outer {
        return 0.0;
    }
    let t = ((cos - cos_outer) / (cos_inner - cos_outer).max(1e-6)).clamp(0.0, 1.0);
    t * t
}
