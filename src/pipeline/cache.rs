//! Radiance caching in image space (§8.3, after Gautron et al.'s radiance cache splatting
//! [GKBP05]): records at sparse eye samples, chosen in several passes over ever finer pixel
//! grids where the image is not yet covered; each record's incident light comes from the
//! photon-ray splats around it and its radius from the harmonic mean distance gathered while
//! splatting (SplatInfo), scaled by the cache error ε and projected to image space. Records
//! are splatted in image space with a tent weight and a geometric compatibility test (normal,
//! plane distance, material), so that every pixel is covered by at least `min_records`.
//!
//! The cache does not know where record values come from: [`build`] asks an evaluator for the
//! values of each pass's new records. `--method rc` splats the photon rays onto the new records
//! only (the speed-up of §8.3); the previewer reads them from the full radiance map, so moving
//! ε re-runs the cache without re-splatting.

use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::radiance_map::{Accumulators, Channel, Interpolated};
use crate::scene::Camera;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Cache parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CacheParams {
    /// ε: a record is valid up to ε × its harmonic mean distance (world space).
    pub error: f32,
    /// Every pixel is covered by at least this many compatible records (4–7 in [GKBP05]).
    pub min_records: u32,
}

impl Default for CacheParams {
    fn default() -> Self {
        Self {
            error: 0.5,
            min_records: 4,
        }
    }
}

/// Grid spacings of the passes, coarse to fine (pixels).
const LEVELS: [u32; 7] = [64, 32, 16, 8, 4, 2, 1];
/// Image-space radius bounds (pixels): at least 1.5 px, so that records on the finest grid
/// overlap their neighbours.
const MIN_RADIUS_PX: f32 = 1.5;
const MAX_RADIUS_PX: f32 = 64.0;
/// Compatibility: plane distance within 5% of the record's depth; normals within the angle
/// Ward's error metric allows for ε: √(1 − n·nᵢ) < ε, i.e. n·nᵢ > 1 − ε² (kept in [0.5, 0.995]).
const COMPAT_PLANE: f32 = 0.05;

/// The smallest n·nᵢ a record of cache error `eps` accepts.
pub fn normal_tolerance(eps: f32) -> f32 {
    (1.0 - eps * eps).clamp(0.5, 0.995)
}

/// What the evaluator returns for one record.
#[derive(Clone, Debug, Default)]
pub struct RecordValue {
    /// Batch-averaged irradiance (eq. 5) at the record.
    pub irradiance: Vec3,
    /// Harmonic mean distance to the origins of the photon rays splatted there (SplatInfo).
    pub harmonic_distance: f32,
    /// The directional record (SH or histogram floats, batch-averaged) where the record lies
    /// on a glossy surface; empty otherwise.
    pub directional: Vec<f32>,
}

/// One cache record.
#[derive(Clone, Debug)]
pub struct Record {
    /// The eye sample the record stands at.
    pub sample: u32,
    pub pixel: (u32, u32),
    pub position: Vec3,
    pub normal: Vec3,
    pub material: u32,
    /// Distance from the camera.
    pub depth: f32,
    /// World-space validity radius ε·R (m).
    pub radius: f32,
    /// Image-space radius (pixels).
    pub radius_px: f32,
    /// The pass (index into the grid levels) that created it.
    pub pass: u8,
    /// Smallest n·nᵢ of the eye samples it serves ([`normal_tolerance`]).
    pub cos_min: f32,
    pub value: RecordValue,
}

/// The per-pixel geometry the cache works with: each pixel's first primary eye sample.
pub struct PixelGeometry {
    pub width: u32,
    pub height: u32,
    /// First eye sample of each pixel seen directly from the camera, or u32::MAX where the
    /// pixel has none (only specular chains, or nothing).
    pub first: Vec<u32>,
    /// The eye samples of pixel p are start[p]..start[p + 1] (samples are in pixel order).
    pub start: Vec<u32>,
}

impl PixelGeometry {
    pub fn new(eye: &EyeSamples, width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        let mut first = vec![u32::MAX; n];
        let mut start = vec![0u32; n + 1];
        for i in (0..eye.len()).rev() {
            if eye.primary[i] {
                first[eye.pixel[i] as usize] = i as u32;
            }
            start[eye.pixel[i] as usize + 1] += 1;
        }
        for p in 0..n {
            start[p + 1] += start[p];
        }
        Self {
            width,
            height,
            first,
            start,
        }
    }
}

/// The cache: its records, and the eye samples valued on their own.
#[derive(Clone, Debug, Default)]
pub struct Cache {
    pub records: Vec<Record>,
    /// Records created per pass.
    pub per_pass: Vec<usize>,
    /// Eye samples reached through specular chains: image-space neighbours say nothing about
    /// them, so each is valued on its own (full splat accuracy), not interpolated.
    pub own: Vec<(u32, RecordValue)>,
}

/// Is the eye sample at (p, n, material) within the validity of `r`?
#[inline]
fn compatible(r: &Record, p: Vec3, n: Vec3, material: u32) -> bool {
    material == r.material
        && n.dot(r.normal) >= r.cos_min
        && ((p - r.position).dot(r.normal)).abs() <= COMPAT_PLANE * r.depth
}

/// Image-space tent weight of record `r` at pixel (x, y); 0 outside its radius.
#[inline]
fn tent(r: &Record, x: u32, y: u32) -> f32 {
    let dx = x as f32 - r.pixel.0 as f32;
    let dy = y as f32 - r.pixel.1 as f32;
    let d = (dx * dx + dy * dy).sqrt();
    (1.0 - d / (r.radius_px + 0.5)).max(0.0)
}

/// Records bucketed by image row for row-parallel splatting: for each row, the records whose
/// disc reaches it.
fn rows_of(records: &[Record], height: u32) -> Vec<Vec<u32>> {
    let mut rows = vec![Vec::new(); height as usize];
    for (k, r) in records.iter().enumerate() {
        let y0 = (r.pixel.1 as f32 - r.radius_px - 1.0).max(0.0) as u32;
        let y1 = ((r.pixel.1 as f32 + r.radius_px + 1.0) as u32).min(height - 1);
        for row in &mut rows[y0 as usize..=y1 as usize] {
            row.push(k as u32);
        }
    }
    rows
}

/// Count compatible records covering the first eye sample of every pixel.
fn pixel_coverage(records: &[Record], eye: &EyeSamples, geo: &PixelGeometry) -> Vec<u32> {
    let rows = rows_of(records, geo.height);
    let w = geo.width as usize;
    let mut cov = vec![0u32; geo.first.len()];
    cov.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        for &k in &rows[y] {
            let r = &records[k as usize];
            let x0 = (r.pixel.0 as f32 - r.radius_px - 1.0).max(0.0) as usize;
            let x1 = ((r.pixel.0 as f32 + r.radius_px + 1.0) as usize).min(w - 1);
            for (x, c) in out.iter_mut().enumerate().take(x1 + 1).skip(x0) {
                let s = geo.first[y * w + x];
                if s == u32::MAX || tent(r, x as u32, y as u32) <= 0.0 {
                    continue;
                }
                let s = s as usize;
                if compatible(r, eye.position[s], eye.normal[s], eye.material[s]) {
                    *c += 1;
                }
            }
        }
    });
    cov
}

/// Build the cache for `eye` seen through `camera`: passes over grids of spacing 64 … 1 px; in
/// each, every grid pixel covered by fewer than `min_records` compatible records gets one, and
/// `evaluate` supplies the new records' values (indices are eye samples). Then any pixel still
/// short of records widens its nearest compatible records (within 64 px) until it is covered,
/// and pixels still short after that become records themselves. Eye samples reached through
/// specular chains are valued on their own (`Cache::own`).
pub fn build(
    eye: &EyeSamples,
    geo: &PixelGeometry,
    camera: &Camera,
    params: &CacheParams,
    mut evaluate: impl FnMut(&[u32]) -> Vec<RecordValue>,
) -> Cache {
    let pixel_angle = 2.0 * (0.5 * camera.yfov).tan() / geo.height as f32;
    let mut cache = Cache::default();
    let eps = params.error.max(1e-3);
    // A record at eye sample i: world radius ε·R (R the harmonic mean distance), projected.
    let place = |i: usize, pass: u8, value: RecordValue| {
        let p = eye.pixel[i];
        let depth = (eye.position[i] - camera.position).length().max(1e-6);
        let radius = eps * value.harmonic_distance;
        let radius_px = (radius / (depth * pixel_angle)).clamp(MIN_RADIUS_PX, MAX_RADIUS_PX);
        Record {
            sample: i as u32,
            pixel: (p % geo.width, p / geo.width),
            position: eye.position[i],
            normal: eye.normal[i],
            material: eye.material[i],
            depth,
            radius,
            radius_px: if radius_px.is_finite() {
                radius_px
            } else {
                MIN_RADIUS_PX
            },
            pass,
            cos_min: normal_tolerance(eps),
            value,
        }
    };
    let own: Vec<u32> = (0..eye.len() as u32)
        .filter(|&i| !eye.primary[i as usize])
        .collect();
    if !own.is_empty() {
        let values = evaluate(&own);
        cache.own = own.into_iter().zip(values).collect();
    }
    for (pass, &s) in LEVELS.iter().enumerate() {
        let cov = if cache.records.is_empty() {
            vec![0; geo.first.len()]
        } else {
            pixel_coverage(&cache.records, eye, geo)
        };
        let mut new_samples = Vec::new();
        for y in (s / 2..geo.height).step_by(s as usize) {
            for x in (s / 2..geo.width).step_by(s as usize) {
                let p = (y * geo.width + x) as usize;
                if geo.first[p] != u32::MAX && cov[p] < params.min_records {
                    new_samples.push(geo.first[p]);
                }
            }
        }
        let values = evaluate(&new_samples);
        for (&i, value) in new_samples.iter().zip(values) {
            cache.records.push(place(i as usize, pass as u8, value));
        }
        cache.per_pass.push(new_samples.len());
    }
    widen_for_coverage(&mut cache, eye, geo, params.min_records);
    // Pixels still short of records (a small surface, few records in reach) become records
    // themselves, one more pass, and the widening runs again.
    let short = short_samples(&cache, eye, geo, params.min_records);
    if !short.is_empty() {
        let values = evaluate(&short);
        for (&i, value) in short.iter().zip(values) {
            cache
                .records
                .push(place(i as usize, LEVELS.len() as u8, value));
        }
        cache.per_pass.push(short.len());
        widen_for_coverage(&mut cache, eye, geo, params.min_records);
    }
    cache
}

/// First primary eye samples of the pixels covered by fewer than `min` compatible records.
fn short_samples(cache: &Cache, eye: &EyeSamples, geo: &PixelGeometry, min: u32) -> Vec<u32> {
    let coverage = pixel_coverage(&cache.records, eye, geo);
    (0..geo.first.len())
        .filter(|&p| geo.first[p] != u32::MAX && coverage[p] < min)
        .map(|p| geo.first[p])
        .collect()
}

/// Give every pixel (its first eye sample) at least `min` compatible records: the nearest
/// compatible records within MAX_RADIUS_PX not yet covering it grow to reach it.
#[allow(clippy::needless_range_loop)] // p addresses the pixel arrays and the image
fn widen_for_coverage(cache: &mut Cache, eye: &EyeSamples, geo: &PixelGeometry, min: u32) {
    let w = geo.width as usize;
    // Records per coarse cell, to search outward from a pixel.
    let cell = 16usize;
    let (cw, ch) = (w.div_ceil(cell), (geo.height as usize).div_ceil(cell));
    let mut grid = vec![Vec::new(); cw * ch];
    for (k, r) in cache.records.iter().enumerate() {
        grid[(r.pixel.1 as usize / cell) * cw + r.pixel.0 as usize / cell].push(k as u32);
    }
    let coverage = pixel_coverage(&cache.records, eye, geo);
    let mut rows = rows_of(&cache.records, geo.height);
    for p in 0..geo.first.len() {
        if geo.first[p] == u32::MAX || coverage[p] >= min {
            continue;
        }
        let i = geo.first[p] as usize;
        let (x, y) = ((p % w) as u32, (p / w) as u32);
        let (ps, ns, ms) = (eye.position[i], eye.normal[i], eye.material[i]);
        // Records grown for earlier pixels may cover this one now.
        let covering = rows[y as usize]
            .iter()
            .filter(|&&k| {
                let r = &cache.records[k as usize];
                tent(r, x, y) > 0.0 && compatible(r, ps, ns, ms)
            })
            .count() as u32;
        if covering >= min {
            continue;
        }
        let mut need = min - covering;
        let (cx, cy) = (x as usize / cell, y as usize / cell);
        let mut found: Vec<(f32, u32)> = Vec::new();
        // Only records within MAX_RADIUS_PX may grow to reach the sample: samples farther
        // from enough compatible records become records themselves (the fix-up pass).
        let max_ring = (MAX_RADIUS_PX as usize).div_ceil(cell) + 1;
        for ring in 0..=max_ring.min(cw.max(ch)) {
            let (x0, x1) = (cx.saturating_sub(ring), (cx + ring).min(cw - 1));
            let (y0, y1) = (cy.saturating_sub(ring), (cy + ring).min(ch - 1));
            for gy in y0..=y1 {
                for gx in x0..=x1 {
                    if gx != x0 && gx != x1 && gy != y0 && gy != y1 {
                        continue; // inner cells were searched in earlier rings
                    }
                    for &k in &grid[gy * cw + gx] {
                        let r = &cache.records[k as usize];
                        if tent(r, x, y) <= 0.0 && compatible(r, ps, ns, ms) {
                            let dx = x as f32 - r.pixel.0 as f32;
                            let dy = y as f32 - r.pixel.1 as f32;
                            let d = (dx * dx + dy * dy).sqrt();
                            if d < MAX_RADIUS_PX {
                                found.push((d, k));
                            }
                        }
                    }
                }
            }
            // Enough candidates, and one more ring searched for nearer ones.
            if found.len() >= need as usize && ring >= 1 {
                break;
            }
        }
        found.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (d, k) in found {
            if need == 0 {
                break;
            }
            let r = &mut cache.records[k as usize];
            let grown = r.radius_px.max(d + 1.0);
            // Keep the row index in step with the grown disc.
            let (y_old0, y_old1) = (
                (r.pixel.1 as f32 - r.radius_px - 1.0).max(0.0) as usize,
                ((r.pixel.1 as f32 + r.radius_px + 1.0) as usize).min(geo.height as usize - 1),
            );
            r.radius_px = grown;
            let y_new0 = (r.pixel.1 as f32 - r.radius_px - 1.0).max(0.0) as usize;
            let y_new1 =
                ((r.pixel.1 as f32 + r.radius_px + 1.0) as usize).min(geo.height as usize - 1);
            for (yy, row) in rows.iter_mut().enumerate().take(y_new1 + 1).skip(y_new0) {
                if yy < y_old0 || yy > y_old1 {
                    row.push(k);
                }
            }
            need -= 1;
        }
    }
}

/// Splat the records in image space: per eye sample, the tent- and compatibility-weighted mean
/// of the covering records' irradiance (and directional floats).
#[allow(clippy::needless_range_loop)] // indices address several per-sample arrays
pub fn interpolate(
    cache: &Cache,
    eye: &EyeSamples,
    geo: &PixelGeometry,
    mode: DirectionalMode,
) -> Interpolated {
    let floats = mode.record_floats();
    let rows = rows_of(&cache.records, geo.height);
    let w = geo.width as usize;
    // Eye samples are in pixel order: row y's samples are one contiguous range.
    let row_start: Vec<usize> = (0..=geo.height as usize)
        .map(|y| eye.pixel.partition_point(|&p| (p as usize) < y * w))
        .collect();
    let mut out = Interpolated::zeroed(eye, floats);
    // Each row's samples, and their glossy ones, are contiguous ranges: split the outputs
    // into per-row slices and fill them in parallel.
    let glossy_before: Vec<usize> = {
        let mut v = Vec::with_capacity(eye.len() + 1);
        let mut n = 0;
        v.push(0);
        for g in &out.glossy_index {
            n += (*g != u32::MAX) as usize;
            v.push(n);
        }
        v
    };
    let mut jobs = Vec::with_capacity(geo.height as usize);
    {
        let (mut e_rest, mut d_rest, mut c_rest) = (
            &mut out.irradiance[..],
            &mut out.directional[..],
            &mut out.coverage[..],
        );
        for y in 0..geo.height as usize {
            let (a, b) = (row_start[y], row_start[y + 1]);
            let (e, et) = e_rest.split_at_mut(b - a);
            let (c, ct) = c_rest.split_at_mut(b - a);
            let nd = (glossy_before[b] - glossy_before[a]) * floats;
            let (d, dt) = d_rest.split_at_mut(nd);
            (e_rest, c_rest, d_rest) = (et, ct, dt);
            jobs.push((y, a, e, d, c));
        }
    }
    let glossy_index = &out.glossy_index;
    jobs.into_par_iter().for_each(|(y, a, e, d, cov)| {
        let g0 = glossy_before[a];
        let mut wsum = vec![0.0f32; e.len()];
        for &k in &rows[y] {
            let r = &cache.records[k as usize];
            let x0 = (r.pixel.0 as f32 - r.radius_px - 1.0).max(0.0) as usize;
            let x1 = ((r.pixel.0 as f32 + r.radius_px + 1.0) as usize).min(w - 1);
            let (s0, s1) = (
                geo.start[y * w + x0] as usize,
                geo.start[y * w + x1 + 1] as usize,
            );
            for i in s0..s1 {
                let x = eye.pixel[i] as usize - y * w;
                let t = tent(r, x as u32, y as u32);
                if t <= 0.0
                    || !eye.primary[i]
                    || !compatible(r, eye.position[i], eye.normal[i], eye.material[i])
                {
                    continue;
                }
                let j = i - a;
                e[j] += t * r.value.irradiance;
                wsum[j] += t;
                cov[j] += 1;
                let g = glossy_index[i];
                if g != u32::MAX && r.value.directional.len() == floats {
                    let at = (g as usize - g0) * floats;
                    for (o, v) in d[at..at + floats].iter_mut().zip(&r.value.directional) {
                        *o += t * v;
                    }
                }
            }
        }
        for j in 0..e.len() {
            if wsum[j] > 0.0 {
                e[j] /= wsum[j];
                let g = glossy_index[a + j];
                if g != u32::MAX {
                    let at = (g as usize - g0) * floats;
                    for v in &mut d[at..at + floats] {
                        *v /= wsum[j];
                    }
                }
            }
        }
    });
    for (i, v) in &cache.own {
        let i = *i as usize;
        out.irradiance[i] = v.irradiance;
        if let Some(d) = out.dir_mut(i)
            && v.directional.len() == d.len()
        {
            d.copy_from_slice(&v.directional);
        }
    }
    out
}

/// Batch-averaged irradiance and directional floats of every eye sample's splat target, in the
/// shape the cache's interpolation gives (for filtering without a cache).
pub fn sample_values(
    eye: &EyeSamples,
    target_slot: &[u32],
    acc: &Accumulators,
    batches: u32,
) -> Interpolated {
    let floats = acc.mode.record_floats();
    let inv_b = 1.0 / batches.max(1) as f32;
    let mut out = Interpolated::zeroed(eye, floats);
    for i in 0..eye.len() {
        let slot = target_slot[eye.target[i] as usize] as usize;
        out.irradiance[i] = Vec3::new(
            acc.get(Channel::R, slot),
            acc.get(Channel::G, slot),
            acc.get(Channel::B, slot),
        ) * inv_b;
        if let (Some(r), Some(dst)) = (acc.record(slot), out.dir_mut(i)) {
            for (o, v) in dst.iter_mut().zip(r) {
                *o = v * inv_b;
            }
        }
    }
    out
}

/// A cache record's value from the sums at `slot` (§8.3): batch-averaged irradiance, the
/// harmonic mean distance (SplatInfo) and the directional record.
pub fn record_value(acc: &Accumulators, slot: usize, inv_b: f32) -> RecordValue {
    let wsum = acc.get(Channel::Weight, slot);
    let inv_d = acc.get(Channel::WeightedInvDist, slot);
    RecordValue {
        irradiance: Vec3::new(
            acc.get(Channel::R, slot),
            acc.get(Channel::G, slot),
            acc.get(Channel::B, slot),
        ) * inv_b,
        // Where no photon ray reached the record, its radius falls back to the clamp.
        harmonic_distance: if inv_d > 0.0 { wsum / inv_d } else { 0.0 },
        directional: acc
            .record(slot)
            .map(|r| r.iter().map(|v| v * inv_b).collect())
            .unwrap_or_default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::eye::EyeSample;

    /// A 64×48 image of one plane facing the camera: one sample per pixel.
    fn plane_samples(w: u32, h: u32) -> (EyeSamples, Camera) {
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
                let s = EyeSample {
                    position: camera.position + d * t,
                    normal: Vec3::Z,
                    geo_normal: Vec3::Z,
                    offset: 0.0,
                    wo: -d,
                    material: 0,
                    pixel: y * w + x,
                    weight: Vec3::ONE,
                    albedo: Vec3::splat(0.5),
                    specular: Vec3::ZERO,
                    primary: true,
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

    #[test]
    fn every_pixel_is_covered_and_constant_light_interpolates_exactly() {
        let (eye, camera) = plane_samples(64, 48);
        let geo = PixelGeometry::new(&eye, 64, 48);
        for min in [4, 7] {
            let params = CacheParams {
                error: 0.5,
                min_records: min,
            };
            let cache = build(&eye, &geo, &camera, &params, constant(0.5));
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
            let n = build(&eye, &geo, &camera, &params, constant(1.0))
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
}
