//! Scattering models with one shape: `eval` (f_r, no cosine), `pdf` (solid angle) and `sample`.
//!
//! Directions point away from the surface: `wo` towards the previous vertex, `wi` towards the
//! next. `n` is the shading normal. The reflecting models (Lambertian, glossy) take it turned
//! to the viewer's side of the geometric surface, which every caller does, and reflect into
//! its hemisphere (a surface is lit from either side, as the side it is seen from); the
//! mirror reflects on `wo`'s side; the dielectric takes the surface's own normal and tells
//! inside from outside by the sign of `wo·n`.

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
    /// glTF 2.0's metallic-roughness BRDF (appendix B): a Trowbridge–Reitz (GGX) specular
    /// layer with height-correlated Smith masking and Schlick's Fresnel F(f0, v·h), over a
    /// Lambertian layer: f = kd/π·(1 − E_d(θo)) + F·D·V. glTF's `mix(dielectric, metal,
    /// metallic)` is this with kd = (1 − m)·base and f0 = (1 − m)·f0_d + m·base (B.3.5). The
    /// diffuse layer keeps what the dielectric's specular layer does not reflect towards ωo,
    /// 1 − E_d(θo) ([`specular_albedo`] with f0_d), instead of the specification's
    /// 1 − F(v·h), which reflects up to 1.37 of the light at grazing angles
    /// (docs/deviations.md §49): the albedo is then ≤ 1 everywhere, as Cycles scales its base
    /// layer. Not reciprocal in the diffuse layer (nor, like the Lambertian, where the shading
    /// normal leans past ωo: [`Bsdf::eval`]): photons weigh by [`Bsdf::eval`] with the
    /// directions swapped (`adjoint`). KHR_materials_specular's factor s and colour c scale
    /// the dielectric's Fresnel: F_d = s·Schlick(min(f0_ior·c, 1), 1), so the layer's Schlick
    /// runs from f0 to f90 = (1 − m)·s + m ([`SpecularLayer`]).
    Glossy {
        /// Diffuse colour (1 − metallic)·base.
        kd: Vec3,
        /// Specular reflectance at normal incidence.
        f0: Vec3,
        /// Specular reflectance at grazing incidence (1 without KHR_materials_specular).
        f90: f32,
        /// The dielectric layer's reflectance at normal incidence, s·max(min(f0_ior·c, 1))
        /// with f0_ior = ((ior − 1)/(ior + 1))², which weights the diffuse layer.
        f0_d: f32,
        /// The dielectric layer's reflectance at grazing incidence, s.
        f90_d: f32,
        /// GGX α = roughness² (never below [`ALPHA_MIN`]).
        alpha: f32,
    },
    /// Perfect specular reflection.
    Mirror {
        /// Reflectance.
        color: Vec3,
    },
    /// Glass: Fresnel-weighted reflection and refraction (KHR_materials_transmission), smooth
    /// (α = 0: two Dirac deltas) or rough through the same microfacet model as the glossy
    /// BRDF (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces",
    /// with GGX's height-correlated masking and the exact dielectric Fresnel at ωo·h).
    Dielectric {
        /// Index of refraction (inside over outside, the normal pointing outside).
        ior: f32,
        /// Colour of the transmitted light (reflection is untinted).
        tint: Vec3,
        /// GGX α = roughness²; 0 for smooth glass (below [`ALPHA_MIN`] it is smooth).
        alpha: f32,
    },
}

impl Bsdf {
    /// True for models whose every lobe is a Dirac delta (handled by deterministic eye chains).
    pub fn is_specular(&self) -> bool {
        match *self {
            Bsdf::Lambert { .. } | Bsdf::Glossy { .. } => false,
            Bsdf::Dielectric { alpha, .. } => alpha <= 0.0,
            Bsdf::Mirror { .. } => true,
        }
    }

    /// True for the reflecting models (Lambertian, glossy): where eye samples and photons
    /// rest. Light reaches the far side of glass, smooth or rough, through it: eye paths and
    /// photons are traced on (a rough glass's lobe is not a reflection the radiance map or
    /// a splat kernel could hold).
    pub fn is_reflecting(&self) -> bool {
        matches!(self, Bsdf::Lambert { .. } | Bsdf::Glossy { .. })
    }

    /// f_r(wo, wi) without the cosine; zero for delta lobes. For the reflecting models `n` is
    /// the shading normal turned to the viewer's side of the geometric surface, and they
    /// reflect into its hemisphere only (wi·n > 0). A viewer below it (a normal texture's
    /// steep texel, a smooth-shaded mesh at a grazing view) still sees the diffuse layer lit
    /// from there, as Cycles' diffuse closure does with the uncorrected normal; the specular
    /// layer then reflects nothing (Cycles bends its normal; docs/deviations.md §53).
    pub fn eval(&self, wo: Vec3, wi: Vec3, n: Vec3) -> Vec3 {
        match *self {
            Bsdf::Lambert { albedo } => {
                if wi.dot(n) > 0.0 {
                    albedo * FRAC_1_PI
                } else {
                    Vec3::ZERO
                }
            }
            Bsdf::Glossy {
                kd,
                f0,
                f90,
                f0_d,
                f90_d,
                alpha,
            } => {
                let (cos_o, cos_i) = (wo.dot(n), wi.dot(n));
                if cos_i <= 0.0 {
                    return Vec3::ZERO;
                }
                let diffuse = kd * (diffuse_share(cos_o.abs(), alpha, f0_d, f90_d) * FRAC_1_PI);
                if cos_o <= 0.0 {
                    return diffuse;
                }
                let h = (wo + wi).normalize_or_zero();
                let vh = wo.dot(h).max(0.0);
                let spec =
                    schlick_to(f0, f90, vh) * ggx_d(h.dot(n), alpha) * ggx_g2(cos_o, cos_i, alpha)
                        / (4.0 * cos_o * cos_i);
                diffuse + spec
            }
            Bsdf::Dielectric { alpha, .. } if alpha > 0.0 => self.rough_glass(wo, wi, n).0,
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf with which [`Bsdf::sample`] picks `wi` given `wo` (0 for delta lobes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        match *self {
            Bsdf::Lambert { .. } => wi.dot(n).max(0.0) * FRAC_1_PI,
            Bsdf::Glossy { alpha, .. } => {
                let (cos_o, cos_i) = (wo.dot(n), wi.dot(n));
                if cos_i <= 0.0 {
                    return 0.0;
                }
                // A viewer below the normal draws the diffuse layer only (eval's docs).
                if cos_o <= 0.0 {
                    return cos_i * FRAC_1_PI;
                }
                let p_s = self.specular_probability(cos_o);
                let h = (wo + wi).normalize_or_zero();
                // Visible normals' density G₁(ωo)·|ωo·h|·D(h)/cos θo (Heitz 2018's D_ωo) times
                // the reflection's Jacobian 1/(4|ωo·h|) (Walter et al. 2007, eq. 14).
                let spec = ggx_g1(cos_o, alpha) * ggx_d(h.dot(n), alpha) / (4.0 * cos_o);
                (1.0 - p_s) * cos_i * FRAC_1_PI + p_s * spec
            }
            Bsdf::Dielectric { ior, alpha, .. } if alpha > 0.0 => {
                RoughGlass::at(wo, wi, n, ior, alpha).map_or(0.0, |m| m.pdf)
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => 0.0,
        }
    }

    /// Rough glass's [`Bsdf::eval`] and the density with which the eye passes' branch of
    /// `wi`'s lobe (reflected on ωo's side of the shading normal, refracted across it) draws
    /// `wi` — [`Bsdf::pdf`] without the Fresnel choice, since the eye passes follow both
    /// lobes about one microfacet normal ([`glass_lobes`]) — from one evaluation of Walter et
    /// al.'s terms (the eye passes' light samples at rough glass need both); zero for every
    /// other model and smooth glass.
    #[inline]
    pub fn rough_glass(&self, wo: Vec3, wi: Vec3, n: Vec3) -> (Vec3, f32) {
        let Bsdf::Dielectric { ior, tint, alpha } = *self else {
            return (Vec3::ZERO, 0.0);
        };
        if alpha <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        match RoughGlass::at(wo, wi, n, ior, alpha) {
            Some(m) if m.transmits => (tint * m.value, m.lobe_pdf),
            Some(m) => (Vec3::splat(m.value), m.lobe_pdf),
            None => (Vec3::ZERO, 0.0),
        }
    }

    /// `u` picks the direction, `u_lobe` the lobe (Fresnel choice for the dielectric).
    pub fn sample(&self, wo: Vec3, n: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match *self {
            Bsdf::Lambert { albedo } => {
                let wi = to_world(cosine_hemisphere(u), n);
                let cos = wi.dot(n);
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
            Bsdf::Glossy { alpha, .. } => {
                let cos_o = wo.dot(n);
                // A viewer below the normal draws the diffuse layer only (eval's docs).
                let wi = if cos_o > 0.0 && u_lobe < self.specular_probability(cos_o) {
                    let h = sample_ggx_visible(wo, n, alpha, u);
                    reflect(wo, h)
                } else {
                    to_world(cosine_hemisphere(u), n)
                };
                // Directions below the surface carry no reflection (f = 0 there).
                let cos = wi.dot(n);
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
            // A conductor's Fresnel, Schlick's with the base colour as f0 (B.3.4).
            Bsdf::Mirror { color } => Some(BsdfSample {
                wi: reflect(wo, n),
                weight: schlick(color, wo.dot(n).abs()),
                pdf: 1.0,
                specular: true,
            }),
            Bsdf::Dielectric { ior, tint, alpha } => {
                let lobes = glass_lobes(wo, n, ior, alpha, u);
                // Fresnel at ωo·h chooses the lobe.
                let reflects = u_lobe < lobes.fresnel;
                let lobe = if reflects {
                    lobes.reflected
                } else {
                    lobes.refracted
                }?;
                let choice = if reflects {
                    lobes.fresnel
                } else {
                    1.0 - lobes.fresnel
                };
                let wi = lobe.dir;
                let colour = if reflects { Vec3::ONE } else { tint };
                if alpha <= 0.0 {
                    return Some(BsdfSample {
                        wi,
                        weight: colour,
                        pdf: choice,
                        specular: true,
                    });
                }
                // The branch's density from the drawn normal (no second evaluation).
                let pdf = choice * lobe.pdf;
                if pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                // f·|cos θi|/pdf with the visible normals' density: G₂/G₁(ωo), the Fresnel
                // choice cancelling F or 1 − F (Heitz 2018, eq. 19 for either lobe).
                Some(BsdfSample {
                    wi,
                    weight: colour * lobe.masking,
                    pdf,
                    specular: false,
                })
            }
        }
    }
}

/// Both lobes of glass about one microfacet normal: the surface's own for smooth glass
/// (α = 0), else one drawn with `u` from GGX's visible normals at ωo (Heitz 2018). `n` is the
/// surface's own normal (pointing outside); ωo's side decides the medium it is in.
pub struct GlassLobes {
    /// The dielectric Fresnel reflectance at ωo·h.
    pub fresnel: f32,
    /// The reflected lobe; `None` where rough glass reflects below the macrosurface.
    pub reflected: Option<GlassLobe>,
    /// The refracted lobe; `None` on total internal reflection, or where rough glass
    /// refracts back to ωo's side.
    pub refracted: Option<GlassLobe>,
}

/// One lobe of [`GlassLobes`].
#[derive(Clone, Copy)]
pub struct GlassLobe {
    /// Its direction.
    pub dir: Vec3,
    /// Its masking G₂/G₁(ωo) (1 for smooth glass).
    pub masking: f32,
    /// The solid-angle density of `dir` without the Fresnel choice ([`RoughGlass`]'s
    /// `lobe_pdf`, from the drawn normal; 1 for smooth glass): what the eye passes' branch of
    /// this lobe is weighted by.
    pub pdf: f32,
}

/// [`GlassLobes`] at ωo: what [`Bsdf::sample`] draws one of by Fresnel, and what the eye
/// passes follow both of (each lobe's one-sample estimate is its F or 1 − F times its masking,
/// times the tint and [`Bsdf::radiance_scale`] where it refracts).
#[inline]
pub fn glass_lobes(wo: Vec3, n: Vec3, ior: f32, alpha: f32, u: Vec2) -> GlassLobes {
    let (eta, nn) = if wo.dot(n) > 0.0 {
        (1.0 / ior, n)
    } else {
        (ior, -n)
    };
    let h = if alpha > 0.0 {
        sample_ggx_visible(wo, nn, alpha, u)
    } else {
        nn
    };
    let cos_o = wo.dot(nn);
    let oh = wo.dot(h);
    // The visible normals' density of h, G₁(ωo)·(ωo·h)·D(h)/cos θo (Heitz 2018, eq. 3),
    // and G₁(ωo) for the masking, once for both lobes.
    let (g1, visible) = if alpha > 0.0 {
        let g1 = ggx_g1(cos_o, alpha);
        (g1, g1 * oh * ggx_d(h.dot(nn), alpha) / cos_o)
    } else {
        (1.0, 0.0)
    };
    // A rough lobe's direction must land on its side of the macrosurface; smooth glass's
    // always does. `jacobian` turns the density of h into that of the direction (Walter et
    // al. 2007, eq. 14 and 17).
    let lobe = |dir: Vec3, above: bool, jacobian: f32| {
        if alpha <= 0.0 {
            return Some(GlassLobe {
                dir,
                masking: 1.0,
                pdf: 1.0,
            });
        }
        let cos_i = dir.dot(nn);
        (cos_i != 0.0 && (cos_i > 0.0) == above).then(|| GlassLobe {
            dir,
            masking: ggx_g2(cos_o, cos_i, alpha) / g1,
            pdf: visible * jacobian,
        })
    };
    let refracted = refract(wo, h, eta).and_then(|t| {
        // η' = 1/η: the medium of ωi over that of ωo.
        let ih = t.dot(h);
        let denom = (ih + oh * eta) * (ih + oh * eta);
        lobe(t, false, ih.abs() / denom)
    });
    GlassLobes {
        fresnel: fresnel_dielectric(oh, eta),
        reflected: lobe(reflect(wo, h), true, 1.0 / (4.0 * oh)),
        refracted,
    }
}

/// Rough glass's value and density for one pair of directions (Walter et al. 2007, §4, with
/// GGX's distribution, their §5.3, height-correlated G₂ and visible-normal sampling; pbrt-v4's
/// `DielectricBxDF` has the same terms). `n` is the surface's own normal (pointing outside);
/// ωo's side decides which medium it is in. Reflection: f = F·D·G₂/(4|cos θo||cos θi|) about
/// h = ωo + ωi (Walter eq. 13, 20). Refraction: with η' = η_i/η_o (the medium of ωi over that
/// of ωo) and h = ωo + η'·ωi turned to ωo's side (eq. 16), f = (1 − F)·D·G₂·|ωi·h||ωo·h| /
/// (|cos θo||cos θi|·(ωi·h + ωo·h/η')²) (eq. 21), the importance (flux) form: radiance takes
/// [`Bsdf::radiance_scale`]'s 1/η'² on top, as smooth glass does. The density is the visible
/// normals' G₁(ωo)·(ωo·h)·D(h)/cos θo times the Fresnel choice and the Jacobian,
/// 1/(4 ωo·h) for reflection and |ωi·h|/(ωi·h + ωo·h/η')² for refraction (Walter eq. 14, 17).
struct RoughGlass {
    value: f32,
    pdf: f32,
    /// The density without the Fresnel choice: that of the eye passes' branch of this lobe,
    /// which follows both lobes about one drawn microfacet normal ([`glass_lobes`]).
    lobe_pdf: f32,
    transmits: bool,
}

impl RoughGlass {
    #[inline]
    fn at(wo: Vec3, wi: Vec3, n: Vec3, ior: f32, alpha: f32) -> Option<Self> {
        let cos_n = wo.dot(n);
        let (eta, nn) = if cos_n > 0.0 {
            (1.0 / ior, n)
        } else {
            (ior, -n)
        };
        let (cos_o, cos_i) = (wo.dot(nn), wi.dot(nn));
        if cos_o <= 0.0 || cos_i == 0.0 {
            return None;
        }
        let transmits = cos_i < 0.0;
        let etap = 1.0 / eta;
        let mut h = if transmits { wo + wi * etap } else { wo + wi }.normalize_or_zero();
        if h == Vec3::ZERO {
            return None;
        }
        if h.dot(nn) < 0.0 {
            h = -h;
        }
        let (oh, ih) = (wo.dot(h), wi.dot(h));
        // The microfacet must face ωo, and ωi lie on its side (reflection) or behind it.
        if oh <= 0.0 || (ih > 0.0) == transmits {
            return None;
        }
        let f = fresnel_dielectric(oh, eta);
        let d = ggx_d(h.dot(nn), alpha);
        let g2 = ggx_g2(cos_o, cos_i, alpha);
        let visible = ggx_g1(cos_o, alpha) * oh * d / cos_o;
        Some(if transmits {
            let denom = (ih + oh / etap) * (ih + oh / etap);
            let lobe_pdf = visible * ih.abs() / denom;
            RoughGlass {
                value: (1.0 - f) * d * g2 * (ih * oh).abs() / (cos_o * cos_i.abs() * denom),
                pdf: (1.0 - f) * lobe_pdf,
                lobe_pdf,
                transmits,
            }
        } else {
            let lobe_pdf = visible / (4.0 * oh);
            RoughGlass {
                value: f * d * g2 / (4.0 * cos_o * cos_i),
                pdf: f * lobe_pdf,
                lobe_pdf,
                transmits,
            }
        })
    }
}

/// The normalised modified-Phong lobe (e+2)/(2π)·max(0, cos α)^e: the shape the directional
/// radiance map integrates a GGX lobe of the same width with (§8.1, [`phong_equivalent`]).
#[inline]
pub fn phong_lobe(cos_a: f32, exponent: f32) -> f32 {
    if cos_a <= 0.0 {
        0.0
    } else {
        (exponent + 2.0) * (0.5 * FRAC_1_PI) * cos_a.powf(exponent)
    }
}

/// The smallest GGX α: a rougher surface than a perfect mirror, sampled by its visible
/// normals; only a metal of roughness exactly 0 is a mirror (a Dirac delta).
pub const ALPHA_MIN: f32 = 1e-3;

/// The Phong exponent of the same lobe width as GGX α (Walter et al. 2007's Beckmann–Phong
/// correspondence, e = 2/α² − 2), kept in [1, 10⁴]: what the directional radiance map and its
/// resolution limits (§8.1, docs/deviations.md §37) read a GGX lobe as.
pub fn phong_equivalent(alpha: f32) -> f32 {
    let a = alpha.max(ALPHA_MIN);
    (2.0 / (a * a) - 2.0).clamp(1.0, 1e4)
}

/// Glass's GGX α for a glTF roughness: roughness² (glTF 2.0 appendix B.3.2), and 0 (smooth,
/// two Dirac deltas) where that is below [`ALPHA_MIN`] (roughness below 0.032), whose lobe
/// is narrower than any pixel's footprint and which the eye passes then split
/// deterministically, or where the
/// IOR is 1: light passes straight through whatever the roughness (the refraction's half
/// vector ωo + ωi vanishes there; pbrt-v4's dielectric is smooth at η = 1 too).
pub fn glass_alpha(roughness: f32, ior: f32) -> f32 {
    let a = roughness.clamp(0.0, 1.0).powi(2);
    // NaN (never from the loader, which keeps factors finite) reads as smooth.
    if a >= ALPHA_MIN && (ior - 1.0).abs() > 1e-4 {
        a
    } else {
        0.0
    }
}

/// Schlick's Fresnel f0 + (1 − f0)(1 − cos)⁵ (glTF appendix B.3.4), per channel.
#[inline]
pub fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let x = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * x
}

/// Schlick's Fresnel from f0 to a grazing reflectance f90: f0 + (f90 − f0)(1 − cos)⁵
/// (KHR_materials_specular's dielectric, scaled by its factor), per channel.
#[inline]
pub fn schlick_to(f0: Vec3, f90: f32, cos: f32) -> Vec3 {
    let x = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::splat(f90) - f0) * x
}

/// [`schlick_to`] for one channel.
#[inline]
pub fn schlick1_to(f0: f32, f90: f32, cos: f32) -> f32 {
    let x = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (f90 - f0) * x
}

/// The Trowbridge–Reitz (GGX) distribution of normals D(h) for cos θ_h = n·h (B.3.2).
#[inline]
pub fn ggx_d(cos_h: f32, alpha: f32) -> f32 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith's Λ for GGX at cos θ: (√(1 + α² tan²θ) − 1)/2 (Heitz 2014, "Understanding the
/// Masking-Shadowing Function in Microfacet-Based BRDFs", its Λ for the GGX distribution);
/// G₁ = 1/(1 + Λ), and the height-correlated G₂ = 1/(1 + Λ(ωo) + Λ(ωi)) of glTF appendix
/// B.3.2 (the same paper's height-correlated masking-shadowing).
#[inline]
fn ggx_lambda(cos: f32, alpha: f32) -> f32 {
    let c2 = (cos * cos).min(1.0);
    if c2 <= 0.0 {
        return f32::INFINITY;
    }
    let t2 = (1.0 - c2) / c2;
    0.5 * ((1.0 + alpha * alpha * t2).sqrt() - 1.0)
}

/// Smith's masking of one direction, 1/(1 + Λ).
#[inline]
pub fn ggx_g1(cos: f32, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(cos, alpha))
}

/// Height-correlated Smith masking-shadowing 1/(1 + Λ(ωo) + Λ(ωi)) (B.3.2; V = G₂/(4|n·l||n·v|)).
#[inline]
pub fn ggx_g2(cos_o: f32, cos_i: f32, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(cos_o, alpha) + ggx_lambda(cos_i, alpha))
}

/// A microfacet normal drawn from GGX's distribution of normals visible from `wo` (on the
/// side of `n`): Heitz 2018, "Sampling the GGX distribution of visible normals". Its density
/// is G₁(ωo)·max(0, ωo·h)·D(h)/cos θo; reflecting `wo` about it gives a direction of density
/// G₁(ωo)·D(h)/(4 cos θo).
#[inline]
pub fn sample_ggx_visible(wo: Vec3, n: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let (t, b) = crate::sampling::onb(n);
    let local = Vec3::new(wo.dot(t), wo.dot(b), wo.dot(n));
    // The view direction in the hemisphere configuration (stretched).
    let vh = Vec3::new(alpha * local.x, alpha * local.y, local.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Back to the ellipsoid configuration (unstretch).
    let m = Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize();
    (t * m.x + b * m.y + n * m.z).normalize()
}

/// The dielectric's reflectance at normal incidence for an index of refraction
/// (KHR_materials_ior; 0.04 for glTF's default 1.5).
pub fn dielectric_f0(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// KHR_materials_specular's scalars: the strength s of the dielectric's specular layer
/// (`specularFactor`) and the colour c its f0 is multiplied by (`specularColorFactor`,
/// linear RGB). Without the extension s = 1, c = (1, 1, 1): glTF's core model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularLayer {
    /// specularFactor.
    pub factor: f32,
    /// specularColorFactor.
    pub color: Vec3,
}

impl Default for SpecularLayer {
    fn default() -> Self {
        Self {
            factor: 1.0,
            color: Vec3::ONE,
        }
    }
}

impl SpecularLayer {
    /// The dielectric's Fresnel ends for an IOR, KHR_materials_specular's "Implementation"
    /// (ratified version): f0 = s·min(f0_ior·c, 1) per channel and f90 = s.
    pub fn dielectric(&self, ior: f32) -> (Vec3, f32) {
        let s = self.factor.clamp(0.0, 1.0);
        let c = self.color.max(Vec3::ZERO);
        ((dielectric_f0(ior) * c).min(Vec3::ONE) * s, s)
    }
}

/// glTF metallic-roughness → [`Bsdf::Glossy`] (appendix B.3.5): kd = (1 − m)·base,
/// f0 = (1 − m)·f0_d + m·base and f90 = (1 − m)·f90_d + m with the dielectric's f0_d, f90_d
/// from the IOR and KHR_materials_specular ([`SpecularLayer::dielectric`]), α = roughness²
/// (at least [`ALPHA_MIN`]).
pub fn glossy_from_pbr(
    base: Vec3,
    roughness: f32,
    metallic: f32,
    ior: f32,
    specular: SpecularLayer,
) -> Bsdf {
    let m = metallic.clamp(0.0, 1.0);
    let base = base.clamp(Vec3::ZERO, Vec3::ONE);
    let (f0_c, f90_d) = specular.dielectric(ior);
    Bsdf::Glossy {
        kd: (1.0 - m) * base,
        f0: (1.0 - m) * f0_c + m * base,
        f90: (1.0 - m) * f90_d + m,
        // What weights the diffuse layer: the dielectric's f0 at its largest channel (the
        // extension's `max_value(dielectric_f0)`) and its f90.
        f0_d: f0_c.max_element(),
        f90_d,
        alpha: (roughness * roughness).clamp(ALPHA_MIN, 1.0),
    }
}

/// Tables of the glossy model's directional albedos, integrated once on stratified grids:
/// `a`, `b` over (μ, √α) the split-sum factors of the specular layer's albedo
/// E(μ) = f0·A + B (Karis 2013), A the part of ∫ D·G₂/(4 cos θo)·(1 − (1 − ωo·h)⁵) and B of
/// ∫ D·G₂/(4 cos θo)·(1 − ωo·h)⁵.
struct AlbedoTables {
    a: [[f32; TABLE_N]; TABLE_N],
    b: [[f32; TABLE_N]; TABLE_N],
    /// The specular lobe's zonal projection about its axis x, bands 0–3:
    /// a_l = ∫ f_s(ωo, ω)·P_l(x·ω) dω / E (F = 1), what [`ggx_zonal`] reads.
    zonal: [[[f32; 4]; TABLE_N]; TABLE_N],
    /// The axis: the lobe's mean direction, as its angle from the normal towards the mirror
    /// direction (a rough lobe seen at a grazing angle leans far less than the mirror
    /// direction does).
    axis: [[f32; TABLE_N]; TABLE_N],
}

const TABLE_N: usize = 32;
/// Visible-normal samples per entry and axis, when the tables were integrated. A finer grid
/// does not converge on the albedo much faster: the grid resolves GGX's heavy tail, where the
/// masking loss lies, poorly (at μ = 1, α = 0.05 the quadrature of
/// `the_albedo_table_matches_a_quadrature` gives 0.9972, grids of 32, 64, 128, 256 and 512
/// per axis 0.99996, 0.99995, 0.99985, 0.99605, 0.99774).
#[cfg(test)]
const TABLE_GRID: u32 = 32;

/// One entry of [`AlbedoTables`] at (μ index `k`, √α index `r`): (a, b, zonal, axis). The
/// program reads the integrals from `albedo_tables.bin`; only the test that checks (and
/// writes) that file integrates them.
#[cfg(test)]
fn albedo_entry(k: usize, r: usize, grid: u32, lobe: &mut Vec<(Vec3, f32)>) -> AlbedoEntry {
    let n = Vec3::Z;
    let mu = (k as f32 / (TABLE_N - 1) as f32).max(1e-3);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let rough = r as f32 / (TABLE_N - 1) as f32;
    let alpha = (rough * rough).max(ALPHA_MIN);
    // Sums in f64: 16,384 samples of order one summed in f32 lose 0.4% of the albedo.
    let (mut sa, mut sb) = (0.0f64, 0.0f64);
    // (direction, f_s/pdf = w/cos θi) of each visible-normal sample above the surface.
    lobe.clear();
    let mut mean = glam::DVec3::ZERO;
    for i in 0..grid {
        for j in 0..grid {
            let u = Vec2::new(
                (i as f32 + 0.5) / grid as f32,
                (j as f32 + 0.5) / grid as f32,
            );
            let h = sample_ggx_visible(wo, n, alpha, u);
            let wi = reflect(wo, h);
            if wi.z <= 0.0 {
                continue;
            }
            // f·cos/pdf of the visible-normal sample without F: G₂/G₁.
            let w = ggx_g2(wo.z, wi.z, alpha) / ggx_g1(wo.z, alpha);
            let x = (1.0 - wo.dot(h).clamp(0.0, 1.0)).powi(5);
            sa += ((1.0 - x) * w) as f64;
            sb += (x * w) as f64;
            lobe.push((wi, w / wi.z));
            mean += wi.as_dvec3() * (w / wi.z) as f64;
        }
    }
    // The lobe's axis: its mean direction, between n and the mirror direction (which lies
    // towards −x here), as the angle from n.
    let angle = ((-mean.x).atan2(mean.z) as f32).max(0.0);
    let axis = Vec3::new(-angle.sin(), 0.0, angle.cos());
    let mut z = [0.0f64; 4];
    for &(wi, fw) in lobe.iter() {
        let c = axis.dot(wi) as f64;
        let p = [
            1.0,
            c,
            0.5 * (3.0 * c * c - 1.0),
            0.5 * (5.0 * c * c * c - 3.0 * c),
        ];
        for (zl, pl) in z.iter_mut().zip(p) {
            *zl += fw as f64 * pl;
        }
    }
    let total = sa + sb;
    let zonal = if total > 0.0 {
        z.map(|zl| (zl / total) as f32)
    } else {
        [0.0; 4]
    };
    let count = (grid * grid) as f64;
    ((sa / count) as f32, (sb / count) as f32, zonal, angle)
}

/// The tables as the program carries them (`albedo_tables.bin`: for each entry, μ index
/// major, its a, b, zonal[0..4] and axis as little-endian f32), integrated once by
/// `integrate_tables` on a `TABLE_GRID`² grid per entry. Integrating them at start-up took
/// 55 ms of both cores (0.1 s on one) beside the previewer's first image (docs/benchmarks.md,
/// "The previewer"); read from the binary they cost microseconds.
/// `bsdf::tests::the_carried_albedo_tables_are_the_integrals` integrates them again and
/// compares (`RAYSPLAT_WRITE_ALBEDO_TABLES=1` writes the file anew).
static ALBEDO: std::sync::LazyLock<AlbedoTables> = std::sync::LazyLock::new(|| {
    let bytes: &[u8] = include_bytes!("albedo_tables.bin");
    let floats: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let entries: Vec<AlbedoEntry> = floats
        .chunks_exact(ENTRY_FLOATS)
        .map(|e| (e[0], e[1], [e[2], e[3], e[4], e[5]], e[6]))
        .collect();
    assert_eq!(
        entries.len(),
        TABLE_N * TABLE_N,
        "albedo_tables.bin is incomplete"
    );
    tables_from(&entries)
});

/// One table entry: (a, b, zonal, axis).
type AlbedoEntry = (f32, f32, [f32; 4], f32);

/// Floats an entry takes in `albedo_tables.bin`.
const ENTRY_FLOATS: usize = 7;

/// The tables from their entries, μ index major.
fn tables_from(entries: &[AlbedoEntry]) -> AlbedoTables {
    let mut t = AlbedoTables {
        a: [[0.0; TABLE_N]; TABLE_N],
        b: [[0.0; TABLE_N]; TABLE_N],
        zonal: [[[0.0; 4]; TABLE_N]; TABLE_N],
        axis: [[0.0; TABLE_N]; TABLE_N],
    };
    for (e, &(a, b, zonal, axis)) in entries.iter().enumerate() {
        let (k, r) = (e / TABLE_N, e % TABLE_N);
        (t.a[k][r], t.b[k][r], t.zonal[k][r], t.axis[k][r]) = (a, b, zonal, axis);
    }
    t
}

/// Every entry of the tables integrated on a `grid`² grid, μ index major (rayon; for the
/// test that checks the carried tables and for writing them).
#[cfg(test)]
fn integrate_tables(grid: u32) -> Vec<AlbedoEntry> {
    use rayon::prelude::*;
    (0..TABLE_N * TABLE_N)
        .into_par_iter()
        .map_init(Vec::new, |lobe, at| {
            albedo_entry(at / TABLE_N, at % TABLE_N, grid, lobe)
        })
        .collect()
}

/// The entries as `albedo_tables.bin` holds them.
#[cfg(test)]
fn table_bytes(entries: &[AlbedoEntry]) -> Vec<u8> {
    entries
        .iter()
        .flat_map(|&(a, b, z, axis)| [a, b, z[0], z[1], z[2], z[3], axis])
        .flat_map(f32::to_le_bytes)
        .collect()
}

/// Linear interpolation into a table over [0, 1].
#[inline]
fn lerp_index(x: f32) -> (usize, usize, f32) {
    let f = x.clamp(0.0, 1.0) * (TABLE_N - 1) as f32;
    let i = (f.floor() as usize).min(TABLE_N - 2);
    (i, i + 1, f - i as f32)
}

/// Where (cos θo, √α) falls in the tables, for bilinear lookups.
struct TableAt {
    i: (usize, usize, f32),
    k: (usize, usize, f32),
}

impl TableAt {
    #[inline]
    fn new(cos_o: f32, alpha: f32) -> Self {
        Self {
            i: lerp_index(cos_o),
            k: lerp_index(alpha.max(0.0).sqrt()),
        }
    }

    /// Bilinear lookup of entry `get(row, column)`.
    #[inline]
    fn read(&self, get: impl Fn(usize, usize) -> f32) -> f32 {
        let ((i, j, t), (k, l, u)) = (self.i, self.k);
        let lo = get(i, k) + (get(i, l) - get(i, k)) * u;
        let hi = get(j, k) + (get(j, l) - get(j, k)) * u;
        lo + (hi - lo) * t
    }
}

/// A glossy model's specular lobe at ωo (shading normal `n`, ωo above it: a viewer below it
/// sees no specular layer, docs/deviations.md §53) as the radiance map's SH mode integrates
/// it (§8.1, docs/deviations.md §49): its axis — the lobe's mean direction, in the plane of
/// `n` and the mirror direction — and its zonal coefficients (bands 0–3) about that axis,
/// normalised to unit albedo.
pub fn ggx_zonal(wo: Vec3, n: Vec3, alpha: f32) -> (Vec3, [f32; 4]) {
    let (at, table) = (TableAt::new(wo.dot(n), alpha), &*ALBEDO);
    let coeffs = std::array::from_fn(|b| at.read(|i, k| table.zonal[i][k][b]));
    let r = reflect(wo, n);
    let along = (r - n * r.dot(n)).normalize_or_zero();
    let angle = at.read(|i, k| table.axis[i][k]);
    (
        (n * angle.cos() + along * angle.sin()).normalize_or(n),
        coeffs,
    )
}

/// The share of the light a glossy model's diffuse layer keeps at cos θo = `cos_o`:
/// 1 − E_d, E_d the albedo of the dielectric's specular layer (Schlick from f0_d to f90_d)
/// towards ωo. The diffuse layer's albedo is kd times this (the radiance map's diffuse term,
/// exact).
#[inline]
pub fn diffuse_share(cos_o: f32, alpha: f32, f0_d: f32, f90_d: f32) -> f32 {
    (1.0 - specular_albedo(cos_o, alpha, Vec3::splat(f0_d), f90_d).x).max(0.0)
}

/// The directional albedo of a glossy model's specular layer at cos θo = `cos_o`:
/// ∫ F·D·G₂/(4 cos θo) dωi = f0·A + f90·B (single scattering; F Schlick's from f0 to f90).
pub fn specular_albedo(cos_o: f32, alpha: f32, f0: Vec3, f90: f32) -> Vec3 {
    let (at, table) = (TableAt::new(cos_o, alpha), &*ALBEDO);
    f0 * at.read(|i, k| table.a[i][k]) + Vec3::splat(f90 * at.read(|i, k| table.b[i][k]))
}

impl Bsdf {
    /// A reflecting model's directional albedos towards ωo, cos θo = `cos_o` against the
    /// normal on the viewer's side: the diffuse layer's kd·(1 − E_d(|cos θo|)) and the
    /// specular layer's f0·A + f90·B, which a viewer below the normal does not see
    /// (docs/deviations.md §53). A Lambertian's is its albedo; the delta models have none.
    pub fn layer_albedos(&self, cos_o: f32) -> (Vec3, Vec3) {
        match *self {
            Bsdf::Lambert { albedo } => (albedo, Vec3::ZERO),
            Bsdf::Glossy {
                kd,
                f0,
                f90,
                f0_d,
                f90_d,
                alpha,
            } => {
                let diffuse = kd * diffuse_share(cos_o.abs(), alpha, f0_d, f90_d);
                let specular = if cos_o > 0.0 {
                    specular_albedo(cos_o, alpha, f0, f90)
                } else {
                    Vec3::ZERO
                };
                (diffuse, specular)
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// The factor a radiance estimate takes on crossing a dielectric from ωo to ωi,
    /// (η_o/η_i)² (Veach 1997, §5.2: radiance over η² is what is conserved; pbrt-v4's
    /// `TransportMode::Radiance`): 1/ior² entering (ωo on the side `n` points to), ior²
    /// leaving, 1 for reflection and every other model. Flux (photons) takes none. A path
    /// that enters and leaves a volume carries both, which cancel: only an estimate that
    /// stops inside one (an eye sample on a surface within glass) sees the difference.
    pub fn radiance_scale(&self, wo: Vec3, wi: Vec3, n: Vec3) -> f32 {
        match *self {
            Bsdf::Dielectric { ior, .. } if wo.dot(n) * wi.dot(n) < 0.0 => {
                if wo.dot(n) > 0.0 {
                    1.0 / (ior * ior)
                } else {
                    ior * ior
                }
            }
            _ => 1.0,
        }
    }

    /// A glossy model's specular layer alone (its diffuse colour zeroed); any other model
    /// as it is.
    pub fn specular_layer(self) -> Bsdf {
        match self {
            Bsdf::Glossy {
                f0,
                f90,
                f0_d,
                f90_d,
                alpha,
                ..
            } => Bsdf::Glossy {
                kd: Vec3::ZERO,
                f0,
                f90,
                f0_d,
                f90_d,
                alpha,
            },
            other => other,
        }
    }

    /// The probability with which [`Bsdf::sample`] draws a glossy model's specular lobe
    /// rather than its diffuse layer, for cos θo = `cos_o`: the layers' reflectance there
    /// (Fresnel at the normal's angle for the specular, 1 − it for the diffuse) by luminance,
    /// kept within [0.1, 0.9] where both reflect, so that neither layer's samples grow rarer
    /// than one in ten and the one-sample weight f·cos/pdf stays within 10× of the layer's
    /// own. 0 for other models.
    #[inline]
    pub fn specular_probability(&self, cos_o: f32) -> f32 {
        let Bsdf::Glossy {
            kd,
            f0,
            f90,
            f0_d,
            f90_d,
            ..
        } = *self
        else {
            return 0.0;
        };
        let s = luminance(schlick_to(f0, f90, cos_o)).max(0.0);
        let d = luminance(kd).max(0.0) * (1.0 - schlick1_to(f0_d, f90_d, cos_o));
        if d <= 0.0 {
            1.0
        } else if s <= 0.0 {
            0.0
        } else {
            (s / (s + d)).clamp(0.1, 0.9)
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

    /// The albedo table against a brute-force quadrature of ∫ D·G₂/(4 cos θo) dωi over the
    /// hemisphere (400 × 800 cells here, not the sampler the table is built with): single
    /// scattering loses what it should, e.g. 39% of a white metal's light at α 0.58 seen
    /// straight on (the quoted values from a finer quadrature, 1600 × 3200, done apart).
    #[test]
    fn the_albedo_table_matches_a_quadrature() {
        let quadrature = |cos_o: f32, alpha: f32| -> f64 {
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let (nt, np) = (400, 800);
            let mut sum = 0.0f64;
            for i in 0..nt {
                let t = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
                for j in 0..np {
                    let p = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let wi = Vec3::new(
                        (t.sin() * p.cos()) as f32,
                        (t.sin() * p.sin()) as f32,
                        t.cos() as f32,
                    );
                    let h = (wo + wi).normalize();
                    let f = ggx_d(h.z, alpha) * ggx_g2(cos_o, wi.z, alpha) / (4.0 * cos_o);
                    sum += f as f64 * t.sin();
                }
            }
            sum * (std::f64::consts::FRAC_PI_2 / nt as f64) * (std::f64::consts::TAU / np as f64)
        };
        for (cos_o, rough) in [
            (1.0, 0.55f32),
            (1.0, 0.76),
            (0.5, 0.76),
            (0.5, 0.3),
            (0.2, 0.9),
        ] {
            let alpha = rough * rough;
            let want = quadrature(cos_o, alpha);
            let got = specular_albedo(cos_o, alpha, Vec3::ONE, 1.0).x as f64;
            assert!(
                (got / want - 1.0).abs() < 0.01,
                "cos {cos_o} α {alpha}: table {got}, quadrature {want}"
            );
        }
        assert!((quadrature(1.0, 0.58) - 0.61).abs() < 0.01);
    }

    /// The tables the program carries are the integrals `albedo_entry` makes on the grid of
    /// [`TABLE_GRID`] (to rounding: another libm's sin and atan2 may differ in the last bit).
    /// `RAYSPLAT_WRITE_ALBEDO_TABLES=1` writes `src/albedo_tables.bin` anew.
    #[test]
    fn the_carried_albedo_tables_are_the_integrals() {
        let fresh = integrate_tables(TABLE_GRID);
        if std::env::var_os("RAYSPLAT_WRITE_ALBEDO_TABLES").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/albedo_tables.bin");
            std::fs::write(path, table_bytes(&fresh)).unwrap();
            return;
        }
        let carried = &*ALBEDO;
        let mut worst = 0.0f32;
        for (e, &(a, b, z, axis)) in fresh.iter().enumerate() {
            let (k, r) = (e / TABLE_N, e % TABLE_N);
            let got = [carried.a[k][r], carried.b[k][r], carried.axis[k][r]]
                .into_iter()
                .chain(carried.zonal[k][r]);
            for (g, w) in got.zip([a, b, axis].into_iter().chain(z)) {
                worst = worst.max((g - w).abs() / w.abs().max(1.0));
            }
        }
        assert!(worst < 1e-5, "the carried tables are off by {worst}");
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
