//! Scattering models with one shape: `eval` (f_r, no cosine), `pdf` (solid angle) and `sample`.
//!
//! Directions point away from the surface: `wo` towards the previous vertex, `wi` towards the
//! next. `n` is the shading normal; models are two-sided where the physics allows (a Lambertian
//! wall is lit from either side), the dielectric tells inside from outside by the sign of `wo·n`.

use crate::sampling::{cosine_hemisphere, luminance, to_world};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// A sampled direction. `weight` = f_r · |cos θ_i| / pdf (the throughput factor).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled unit direction towards the next vertex.
    pub wi: Vec3,
    /// f_r·|cos θ_i|/pdf; for specular events the lobe's colour over its probability.
    pub weight: Vec3,
    /// Solid-angle pdf; for specular events the discrete probability of the chosen lobe.
    pub pdf: f32,
    /// A Dirac-delta lobe was sampled (mirror, or the dielectric's reflection or refraction).
    pub specular: bool,
}

/// A scattering model at one surface point (a material evaluated at a hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Ideal diffuse reflection, f = albedo/π.
    Lambert {
        /// Diffuse reflectance (linear RGB).
        albedo: Vec3,
    },
    /// Moderately glossy (§8.1): a Lambertian part plus a normalised modified-Phong lobe
    /// around the mirror direction (Lafortune & Willems 1994),
    /// f = kd/π + ks·(e+2)/(2π)·cos^e α, α the angle between wi and the mirror direction of wo.
    /// Energy-conserving whenever kd + ks ≤ 1 per channel (see [`glossy_from_pbr`]).
    Glossy {
        /// Diffuse reflectance of the Lambertian part.
        kd: Vec3,
        /// Reflectance of the glossy lobe.
        ks: Vec3,
        /// Phong exponent e ([`phong_exponent`] of the roughness).
        exponent: f32,
    },
    /// Perfect specular reflection.
    Mirror {
        /// Reflectance.
        color: Vec3,
    },
    /// Smooth glass: Fresnel-weighted specular reflection and refraction.
    Dielectric {
        /// Index of refraction (inside over outside, the normal pointing outside).
        ior: f32,
        /// Colour of the transmitted light (reflection is untinted).
        tint: Vec3,
    },
}

impl Bsdf {
    /// True for models whose every lobe is a Dirac delta (handled by deterministic eye chains).
    pub fn is_specular(&self) -> bool {
        !matches!(self, Bsdf::Lambert { .. } | Bsdf::Glossy { .. })
    }

    /// f_r(wo, wi) without the cosine; zero for delta lobes and for directions on opposite
    /// sides of `n`.
    pub fn eval(&self, wo: Vec3, wi: Vec3, n: Vec3) -> Vec3 {
        match *self {
            Bsdf::Lambert { albedo } => {
                if wo.dot(n) * wi.dot(n) > 0.0 {
                    albedo * FRAC_1_PI
                } else {
                    Vec3::ZERO
                }
            }
            Bsdf::Glossy { kd, ks, exponent } => {
                let cos_o = wo.dot(n);
                if cos_o * wi.dot(n) <= 0.0 {
                    return Vec3::ZERO;
                }
                let r = reflect(wo, n);
                kd * FRAC_1_PI + ks * phong_lobe(r.dot(wi), exponent)
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf with which [`Bsdf::sample`] picks `wi` given `wo` (0 for delta lobes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        match *self {
            Bsdf::Lambert { .. } => {
                if wo.dot(n) * wi.dot(n) > 0.0 {
                    wi.dot(n).abs() * FRAC_1_PI
                } else {
                    0.0
                }
            }
            Bsdf::Glossy { kd, ks, exponent } => {
                if wo.dot(n) * wi.dot(n) <= 0.0 {
                    return 0.0;
                }
                let p_s = specular_probability(kd, ks);
                let cos_a = reflect(wo, n).dot(wi);
                (1.0 - p_s) * wi.dot(n).abs() * FRAC_1_PI + p_s * phong_pdf(cos_a, exponent)
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
            Bsdf::Glossy { kd, ks, exponent } => {
                let side = if wo.dot(n) >= 0.0 { n } else { -n };
                let p_s = specular_probability(kd, ks);
                let wi = if u_lobe < p_s {
                    // The lobe around the mirror direction: cos α = u^(1/(e+1)).
                    let cos_a = u.x.powf(1.0 / (exponent + 1.0));
                    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
                    let phi = 2.0 * PI * u.y;
                    let local = Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
                    to_world(local, reflect(wo, side))
                } else {
                    to_world(cosine_hemisphere(u), side)
                };
                // Lobe directions below the surface carry no reflection (f = 0 there).
                let cos = wi.dot(side);
                if cos <= 0.0 {
                    return None;
                }
                let pdf = self.pdf(wo, wi, n);
                if pdf <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: self.eval(wo, wi, n) * cos / pdf,
                    pdf,
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

/// The normalised modified-Phong lobe (e+2)/(2π)·max(0, cos α)^e.
#[inline]
pub fn phong_lobe(cos_a: f32, exponent: f32) -> f32 {
    if cos_a <= 0.0 {
        0.0
    } else {
        (exponent + 2.0) * (0.5 * FRAC_1_PI) * cos_a.powf(exponent)
    }
}

/// Solid-angle pdf of sampling the Phong lobe around its axis: (e+1)/(2π)·cos^e α.
#[inline]
pub fn phong_pdf(cos_a: f32, exponent: f32) -> f32 {
    if cos_a <= 0.0 {
        0.0
    } else {
        (exponent + 1.0) * (0.5 * FRAC_1_PI) * cos_a.powf(exponent)
    }
}

/// Probability of sampling the glossy lobe rather than the diffuse part: its share of the
/// reflectance by luminance.
#[inline]
pub fn specular_probability(kd: Vec3, ks: Vec3) -> f32 {
    let (d, s) = (luminance(kd).max(0.0), luminance(ks).max(0.0));
    if d + s <= 0.0 { 0.5 } else { s / (d + s) }
}

/// Specular reflectance of glTF's dielectric (F0 = 0.04) averaged over the hemisphere with
/// Schlick's approximation: F0 + (1 − F0)/21.
pub const DIELECTRIC_SPECULAR: f32 = 0.04 + 0.96 / 21.0;

/// The Phong exponent for glTF's perceptual roughness: α = roughness² (glTF spec), and
/// e = 2/α² − 2 (Walter et al. 2007's Beckmann–Phong correspondence), kept in [1, 10⁴].
pub fn phong_exponent(roughness: f32) -> f32 {
    let a = (roughness * roughness).max(1e-3);
    (2.0 / (a * a) - 2.0).clamp(1.0, 1e4)
}

/// glTF metallic-roughness → [`Bsdf::Glossy`]: metals reflect their base colour in the lobe,
/// dielectrics reflect [`DIELECTRIC_SPECULAR`] in the lobe and the rest of their base colour
/// diffusely. kd + ks ≤ 1 per channel for base ≤ 1, so the model conserves energy.
pub fn glossy_from_pbr(base: Vec3, roughness: f32, metallic: f32) -> Bsdf {
    let m = metallic.clamp(0.0, 1.0);
    let base = base.clamp(Vec3::ZERO, Vec3::ONE);
    Bsdf::Glossy {
        kd: (1.0 - m) * (1.0 - DIELECTRIC_SPECULAR) * base,
        ks: m * base + Vec3::splat((1.0 - m) * DIELECTRIC_SPECULAR),
        exponent: phong_exponent(roughness),
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
