//! Materials and textures, and what a hit's material means: its BSDF, albedo and emission.

use super::{Hit, Scene};
use crate::bsdf::Bsdf;
use glam::{Affine2, Vec2, Vec3};

/// How a material scatters; glTF's metallic/roughness model mapped onto the models we render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian (roughness ≥ 0.9 and not metallic, or specular turned off).
    Diffuse,
    /// Moderately glossy (0.05 ≤ roughness < 0.9 or metallic but rough): [`Bsdf::Glossy`],
    /// rendered through the directional radiance map (§8.1).
    Glossy {
        /// glTF roughness in [0, 1] (the Phong exponent follows from it).
        roughness: f32,
        /// glTF metallic in [0, 1] (splits base colour between kd and ks).
        metallic: f32,
    },
    /// A perfect mirror (metallic, roughness < 0.05).
    Mirror,
    /// Smooth glass (KHR_materials_transmission > 0.5).
    Dielectric {
        /// Index of refraction (KHR_materials_ior, 1.5 by default).
        ior: f32,
    },
}

/// A material's base-colour texture and its KHR_texture_transform.
#[derive(Clone, Debug)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub image: usize,
    /// Maps the mesh's texture coordinates to the texture's.
    pub transform: Affine2,
}

/// A material: what the scene's triangles are made of.
#[derive(Clone, Debug)]
pub struct Material {
    /// The glTF material's name ("unnamed" when it has none).
    pub name: String,
    /// Linear RGB base colour (glTF baseColorFactor).
    pub base_color: Vec3,
    /// Base-colour texture, multiplied with `base_color`.
    pub base_texture: Option<TextureRef>,
    /// How it scatters.
    pub kind: MaterialKind,
    /// Emitted radiance, emissiveFactor × KHR_materials_emissive_strength.
    pub emission: Vec3,
    /// glTF doubleSided: an emissive material emits from both faces.
    pub double_sided: bool,
}

impl Material {
    /// A Lambertian material of linear RGB `color` that does not emit.
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Self {
            name: name.to_string(),
            base_color: color,
            base_texture: None,
            kind: MaterialKind::Diffuse,
            emission: Vec3::ZERO,
            double_sided: false,
        }
    }

    /// A mirror or glass (a Dirac-delta BSDF): eye paths and photons pass on from it rather
    /// than being stored there.
    pub fn is_specular(&self) -> bool {
        matches!(
            self.kind,
            MaterialKind::Mirror | MaterialKind::Dielectric { .. }
        )
    }
}

/// A decoded base-colour texture, stored as linear RGB.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Width (texels).
    pub width: u32,
    /// Height (texels).
    pub height: u32,
    /// Linear RGB texels, row by row (index y·width + x).
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// Nearest-texel lookup with repeat wrapping.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let u = uv.x - uv.x.floor();
        let v = uv.y - uv.y.floor();
        let x = ((u * self.width as f32) as u32).min(self.width - 1);
        let y = ((v * self.height as f32) as u32).min(self.height - 1);
        self.texels[(y * self.width + x) as usize]
    }
}

impl Scene {
    /// Phong exponent of a glossy material (1 for any other).
    #[inline]
    pub fn glossy_exponent(&self, material: u32) -> f32 {
        match self.materials[material as usize].kind {
            MaterialKind::Glossy { roughness, .. } => crate::bsdf::phong_exponent(roughness),
            _ => 1.0,
        }
    }

    /// Diffuse albedo at a hit (base colour × texture).
    #[inline]
    pub fn albedo(&self, hit: &Hit) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        match &m.base_texture {
            Some(t) => {
                let uv = t.transform.transform_point2(hit.uv);
                m.base_color * self.textures[t.image].sample(uv)
            }
            None => m.base_color,
        }
    }

    /// The scattering model at a hit.
    #[inline]
    pub fn bsdf(&self, hit: &Hit) -> Bsdf {
        let m = &self.materials[hit.material as usize];
        match m.kind {
            MaterialKind::Diffuse => Bsdf::Lambert {
                albedo: self.albedo(hit),
            },
            MaterialKind::Glossy {
                roughness,
                metallic,
            } => crate::bsdf::glossy_from_pbr(self.albedo(hit), roughness, metallic),
            MaterialKind::Mirror => Bsdf::Mirror {
                color: self.albedo(hit),
            },
            MaterialKind::Dielectric { ior } => Bsdf::Dielectric {
                ior,
                tint: self.albedo(hit),
            },
        }
    }

    /// Radiance emitted from a hit towards `wo` (one-sided along the winding unless double-sided).
    #[inline]
    pub fn emitted(&self, hit: &Hit, wo: Vec3) -> Vec3 {
        let m = &self.materials[hit.material as usize];
        if m.emission == Vec3::ZERO {
            return Vec3::ZERO;
        }
        if m.double_sided || hit.geo_normal.dot(wo) > 0.0 {
            m.emission
        } else {
            Vec3::ZERO
        }
    }
}
