//! [`super::BuiltinScene::Features`]: one object for each part of glTF's material model that
//! raysplat reads (issue 31), on a floor, with no light of its own: a checker base-colour
//! texture and a normal texture of dimples on the floor (repeat sampler, tangents computed),
//! a sphere whose metallic-roughness texture bands smooth metal with rough plastic, a cube
//! coloured by COLOR_0, an alpha-MASK screen with round holes, a panel whose emissive
//! texture (read through TEXCOORD_1, clamped at its edges) is bright on one half of the
//! image, two plain plastic spheres (roughness 0.3, 0.6; the
//! rougher one's specular layer tinted by KHR_materials_specular), a frosted glass sphere
//! (rough transmission, IOR, volume) and an alpha-BLEND pane. The banded sphere's texture is
//! scaled by KHR_texture_transform and mirrored by its sampler; the floor has an occlusion
//! texture (read, not applied).
//! Textures are generated here and written as PNG.

use super::GlbBuilder;
use super::shapes::{Quads, uv_sphere};
use glam::Vec3;
use serde_json::{Value, json};

/// An RGBA image of `w`×`h` from `texel(x, y)`, as PNG bytes.
fn png(w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y)));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .expect("encoding a PNG into memory cannot fail");
    out.into_inner()
}

/// TEXCOORD_0 of [`uv_sphere`]'s vertices: u around, v from the top pole down.
fn sphere_uvs(segments: u32, rings: u32) -> Vec<f32> {
    (0..=rings)
        .flat_map(|r| {
            (0..=segments).flat_map(move |s| [s as f32 / segments as f32, r as f32 / rings as f32])
        })
        .collect()
}

/// A quad facing `normal` with TEXCOORD_0 from each vertex's position (`uv_of`), as mesh
/// `name` of `material`.
fn textured_quad(
    g: &mut GlbBuilder,
    name: &str,
    corners: [Vec3; 4],
    normal: Vec3,
    uv_of: impl Fn(Vec3) -> [f32; 2],
    material: u32,
) {
    let mut q = Quads::default();
    q.add(corners, normal);
    let uv: Vec<f32> = q.p.iter().flat_map(|&p| uv_of(p)).collect();
    g.mesh_with(name, &q.p, &q.n, &[("TEXCOORD_0", 2, &uv)], &q.i, material);
}

fn pbr(name: &str, color: [f32; 4], metallic: f32, roughness: f32) -> Value {
    json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": color,
        "metallicFactor": metallic, "roughnessFactor": roughness}})
}

pub(super) fn features(g: &mut GlbBuilder) {
    // The floor: a checker base colour and dimples in its normal texture, tiled 6 × 6.
    let checker = g.texture(
        &png(64, 64, |x, y| {
            if (x / 8 + y / 8) % 2 == 0 {
                [200, 200, 190, 255]
            } else {
                [60, 80, 130, 255]
            }
        }),
        None,
    );
    let dimples = g.texture(
        &png(64, 64, |x, y| {
            // A spherical cap of radius 12 texels in each 32-texel cell, its slope encoded.
            let (dx, dy) = ((x % 32) as f32 - 15.5, (y % 32) as f32 - 15.5);
            let r2 = dx * dx + dy * dy;
            let n = if r2 < 144.0 {
                let h = (144.0 - r2).sqrt();
                Vec3::new(dx / h, dy / h, 1.0).normalize()
            } else {
                Vec3::Z
            };
            let e = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
            [e(n.x), e(n.y), e(n.z), 255]
        }),
        None,
    );
    let mut floor = pbr("floor", [1.0; 4], 0.0, 0.8);
    floor["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": checker});
    floor["normalTexture"] = json!({"index": dimples, "scale": 1.0});
    // Read and, as glTF's renderers with global illumination do, not applied (deviations
    // §45): the image must not change with it. The normal texture's image, linear as
    // occlusion is (Blender's importer keeps one colour space per image: sharing the sRGB
    // checker made it read the base colour as linear).
    floor["occlusionTexture"] = json!({"index": dimples, "strength": 1.0});
    let floor = g.material(floor);
    let corners = [
        Vec3::new(-3.0, 0.0, 3.0),
        Vec3::new(3.0, 0.0, 3.0),
        Vec3::new(3.0, 0.0, -3.0),
        Vec3::new(-3.0, 0.0, -3.0),
    ];
    // Six tiles each way.
    textured_quad(
        g,
        "floor",
        corners,
        Vec3::Y,
        |p| [p.x + 3.0, 3.0 - p.z],
        floor,
    );

    // A sphere banded by its metallic-roughness texture: smooth metal and rough plastic.
    let bands = g.texture(
        &png(4, 64, |_, y| {
            if (y / 8) % 2 == 0 {
                [0, 20, 255, 255]
            } else {
                [0, 230, 0, 255]
            }
        }),
        // Mirrored along v, which KHR_texture_transform's scale takes past 1.
        Some(json!({"magFilter": 9728, "wrapS": 10497, "wrapT": 33648})),
    );
    let mut banded = pbr("banded", [0.95, 0.75, 0.35, 1.0], 1.0, 1.0);
    banded["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({"index": bands,
        "extensions": {"KHR_texture_transform": {"scale": [1.0, 2.0]}}});
    let banded = g.material(banded);
    let (segments, rings) = (64, 32);
    let uv = sphere_uvs(segments, rings);
    let (p, n, i) = uv_sphere(Vec3::new(-1.2, 0.5, 0.0), 0.5, segments, rings);
    g.mesh_with(
        "banded_sphere",
        &p,
        &n,
        &[("TEXCOORD_0", 2, &uv)],
        &i,
        banded,
    );

    // Plain plastic spheres: the glossy highlight of a rough dielectric.
    // The rougher one's specular layer tinted by KHR_materials_specular.
    for (k, rough) in [0.3f32, 0.6].into_iter().enumerate() {
        let mut m = pbr(
            &format!("plastic_{rough}"),
            [0.1, 0.35, 0.8, 1.0],
            0.0,
            rough,
        );
        if k == 1 {
            m["extensions"] = json!({"KHR_materials_specular":
                {"specularFactor": 1.0, "specularColorFactor": [1.0, 0.6, 0.3]}});
        }
        let m = g.material(m);
        let (p, n, i) = uv_sphere(Vec3::new(0.9 + 0.9 * k as f32, 0.35, 1.0), 0.35, 48, 24);
        g.mesh(&format!("plastic_sphere_{k}"), &p, &n, &i, m);
    }

    // A frosted glass sphere: KHR_materials_transmission through the microfacet model
    // (roughness 0.25), KHR_materials_ior and KHR_materials_volume (solid, clear).
    let frosted = g.material(json!({"name": "frosted_glass",
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 0.25},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 0.6}}}));
    let (p, n, i) = uv_sphere(Vec3::new(-0.6, 0.28, 1.5), 0.28, 48, 24);
    g.mesh("frosted_sphere", &p, &n, &i, frosted);

    // A cube coloured by COLOR_0, one colour per face.
    let white = g.material(pbr("vertex_coloured", [1.0; 4], 0.0, 1.0));
    let (c, h) = (Vec3::new(0.2, 0.3, 0.9), 0.3);
    let mut cube = Quads::default();
    let mut colors = Vec::new();
    let face_colors = [
        [0.8, 0.1, 0.1, 1.0],
        [0.1, 0.7, 0.1, 1.0],
        [0.1, 0.2, 0.8, 1.0],
        [0.8, 0.8, 0.1, 1.0],
        [0.8, 0.1, 0.8, 1.0],
        [0.1, 0.8, 0.8, 1.0],
    ];
    for (f, axis) in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
        .into_iter()
        .enumerate()
    {
        let (u, v) = crate::sampling::onb(axis);
        let o = c + axis * h;
        cube.add(
            [
                o - u * h - v * h,
                o + u * h - v * h,
                o + u * h + v * h,
                o - u * h + v * h,
            ],
            axis,
        );
        for _ in 0..4 {
            colors.extend_from_slice(&face_colors[f]);
        }
    }
    g.mesh_with(
        "vertex_coloured_cube",
        &cube.p,
        &cube.n,
        &[("COLOR_0", 4, &colors)],
        &cube.i,
        white,
    );

    // An alpha-MASK screen with round holes, standing behind the spheres.
    let holes = g.texture(
        &png(64, 64, |x, y| {
            let (dx, dy) = ((x % 16) as f32 - 7.5, (y % 16) as f32 - 7.5);
            let a = if dx * dx + dy * dy < 25.0 { 0 } else { 255 };
            [230, 230, 230, a]
        }),
        Some(json!({"magFilter": 9728})),
    );
    let mut screen = pbr("screen", [1.0; 4], 0.0, 1.0);
    screen["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": holes});
    screen["alphaMode"] = json!("MASK");
    screen["doubleSided"] = json!(true);
    let screen = g.material(screen);
    let corners = [
        Vec3::new(-2.2, 0.0, -1.2),
        Vec3::new(0.2, 0.0, -1.2),
        Vec3::new(0.2, 1.6, -1.2),
        Vec3::new(-2.2, 1.6, -1.2),
    ];
    let uv = |p: Vec3| [(p.x + 2.2) / 2.4, p.y / 1.6];
    textured_quad(g, "screen", corners, Vec3::Z, uv, screen);

    // An alpha-BLEND pane, orange at half coverage, in front of the plastic spheres.
    let mut pane = pbr("blend_pane", [1.0, 0.55, 0.2, 0.5], 0.0, 1.0);
    pane["alphaMode"] = json!("BLEND");
    pane["doubleSided"] = json!(true);
    let pane = g.material(pane);
    let corners = [
        Vec3::new(0.6, 0.0, 1.45),
        Vec3::new(1.1, 0.0, 1.45),
        Vec3::new(1.1, 0.45, 1.45),
        Vec3::new(0.6, 0.45, 1.45),
    ];
    let uv = |p: Vec3| [(p.x - 0.6) / 0.5, 1.0 - p.y / 0.45];
    textured_quad(g, "blend_pane", corners, Vec3::Z, uv, pane);

    // A panel whose emissive texture is warm white on its upper half and black below, read
    // through TEXCOORD_1 (v from −0.5 at the panel's top edge to 0.75 at its foot) with
    // clamped edges: the panel glows down to a fifth of its height from the foot. Read
    // through TEXCOORD_0, it would glow on its upper half; with a repeating sampler, its top
    // two fifths would be dark.
    let glow = g.texture(
        &png(32, 32, |_, y| {
            if y < 16 {
                [255, 220, 170, 255]
            } else {
                [0, 0, 0, 255]
            }
        }),
        Some(json!({"magFilter": 9728, "wrapS": 33071, "wrapT": 33071})),
    );
    let mut panel = pbr("panel", [0.2, 0.2, 0.2, 1.0], 0.0, 0.9);
    panel["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    panel["emissiveTexture"] = json!({"index": glow, "texCoord": 1});
    panel["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}});
    let panel = g.material(panel);
    let corners = [
        Vec3::new(0.8, 0.0, -1.5),
        Vec3::new(2.2, 0.0, -1.5),
        Vec3::new(2.2, 1.4, -1.5),
        Vec3::new(0.8, 1.4, -1.5),
    ];
    // TEXCOORD_0: v = 0 at the top of the image, the panel's top edge; TEXCOORD_1 as above.
    let mut q = Quads::default();
    q.add(corners, Vec3::Z);
    let uv0: Vec<f32> =
        q.p.iter()
            .flat_map(|p| [(p.x - 0.8) / 1.4, 1.0 - p.y / 1.4])
            .collect();
    let uv1: Vec<f32> =
        q.p.iter()
            .flat_map(|p| [(p.x - 0.8) / 1.4, 1.25 * (1.0 - p.y / 1.4) - 0.5])
            .collect();
    g.mesh_with(
        "emissive_panel",
        &q.p,
        &q.n,
        &[("TEXCOORD_0", 2, &uv0), ("TEXCOORD_1", 2, &uv1)],
        &q.i,
        panel,
    );

    g.camera(
        "features_camera",
        Vec3::new(0.0, 1.8, 4.6),
        Vec3::new(0.0, 0.5, -0.3),
        38f32.to_radians(),
    );
}
