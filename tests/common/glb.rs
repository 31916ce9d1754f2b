//! Taking GLB files apart and putting them back together, to make malformed ones on purpose.
#![allow(dead_code)]

use glam::Vec3;
use raysplat::scene::GlbBuilder;
use serde_json::{Value, json};

/// (JSON chunk, BIN chunk) of a GLB file.
pub fn split(glb: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |i: usize| u32::from_le_bytes(glb[i..i + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin = if glb.len() > bin_at + 8 {
        let len = u32_at(bin_at);
        glb[bin_at + 8..bin_at + 8 + len].to_vec()
    } else {
        Vec::new()
    };
    (json, bin)
}

/// A GLB file from a JSON value and a BIN chunk (padded as the format asks).
pub fn join(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if !b.is_empty() {
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    out
}

/// A small valid scene: a floor (mesh 0), a downward area light (mesh 1) and a camera.
pub fn small_scene() -> Vec<u8> {
    let mut g = GlbBuilder::default();
    let m = super::white(&mut g);
    super::plane(&mut g, 1.0, m);
    super::ceiling_light(&mut g, Vec3::Y, 0.2, 10.0);
    g.camera("top", Vec3::new(0.0, 2.0, 0.01), Vec3::ZERO, 0.8);
    g.to_glb()
}

/// Overwrite the f32 at `offset` of the BIN chunk.
pub fn put_f32(bin: &mut [u8], offset: usize, v: f32) {
    bin[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
}

/// Byte offset in the BIN chunk of the accessor `a`'s first element.
pub fn accessor_offset(json: &Value, a: usize) -> usize {
    let acc = &json["accessors"][a];
    let view = &json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    view["byteOffset"].as_u64().unwrap_or(0) as usize
        + acc["byteOffset"].as_u64().unwrap_or(0) as usize
}

/// The same scene with every root node under one parent scaled by `s` (cameras included):
/// physically the same picture, as area lights keep their radiance.
pub fn scaled(glb: &[u8], s: f32) -> Vec<u8> {
    let (mut json, bin) = split(glb);
    let scene = json["scene"].as_u64().unwrap_or(0) as usize;
    let roots = json["scenes"][scene]["nodes"].clone();
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "scale", "scale": [s, s, s], "children": roots}));
    let parent = nodes.len() - 1;
    json["scenes"][scene]["nodes"] = json!([parent]);
    join(&json, &bin)
}

/// The same scene with a black (albedo 0) square ground plane of half size `half` at height
/// `y`, facing up: it reflects nothing, only the bounding box grows.
pub fn with_black_ground(glb: &[u8], y: f32, half: f32) -> Vec<u8> {
    let (mut json, mut bin) = split(glb);
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        let views = json["bufferViews"].as_array_mut().unwrap();
        views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        views.len() - 1
    };
    let p = [
        Vec3::new(-half, y, -half),
        Vec3::new(half, y, -half),
        Vec3::new(half, y, half),
        Vec3::new(-half, y, half),
    ];
    let f32s = |v: &[Vec3]| -> Vec<u8> {
        v.iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect()
    };
    let pv = view(&mut bin, &f32s(&p), 34962);
    let nv = view(&mut bin, &f32s(&[Vec3::Y; 4]), 34962);
    let idx: Vec<u8> = [0u32, 2, 1, 0, 3, 2]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let iv = view(&mut bin, &idx, 34963);
    let accessors = json["accessors"].as_array_mut().unwrap();
    accessors.push(
        json!({"bufferView": pv, "componentType": 5126, "count": 4, "type": "VEC3",
        "min": [-half, y, -half], "max": [half, y, half]}),
    );
    accessors.push(json!({"bufferView": nv, "componentType": 5126, "count": 4, "type": "VEC3"}));
    accessors.push(json!({"bufferView": iv, "componentType": 5125, "count": 6, "type": "SCALAR"}));
    let a = accessors.len();
    let materials = json["materials"].as_array_mut().unwrap();
    materials.push(json!({"name": "black_ground", "pbrMetallicRoughness": {
        "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let m = materials.len() - 1;
    let meshes = json["meshes"].as_array_mut().unwrap();
    meshes.push(json!({"name": "black_ground", "primitives": [{
        "attributes": {"POSITION": a - 3, "NORMAL": a - 2}, "indices": a - 1, "material": m}]}));
    let mesh = meshes.len() - 1;
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "black_ground", "mesh": mesh}));
    let node = nodes.len() - 1;
    let scene = json["scene"].as_u64().unwrap_or(0) as usize;
    json["scenes"][scene]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(node));
    json["buffers"][0]["byteLength"] = json!(bin.len());
    join(&json, &bin)
}

/// Standard base64 with padding, for data: URIs.
pub fn base64(b: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            if i <= c.len() {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A PNG of `w`×`h` RGBA pixels, row by row from the top.
pub fn png_rgba(w: u32, h: u32, pixels: &[[u8; 4]]) -> Vec<u8> {
    let img = image::RgbaImage::from_raw(w, h, pixels.concat()).expect("w·h pixels");
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .expect("PNG encodes");
    out.into_inner()
}
