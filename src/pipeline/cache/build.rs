//! Placing the cache's records (§8.3): coarse-to-fine passes, widening, and the fix-up pass.

use super::interpolate::{interpolate_records, lead_of, set_value};
use super::{
    Cache, CacheParams, Compatibility, FirstPoint, LEVELS, MAX_RADIUS_PX, MIN_RADIUS_PX,
    PixelGeometry, Record, RecordValue, add_coverage, first_points, normal_tolerance, rows_of,
    tent,
};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::radiance_map::Interpolated;
use crate::scene::Camera;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Build the cache for `eye` seen through `camera`: passes over grids of spacing 64 … 1 px; in
/// each, every grid pixel covered by fewer than `min_records` compatible records gets one, and
/// `evaluate` supplies the new records' values (indices are eye samples). Then any pixel still
/// short of records widens its nearest compatible records (within 64 px) until it is covered,
/// and pixels still short after that become records themselves. Two kinds of records are placed
/// in the same passes: at each pixel's first eye sample seen directly, and at its first reached
/// through a specular chain or a traced lobe (a mirror's or a glass's image is as coherent in
/// image space as a wall; a chained record serves only within its world reach), each kind
/// serving its own. Samples no record covers in image space (a pixel's other chains) are
/// interpolated from the records around them in world space (`Cache::from_world`), and only
/// those with none there are valued on their own (`Cache::own`). Returns the cache and every
/// eye sample's value from it (what [`super::interpolate`] gives, made once here).
pub fn build(
    eye: &EyeSamples,
    geo: &PixelGeometry,
    camera: &Camera,
    params: &CacheParams,
    mode: DirectionalMode,
    mut evaluate: impl FnMut(&[u32]) -> Vec<RecordValue>,
) -> (Cache, Interpolated) {
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
            primary: eye.primary(i),
            depth,
            pixel_size: depth * pixel_angle,
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
    // The kinds with samples: each pixel's first sample seen directly, and its first reached
    // through a specular chain. Both kinds' records are placed in the same passes (one
    // evaluation per pass), each kind's coverage counting its own records only.
    let kinds: Vec<bool> = [true, false]
        .into_iter()
        .filter(|&primary| geo.first_of(primary).iter().any(|&s| s != u32::MAX))
        .collect();
    let mut coverage: Vec<Vec<u32>> = kinds.iter().map(|_| vec![0; geo.first.len()]).collect();
    let points: Vec<Vec<FirstPoint>> = kinds
        .iter()
        .map(|&primary| first_points(eye, geo, primary))
        .collect();
    for (pass, &s) in LEVELS.iter().enumerate() {
        let mut new_samples = Vec::new();
        for (&primary, cov) in kinds.iter().zip(&coverage) {
            let first = geo.first_of(primary);
            for y in (s / 2..geo.height).step_by(s as usize) {
                for x in (s / 2..geo.width).step_by(s as usize) {
                    let p = (y * geo.width + x) as usize;
                    if first[p] != u32::MAX && cov[p] < params.min_records {
                        new_samples.push(first[p]);
                    }
                }
            }
        }
        let values = evaluate(&new_samples);
        let from = cache.records.len();
        for (&i, value) in new_samples.iter().zip(values) {
            cache.records.push(place(i as usize, pass as u8, value));
        }
        cache.per_pass.push(new_samples.len());
        // Only the new records' discs are added to the coverage.
        for ((&primary, cov), points) in kinds.iter().zip(&mut coverage).zip(&points) {
            add_coverage(&cache.records[from..], points, geo, primary, cov);
        }
    }
    // The pixels each kind's records leave short grow the nearest records; those still short
    // after that (a small surface, few records in reach) become records themselves, one more
    // pass, and the widening runs again over them.
    let mut short_px: Vec<Vec<usize>> = Vec::with_capacity(kinds.len());
    for (&primary, cov) in kinds.iter().zip(&coverage) {
        let first = geo.first_of(primary);
        let candidates: Vec<usize> = (0..first.len())
            .filter(|&p| first[p] != u32::MAX && cov[p] < params.min_records)
            .collect();
        short_px.push(widen_for_coverage(
            &mut cache,
            eye,
            geo,
            primary,
            params.min_records,
            &candidates,
        ));
    }
    let short: Vec<u32> = kinds
        .iter()
        .zip(&short_px)
        .flat_map(|(&primary, px)| px.iter().map(move |&p| geo.first_of(primary)[p]))
        .collect();
    if !short.is_empty() {
        let values = evaluate(&short);
        for (&i, value) in short.iter().zip(values) {
            cache
                .records
                .push(place(i as usize, LEVELS.len() as u8, value));
        }
        cache.per_pass.push(short.len());
        for (&primary, px) in kinds.iter().zip(&short_px) {
            widen_for_coverage(&mut cache, eye, geo, primary, params.min_records, px);
        }
    }
    // The records interpolated in image space; the eye samples none of them covers (their
    // lead's tests found none: mostly a pixel's other chains behind glass, such as its faint
    // reflection; rarely a sample on another surface than its pixel's first) take the records
    // around them in world space (Ward's test, as a world-space irradiance cache would), and
    // only those with no record there are valued on their own (docs/benchmarks.md, "Radiance
    // caching"). As in image space, a lead's value is its followers'.
    let mut values = interpolate_records(&cache.records, eye, geo, mode);
    // (sample, its lead) of every uncovered sample, leads and followers apart.
    type Pairs = Vec<(u32, u32)>;
    let (leads, followers): (Pairs, Pairs) = (0..eye.len())
        .into_par_iter()
        .filter(|&i| values.coverage[i] == 0)
        .map(|i| (i as u32, lead_of(eye, geo, i) as u32))
        .partition(|&(i, lead)| i == lead);
    let index = WorldIndex::new(&cache.records);
    let looked_up: Vec<(u32, Option<RecordValue>)> = leads
        .par_iter()
        .map(|&(i, _)| (i, index.value_at(&cache.records, eye, i as usize)))
        .collect();
    let mut own = Vec::new();
    for (i, value) in looked_up {
        match value {
            Some(v) => cache.from_world.push((i, v)),
            None => own.push(i),
        }
    }
    if !own.is_empty() {
        let evaluated = evaluate(&own);
        cache.own = own.into_iter().zip(evaluated).collect();
    }
    // Both lists are in sample order, as the leads were: each follower finds its lead's value.
    let of_lead = |list: &[(u32, RecordValue)], followers: &[(u32, u32)]| {
        followers
            .iter()
            .filter_map(|&(i, lead)| {
                let k = list.binary_search_by_key(&lead, |(j, _)| *j).ok()?;
                Some((i, list[k].1.clone()))
            })
            .collect::<Vec<_>>()
    };
    let (world, own) = (
        of_lead(&cache.from_world, &followers),
        of_lead(&cache.own, &followers),
    );
    // A follower is uncovered only with its lead (coverage is shared), so every lead is in
    // one of the lists.
    debug_assert_eq!(world.len() + own.len(), followers.len());
    cache.from_world.extend(world);
    cache.own.extend(own);
    for (i, v) in cache.own.iter().chain(&cache.from_world) {
        set_value(&mut values, *i as usize, v);
    }
    (cache, values)
}

/// Records by world-space cell, for the lookup of samples image space leaves uncovered: cells
/// as wide as the largest validity radius, so that a point's records lie in its cell and the
/// 26 around it.
struct WorldIndex {
    cell: f32,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl WorldIndex {
    fn new(records: &[Record]) -> Self {
        let valid = |r: &Record| r.radius.is_finite() && r.radius > 0.0;
        let cell = records
            .iter()
            .filter(|r| valid(r))
            .map(|r| r.radius)
            .fold(0.0f32, f32::max);
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        if cell > 0.0 {
            for (k, r) in records.iter().enumerate().filter(|(_, r)| valid(r)) {
                cells
                    .entry(key(r.position, cell))
                    .or_default()
                    .push(k as u32);
            }
        }
        Self { cell, cells }
    }

    /// Eye sample `i`'s irradiance (and directional floats) from the compatible records whose
    /// validity sphere (radius ε·R) holds it, weighted 1 − d/(ε·R); None where there are none.
    fn value_at(&self, records: &[Record], eye: &EyeSamples, i: usize) -> Option<RecordValue> {
        if self.cell <= 0.0 {
            return None;
        }
        let (p, n, m) = (eye.position[i], eye.normal[i].get(), eye.material[i]);
        let c = key(p, self.cell);
        let mut out = RecordValue::default();
        let (mut wsum, mut wdir) = (0.0f32, 0.0f32);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(ks) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &k in ks {
                        let r = &records[k as usize];
                        let d = (p - r.position).length();
                        if d >= r.radius || !Compatibility::of(r).on_surface(p, n, m) {
                            continue;
                        }
                        let w = 1.0 - d / r.radius;
                        out.irradiance += w * r.value.irradiance;
                        out.harmonic_distance += w * r.value.harmonic_distance;
                        wsum += w;
                        let dir = &r.value.directional;
                        if !dir.is_empty() {
                            if out.directional.is_empty() {
                                out.directional = vec![0.0; dir.len()];
                            }
                            if out.directional.len() == dir.len() {
                                for (o, v) in out.directional.iter_mut().zip(dir) {
                                    *o += w * v;
                                }
                                wdir += w;
                            }
                        }
                    }
                }
            }
        }
        if wsum <= 0.0 {
            return None;
        }
        out.irradiance /= wsum;
        out.harmonic_distance /= wsum;
        for v in &mut out.directional {
            *v /= wdir;
        }
        Some(out)
    }
}

/// The world-space cell of `p` for cells `cell` wide.
fn key(p: Vec3, cell: f32) -> [i64; 3] {
    let q = (p / cell).floor();
    [q.x as i64, q.y as i64, q.z as i64]
}

/// Give each of the `candidates` (pixels, by their first eye sample of one kind,
/// [`PixelGeometry::first_of`]) at least `min` compatible records: the nearest compatible
/// records within MAX_RADIUS_PX not yet covering it grow to reach it. Returns the candidates
/// still short.
fn widen_for_coverage(
    cache: &mut Cache,
    eye: &EyeSamples,
    geo: &PixelGeometry,
    primary: bool,
    min: u32,
    candidates: &[usize],
) -> Vec<usize> {
    let first = geo.first_of(primary);
    let w = geo.width as usize;
    // Records per coarse cell, to search outward from a pixel.
    let cell = 16usize;
    let (cw, ch) = (w.div_ceil(cell), (geo.height as usize).div_ceil(cell));
    let mut grid = vec![Vec::new(); cw * ch];
    for (k, r) in cache.records.iter().enumerate() {
        if r.primary != primary {
            continue;
        }
        grid[(r.pixel.1 as usize / cell) * cw + r.pixel.0 as usize / cell].push(k as u32);
    }
    let mut rows = rows_of(&cache.records, geo.height, Some(primary));
    // Compatible records covering pixel p's sample.
    let covering = |records: &[Record], rows: &[Vec<u32>], p: usize| {
        let i = first[p] as usize;
        let (x, y) = ((p % w) as u32, (p / w) as u32);
        let test = |r: &Record| tent(r, x, y) > 0.0 && Compatibility::of(r).accepts(eye, i);
        rows[y as usize]
            .iter()
            .filter(|&&k| test(&records[k as usize]))
            .count() as u32
    };
    let mut failed = Vec::new();
    for &p in candidates {
        let i = first[p] as usize;
        let (x, y) = ((p % w) as u32, (p / w) as u32);
        let (ps, ns, ms) = (eye.position[i], eye.normal[i].get(), eye.material[i]);
        let compatible =
            |r: &Record| r.primary == primary && Compatibility::of(r).on_surface(ps, ns, ms);
        // Records grown for earlier pixels may cover this one now.
        let covering = covering(&cache.records, &rows, p);
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
                        if tent(r, x, y) <= 0.0 && compatible(r) {
                            let dx = x as f32 - r.pixel.0 as f32;
                            let dy = y as f32 - r.pixel.1 as f32;
                            let d = (dx * dx + dy * dy).sqrt();
                            // At the image's edge a ring's clamped border repeats cells
                            // of the rings before it: each record counts once.
                            if d < MAX_RADIUS_PX
                                && ps.distance(r.position) <= r.reach(d + 1.0)
                                && !found.iter().any(|f| f.1 == k)
                            {
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
        if need > 0 {
            failed.push(p);
        }
    }
    // Records grown for later pixels may cover an earlier one that fell short.
    failed.retain(|&p| covering(&cache.records, &rows, p) < min);
    failed
}
