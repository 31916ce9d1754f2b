//! Unit tests of the radiance cache: coverage, exact interpolation of constant light, chained
//! records' world reach, and merged samples sharing their lead's value.

use super::*;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSample;
use crate::scene::Camera;

/// A 64×48 image of one plane facing the camera: one sample per pixel.
fn plane_samples(w: u32, h: u32) -> (EyeSamples, Camera) {
    plane_seen_through(w, h, 1.0, true)
}

/// [`plane_samples`], its points spread `minify` times wider apart than their pixels,
/// as seen through a minifying specular chain when not `primary`.
fn plane_seen_through(w: u32, h: u32, minify: f32, primary: bool) -> (EyeSamples, Camera) {
    let camera = Camera::look_at("c", Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 0.8);
    let mut eye = EyeSamples::default();
    let aspect = w as f32 / h as f32;
    for y in 0..h {
        for x in 0..w {
            let d = camera.direction(
                (x as f32 + 0.5) / w as f32,
                (y as f32 + 0.5) / h as f32,
                aspect,
            );
            let t = 2.0 / -d.z;
            let on_plane = camera.position + d * t;
            let s = EyeSample {
                position: Vec3::new(on_plane.x * minify, on_plane.y * minify, 0.0),
                normal: Vec3::Z,
                geo_normal: Vec3::Z,
                offset: 0.0,
                wo: -d,
                material: 0,
                pixel: y * w + x,
                weight: Vec3::ONE,
                albedo: Vec3::splat(0.5),
                specular: Vec3::ZERO,
                alpha: 1.0,
                f90: 0.0,
                primary,
                lobe_traced: false,
            };
            let n = eye.len() as u32;
            eye.push_sample(&s, n);
        }
    }
    (eye, camera)
}

fn constant(h: f32) -> impl FnMut(&[u32]) -> Vec<RecordValue> {
    move |s| {
        s.iter()
            .map(|_| RecordValue {
                irradiance: Vec3::ONE,
                harmonic_distance: h,
                directional: Vec::new(),
            })
            .collect()
    }
}

/// The cache `build` makes in diffuse mode (its values set aside).
fn diffuse_cache(
    eye: &EyeSamples,
    geo: &PixelGeometry,
    camera: &Camera,
    params: &CacheParams,
    evaluate: impl FnMut(&[u32]) -> Vec<RecordValue>,
) -> Cache {
    build(eye, geo, camera, params, DirectionalMode::Diffuse, evaluate).0
}

#[test]
fn every_pixel_is_covered_and_constant_light_interpolates_exactly() {
    let (eye, camera) = plane_samples(64, 48);
    let geo = PixelGeometry::new(&eye, 64, 48);
    for min in [4, 7] {
        let params = CacheParams {
            error: 0.5,
            min_records: min,
        };
        let cache = diffuse_cache(&eye, &geo, &camera, &params, constant(0.5));
        let it = interpolate(&cache, &eye, &geo, DirectionalMode::Diffuse);
        assert!(
            it.coverage.iter().all(|&c| c >= min),
            "min {min}: {:?}",
            it.coverage.iter().min()
        );
        assert!(
            it.irradiance
                .iter()
                .all(|e| (*e - Vec3::ONE).abs().max_element() < 1e-5)
        );
    }
}

/// A plane seen only through a chain that spreads neighbouring pixels 8× farther apart
/// in world space than seen directly, lit by a step in x: all records are of the chained
/// kind, every sample is valued (covered, looked up in world space, or on its own), and
/// samples farther from the step than the largest record reach get its exact value.
#[test]
fn chained_records_serve_only_within_their_world_reach() {
    let (w, h) = (64, 48);
    let (eye, camera) = plane_seen_through(w, h, 8.0, false);
    let geo = PixelGeometry::new(&eye, w, h);
    assert!(geo.first.iter().all(|&s| s == u32::MAX));
    // A step in x: a record serving across it from beyond its reach shows at once.
    let light = |p: Vec3| Vec3::splat(if p.x < 0.0 { 1.0 } else { 1000.0 });
    let params = CacheParams::default();
    let cache = diffuse_cache(&eye, &geo, &camera, &params, |s| {
        s.iter()
            .map(|&i| RecordValue {
                irradiance: light(eye.position[i as usize]),
                harmonic_distance: 0.5,
                directional: Vec::new(),
            })
            .collect()
    });
    assert!(!cache.records.is_empty());
    assert!(cache.records.iter().all(|r| !r.primary));
    let reach = cache
        .records
        .iter()
        .map(|r| r.reach(r.radius_px))
        .fold(0.0f32, f32::max);
    let it = interpolate(&cache, &eye, &geo, DirectionalMode::Diffuse);
    let valued: std::collections::HashSet<u32> = cache
        .own
        .iter()
        .chain(&cache.from_world)
        .map(|(i, _)| *i)
        .collect();
    let mut near_step = 0;
    for i in 0..eye.len() {
        assert!(
            it.coverage[i] > 0 || valued.contains(&(i as u32)),
            "sample {i}"
        );
        let x = eye.position[i].x;
        if x.abs() <= reach * 1.001 {
            near_step += 1;
            continue;
        }
        let err = (it.irradiance[i] - light(eye.position[i]))
            .abs()
            .max_element();
        assert!(
            err < 1e-3,
            "sample {i} at x {x}: off by {err}, reach {reach}"
        );
    }
    // Some samples lie within reach of the step: the image-space discs (8× wider in
    // world space) reach well beyond it.
    assert!(near_step > 0 && near_step < eye.len() / 4);
}

/// A chained record accepts a sample on its plane within CHAIN_REACH × its disc's world
/// size and refuses one beyond it; a record seen directly has no such limit.
#[test]
fn a_chained_record_serves_only_within_its_reach() {
    let (mut eye, _) = plane_seen_through(4, 1, 1.0, false);
    let (direct, _) = plane_seen_through(4, 1, 1.0, true);
    let record = |primary: bool| Record {
        sample: 0,
        pixel: (0, 0),
        position: Vec3::ZERO,
        normal: Vec3::Z,
        material: 0,
        primary,
        depth: 2.0,
        pixel_size: 0.01,
        radius: 0.05,
        radius_px: 2.0,
        pass: 0,
        cos_min: normal_tolerance(0.5),
        value: RecordValue::default(),
    };
    let reach = record(false).reach(2.0);
    assert!((reach - CHAIN_REACH * 2.5 * 0.01).abs() < 1e-6);
    for (i, d) in [0.5, 0.99, 1.01, 3.0].into_iter().enumerate() {
        eye.position[i] = Vec3::new(d * reach, 0.0, 0.0);
    }
    let chained = Compatibility::of(&record(false));
    let got: Vec<bool> = (0..4).map(|i| chained.accepts(&eye, i)).collect();
    assert_eq!(got, [true, true, false, false]);
    let mut direct = direct;
    direct.position.clone_from(&eye.position);
    let seen = Compatibility::of(&record(true));
    assert!((0..4).all(|i| seen.accepts(&direct, i)));
    // Kinds never mix.
    assert!(!seen.accepts(&eye, 0) && !chained.accepts(&direct, 0));
}

#[test]
fn lower_error_means_more_records() {
    let (eye, camera) = plane_samples(96, 64);
    let geo = PixelGeometry::new(&eye, 96, 64);
    let mut last = 0;
    for eps in [2.0, 1.0, 0.5, 0.25, 0.12, 0.06] {
        let params = CacheParams {
            error: eps,
            min_records: 4,
        };
        let n = diffuse_cache(&eye, &geo, &camera, &params, constant(1.0))
            .records
            .len();
        assert!(
            n >= last,
            "ε = {eps}: {n} records, fewer than {last} at the larger ε"
        );
        last = n;
    }
    assert!(last > 200);
}

/// Samples merged onto one splat target share their lead's value (irradiance, coverage and
/// directional floats, bit for bit), whether the lead was interpolated in image space,
/// looked up in world space or valued on its own; a sample of another material, or of the
/// other kind on the same target, is valued apart. Per pixel: a glossy material-0 group of
/// three (the third's shading normal 12° off, within the merge's 15° but beyond what a
/// record of ε = 0.1 accepts), a matte material-1 sample, and a chained material-0 sample
/// on the group's target (on a plane farther away). In the left half the group comes first
/// (its records cover it), and a chained pair lies on the near plane, where no chained
/// record serves it: its lead takes the group's record from the world lookup where its
/// pixel has one, and its follower (10⁻³ aside, 12° off: refused by that record on its
/// own) takes the lead's value. In the right half the material-1 sample comes first, so
/// records there are material 1's and the group falls to the world lookup or to its own
/// value. SH records hold (k+1)·E.x, so the directional floats must come out as (k+1)
/// times the sample's E.x. `build`'s values are `interpolate`'s of its cache (the world
/// and own values written alike). Fails when every sample is its own lead, when the kind
/// leaves the key, and when followers are looked up in world space on their own.
#[test]
fn merged_samples_share_their_leads_value() {
    let (w, h) = (48u32, 32u32);
    let (one, camera) = plane_samples(w, h);
    let mode = DirectionalMode::Sh;
    let floats = mode.record_floats();
    let tilted = Vec3::new(12f32.to_radians().sin(), 0.0, 12f32.to_radians().cos());
    let mut eye = EyeSamples::default();
    let mut target = 0u32;
    for i in 0..one.len() {
        let base = EyeSample {
            position: one.position[i],
            normal: Vec3::Z,
            geo_normal: Vec3::Z,
            offset: 0.0,
            wo: Vec3::Z,
            material: 0,
            pixel: one.pixel[i],
            weight: Vec3::splat(0.2),
            albedo: Vec3::splat(0.5),
            specular: Vec3::splat(0.3),
            alpha: 0.3,
            f90: 1.0,
            primary: true,
            lobe_traced: false,
        };
        let group = |k: usize| {
            let mut s = base;
            s.position.x += 1e-4 * k as f32;
            s.normal = if k == 2 { tilted } else { Vec3::Z };
            s
        };
        let matte = EyeSample {
            material: 1,
            specular: Vec3::ZERO,
            f90: 0.0,
            ..base
        };
        // Seen through a chain: a plane farther away (irradiance belongs to a point, and
        // the world lookup rightly mixes the kinds there).
        let chained = EyeSample {
            primary: false,
            position: base.position - Vec3::Z * 10.0,
            ..base
        };
        let (g, m) = (target, target + 1);
        if one.pixel[i] % w < w / 2 {
            for k in 0..3 {
                eye.push_sample(&group(k), g);
            }
            eye.push_sample(&matte, m);
        } else {
            eye.push_sample(&matte, m);
            for k in 0..3 {
                eye.push_sample(&group(k), g);
            }
        }
        eye.push_sample(&chained, g);
        // In the left half, a chained pair on the near plane where the group's first
        // sample lies: no chained record serves it there (those are on the far plane),
        // but in the pixels with a record of the group, the world lookup finds it.
        if one.pixel[i] % w < w / 2 {
            let near = EyeSample {
                primary: false,
                ..group(0)
            };
            // Its follower 10⁻³ aside and 12° off: valued apart, it would be refused
            // by the record and splatted on its own (1 + x, not the record's value).
            let mut follower = near;
            follower.position.x += 1e-3;
            follower.normal = tilted;
            eye.push_sample(&near, target + 2);
            eye.push_sample(&follower, target + 2);
        }
        target += 3;
    }
    let geo = PixelGeometry::new(&eye, w, h);
    let light = |i: usize| {
        let x = eye.position[i].x;
        if eye.position[i].z < -5.0 {
            3.0
        } else if eye.material[i] == 0 {
            1.0 + x
        } else {
            5.0 - x
        }
    };
    let params = CacheParams {
        error: 0.1,
        min_records: 4,
    };
    assert!(12f32.to_radians().cos() < normal_tolerance(params.error));
    let (cache, values) = build(&eye, &geo, &camera, &params, mode, |s| {
        s.iter()
            .map(|&i| {
                let e = light(i as usize);
                RecordValue {
                    irradiance: Vec3::splat(e),
                    harmonic_distance: 0.5,
                    directional: if eye.lobe_in_map(i as usize) {
                        (0..floats).map(|k| (k + 1) as f32 * e).collect()
                    } else {
                        Vec::new()
                    },
                }
            })
            .collect()
    });
    let again = interpolate(&cache, &eye, &geo, mode);
    assert_eq!(values.irradiance, again.irradiance);
    assert_eq!(values.coverage, again.coverage);
    assert_eq!(values.directional, again.directional);
    let mut right_group_by_world_or_own = 0;
    let from_world: std::collections::HashSet<u32> =
        cache.from_world.iter().map(|(i, _)| *i).collect();
    let mut near_pair_from_world = 0;
    for p in 0..(w * h) as usize {
        let a = geo.start[p] as usize;
        let left = p as u32 % w < w / 2;
        let (lead, m1) = if left { (a, a + 3) } else { (a + 1, a) };
        for k in 1..3 {
            assert_eq!(values.irradiance[lead + k], values.irradiance[lead]);
            assert_eq!(values.coverage[lead + k], values.coverage[lead]);
            assert_eq!(values.dir(lead + k), values.dir(lead));
        }
        if left {
            assert!(values.coverage[lead + 2] > 0, "pixel {p}");
            // The near chained pair: uncovered, the follower as its lead.
            let (l, f) = (a + 5, a + 6);
            assert_eq!(values.coverage[l], 0);
            assert_eq!(values.irradiance[f], values.irradiance[l]);
            assert_eq!(values.dir(f), values.dir(l));
            near_pair_from_world += from_world.contains(&(f as u32)) as usize;
        } else {
            assert!(values.coverage[m1] > 0, "pixel {p}");
            right_group_by_world_or_own += (values.coverage[lead] == 0) as usize;
        }
        let x = eye.position[a].x;
        assert!(
            (values.irradiance[m1].x - (5.0 - x)).abs() < 0.2,
            "pixel {p}"
        );
        assert!(
            (values.irradiance[lead].x - (1.0 + x)).abs() < 0.2,
            "pixel {p}"
        );
        // The chained sample, on the group's target, takes the chained records' 3.
        assert!((values.irradiance[a + 4].x - 3.0).abs() < 1e-4, "pixel {p}");
        for i in a..geo.start[p + 1] as usize {
            match values.dir(i) {
                Some(d) => {
                    let e = values.irradiance[i].x;
                    for (k, v) in d.iter().enumerate() {
                        let want = (k + 1) as f32 * e;
                        assert!(
                            (v - want).abs() <= 1e-4 * want.abs().max(1.0),
                            "sample {i}: {v} vs {want}"
                        );
                    }
                }
                None => assert!(!eye.lobe_in_map(i)),
            }
        }
    }
    // Most of the right half's groups were valued by the world lookup or on their own, and
    // some near pairs' followers took their lead's value from the world lookup.
    assert!(right_group_by_world_or_own > (w * h / 4) as usize);
    assert!(near_pair_from_world > 0);
}
