//! Placing the cache's records (§8.3): coarse-to-fine passes, widening, and the fix-up pass.

use super::{
    Cache, CacheParams, LEVELS, MAX_RADIUS_PX, MIN_RADIUS_PX, PixelGeometry, Record, RecordValue,
    compatible, normal_tolerance, pixel_coverage, rows_of, tent,
};
use crate::pipeline::eye::EyeSamples;
use crate::scene::Camera;

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
            normal: eye.normal[i].get(),
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
        .filter(|&i| !eye.primary(i as usize))
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
        let (ps, ns, ms) = (eye.position[i], eye.normal[i].get(), eye.material[i]);
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
