//! glTF materials, base-colour textures (with KHR_texture_transform) and KHR_lights_punctual
//! lights converted to the scene's own types.

use super::data::{Buffers, read_uri, view_bytes};
use super::document::get;
use crate::scene::{Light, Material, MaterialKind, Texture, TextureRef};
use glam::{Affine2, Mat4, Quat, Vec2, Vec3};
use gltf::json::{self, validation::Checked};
use serde_json::Value;
use std::path::Path;

/// A KHR_lights_punctual light as the file gives it.
pub(super) type Punctual = json::extensions::scene::khr_lights_punctual::Light;

fn finite_or(x: f32, d: f32) -> f32 {
    if x.is_finite() { x } else { d }
}

/// Base-colour textures, decoded on first use: a glTF texture resolved to its image (the
/// PNG/JPEG `source`; an image only an extension gives, KHR_texture_basisu, EXT_texture_webp or
/// MSFT_texture_dds, is not decoded: the base colour factor is used, with a warning), each image
/// decoded once into [`Texture`]s. An image that cannot be read or decoded is a warning too.
pub(super) struct TextureLoader<'a> {
    pub(super) root: &'a json::Root,
    pub(super) raw: &'a Value,
    pub(super) buffers: &'a Buffers,
    pub(super) base: Option<&'a Path>,
    /// Per glTF image: not tried yet, failed, or its index in `textures`.
    pub(super) decoded: Vec<Option<Option<usize>>>,
    pub(super) textures: Vec<Texture>,
    pub(super) warnings: Vec<String>,
}

impl TextureLoader<'_> {
    fn warn(&mut self, w: String) {
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    /// The scene texture of glTF texture `t` (named by `what`), or `None` when its image is
    /// unusable (warned); an error only when `t` or its `source` does not exist.
    fn texture(&mut self, t: usize, what: &str) -> Result<Option<usize>, String> {
        let tex = get(&self.root.textures, t, what)?;
        let source = tex.source.value();
        if source != u32::MAX as usize {
            get(&self.root.images, source, &format!("texture {t}"))?;
            return Ok(self.image(source));
        }
        let from_extensions: Vec<&str> = self.raw["textures"][t]["extensions"]
            .as_object()
            .map(|e| {
                e.iter()
                    .filter(|(_, v)| v.get("source").is_some())
                    .map(|(k, _)| k.as_str())
                    .collect()
            })
            .unwrap_or_default();
        self.warn(if from_extensions.is_empty() {
            format!("texture {t} has no image: the base colour factor is used instead")
        } else {
            format!(
                "texture {t}: its image comes only from {} (an image format raysplat does not decode): the base colour factor is used instead",
                from_extensions.join(", ")
            )
        });
        Ok(None)
    }

    fn image(&mut self, i: usize) -> Option<usize> {
        if let Some(done) = self.decoded[i] {
            return done;
        }
        let result = self.decode(i);
        let slot = match result {
            Ok(texture) => {
                self.textures.push(texture);
                Some(self.textures.len() - 1)
            }
            Err(why) => {
                self.warn(format!(
                    "image {i} ignored, the base colour factor is used instead: {why}"
                ));
                None
            }
        };
        self.decoded[i] = Some(slot);
        slot
    }

    fn decode(&self, i: usize) -> Result<Texture, String> {
        let image = &self.root.images[i];
        let bytes = match (&image.uri, image.buffer_view) {
            (Some(uri), _) => read_uri(uri, self.base),
            (None, Some(v)) => {
                view_bytes(self.root, self.buffers, v.value(), &format!("image {i}"))
                    .map(|(bytes, _)| bytes.to_vec())
            }
            (None, None) => return Err("it has neither a uri nor a buffer view".into()),
        }
        .map_err(|e| e.message().to_string())?;
        let decoded = ::image::load_from_memory(&bytes)
            .map_err(|e| format!("it cannot be decoded ({e})"))?
            .to_rgb8();
        let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
        let texels: Vec<Vec3> = decoded
            .pixels()
            .map(|p| Vec3::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]))
            .collect();
        if texels.is_empty() {
            return Err("it has no pixels".into());
        }
        Ok(Texture {
            width: decoded.width(),
            height: decoded.height(),
            texels,
        })
    }
}

/// glTF material `index` as ours, and the TEXCOORD set its base-colour texture reads (0
/// without one; KHR_texture_transform's `texCoord` overrides the texture info's).
pub(super) fn convert_material(
    index: usize,
    m: &json::Material,
    textures: &mut TextureLoader,
) -> Result<(Material, u32), String> {
    let pbr = &m.pbr_metallic_roughness;
    let bc = pbr.base_color_factor.0;
    let base_color = Vec3::new(
        finite_or(bc[0], 0.8),
        finite_or(bc[1], 0.8),
        finite_or(bc[2], 0.8),
    )
    .clamp(Vec3::ZERO, Vec3::ONE);
    let metallic = finite_or(pbr.metallic_factor.0, 1.0).clamp(0.0, 1.0);
    let roughness = finite_or(pbr.roughness_factor.0, 1.0).clamp(0.0, 1.0);
    let ext = m.extensions.as_ref();
    let transmission = ext
        .and_then(|e| e.transmission.as_ref())
        .map(|t| finite_or(t.transmission_factor.0, 0.0))
        .unwrap_or(0.0);
    let ior = ext
        .and_then(|e| e.ior.as_ref())
        .map(|i| i.ior.0)
        .filter(|i| i.is_finite() && *i >= 1.0)
        .unwrap_or(1.5);
    let specular_off = ext
        .and_then(|e| e.specular.as_ref())
        .is_some_and(|s| s.specular_factor.0 == 0.0);
    let kind = if transmission > 0.5 {
        MaterialKind::Dielectric { ior }
    } else if metallic > 0.5 && roughness < 0.05 {
        MaterialKind::Mirror
    } else if specular_off || (roughness >= 0.9 && metallic < 0.5) {
        MaterialKind::Diffuse
    } else {
        MaterialKind::Glossy {
            roughness,
            metallic,
        }
    };
    let name = m.name.as_deref().unwrap_or("unnamed");
    // A negative or non-finite strength is not light: the material does not emit (and the
    // loader says so).
    let strength = match ext.and_then(|e| e.emissive_strength.as_ref()) {
        Some(s) if s.emissive_strength.0.is_finite() && s.emissive_strength.0 >= 0.0 => {
            s.emissive_strength.0
        }
        Some(s) => {
            textures.warn(format!(
                "material {index} ({name}): emissive strength {} ignored, it does not emit",
                s.emissive_strength.0
            ));
            0.0
        }
        None => 1.0,
    };
    let emission = Vec3::from(m.emissive_factor.0) * strength;
    let emission = if emission.is_finite() {
        emission.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    };
    let mut tex_coord = 0;
    let mut base_texture = None;
    if let Some(info) = &pbr.base_color_texture {
        let what = format!("material {index}'s base colour texture");
        let transform = info
            .extensions
            .as_ref()
            .and_then(|e| e.texture_transform.as_ref());
        tex_coord = transform
            .and_then(|t| t.tex_coord)
            .unwrap_or(info.tex_coord);
        if let Some(image) = textures.texture(info.index.value(), &what)? {
            let transform = transform
                .map(|t| {
                    Affine2::from_scale_angle_translation(
                        Vec2::from(t.scale.0),
                        -t.rotation.0,
                        Vec2::from(t.offset.0),
                    )
                })
                .filter(|a| a.is_finite())
                .unwrap_or(Affine2::IDENTITY);
            base_texture = Some(TextureRef { image, transform });
        }
    }
    let material = Material {
        name: name.to_string(),
        base_color,
        base_texture,
        kind,
        emission,
        double_sided: m.double_sided,
    };
    Ok((material, tex_coord))
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A KHR_lights_punctual light placed by `world`, or `None` when its intensity or colour is not
/// positive and finite, or its type unknown.
pub(super) fn convert_light(light: &Punctual, world: Mat4) -> Option<Light> {
    use json::extensions::scene::khr_lights_punctual::Type;
    let (_, rot, pos): (Vec3, Quat, Vec3) = world.to_scale_rotation_translation();
    let color = Vec3::from(light.color) * light.intensity;
    if !color.is_finite() || color.max_element() <= 0.0 {
        return None;
    }
    let dir = (rot * -Vec3::Z).normalize();
    match light.type_ {
        Checked::Valid(Type::Point) => Some(Light::Point {
            position: pos,
            intensity: color,
        }),
        Checked::Valid(Type::Spot) => {
            // The specification's defaults: inner 0, outer π/4.
            let (inner, outer) = light
                .spot
                .as_ref()
                .map_or((0.0, std::f32::consts::FRAC_PI_4), |s| {
                    (s.inner_cone_angle, s.outer_cone_angle)
                });
            if !(inner.is_finite() && outer.is_finite()) {
                return None;
            }
            let outer = outer.clamp(1e-3, std::f32::consts::FRAC_PI_2);
            let inner = inner.clamp(0.0, outer);
            Some(Light::Spot {
                position: pos,
                direction: dir,
                intensity: color,
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            })
        }
        Checked::Valid(Type::Directional) => Some(Light::Directional {
            direction: dir,
            irradiance: color,
        }),
        Checked::Invalid => None,
    }
}
