//! Hand-made glTF files for each case the loader must handle: files the specification allows
//! (accessors without a buffer view, sparse accessors, integers written as `1.0`, images from
//! extensions, KHR_mesh_quantization, KHR_texture_transform, scenes without nodes) load with
//! the geometry and colours the specification gives them and render without NaN; malformed
//! files (an empty image object, indices past their lists, views past their buffer, huge
//! counts, node cycles) give one clean line. Nothing panics.

mod common;

use common::glb::{base64, join};
use glam::{Vec2, Vec3};
use raysplat::scene::{Hit, Scene};
use serde_json::{Value, json};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;

/// An emissive, double-sided white material: every test triangle lights itself.
fn emissive() -> Value {
    json!({"emissiveFactor": [1.0, 1.0, 1.0], "doubleSided": true,
        "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}})
}

/// The little-endian bytes of `v`.
fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Appends `bytes` to `bin` at a 4-byte boundary; returns their offset.
fn push(bin: &mut Vec<u8>, bytes: &[u8]) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let at = bin.len();
    bin.extend_from_slice(bytes);
    at
}

/// A GLB of one node with one mesh of `primitive`, material 0 emissive unless `materials`
/// is given, with the accessors and views given and `bin` as buffer 0.
fn glb(
    bin: &[u8],
    accessors: Value,
    views: Value,
    primitive: Value,
    edit: impl FnOnce(&mut Value),
) -> Vec<u8> {
    let mut root = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [primitive]}],
        "materials": [emissive()],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    edit(&mut root);
    join(&root, bin)
}

/// The triangle most tests draw: (0,0,0), (2,0,0), (0,0,2).
const TRI: [f32; 9] = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0];

/// A GLB whose POSITION is accessor 0 over TRI: the base the malformed cases edit.
fn plain_triangle(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let bin = f32s(&TRI);
    glb(
        &bin,
        json!([{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}]),
        json!([{"buffer": 0, "byteLength": 36}]),
        json!({"attributes": {"POSITION": 0}, "material": 0}),
        edit,
    )
}

fn load(bytes: &[u8]) -> Result<Scene, String> {
    catch_unwind(AssertUnwindSafe(|| Scene::from_glb_bytes(bytes, "case")))
        .expect("loading must not panic")
        .map_err(|e| e.to_string())
}

/// Loads, and renders a tiny image with photon splatting without NaN or infinite pixels.
fn loads_and_renders(bytes: &[u8]) -> Arc<Scene> {
    let scene = Arc::new(load(bytes).unwrap_or_else(|e| panic!("refused: {e}")));
    if let Err(e) = common::renders_cleanly(scene.clone()) {
        panic!("{e}");
    }
    scene
}

/// Refused with one non-empty line containing `needle`.
fn refused(bytes: &[u8], needle: &str) -> String {
    let e = match load(bytes) {
        Ok(_) => panic!("loaded, expected an error with '{needle}'"),
        Err(e) => e,
    };
    assert!(!e.contains('\n') && !e.trim().is_empty(), "{e:?}");
    assert!(
        !e.contains("glTF reader failed"),
        "reached the last line of defence: {e}"
    );
    assert!(e.contains(needle), "expected '{needle}' in: {e}");
    e
}

fn vertices(scene: &Scene, t: usize) -> [Vec3; 3] {
    let t = &scene.triangles[t];
    [t.v0.into(), t.v1.into(), t.v2.into()]
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn a_degenerate_triangle_skips_only_itself() {
    // Triangle 0 repeats a vertex; triangle 1 is good and must still load.
    let bin = [f32s(&TRI), vec![0, 0, 0, 0, 1, 2, 0, 0]].concat();
    let bytes = glb(
        &bin,
        json!([{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
               {"bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR"}]),
        json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}]),
        json!({"attributes": {"POSITION": 0}, "indices": 1, "material": 0}),
        |_| {},
    );
    let scene = loads_and_renders(&bytes);
    assert_eq!(scene.triangle_count(), 1);
    assert!(
        scene.warnings.iter().any(|w| w.contains("1 degenerate")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn an_accessor_without_a_buffer_view_is_zeros_with_its_sparse_values() {
    let mut bin = Vec::new();
    // Sparse: vertices 1 and 2 substituted; vertex 0 stays the zero fill.
    let idx = push(&mut bin, &[1, 2]);
    let val = push(&mut bin, &f32s(&TRI[3..]));
    let bytes = glb(
        &bin,
        json!([
            {"componentType": 5126, "count": 3, "type": "VEC3",
             "sparse": {"count": 2, "indices": {"bufferView": 0, "componentType": 5121},
                        "values": {"bufferView": 1}}},
            // NORMAL without a view and without sparse: all zeros, so unusable normals.
            {"componentType": 5126, "count": 3, "type": "VEC3"}
        ]),
        json!([{"buffer": 0, "byteOffset": idx, "byteLength": 2},
               {"buffer": 0, "byteOffset": val, "byteLength": 24}]),
        json!({"attributes": {"POSITION": 0, "NORMAL": 1}, "material": 0}),
        |_| {},
    );
    let scene = loads_and_renders(&bytes);
    assert_eq!(scene.triangle_count(), 1);
    let [a, b, c] = vertices(&scene, 0);
    assert_eq!(
        (a, b, c),
        (
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0)
        )
    );
    // Zero normals fall back to the geometric normal.
    let geo = (b - a).cross(c - a).normalize();
    assert!(scene.shading[0].normals.iter().all(|n| close(*n, geo)));
}

#[test]
fn a_sparse_accessor_substitutes_values_on_its_buffer_view() {
    let mut bin = Vec::new();
    let base = push(
        &mut bin,
        &f32s(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 9.0, 9.0, 9.0]),
    );
    // Indices as unsigned shorts at byte offset 2; values at byte offset 4.
    let idx = push(&mut bin, &[0xff, 0xff, 2, 0]);
    let val = push(
        &mut bin,
        &[[0xffu8; 4].as_slice(), &f32s(&[0.0, 0.0, 2.0])].concat(),
    );
    // The same sparse accessor over `count` base elements.
    let sparse = |count: u32| {
        glb(
            &bin,
            json!([{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
                "sparse": {"count": 1,
                    "indices": {"bufferView": 1, "byteOffset": 2, "componentType": 5123},
                    "values": {"bufferView": 2, "byteOffset": 4}}}]),
            json!([{"buffer": 0, "byteOffset": base, "byteLength": 36},
                   {"buffer": 0, "byteOffset": idx, "byteLength": 4},
                   {"buffer": 0, "byteOffset": val, "byteLength": 16}]),
            json!({"attributes": {"POSITION": 0}, "material": 0}),
            |_| {},
        )
    };
    let scene = loads_and_renders(&sparse(3));
    assert_eq!(vertices(&scene, 0)[2], Vec3::new(0.0, 0.0, 2.0));
    // A sparse index past the accessor's count is malformed.
    refused(&sparse(2), "sparse index 2 is out of range");
}

#[test]
fn integers_written_as_floats_load_from_gltf_text_with_a_data_uri() {
    let mut bin = f32s(&TRI);
    let idx = push(&mut bin, &[0, 0, 1, 0, 2, 0]);
    let root = json!({
        "asset": {"version": "2.0"},
        "scene": 0.0,
        "scenes": [{"nodes": [0.0]}],
        "nodes": [{"mesh": 0.0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0.0}, "indices": 1.0,
            "material": 0.0, "mode": 4.0}]}],
        "materials": [emissive()],
        "accessors": [
            {"bufferView": 0.0, "byteOffset": 0.0, "componentType": 5126.0, "count": 3.0, "type": "VEC3"},
            {"bufferView": 1.0, "componentType": 5123.0, "count": 3.0, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0.0, "byteOffset": 0.0, "byteLength": 36.0, "byteStride": 12.0},
            {"buffer": 0.0, "byteOffset": idx as f64, "byteLength": 6.0}
        ],
        "buffers": [{"byteLength": bin.len() as f64,
            "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}],
    });
    let text = serde_json::to_string(&root).unwrap();
    assert!(text.contains("\"count\":3.0") && text.contains("\"componentType\":5126.0"));
    let scene = loads_and_renders(text.as_bytes());
    assert_eq!(scene.triangle_count(), 1);
    assert_eq!(vertices(&scene, 0)[1], Vec3::new(2.0, 0.0, 0.0));
}

#[test]
fn a_gltf_with_a_relative_percent_encoded_buffer_file_loads() {
    let dir = std::env::temp_dir().join(format!("raysplat-cases-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("tri data.bin"), f32s(&TRI)).unwrap();
    let (mut json, _) = common::glb::split(&plain_triangle(|_| {}));
    json["buffers"][0]["uri"] = json!("tri%20data.bin");
    let path = dir.join("tri.gltf");
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), 1);
    // From memory the file cannot be reached: the mesh has no data, and the line says so.
    refused(
        &serde_json::to_vec(&json).unwrap(),
        "cannot be read when loading from memory",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A PNG of `w`×`h` sRGB pixels.
fn png(w: u32, h: u32, pixels: &[[u8; 3]]) -> Vec<u8> {
    let img = image::RgbImage::from_raw(w, h, pixels.concat()).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A triangle with TEXCOORD_0 (and TEXCOORD_1 = `uv1`), material 0 emissive with the base
/// colour texture `texture_info`, textures and images as given; images' `bufferView: "png"`
/// is replaced by a view of `png_bytes`.
fn textured(
    texture_info: Value,
    textures: Value,
    mut images: Value,
    png_bytes: &[u8],
    uv1: [f32; 6],
) -> Vec<u8> {
    let mut bin = f32s(&TRI);
    let uv0 = push(&mut bin, &f32s(&[0.1, 0.1, 0.2, 0.1, 0.1, 0.2]));
    let uv1 = push(&mut bin, &f32s(&uv1));
    let img = push(&mut bin, png_bytes);
    let webp = push(&mut bin, b"RIFF\x04\0\0\0WEBP");
    for i in images.as_array_mut().unwrap() {
        match i.get("bufferView").and_then(Value::as_str) {
            Some("png") => i["bufferView"] = json!(3),
            Some("other") => i["bufferView"] = json!(4),
            _ => {}
        }
    }
    glb(
        &bin,
        json!([
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}
        ]),
        json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": uv0, "byteLength": 24},
               {"buffer": 0, "byteOffset": uv1, "byteLength": 24},
               {"buffer": 0, "byteOffset": img, "byteLength": png_bytes.len()},
               {"buffer": 0, "byteOffset": webp, "byteLength": 12}]),
        json!({"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2}, "material": 0}),
        |root| {
            root["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = texture_info;
            root["textures"] = textures;
            root["images"] = images;
            // Sampler 0 reads the nearest texel, for the tests that name it.
            root["samplers"] = json!([{"magFilter": 9728}]);
        },
    )
}

const RED: [u8; 3] = [255, 0, 0];
const GREEN: [u8; 3] = [0, 255, 0];
const BLUE: [u8; 3] = [0, 0, 255];
const WHITE: [u8; 3] = [255, 255, 255];

fn linear(c: [u8; 3]) -> Vec3 {
    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0
}

#[test]
fn an_image_from_an_extension_uses_the_png_fallback_or_the_base_colour_factor() {
    let red = png(1, 1, &[RED]);
    let images = json!([{"bufferView": "png", "mimeType": "image/png"},
                        {"bufferView": "other", "mimeType": "image/webp"}]);
    // With a PNG fallback in `source`: the PNG is used.
    let with_fallback = textured(
        json!({"index": 0}),
        json!([{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}]),
        images.clone(),
        &red,
        [0.0; 6],
    );
    let scene = loads_and_renders(&with_fallback);
    let t = scene.materials[0]
        .base_texture
        .as_ref()
        .expect("the PNG fallback is used");
    assert_eq!(scene.textures[t.image].texels[0], [255, 0, 0, 255]);
    // Only an extension's image: the base colour factor, and one warning naming it.
    for ext in ["EXT_texture_webp", "KHR_texture_basisu", "MSFT_texture_dds"] {
        let only = textured(
            json!({"index": 0}),
            json!([{"extensions": {ext: {"source": 1}}}]),
            images.clone(),
            &red,
            [0.0; 6],
        );
        let scene = loads_and_renders(&only);
        assert!(scene.materials[0].base_texture.is_none(), "{ext}");
        let w: Vec<&String> = scene.warnings.iter().filter(|w| w.contains(ext)).collect();
        assert_eq!(w.len(), 1, "{ext}: {:?}", scene.warnings);
        assert!(w[0].contains("factor is used instead"), "{w:?}");
    }
}

#[test]
fn an_empty_image_object_falls_back_to_the_base_colour_factor() {
    let bytes = textured(
        json!({"index": 0}),
        json!([{"source": 0}]),
        json!([{}]),
        &[],
        [0.0; 6],
    );
    let scene = loads_and_renders(&bytes);
    assert!(scene.materials[0].base_texture.is_none());
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("neither a uri nor a buffer view")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn quantized_attributes_are_dequantized() {
    let mut bin = Vec::new();
    // SHORT normalized positions, 6 bytes each, 8 apart.
    let mut pos = Vec::new();
    for p in [[0i16, 0, 0], [32767, 0, 0], [0, 0, 32767]] {
        for c in p {
            pos.extend_from_slice(&c.to_le_bytes());
        }
        pos.extend_from_slice(&[0, 0]);
    }
    let pos = push(&mut bin, &pos);
    // BYTE normalized normals (0, −127, 127), 4 bytes apart.
    let nrm = push(&mut bin, &[0, 0x81, 127, 0].repeat(3));
    // UNSIGNED_SHORT normalized texture coordinates.
    let uv: Vec<u8> = [0u16, 0, 65535, 0, 0, 65535]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let uv = push(&mut bin, &uv);
    let bytes = glb(
        &bin,
        json!([
            {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2"}
        ]),
        json!([{"buffer": 0, "byteOffset": pos, "byteLength": 24, "byteStride": 8},
               {"buffer": 0, "byteOffset": nrm, "byteLength": 12, "byteStride": 4},
               {"buffer": 0, "byteOffset": uv, "byteLength": 12}]),
        json!({"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "material": 0}),
        |root| {
            // The node's scale dequantizes, as KHR_mesh_quantization intends.
            root["nodes"][0]["scale"] = json!([2.0, 2.0, 2.0]);
            root["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
            root["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
        },
    );
    let scene = loads_and_renders(&bytes);
    let [a, b, c] = vertices(&scene, 0);
    assert!(
        close(a, Vec3::ZERO)
            && close(b, Vec3::new(2.0, 0.0, 0.0))
            && close(c, Vec3::new(0.0, 0.0, 2.0))
    );
    let n = Vec3::new(0.0, -1.0, 1.0).normalize();
    assert!(
        scene.shading[0].normals.iter().all(|m| close(*m, n)),
        "{:?}",
        scene.shading[0].normals
    );
    assert_eq!(scene.shading[0].uvs, [Vec2::ZERO, Vec2::X, Vec2::Y]);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

/// The texel of the 2×2 texture [[RED, GREEN], [BLUE, WHITE]] (row 0 first) at `uv`, repeat
/// wrapping, nearest texel.
fn texel_2x2(uv: Vec2) -> [u8; 3] {
    let f = |x: f32| ((x - x.floor()) * 2.0).floor().min(1.0) as usize;
    [[RED, GREEN], [BLUE, WHITE]][f(uv.y)][f(uv.x)]
}

/// KHR_texture_transform's matrix as the extension's specification writes it out:
/// translation × rotation × scale with rotation [[cos, sin], [−sin, cos]].
fn spec_transform(uv: Vec2, offset: Vec2, rotation: f32, scale: Vec2) -> Vec2 {
    let s = uv * scale;
    let (sin, cos) = rotation.sin_cos();
    Vec2::new(cos * s.x + sin * s.y, -sin * s.x + cos * s.y) + offset
}

#[test]
fn texture_transform_moves_the_sampled_colour_as_the_extension_says() {
    let tex = png(2, 2, &[RED, GREEN, BLUE, WHITE]);
    let images = json!([{"bufferView": "png", "mimeType": "image/png"}]);
    let hit = |uv: Vec2| Hit {
        t: 1.0,
        position: Vec3::ZERO,
        geo_normal: Vec3::Y,
        normal: Vec3::Y,
        uv,
        uv1: uv,
        color: glam::Vec4::ONE,
        triangle: 0,
        material: 0,
        offset: 0.0,
    };
    let probes = [
        Vec2::new(0.25, 0.25),
        Vec2::new(0.7, 0.3),
        Vec2::new(0.2, 0.8),
        Vec2::new(0.6, 0.6),
    ];
    // Without a transform the texture is where the coordinates say.
    let plain = textured(
        json!({"index": 0}),
        json!([{"source": 0, "sampler": 0}]),
        images.clone(),
        &tex,
        [0.0; 6],
    );
    let scene = loads_and_renders(&plain);
    for uv in probes {
        assert_eq!(scene.albedo(&hit(uv)), linear(texel_2x2(uv)), "{uv}");
    }
    for (offset, rotation, scale) in [
        (Vec2::new(0.5, 0.0), 0.0, Vec2::ONE),
        (Vec2::new(0.5, 0.0), std::f32::consts::FRAC_PI_2, Vec2::ONE),
        (Vec2::new(0.1, 0.3), 0.4, Vec2::new(2.0, 0.5)),
    ] {
        let info = json!({"index": 0, "extensions": {"KHR_texture_transform": {
            "offset": offset.to_array(), "rotation": rotation, "scale": scale.to_array()}}});
        let bytes = textured(
            info,
            json!([{"source": 0, "sampler": 0}]),
            images.clone(),
            &tex,
            [0.0; 6],
        );
        let scene = loads_and_renders(&bytes);
        let mut moved = 0;
        for uv in probes {
            let expected = linear(texel_2x2(spec_transform(uv, offset, rotation, scale)));
            assert_eq!(
                scene.albedo(&hit(uv)),
                expected,
                "{uv} {offset} {rotation} {scale}"
            );
            moved += usize::from(expected != linear(texel_2x2(uv)));
        }
        assert!(moved >= 2, "the transform moves the colour at most probes");
    }
    // texCoord in the transform overrides the texture info's: the triangle carries TEXCOORD_1.
    let uv1 = [0.9, 0.1, 0.8, 0.1, 0.9, 0.2];
    let info = json!({"index": 0, "texCoord": 0,
        "extensions": {"KHR_texture_transform": {"texCoord": 1}}});
    let scene = loads_and_renders(&textured(
        info,
        json!([{"source": 0, "sampler": 0}]),
        images,
        &tex,
        uv1,
    ));
    let t = scene.materials[0].base_texture.as_ref().expect("textured");
    assert_eq!(t.set, 1);
    assert_eq!(
        scene.extras[scene.shading[0].extra as usize].uv1,
        [
            Vec2::new(0.9, 0.1),
            Vec2::new(0.8, 0.1),
            Vec2::new(0.9, 0.2)
        ]
    );
}

#[test]
fn scenes_without_nodes_and_files_without_scenes() {
    // The default scene lists no nodes (the property is absent): nothing to show, one line.
    refused(
        &plain_triangle(|r| r["scenes"] = json!([{}])),
        "no triangles",
    );
    refused(
        &plain_triangle(|r| r["scenes"] = json!([{"name": "empty", "nodes": []}])),
        "no triangles",
    );
    // No scene at all: the nodes that are nobody's child are shown, each once.
    let bytes = plain_triangle(|r| {
        r.as_object_mut().unwrap().remove("scene");
        r.as_object_mut().unwrap().remove("scenes");
        r["nodes"] = json!([{"children": [1]}, {"mesh": 0}]);
    });
    assert_eq!(loads_and_renders(&bytes).triangle_count(), 1);
}

#[test]
fn a_position_accessor_that_does_not_exist_is_one_line() {
    let e = refused(
        &plain_triangle(|r| r["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(7)),
        "accessor 7",
    );
    assert!(e.contains("POSITION"), "{e}");
}

#[test]
fn malformed_files_are_one_line() {
    // A buffer view past the end of its buffer.
    refused(
        &plain_triangle(|r| r["bufferViews"][0]["byteLength"] = json!(1000)),
        "runs past the end",
    );
    // Counts no data can hold: on a view, and without one (zeros that would exhaust memory).
    refused(
        &plain_triangle(|r| r["accessors"][0]["count"] = json!(4_294_967_296u64)),
        "reads past the end",
    );
    refused(
        &plain_triangle(|r| {
            r["accessors"][0]
                .as_object_mut()
                .unwrap()
                .remove("bufferView");
            r["accessors"][0]["count"] = json!(1_000_000_000_000u64);
        }),
        "no buffer view: more than the loader",
    );
    // Node cycles, of two nodes and of one.
    refused(
        &plain_triangle(|r| r["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}])),
        "reached twice",
    );
    refused(
        &plain_triangle(|r| r["nodes"] = json!([{"mesh": 0, "children": [0]}])),
        "reached twice",
    );
    // Indices past their lists.
    refused(&plain_triangle(|r| r["scene"] = json!(5)), "scene 5");
    refused(
        &plain_triangle(|r| r["nodes"][0]["mesh"] = json!(3)),
        "mesh 3",
    );
    refused(
        &plain_triangle(|r| r["meshes"][0]["primitives"][0]["material"] = json!(9)),
        "material 9",
    );
    refused(
        &plain_triangle(|r| r["bufferViews"][0]["buffer"] = json!(2)),
        "buffer 2",
    );
    refused(
        &plain_triangle(|r| r["nodes"][0]["camera"] = json!(0)),
        "camera 0",
    );
    // A component type that does not exist, and a stride shorter than the element.
    refused(
        &plain_triangle(|r| r["accessors"][0]["componentType"] = json!(5000)),
        "component type",
    );
    refused(
        &plain_triangle(|r| r["bufferViews"][0]["byteStride"] = json!(4)),
        "byte stride",
    );
    // Not JSON, not an object.
    refused(b"{\"asset\": ", "not valid glTF");
    refused(b"[1, 2]", "not valid glTF");
}

/// The quad both compressed-mesh cases encode: its corners, texture coordinates and (before
/// normalising) normals, drawn as the triangles 0 1 2 and 0 2 3.
const QUAD_CORNERS: [Vec3; 4] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(2.0, 0.0, 0.0),
    Vec3::new(2.0, 0.0, 2.0),
    Vec3::new(0.0, 0.0, 2.0),
];
const QUAD_UVS: [Vec2; 4] = [
    Vec2::new(0.0, 0.0),
    Vec2::new(1.0, 0.0),
    Vec2::new(1.0, 1.5),
    Vec2::new(0.0, 1.5),
];
const QUAD_NORMALS: [Vec3; 4] = [
    Vec3::new(0.0, 1.0, 0.3),
    Vec3::new(0.2, 1.0, 0.0),
    Vec3::new(0.0, 1.0, 0.0),
    Vec3::new(-0.5, 0.8, 0.1),
];
const QUAD_TRIANGLES: [u32; 6] = [0, 1, 2, 0, 2, 3];

/// The quad's corner, texture coordinate and (`Some`, within its tolerance) normal at each
/// corner of both triangles of `scene`, whatever order the loader gives them; every corner
/// of the quad is drawn.
fn assert_is_the_quad(scene: &Scene, uv_tolerance: f32, normals: Option<f32>) {
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.triangles.len(), 2);
    let mut seen = [false; 4];
    for t in 0..2 {
        let s = &scene.shading[t];
        for (k, p) in vertices(scene, t).iter().enumerate() {
            let id = QUAD_CORNERS
                .iter()
                .position(|c| (*c - *p).length() < 2.0 / 8192.0)
                .unwrap_or_else(|| panic!("triangle {t} corner {k} at {p} is none of the quad's"));
            seen[id] = true;
            let uv = QUAD_UVS[id];
            assert!(
                (s.uvs[k] - uv).length() < uv_tolerance,
                "uv {} against {uv}",
                s.uvs[k]
            );
            if let Some(tolerance) = normals {
                let n = QUAD_NORMALS[id].normalize();
                let got = s.normals[k];
                assert!((got - n).length() < tolerance, "normal {got} against {n}");
            }
        }
    }
    assert_eq!(seen, [true; 4], "every corner of the quad is drawn");
}

/// The quad stored as gltfpack stores it with EXT_meshopt_compression: positions by the
/// vertex codec, octahedral normals (bytes, or `wide` 16-bit), texture coordinates by the
/// exponential filter, indices by the index codec (or `wide` 32-bit ones by the
/// index-sequence codec), all in buffer 0, and the views they stand in for on a fallback
/// buffer without data. `edit` changes the JSON.
fn meshopt_quad(wide: bool, edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let normals: Vec<[f32; 4]> = QUAD_NORMALS
        .iter()
        .map(|n| n.normalize().extend(0.0).to_array())
        .collect();
    let mut bin = Vec::new();
    let mut encoded = |bytes: Vec<u8>| (push(&mut bin, &bytes), bytes.len());
    let p = encoded(meshopt::encode_vertex_buffer(&QUAD_CORNERS.map(|c| c.to_array())).unwrap());
    let (n, n_stride, n_type) = if wide {
        let oct = meshopt::encode_filter_oct::<i16>(&normals, 16);
        (
            encoded(meshopt::encode_vertex_buffer(&oct).unwrap()),
            8,
            5122,
        )
    } else {
        let oct = meshopt::encode_filter_oct::<i8>(&normals, 8);
        (
            encoded(meshopt::encode_vertex_buffer(&oct).unwrap()),
            4,
            5120,
        )
    };
    let uvs = QUAD_UVS.map(|c| c.to_array());
    let uv_exp = meshopt::encode_filter_exp(&uvs, 15, meshopt::EncodeExpMode::Separate);
    let t = encoded(meshopt::encode_vertex_buffer(&uv_exp).unwrap());
    let (i, i_stride, i_type, i_mode) = if wide {
        let seq = meshopt::encode_index_sequence(&QUAD_TRIANGLES, 4).unwrap();
        (encoded(seq), 4, 5125, "INDICES")
    } else {
        let tri = meshopt::encode_index_buffer(&QUAD_TRIANGLES, 4).unwrap();
        (encoded(tri), 2, 5123, "TRIANGLES")
    };
    // Each view: its compressed bytes, stride, count, mode and filter; the fallback buffer
    // lays the decoded views end to end.
    let views = [
        (p, 12, 4, "ATTRIBUTES", "NONE"),
        (n, n_stride, 4, "ATTRIBUTES", "OCTAHEDRAL"),
        (t, 8, 4, "ATTRIBUTES", "EXPONENTIAL"),
        (i, i_stride, 6, i_mode, "NONE"),
    ];
    let mut fallback = 0;
    let views: Vec<Value> = views
        .iter()
        .map(|&((at, len), stride, count, mode, filter)| {
            let mut view = json!({"buffer": 1, "byteOffset": fallback,
                "byteLength": stride * count,
                "extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": at,
                    "byteLength": len, "byteStride": stride, "count": count, "mode": mode,
                    "filter": filter}}});
            if mode == "ATTRIBUTES" {
                view["byteStride"] = json!(stride);
            }
            fallback += stride * count;
            view
        })
        .collect();
    glb(
        &bin,
        json!([
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": n_type, "normalized": true, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": i_type, "count": 6, "type": "SCALAR"}
        ]),
        json!(views),
        json!({"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
            "material": 0}),
        |root| {
            root["buffers"] = json!([{"byteLength": bin.len()}, {"byteLength": fallback,
                "extensions": {"EXT_meshopt_compression": {"fallback": true}}}]);
            root["extensionsUsed"] = json!(["EXT_meshopt_compression", "KHR_mesh_quantization"]);
            root["extensionsRequired"] =
                json!(["EXT_meshopt_compression", "KHR_mesh_quantization"]);
            edit(root);
        },
    )
}

/// EXT_meshopt_compression is decoded: the quad's triangles, normals (8-bit octahedral
/// within 0.02, 16-bit within 0.001) and texture coordinates (15-bit exponential, within
/// 1e-4) are the ones that were encoded, through the index codec and (16-bit normals, 32-bit
/// indices) the index-sequence codec, and the fallback buffer, which has no data, is never
/// read. The attribute views' stride is the extension's: without the fallback view's own
/// `byteStride` they read the same.
#[test]
fn a_meshopt_compressed_mesh_loads_as_it_was_encoded() {
    assert_is_the_quad(
        &loads_and_renders(&meshopt_quad(false, |_| {})),
        1e-4,
        Some(0.02),
    );
    assert_is_the_quad(
        &loads_and_renders(&meshopt_quad(true, |_| {})),
        1e-4,
        Some(0.001),
    );
    let without_strides = meshopt_quad(false, |r| {
        for v in r["bufferViews"].as_array_mut().unwrap() {
            v.as_object_mut().unwrap().remove("byteStride");
        }
    });
    assert_is_the_quad(&loads_and_renders(&without_strides), 1e-4, Some(0.02));
}

/// A malformed EXT_meshopt_compression is one line naming what is wrong; nothing panics or
/// allocates what a count asks for.
#[test]
fn malformed_meshopt_compression_is_one_line() {
    fn ext(r: &mut Value, view: usize) -> &mut Value {
        &mut r["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]
    }
    refused(
        &meshopt_quad(false, |r| ext(r, 0)["mode"] = json!("VERTICES")),
        "unknown mode",
    );
    refused(
        &meshopt_quad(false, |r| ext(r, 1)["byteStride"] = json!(12)),
        "byteStride 12 is not allowed",
    );
    refused(
        &meshopt_quad(false, |r| ext(r, 0)["byteOffset"] = json!(1 << 20)),
        "runs past the end",
    );
    refused(
        &meshopt_quad(false, |r| ext(r, 0)["count"] = json!(1u64 << 40)),
        "more than raysplat reads",
    );
    // A count whose size in bytes does not fit 64 bits.
    refused(
        &meshopt_quad(false, |r| ext(r, 0)["count"] = json!(1u64 << 62)),
        "more than raysplat reads",
    );
    // The index data read by the vertex codec: not a vertex stream.
    refused(
        &meshopt_quad(false, |r| {
            let indices = ext(r, 3).clone();
            *ext(r, 0) = indices;
            ext(r, 0)["mode"] = json!("ATTRIBUTES");
            ext(r, 0)["byteStride"] = json!(12);
            ext(r, 0)["count"] = json!(4);
        }),
        "cannot be decoded",
    );
    refused(
        &meshopt_quad(false, |r| ext(r, 2)["count"] = json!("four")),
        "not a count",
    );
}

/// A quad of two triangles as one Draco stream (KHR_draco_mesh_compression), encoded in the
/// test: positions at 14 bits, texture coordinates at 12, COLOR_0 as unsigned bytes read
/// through a normalized accessor; the accessors have no data of their own. `edit` changes the
/// JSON.
fn draco_quad(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    use draco_core::{
        DataType, EncoderBuffer, EncoderOptions, FaceIndex, GeometryAttributeType, Mesh,
        MeshEncoder, PointAttribute,
    };
    let mut mesh = Mesh::new();
    let attribute = |kind, width: usize, ty, values: &[u8]| {
        let mut a = PointAttribute::new();
        a.init(kind, width as u8, ty, false, 4);
        a.buffer_mut().write(0, values);
        a
    };
    let corners: Vec<f32> = QUAD_CORNERS.iter().flat_map(|c| c.to_array()).collect();
    let uvs: Vec<f32> = QUAD_UVS.iter().flat_map(|c| c.to_array()).collect();
    mesh.add_attribute(attribute(
        GeometryAttributeType::Position,
        3,
        DataType::Float32,
        &f32s(&corners),
    ));
    mesh.add_attribute(attribute(
        GeometryAttributeType::TexCoord,
        2,
        DataType::Float32,
        &f32s(&uvs),
    ));
    mesh.add_attribute(attribute(
        GeometryAttributeType::Color,
        4,
        DataType::Uint8,
        &DRACO_COLORS.concat(),
    ));
    mesh.set_num_faces(2);
    mesh.set_face(FaceIndex(0), [0u32.into(), 1u32.into(), 2u32.into()]);
    mesh.set_face(FaceIndex(1), [0u32.into(), 2u32.into(), 3u32.into()]);
    let mut options = EncoderOptions::new();
    options.set_attribute_int(0, "quantization_bits", 14);
    options.set_attribute_int(1, "quantization_bits", 12);
    let mut encoder = MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut stream = EncoderBuffer::new();
    encoder
        .encode(&options, &mut stream)
        .expect("the test's mesh encodes");
    let stream = stream.data().to_vec();
    glb(
        &stream,
        json!([
            {"componentType": 5126, "count": 4, "type": "VEC3",
                "min": [0.0, 0.0, 0.0], "max": [2.0, 0.0, 2.0]},
            {"componentType": 5126, "count": 4, "type": "VEC2"},
            {"componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"},
            {"componentType": 5123, "count": 6, "type": "SCALAR"}
        ]),
        json!([{"buffer": 0, "byteLength": stream.len()}]),
        json!({"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 2}, "indices": 3,
            "material": 0, "extensions": {"KHR_draco_mesh_compression": {"bufferView": 0,
            "attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 2}}}}),
        |root| {
            root["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
            root["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
            edit(root);
        },
    )
}

const DRACO_COLORS: [[u8; 4]; 4] = [
    [255, 0, 0, 255],
    [0, 255, 0, 255],
    [0, 0, 255, 255],
    [255, 255, 255, 255],
];

/// KHR_draco_mesh_compression is decoded: both triangles come back with the quad's corners
/// (within the 14-bit quantisation), texture coordinates (12 bits) and vertex colours (bytes
/// read as the normalized accessor says: 255 is 1), whatever order Draco gives the points.
#[test]
fn a_draco_compressed_mesh_loads_as_it_was_encoded() {
    let scene = loads_and_renders(&draco_quad(|_| {}));
    assert_is_the_quad(&scene, 1.0 / 2048.0, None);
    for t in 0..2 {
        let s = &scene.shading[t];
        assert_ne!(s.extra, raysplat::scene::NO_EXTRA, "COLOR_0 was not read");
        let extra = &scene.extras[s.extra as usize];
        for (k, p) in vertices(&scene, t).iter().enumerate() {
            let id = QUAD_CORNERS
                .iter()
                .position(|c| (*c - *p).length() < 2.0 / 8192.0);
            let [r, g, b, _] =
                DRACO_COLORS[id.expect("a corner of the quad")].map(|c| c as f32 / 255.0);
            let colour = Vec3::new(r, g, b);
            assert!(
                (extra.color[k].truncate() - colour).length() < 1e-5 && extra.color[k].w == 1.0,
                "triangle {t} corner {k}: colour {} against {colour}",
                extra.color[k]
            );
        }
    }
}

/// A malformed Draco primitive is one line; nothing panics.
#[test]
fn malformed_draco_compression_is_one_line() {
    fn ext(r: &mut Value) -> &mut Value {
        &mut r["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
    }
    refused(
        &draco_quad(|r| {
            ext(r).as_object_mut().unwrap().remove("bufferView");
        }),
        "has no bufferView",
    );
    refused(
        &draco_quad(|r| ext(r)["attributes"]["POSITION"] = json!(7)),
        "is not in the stream",
    );
    refused(
        &draco_quad(|r| ext(r)["bufferView"] = json!(4)),
        "KHR_draco_mesh_compression refers to buffer view 4",
    );
    // The stream cut short.
    refused(
        &draco_quad(|r| r["bufferViews"][0]["byteLength"] = json!(20)),
        "cannot be decoded",
    );
}
