//! glTF materials with their textures (KHR_texture_transform, samplers) and KHR_lights_punctual
//! lights converted to the scene's own types.

use super::data::{Buffers, read_uri, view_bytes};
use super::document::get;
use crate::scene::{AlphaMode, Light, Material, MaterialKind, Texture, TextureRef, Wrap};
use glam::{Affine2, Mat4, Quat, Vec2, Vec3};
use gltf::json::{self, validation::Checked};
use serde_json::Value;
use std::path::Path;

/// A KHR_lights_punctual light as the file gives it.
pub(super) type Punctual = json::extensions::scene::khr_lights_punctual::Light;

fn finite_or(x: f32, d: f32) -> f32 {
    if x.is_finite() { x } else { d }
}

/// Textures, decoded on first use: a glTF texture resolved to its image (the PNG/JPEG
/// `source`; an image only an extension gives, KHR_texture_basisu, EXT_texture_webp or
/// MSFT_texture_dds, is not decoded: the factor alone is used, with a warning) and its sampler,
/// each image decoded once into a [`Texture`] shared by every material slot that reads it. An
/// image that cannot be read or decoded is a warning too.
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
    pub(super) fn warn(&mut self, w: String) {
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
            format!("texture {t} has no image: the material's factor is used instead")
        } else {
            format!(
                "texture {t}: its image comes only from {} (an image format raysplat does not decode): the material's factor is used instead",
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
                    "image {i} ignored, the material's factor is used instead: {why}"
                ));
                None
            }
        };
        self.decoded[i] = Some(slot);
        slot
    }

    /// The material slot `what` reading glTF texture `index` through set `tex_coord`, as the
    /// raw JSON `info` (the texture info object) transforms it: its KHR_texture_transform
    /// (whose `texCoord` overrides the info's) and its texture's sampler. `None` when the
    /// image is unusable (warned). Sets beyond TEXCOORD_1 are read as TEXCOORD_0 (warned).
    pub(super) fn slot(
        &mut self,
        info: &Value,
        index: usize,
        tex_coord: u32,
        what: &str,
    ) -> Result<Option<TextureRef>, String> {
        let Some(image) = self.texture(index, what)? else {
            return Ok(None);
        };
        let tt = &info["extensions"]["KHR_texture_transform"];
        let pair = |v: &Value, d: [f32; 2]| -> Vec2 {
            match (v[0].as_f64(), v[1].as_f64()) {
                (Some(a), Some(b)) => Vec2::new(a as f32, b as f32),
                _ => Vec2::from(d),
            }
        };
        let transform = if tt.is_object() {
            Affine2::from_scale_angle_translation(
                pair(&tt["scale"], [1.0, 1.0]),
                -(tt["rotation"].as_f64().unwrap_or(0.0) as f32),
                pair(&tt["offset"], [0.0, 0.0]),
            )
        } else {
            Affine2::IDENTITY
        };
        let transform = if transform.is_finite() {
            transform
        } else {
            Affine2::IDENTITY
        };
        let set = tt["texCoord"]
            .as_u64()
            .map_or(tex_coord, |s| s.min(u32::MAX as u64) as u32);
        let set = if set > 1 {
            self.warn(format!(
                "{what} reads TEXCOORD_{set}: raysplat reads sets 0 and 1, TEXCOORD_0 is used"
            ));
            0
        } else {
            set as u8
        };
        use json::texture::{MagFilter, WrappingMode};
        let sampler = self.root.textures[index]
            .sampler
            .and_then(|s| self.root.samplers.get(s.value()));
        let wrap = |m: Option<&Checked<WrappingMode>>| match m {
            Some(Checked::Valid(WrappingMode::ClampToEdge)) => Wrap::Clamp,
            Some(Checked::Valid(WrappingMode::MirroredRepeat)) => Wrap::Mirror,
            _ => Wrap::Repeat,
        };
        Ok(Some(TextureRef {
            image,
            transform,
            set,
            wrap: [
                wrap(sampler.map(|s| &s.wrap_s)),
                wrap(sampler.map(|s| &s.wrap_t)),
            ],
            nearest: sampler
                .is_some_and(|s| s.mag_filter == Some(Checked::Valid(MagFilter::Nearest))),
        }))
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
            .to_rgba8();
        let texels: Vec<[u8; 4]> = decoded.pixels().map(|p| p.0).collect();
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

/// glTF material `index` as ours.
pub(super) fn convert_material(
    index: usize,
    m: &json::Material,
    textures: &mut TextureLoader,
) -> Result<Material, String> {
    let pbr = &m.pbr_metallic_roughness;
    let bc = pbr.base_color_factor.0;
    let base_color = Vec3::new(
        finite_or(bc[0], 0.8),
        finite_or(bc[1], 0.8),
        finite_or(bc[2], 0.8),
    )
    .clamp(Vec3::ZERO, Vec3::ONE);
    let base_alpha = finite_or(bc[3], 1.0).clamp(0.0, 1.0);
    let metallic = finite_or(pbr.metallic_factor.0, 1.0).clamp(0.0, 1.0);
    let roughness = finite_or(pbr.roughness_factor.0, 1.0).clamp(0.0, 1.0);
    let ext = m.extensions.as_ref();
    let transmission = ext
        .and_then(|e| e.transmission.as_ref())
        .map(|t| finite_or(t.transmission_factor.0, 0.0))
        .unwrap_or(0.0)
        .clamp(0.0, 1.0);
    let ior = ext
        .and_then(|e| e.ior.as_ref())
        .map(|i| i.ior.0)
        .filter(|i| i.is_finite() && *i >= 1.0)
        .unwrap_or(1.5);
    // KHR_materials_specular's factor and colour (its textures are read below).
    let specular = ext
        .and_then(|e| e.specular.as_ref())
        .map(|s| {
            let c = s.specular_color_factor.0;
            crate::bsdf::SpecularLayer {
                factor: finite_or(s.specular_factor.0, 1.0).clamp(0.0, 1.0),
                color: Vec3::new(
                    finite_or(c[0], 1.0),
                    finite_or(c[1], 1.0),
                    finite_or(c[2], 1.0),
                )
                .max(Vec3::ZERO),
            }
        })
        .unwrap_or_default();
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
    let raw = textures.raw["materials"][index].clone();
    // Each texture info as the JSON gives it (index, texCoord, KHR_texture_transform).
    let mut slot = |info: &Value, what: &str| -> Result<Option<TextureRef>, String> {
        let Some(t) = info["index"].as_u64() else {
            return Ok(None);
        };
        let set = info["texCoord"].as_u64().unwrap_or(0).min(u32::MAX as u64) as u32;
        textures.slot(info, t as usize, set, &format!("material {index}'s {what}"))
    };
    let pbr_raw = &raw["pbrMetallicRoughness"];
    let base_texture = slot(&pbr_raw["baseColorTexture"], "base colour texture")?;
    let metal_rough_texture = slot(
        &pbr_raw["metallicRoughnessTexture"],
        "metallic-roughness texture",
    )?;
    let normal_scale = finite_or(m.normal_texture.as_ref().map_or(1.0, |n| n.scale), 1.0);
    let normal_texture = slot(&raw["normalTexture"], "normal texture")?.map(|t| (t, normal_scale));
    let emissive_texture = slot(&raw["emissiveTexture"], "emissive texture")?;
    let transmission_texture = slot(
        &raw["extensions"]["KHR_materials_transmission"]["transmissionTexture"],
        "transmission texture",
    )?;
    // Smooth glass everywhere, or a share of it chosen per hit (Scene::bsdf).
    let kind = if transmission >= 1.0
        && metallic <= 0.0
        && transmission_texture.is_none()
        && metal_rough_texture.is_none()
    {
        MaterialKind::Dielectric { ior }
    } else {
        MaterialKind::classify(metallic, roughness, specular)
    };
    let spec_raw = &raw["extensions"]["KHR_materials_specular"];
    let specular_texture = slot(&spec_raw["specularTexture"], "specular texture")?;
    let specular_color_texture =
        slot(&spec_raw["specularColorTexture"], "specular colour texture")?;
    // The occlusion texture is checked but not applied: raysplat computes the occlusion it
    // stands for (docs/deviations.md §45).
    if let Some(o) = &m.occlusion_texture {
        get(
            &textures.root.textures,
            o.index.value(),
            &format!("material {index}'s occlusion texture"),
        )?;
    }
    // KHR_materials_volume on glass: Beer–Lambert absorption inside. A thickness of 0 (the
    // default) is the extension's thin wall, which absorbs nothing; the thickness itself (and
    // its texture) is for renderers that cannot trace the volume: raysplat measures the path
    // inside (docs/deviations.md §54).
    let volume = &raw["extensions"]["KHR_materials_volume"];
    let absorption =
        if transmission > 0.0 && volume["thicknessFactor"].as_f64().is_some_and(|t| t > 0.0) {
            absorption(volume)
        } else {
            None
        };
    use json::material::AlphaMode as Mode;
    let alpha = match m.alpha_mode {
        Checked::Valid(Mode::Mask) => {
            AlphaMode::Mask(finite_or(m.alpha_cutoff.as_ref().map_or(0.5, |c| c.0), 0.5))
        }
        Checked::Valid(Mode::Blend) => AlphaMode::Blend,
        _ => AlphaMode::Opaque,
    };
    Ok(Material {
        name: name.to_string(),
        base_color,
        base_alpha,
        base_texture,
        kind,
        metallic,
        roughness,
        specular,
        specular_texture,
        specular_color_texture,
        ior,
        metal_rough_texture,
        normal_texture,
        emission,
        emissive_texture,
        alpha,
        double_sided: m.double_sided,
        transmission,
        transmission_texture,
        absorption,
    })
}

/// σ = −ln(c)/d per channel for KHR_materials_volume's `attenuationColor` c (white by
/// default) and `attenuationDistance` d (+∞ by default: no absorption); a black channel
/// absorbs all (σ saturates at f32::MAX, so that exp(−σ·0) stays 1).
fn absorption(volume: &Value) -> Option<Vec3> {
    let d = volume["attenuationDistance"].as_f64()?;
    let c = &volume["attenuationColor"];
    let channel = |i: usize| c[i].as_f64().unwrap_or(1.0);
    if !(d.is_finite() && d > 0.0) {
        return None;
    }
    let sigma = Vec3::from_array(std::array::from_fn(|i| {
        let c = channel(i).clamp(0.0, 1.0);
        (-c.ln() / d).min(f32::MAX as f64) as f32
    }));
    (sigma.max_element() > 0.0).then_some(sigma)
}

/// What material `m` (its raw JSON) asks for that raysplat does not render: one name per
/// extension, with what part of it is not rendered where part is.
pub(super) fn unrendered(m: &json::Material, raw: &Value) -> Vec<String> {
    let mut out = Vec::new();
    let Some(exts) = raw["extensions"].as_object() else {
        return out;
    };
    // Some of it is glass: a transmission factor on a dielectric share (glTF's metallic is 1
    // unless the file says otherwise, and transmission replaces only the dielectric's diffuse
    // layer; a metallic-roughness texture may lower it). Scene::bsdf draws that share.
    let pbr = &m.pbr_metallic_roughness;
    let glass = exts
        .get("KHR_materials_transmission")
        .and_then(|t| t["transmissionFactor"].as_f64())
        .is_some_and(|t| t > 0.0)
        && (pbr.metallic_factor.0 < 1.0 || pbr.metallic_roughness_texture.is_some());
    for (name, e) in exts {
        let what = match name.as_str() {
            "KHR_materials_emissive_strength" | "KHR_materials_ior" => continue,
            "KHR_materials_transmission" => {
                // Rough transmission is rendered (bsdf::Bsdf::Dielectric's microfacet model).
                let solid = raw["extensions"]["KHR_materials_volume"]["thicknessFactor"]
                    .as_f64()
                    .is_some_and(|t| t > 0.0);
                if glass && !solid {
                    // glTF's default is a thin wall; the volume extension makes it solid
                    // (docs/deviations.md §54).
                    out.push("KHR_materials_transmission's thin wall (no KHR_materials_volume; rendered as solid, refracting glass)".to_string());
                }
                continue;
            }
            // Rendered on glass with a thickness; elsewhere it has no effect.
            "KHR_materials_volume" => continue,
            "KHR_materials_specular" => {
                // Factor, colour and their textures are read; the glass share's Fresnel
                // (smooth glass keeps its own) is not.
                let textures =
                    e.get("specularTexture").is_some() || e.get("specularColorTexture").is_some();
                let default = e["specularFactor"].as_f64().is_none_or(|f| f == 1.0)
                    && e["specularColorFactor"]
                        .as_array()
                        .is_none_or(|c| c.iter().all(|v| v.as_f64() == Some(1.0)));
                if glass && (textures || !default) {
                    "KHR_materials_specular on a transmissive material".to_string()
                } else {
                    continue;
                }
            }
            other => other.to_string(),
        };
        out.push(what);
    }
    out
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
