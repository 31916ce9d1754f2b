//! Scattering models with one shape: `eval` (f_r, no cosine), `pdf` (solid angle) and `sample`.
//!
//! Directions point away from the surface: `wo` towards the previous vertex, `wi` towards the
//! next. `n` is the shading normal; models are two-sided where the physics allows (a Lambertian
//! wall is lit from either side), the dielectric tells inside from outside by the sign of `wo·n`.

use crate::sampling::{cosine_hemisphere, to_world};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A sampled direction. `weight` = f_r · |cos θ_i| / pdf (the throughput factor).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Vec3,
    /// Solid-angle pdf; for specular events the discrete probability of the chosen lobe.
    pub pdf: f32,
    pub specular: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Lambert { albedo: Vec3 },
    Mirror { color: Vec3 },
    Dielectric { ior: f32, tint: Vec3 },
}

impl Bsdf {
    /// True for models whose every lobe is a Dirac delta (handled by deterministic eye chains).
    pub fn is_specular(&self) -> bool {
        !matches!(self, Bsdf::Lambert { .. })
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, n: Vec3) -> Vec3 {
        match *self {
            Bsdf::Lambert { albedo } => {
                if wo.dot(n) * wi.dot(n) > 0.0 {
                    albedo * FRAC_1_PI
                } else {
                    Vec3::ZERO
                }
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => Vec3::ZERO,
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        match *self {
            Bsdf::Lambert { .. } => {
                if wo.dot(n) * wi.dot(n) > 0.0 {
                    wi.dot(n).abs() * FRAC_1_PI
                } else {
                    0.0
                }
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => 0.0,
        }
    }

    /// `u` picks the direction, `u_lobe` the lobe (Fresnel choice for the dielectric).
    pub fn sample(&self, wo: Vec3, n: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match *self {
            Bsdf::Lambert { albedo } => {
                let side = if wo.dot(n) >= 0.0 { n } else { -n };
                let wi = to_world(cosine_hemisphere(u), side);
                let cos = wi.dot(side);
                if cos <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: albedo,
                    pdf: cos * FRAC_1_PI,
                    specular: false,
                })
            }
            Bsdf::Mirror { color } => Some(BsdfSample {
                wi: reflect(wo, n),
                weight: color,
                pdf: 1.0,
                specular: true,
            }),
            Bsdf::Dielectric { ior, tint } => {
                let cos_o = wo.dot(n);
                let entering = cos_o > 0.0;
                let (eta, nn) = if entering { (1.0 / ior, n) } else { (ior, -n) };
                let f = fresnel_dielectric(cos_o.abs(), eta);
                if u_lobe < f {
                    Some(BsdfSample {
                        wi: reflect(wo, nn),
                        weight: Vec3::ONE,
                        pdf: f,
                        specular: true,
                    })
                } else {
                    let wi = refract(wo, nn, eta)?;
                    Some(BsdfSample {
                        wi,
                        weight: tint,
                        pdf: 1.0 - f,
                        specular: true,
                    })
                }
            }
        }
    }
}

/// Mirror `wo` about `n` (both unit; result points to the same side as `wo`).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Refract `wo` (on the side of `n`) through the interface; `eta` = η_incident / η_transmitted.
/// `None` on total internal reflection.
#[inline]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-eta * wo + (eta * cos_i - cos_t) * n).normalize())
}

/// Unpolarised Fresnel reflectance; `cos_i` ≥ 0 on the incident side, `eta` = η_i / η_t.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_par = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_perp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, uniform_sphere};

    #[test]
    fn lambert_sample_matches_eval_and_pdf() {
        let b = Bsdf::Lambert {
            albedo: Vec3::new(0.5, 0.6, 0.7),
        };
        let mut rng = Rng::new(1, 2);
        for _ in 0..1000 {
            let n = uniform_sphere(rng.next_2d());
            let wo = uniform_sphere(rng.next_2d());
            if let Some(s) = b.sample(wo, n, rng.next_2d(), rng.next_f32()) {
                let f = b.eval(wo, s.wi, n);
                let pdf = b.pdf(wo, s.wi, n);
                assert!((pdf - s.pdf).abs() < 1e-4);
                let w = f * s.wi.dot(n).abs() / pdf;
                assert!((w - s.weight).abs().max_element() < 1e-3);
            }
        }
    }

    #[test]
    fn fresnel_limits() {
        // Normal incidence glass: ((1-1.5)/(1+1.5))² = 0.04.
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-5);
        // Grazing incidence reflects everything.
        assert!((fresnel_dielectric(0.0, 1.0 / 1.5) - 1.0).abs() < 1e-5);
        // Total internal reflection beyond the critical angle (41.8° for 1.5).
        assert_eq!(fresnel_dielectric(0.5, 1.5), 1.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let wt = refract(wo, n, 1.0 / 1.5).unwrap();
        let sin_i = 0.6;
        let sin_t = (1.0 - wt.z * wt.z).sqrt();
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-5);
        assert!(wt.z < 0.0 && wt.x < 0.0);
    }
}
