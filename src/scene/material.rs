//! Materials and textures, and what a hit's material means: its BSDF, albedo, alpha and
//! emission (glTF 2.0 §3.9: the metallic-roughness model and its five textures).

use super::{Hit, Scene};
use crate::bsdf::Bsdf;
use glam::{Affine2, Vec2, Vec3, Vec4, Vec4Swizzles};
use std::sync::LazyLock;

/// How a material scatters; glTF's metallic/roughness model mapped onto the models we render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian: a dielectric (metallic 0) of roughness ≥ 0.9, or with its specular layer
    /// turned off (docs/deviations.md §49).
    Diffuse,
    /// glTF's metallic-roughness BRDF, [`Bsdf::Glossy`]: GGX over a Fresnel-weighted
    /// Lambertian layer; lobes the directional radiance map can hold go through it (§8.1),
    /// sharper ones are traced.
    Glossy {
        /// glTF roughness in [0, 1] (α = roughness²).
        roughness: f32,
        /// glTF metallic in [0, 1] (splits the base colour between kd and f0).
        metallic: f32,
    },
    /// A perfect mirror: a metal of roughness 0 (the specification's exact limit).
    Mirror,
    /// Glass, smooth or rough (its material's roughness): KHR_materials_transmission's
    /// factor 1 on a dielectric (metallic 0) with no texture to vary either (a partial share
    /// is chosen per hit, [`Scene::bsdf`]).
    Dielectric {
        /// Index of refraction (KHR_materials_ior, 1.5 by default).
        ior: f32,
    },
}

impl MaterialKind {
    /// The model a metallic-roughness surface point is rendered with (not transmissive).
    pub fn classify(metallic: f32, roughness: f32, specular: crate::bsdf::SpecularLayer) -> Self {
        // A KHR_materials_specular colour above white can raise the layer far above the
        // IOR's f0 (up to 1): such a layer is kept however rough.
        let faint = specular.factor <= 0.0 || specular.color.max_element() <= 1.0;
        if metallic >= 1.0 && roughness <= 0.0 {
            MaterialKind::Mirror
        } else if metallic <= 0.0 && (specular.factor <= 0.0 || (roughness >= 0.9 && faint)) {
            // A pure dielectric without its specular layer, or one so rough that its faint
            // layer (the IOR's f0, 4% at glTF's 1.5) is left out (docs/deviations.md §49,
            // §52). Any metal share keeps the model.
            MaterialKind::Diffuse
        } else {
            MaterialKind::Glossy {
                roughness,
                metallic,
            }
        }
    }
}

/// How texture coordinates outside [0, 1] wrap (glTF sampler `wrapS`, `wrapT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// REPEAT (10497), the default.
    Repeat,
    /// CLAMP_TO_EDGE (33071).
    Clamp,
    /// MIRRORED_REPEAT (33648).
    Mirror,
}

impl Wrap {
    #[inline]
    fn index(self, i: i64, n: u32) -> usize {
        let n = n as i64;
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n { 2 * n - 1 - m } else { m }
            }
        }) as usize
    }
}

/// One of a material's textures: its image, the KHR_texture_transform, the TEXCOORD set it
/// reads and its sampler.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub image: usize,
    /// Maps the mesh's texture coordinates to the texture's.
    pub transform: Affine2,
    /// The TEXCOORD set (0 or 1; KHR_texture_transform's `texCoord` overrides the info's).
    pub set: u8,
    /// Wrap modes along u and v.
    pub wrap: [Wrap; 2],
    /// The sampler's magFilter is NEAREST: one texel, not bilinear.
    pub nearest: bool,
}

impl TextureRef {
    /// A texture read through TEXCOORD_0 with the default sampler (repeat, bilinear).
    pub fn plain(image: usize) -> Self {
        Self {
            image,
            transform: Affine2::IDENTITY,
            set: 0,
            wrap: [Wrap::Repeat; 2],
            nearest: false,
        }
    }

    /// The texture coordinates this texture reads at `hit`.
    #[inline]
    pub fn uv(&self, hit: &Hit) -> Vec2 {
        self.transform
            .transform_point2(if self.set == 1 { hit.uv1 } else { hit.uv })
    }
}

/// glTF `alphaMode` with its cutoff.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored (the default).
    Opaque,
    /// Cut out where alpha < the cutoff (0.5 by default).
    Mask(f32),
    /// Partly transparent: stochastic coverage per ray, except for eye paths, which split at
    /// it (docs/deviations.md §47, §61).
    Blend,
}

/// A material: what the scene's triangles are made of.
#[derive(Clone, Debug)]
pub struct Material {
    /// The glTF material's name ("unnamed" when it has none).
    pub name: String,
    /// Linear RGB base colour (glTF baseColorFactor).
    pub base_color: Vec3,
    /// baseColorFactor's alpha.
    pub base_alpha: f32,
    /// Base-colour texture (sRGB colour, linear alpha), multiplied with the factor.
    pub base_texture: Option<TextureRef>,
    /// How it scatters where no metallic-roughness texture varies it.
    pub kind: MaterialKind,
    /// metallicFactor.
    pub metallic: f32,
    /// roughnessFactor.
    pub roughness: f32,
    /// KHR_materials_specular's factor and colour (the core model's 1 and white without it).
    pub specular: crate::bsdf::SpecularLayer,
    /// KHR_materials_specular's `specularTexture` (linear; its A channel), multiplied with
    /// the factor.
    pub specular_texture: Option<TextureRef>,
    /// KHR_materials_specular's `specularColorTexture` (sRGB; RGB), multiplied with the
    /// colour.
    pub specular_color_texture: Option<TextureRef>,
    /// Index of refraction (KHR_materials_ior; 1.5 by default): the dielectric's f0.
    pub ior: f32,
    /// metallicRoughnessTexture (linear; B metal, G rough), multiplied with the factors.
    pub metal_rough_texture: Option<TextureRef>,
    /// normalTexture (linear, tangent space) and its `scale`.
    pub normal_texture: Option<(TextureRef, f32)>,
    /// Emitted radiance, emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    /// emissiveTexture (sRGB), multiplied with `emission`.
    pub emissive_texture: Option<TextureRef>,
    /// alphaMode and alphaCutoff.
    pub alpha: AlphaMode,
    /// glTF doubleSided: an emissive material emits from both faces.
    pub double_sided: bool,
    /// KHR_materials_transmission's factor (0 without the extension): the share of the
    /// dielectric's diffuse layer replaced by glass (as rough as the surface).
    pub transmission: f32,
    /// `transmissionTexture` (linear; its R channel), multiplied with the factor.
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_volume's absorption coefficient σ = −ln(attenuationColor) /
    /// attenuationDistance per channel (world units⁻¹), on glass whose volume has a thickness
    /// (a thickness of 0 is the extension's thin wall); `None` where light inside is not
    /// absorbed.
    pub absorption: Option<Vec3>,
}

impl Material {
    /// A Lambertian material of linear RGB `color` that does not emit.
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Self {
            name: name.to_string(),
            base_color: color,
            base_alpha: 1.0,
            base_texture: None,
            kind: MaterialKind::Diffuse,
            metallic: 0.0,
            roughness: 1.0,
            specular: crate::bsdf::SpecularLayer::default(),
            specular_texture: None,
            specular_color_texture: None,
            ior: 1.5,
            metal_rough_texture: None,
            normal_texture: None,
            emission: Vec3::ZERO,
            emissive_texture: None,
            alpha: AlphaMode::Opaque,
            double_sided: false,
            transmission: 0.0,
            transmission_texture: None,
            absorption: None,
        }
    }

    /// The material emits somewhere (a positive factor; a texture may still be black).
    pub fn emits(&self) -> bool {
        self.emission.is_finite() && self.emission.max_element() > 0.0
    }

    /// Rays may pass through it where its alpha says so (MASK or BLEND).
    pub fn alpha_tested(&self) -> bool {
        self.alpha != AlphaMode::Opaque
    }

    /// The vertex data beyond TEXCOORD_0 that its textures need: TEXCOORD_1 or tangents.
    pub fn needs_extra(&self) -> bool {
        let refs = [
            &self.base_texture,
            &self.metal_rough_texture,
            &self.emissive_texture,
            &self.specular_texture,
            &self.specular_color_texture,
            &self.transmission_texture,
        ];
        self.normal_texture.is_some() || refs.iter().any(|t| t.as_ref().is_some_and(|t| t.set == 1))
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1) for the 256 8-bit codes.
static SRGB_TO_LINEAR: LazyLock<[f32; 256]> = LazyLock::new(|| {
    std::array::from_fn(|c| {
        let c = c as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
});

/// A decoded texture image: 8-bit RGBA as the file stores it; a material slot decides
/// whether its colour channels are sRGB (base colour, emissive) or linear (the others).
#[derive(Clone, Debug)]
pub struct Texture {
    /// Width (texels).
    pub width: u32,
    /// Height (texels).
    pub height: u32,
    /// RGBA texels, row by row from the top (index y·width + x).
    pub texels: Vec<[u8; 4]>,
}

impl Texture {
    #[inline]
    fn texel(&self, x: i64, y: i64, wrap: [Wrap; 2], srgb: bool) -> Vec4 {
        let t = self.texels
            [wrap[1].index(y, self.height) * self.width as usize + wrap[0].index(x, self.width)];
        let a = t[3] as f32 / 255.0;
        if srgb {
            let lut = &*SRGB_TO_LINEAR;
            Vec4::new(
                lut[t[0] as usize],
                lut[t[1] as usize],
                lut[t[2] as usize],
                a,
            )
        } else {
            Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, 255.0 * a) / 255.0
        }
    }

    /// The texture at texture coordinates `uv` (already transformed) through `r`'s sampler:
    /// bilinear between the four nearest texel centres (filtered in linear space), or the
    /// nearest texel; `srgb` decodes the colour channels, alpha is always linear.
    #[inline]
    pub fn lookup(&self, uv: Vec2, r: &TextureRef, srgb: bool) -> Vec4 {
        if !uv.is_finite() {
            return self.texel(0, 0, r.wrap, srgb);
        }
        // Far-out coordinates (where f32 has no fraction left anyway) are kept within 2⁴⁰
        // texels, so that the neighbour's index never overflows.
        const FAR: f64 = (1u64 << 40) as f64;
        let x = (uv.x as f64 * self.width as f64 - 0.5).clamp(-FAR, FAR);
        let y = (uv.y as f64 * self.height as f64 - 0.5).clamp(-FAR, FAR);
        if r.nearest {
            return self.texel(
                (x + 0.5).floor() as i64,
                (y + 0.5).floor() as i64,
                r.wrap,
                srgb,
            );
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let t = |dx, dy| self.texel(x0 + dx, y0 + dy, r.wrap, srgb);
        let top = t(0, 0).lerp(t(1, 0), fx);
        let bottom = t(0, 1).lerp(t(1, 1), fx);
        top.lerp(bottom, fy)
    }

    /// Largest luminance of `scale` × the sRGB-decoded colour over the texels a lookup
    /// through `r`'s sampler anywhere in the texture-coordinate box [`lo`, `hi`] can read
    /// (bilinear: a one-texel margin; nearest: the texels under the box, widened by a
    /// rounding's worth); `None` when the box spans more than `max_texels` texels (the
    /// caller then bounds by [`Texture::max_channel`]).
    pub fn max_luminance_in(
        &self,
        lo: Vec2,
        hi: Vec2,
        r: &TextureRef,
        scale: Vec3,
        max_texels: u64,
    ) -> Option<f32> {
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let nearest = r.nearest;
        // In f64 first: coordinates far out (a huge KHR_texture_transform scale) must give a
        // count too large, never wrap round to a small one.
        let cover = |a: f32, b: f32, n: u32| -> (f64, f64) {
            let (a, b, n) = (a as f64, b as f64, n as f64);
            if nearest {
                let eps = 1e-4;
                ((a * n - eps).floor(), (b * n + eps).floor())
            } else {
                ((a * n - 0.5).floor(), (b * n - 0.5).floor() + 1.0)
            }
        };
        let wrap = r.wrap;
        let (x0, x1) = cover(lo.x, hi.x, self.width);
        let (y0, y1) = cover(lo.y, hi.y, self.height);
        let count = (x1 - x0 + 1.0) * (y1 - y0 + 1.0);
        if count.is_nan() || count > max_texels as f64 {
            return None;
        }
        let (x0, x1, y0, y1) = (x0 as i64, x1 as i64, y0 as i64, y1 as i64);
        let mut m = 0.0f32;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let c = scale * self.texel(x, y, wrap, true).xyz();
                m = m.max(crate::sampling::luminance(c));
            }
        }
        Some(m)
    }

    /// Largest sRGB-decoded colour channel of any texel.
    pub fn max_channel(&self) -> f32 {
        let top = self
            .texels
            .iter()
            .map(|t| t[0].max(t[1]).max(t[2]))
            .max()
            .unwrap_or(0);
        SRGB_TO_LINEAR[top as usize]
    }
}

impl Scene {
    #[inline]
    fn read(&self, t: &TextureRef, uv: Vec2, srgb: bool) -> Vec4 {
        self.textures[t.image].lookup(uv, t, srgb)
    }

    /// Linear RGBA base colour at a hit: factor × texture × COLOR_0 (glTF §3.9.2).
    #[inline]
    pub fn base_color(&self, hit: &Hit) -> Vec4 {
        let m = &self.materials[hit.material as usize];
        let mut c = m.base_color.extend(m.base_alpha) * hit.color;
        if let Some(t) = &m.base_texture {
            c *= self.read(t, t.uv(hit), true);
        }
        c
    }

    /// The share α of light an alpha-`BLEND` surface stops at a hit (the base colour's
    /// alpha: factor × texture × COLOR_0, glTF §3.9.4), in [0, 1]; `None` for every other
    /// alpha mode (MASK's cut-outs are never hit).
    #[inline]
    pub fn coverage(&self, hit: &Hit) -> Option<f32> {
        let m = &self.materials[hit.material as usize];
        matches!(m.alpha, AlphaMode::Blend).then(|| self.base_color(hit).w.clamp(0.0, 1.0))
    }

    /// Diffuse albedo at a hit (the base colour's RGB).
    #[inline]
    pub fn albedo(&self, hit: &Hit) -> Vec3 {
        self.base_color(hit).xyz()
    }

    /// (metallic, roughness) at a hit: the factors × the texture's B and G channels.
    #[inline]
    pub fn metal_rough(&self, hit: &Hit) -> (f32, f32) {
        let m = &self.materials[hit.material as usize];
        match &m.metal_rough_texture {
            Some(t) => {
                let s = self.read(t, t.uv(hit), false);
                (m.metallic * s.z, m.roughness * s.y)
            }
            None => (m.metallic, m.roughness),
        }
    }

    /// KHR_materials_specular at a hit: the factor × `specularTexture`'s A channel and the
    /// colour × `specularColorTexture`'s RGB (sRGB), as the extension's "Properties" say.
    #[inline]
    pub fn specular_layer(&self, hit: &Hit) -> crate::bsdf::SpecularLayer {
        let m = &self.materials[hit.material as usize];
        let mut layer = m.specular;
        if let Some(t) = &m.specular_texture {
            layer.factor *= self.read(t, t.uv(hit), false).w;
        }
        if let Some(t) = &m.specular_color_texture {
            layer.color *= self.read(t, t.uv(hit), true).xyz();
        }
        layer
    }

    /// Part of its light goes through as glass (KHR_materials_transmission above 0, but not
    /// the whole of it everywhere): a photon reaching it lands, since wherever the hit is not
    /// glass the surface is seen ([`Scene::bsdf`]).
    #[inline]
    pub fn partly_transmissive(&self, hit: &Hit) -> bool {
        let m = &self.materials[hit.material as usize];
        m.transmission > 0.0 && !matches!(m.kind, MaterialKind::Dielectric { .. })
    }

    /// The scattering model at a hit. A partly transmissive material is glTF's mixture
    /// (KHR_materials_transmission, "Implementation"): of the dielectric share (1 − m) a
    /// share t (factor × texture) is glass; both share one specular reflection, so the BSDF
    /// is p·f_glass + (1 − p)·f_opaque with p = (1 − m)·t, f_opaque the metallic-roughness
    /// model with metallic m/(1 − p). Each hit draws one of the two with probability p from
    /// a hash of the hit (the same hit always draws the same, different rays independently):
    /// unbiased for every estimator that samples its paths (docs/deviations.md §55).
    #[inline]
    pub fn bsdf(&self, hit: &Hit) -> Bsdf {
        let m = &self.materials[hit.material as usize];
        let textured = m.specular_texture.is_some() || m.specular_color_texture.is_some();
        let specular = if textured {
            self.specular_layer(hit)
        } else {
            m.specular
        };
        let kind = match m.kind {
            MaterialKind::Dielectric { .. } => m.kind,
            _ if m.metal_rough_texture.is_some() || textured || m.transmission > 0.0 => {
                let (mut metallic, roughness) = self.metal_rough(hit);
                if m.transmission > 0.0 {
                    let t = match &m.transmission_texture {
                        Some(tex) => m.transmission * self.read(tex, tex.uv(hit), false).x,
                        None => m.transmission,
                    };
                    let p = (1.0 - metallic) * t;
                    if p >= 1.0 || (p > 0.0 && self.glass_draw(hit) < p) {
                        return Bsdf::Dielectric {
                            ior: m.ior,
                            tint: self.albedo(hit),
                            alpha: crate::bsdf::glass_alpha(roughness, m.ior),
                        };
                    }
                    if p > 0.0 {
                        metallic = (metallic / (1.0 - p)).min(1.0);
                    }
                }
                MaterialKind::classify(metallic, roughness, specular)
            }
            k => k,
        };
        match kind {
            MaterialKind::Diffuse => Bsdf::Lambert {
                albedo: self.albedo(hit),
            },
            MaterialKind::Glossy {
                roughness,
                metallic,
            } => {
                crate::bsdf::glossy_from_pbr(self.albedo(hit), roughness, metallic, m.ior, specular)
            }
            MaterialKind::Mirror => Bsdf::Mirror {
                color: self.albedo(hit),
            },
            MaterialKind::Dielectric { ior } => Bsdf::Dielectric {
                ior,
                tint: self.albedo(hit),
                alpha: crate::bsdf::glass_alpha(m.roughness, ior),
            },
        }
    }

    /// Emitted radiance of a material at texture coordinates: factor × emissive texture
    /// (glTF §3.9.3; `uv0`, `uv1` the hit's two sets).
    #[inline]
    pub fn emission_at(&self, material: u32, uv0: Vec2, uv1: Vec2) -> Vec3 {
        let m = &self.materials[material as usize];
        match &m.emissive_texture {
            Some(t) => {
                let uv = t
                    .transform
                    .transform_point2(if t.set == 1 { uv1 } else { uv0 });
                m.emission * self.read(t, uv, true).xyz()
            }
            None => m.emission,
        }
    }

    /// The share of light that crosses the segment ending at `hit`, reached along `dir`:
    /// Beer–Lambert's exp(−σ·t) (KHR_materials_volume, "Attenuation") where the segment ran
    /// inside an absorbing volume — it reaches the volume's boundary from the back of its
    /// winding, the boundary being closed as the extension asks — and 1 elsewhere.
    #[inline]
    pub fn transmittance(&self, hit: &Hit, dir: Vec3) -> Vec3 {
        match self.materials[hit.material as usize].absorption {
            Some(sigma) if hit.geo_normal.dot(dir) > 0.0 => (-sigma * hit.t).exp(),
            _ => Vec3::ONE,
        }
    }

    /// A uniform number in [0, 1) for a hit's choice between glass and the opaque model: a
    /// hash of where on its triangle the ray met it and how far it came in units of the
    /// triangle's size, each quantised, so that the same hit always draws the same and the
    /// draw does not depend on the unit of length (its world position and distance, hashed
    /// before, change their bits when a scene is scaled: `tests/invariance.rs`).
    #[inline]
    fn glass_draw(&self, hit: &Hit) -> f32 {
        let tr = &self.triangles[hit.triangle as usize];
        let v0 = Vec3::from(tr.v0);
        let (e1, e2) = (Vec3::from(tr.v1) - v0, Vec3::from(tr.v2) - v0);
        let (b1, b2) = super::light::barycentrics(hit.position - v0, e1, e2);
        // To 2⁻¹³ of itself: ten of the mantissa's low bits dropped.
        let reach = f32::from_bits((hit.t / e1.length().max(e2.length())).to_bits() & !0x3ff);
        let q = |b: f32| super::trace::quantised(b, super::trace::BARYCENTRIC_CELL);
        super::trace::unit_hash(
            hit.triangle ^ 0x7a5c_e1d3,
            [q(b1), q(b2), reach, 0.0, 0.0, 0.0],
        )
    }

    /// Radiance emitted from a hit towards `wo` (one-sided along the winding unless double-sided).
    #[inline]
    pub fn emitted(&self, hit: &Hit, wo: Vec3) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        if !m.emits() {
            return Vec3::ZERO;
        }
        if m.double_sided || hit.geo_normal.dot(wo) > 0.0 {
            self.emission_at(hit.material, hit.uv, hit.uv1)
        } else {
            Vec3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four texels in a row, linear values 0, 1/255·{60, 120, 180}.
    fn row() -> Texture {
        Texture {
            width: 4,
            height: 1,
            texels: [0u8, 60, 120, 180].map(|v| [v, v, v, 255]).to_vec(),
        }
    }

    #[test]
    fn only_pure_dielectrics_and_roughness_zero_metals_leave_the_microfacet_model() {
        use crate::bsdf::SpecularLayer;
        let core = SpecularLayer::default();
        let off = SpecularLayer {
            factor: 0.0,
            color: Vec3::ONE,
        };
        assert_eq!(
            MaterialKind::classify(0.0, 0.95, core),
            MaterialKind::Diffuse
        );
        assert_eq!(MaterialKind::classify(1.0, 0.0, core), MaterialKind::Mirror);
        // A metal share keeps the model, however rough (an antialiased texel between metal
        // and plastic), and KHR_materials_specular's zero factor turns off the dielectric's
        // layer only; a specular colour above white keeps even a very rough dielectric's
        // layer, which it can raise far above the IOR's 4%.
        let bright = SpecularLayer {
            factor: 1.0,
            color: Vec3::splat(10.0),
        };
        for (m, r, s) in [
            (0.4, 0.95, core),
            (1.0, 0.5, off),
            (0.7, 0.0, core),
            (0.0, 0.95, bright),
        ] {
            assert!(
                matches!(MaterialKind::classify(m, r, s), MaterialKind::Glossy { .. }),
                "{m} {r} {s:?}"
            );
        }
        assert_eq!(MaterialKind::classify(0.0, 0.3, off), MaterialKind::Diffuse);
    }

    #[test]
    fn wrap_modes_pick_the_texel_the_sampler_names() {
        let t = row();
        // u = 1.25 lands on texel 5 of the repeated row: repeat 1, clamp 3, mirror 2.
        for (wrap, texel) in [(Wrap::Repeat, 60), (Wrap::Clamp, 180), (Wrap::Mirror, 120)] {
            let r = TextureRef {
                wrap: [wrap; 2],
                nearest: true,
                ..TextureRef::plain(0)
            };
            let v = t.lookup(Vec2::new(1.25 + 0.125, 0.5), &r, false).x;
            assert_eq!(v, texel as f32 / 255.0, "{wrap:?}");
        }
    }

    #[test]
    fn bilinear_filtering_blends_decoded_texels() {
        let t = row();
        let r = TextureRef::plain(0);
        // Halfway between the centres of texels 1 and 2.
        let v = t.lookup(Vec2::new(0.5, 0.5), &r, true).x;
        let lut = &*SRGB_TO_LINEAR;
        assert!((v - 0.5 * (lut[60] + lut[120])).abs() < 1e-6, "{v}");
        // Linear channels are not decoded; alpha never is.
        let l = t.lookup(Vec2::new(0.5, 0.5), &r, false);
        assert!((l.x - 90.0 / 255.0).abs() < 1e-6 && l.w == 1.0);
        // Repeat wraps the filter across the edge: between texel 3 and texel 0.
        let e = t.lookup(Vec2::new(0.0, 0.5), &r, false).x;
        assert!((e - 90.0 / 255.0).abs() < 1e-6, "{e}");
    }
}
