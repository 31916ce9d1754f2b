//! glTF materials, textures and KHR_lights_punctual lights converted to the scene's own types.

use crate::scene::{Light, Material, MaterialKind, Texture, TextureRef};
use glam::{Affine2, Mat4, Quat, Vec2, Vec3};
use gltf::image;

fn finite_or(x: f32, d: f32) -> f32 {
    if x.is_finite() { x } else { d }
}

pub(super) fn convert_material(m: &gltf::Material, textures: &[Texture]) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let bc = pbr.base_color_factor();
    let base_color = Vec3::new(
        finite_or(bc[0], 0.8),
        finite_or(bc[1], 0.8),
        finite_or(bc[2], 0.8),
    )
    .clamp(Vec3::ZERO, Vec3::ONE);
    let metallic = finite_or(pbr.metallic_factor(), 1.0).clamp(0.0, 1.0);
    let roughness = finite_or(pbr.roughness_factor(), 1.0).clamp(0.0, 1.0);
    let transmission = m
        .transmission()
        .map(|t| finite_or(t.transmission_factor(), 0.0))
        .unwrap_or(0.0);
    let ior = m
        .ior()
        .filter(|i| i.is_finite() && *i >= 1.0)
        .unwrap_or(1.5);
    let specular_off = m.specular().is_some_and(|s| s.specular_factor() == 0.0);
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
    // A negative or non-finite strength is not light: the material does not emit (and the
    // loader says so).
    let strength = m
        .emissive_strength()
        .map(|s| if s.is_finite() && s >= 0.0 { s } else { 0.0 })
        .unwrap_or(1.0);
    let ef = m.emissive_factor();
    let emission = Vec3::new(ef[0], ef[1], ef[2]) * strength;
    let emission = if emission.is_finite() {
        emission.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    };
    let base_texture = pbr.base_color_texture().and_then(|info| {
        let image = info.texture().source().index();
        if image >= textures.len() {
            return None;
        }
        let transform = info
            .texture_transform()
            .map(|t| {
                let [ox, oy] = t.offset();
                let [sx, sy] = t.scale();
                Affine2::from_scale_angle_translation(
                    Vec2::new(sx, sy),
                    -t.rotation(),
                    Vec2::new(ox, oy),
                )
            })
            .filter(|a| a.is_finite())
            .unwrap_or(Affine2::IDENTITY);
        Some(TextureRef { image, transform })
    });
    Material {
        name: m.name().unwrap_or("unnamed").to_string(),
        base_color,
        base_texture,
        kind,
        emission,
        double_sided: m.double_sided(),
    }
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

pub(super) fn decode_texture(img: &image::Data) -> Texture {
    use image::Format;
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    let channels = match img.format {
        Format::R8 => 1,
        Format::R8G8 => 2,
        Format::R8G8B8 => 3,
        Format::R8G8B8A8 => 4,
        // 16-bit and float textures: read the high byte of the first channels.
        Format::R16 => 2,
        Format::R16G16 => 4,
        Format::R16G16B16 => 6,
        Format::R16G16B16A16 => 8,
        Format::R32G32B32FLOAT => 12,
        Format::R32G32B32A32FLOAT => 16,
    };
    let wide = matches!(
        img.format,
        Format::R16 | Format::R16G16 | Format::R16G16B16 | Format::R16G16B16A16
    );
    let float = matches!(
        img.format,
        Format::R32G32B32FLOAT | Format::R32G32B32A32FLOAT
    );
    let n = (img.width * img.height) as usize;
    let mut texels = Vec::with_capacity(n);
    for i in 0..n {
        let px = &img.pixels[i * channels..(i + 1) * channels];
        let c = if float {
            let f = |k: usize| {
                f32::from_le_bytes([px[4 * k], px[4 * k + 1], px[4 * k + 2], px[4 * k + 3]])
            };
            Vec3::new(f(0), f(1), f(2))
        } else if wide {
            let k = channels / 2;
            let g = |j: usize| lut[px[2 * j.min(k - 1) + 1] as usize];
            Vec3::new(g(0), g(1), g(2))
        } else {
            let g = |j: usize| lut[px[j.min(channels - 1).min(2)] as usize];
            if channels <= 2 {
                Vec3::splat(g(0))
            } else {
                Vec3::new(g(0), g(1), g(2))
            }
        };
        texels.push(if c.is_finite() { c } else { Vec3::ONE });
    }
    if texels.is_empty() {
        texels.push(Vec3::ONE);
    }
    Texture {
        width: img.width.max(1),
        height: img.height.max(1),
        texels,
    }
}

pub(super) fn convert_light(
    light: &gltf::khr_lights_punctual::Light,
    world: Mat4,
) -> Option<Light> {
    use gltf::khr_lights_punctual::Kind;
    let (_, rot, pos): (Vec3, Quat, Vec3) = world.to_scale_rotation_translation();
    let color = Vec3::from(light.color()) * light.intensity();
    if !color.is_finite() || color.max_element() <= 0.0 {
        return None;
    }
    let dir = (rot * -Vec3::Z).normalize();
    match light.kind() {
        Kind::Point => Some(Light::Point {
            position: pos,
            intensity: color,
        }),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let outer = outer_cone_angle.clamp(1e-3, std::f32::consts::FRAC_PI_2);
            let inner = inner_cone_angle.clamp(0.0, outer);
            Some(Light::Spot {
                position: pos,
                direction: dir,
                intensity: color,
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            })
        }
        Kind::Directional => Some(Light::Directional {
            direction: dir,
            irradiance: color,
        }),
    }
}
