//! Reading the cache (§8.3): records splatted in image space, and record values from the splat
//! accumulators.

use super::{Cache, Compatibility, PixelGeometry, RecordValue, rows_of, span, tent_at};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::radiance_map::{Accumulators, Channel, Interpolated};
use glam::Vec3;
use rayon::prelude::*;

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
    let rows = rows_of(&cache.records, geo.height, None);
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
            let Some((x0, x1)) = span(r, y as u32, w) else {
                continue;
            };
            let (s0, s1) = (
                geo.start[y * w + x0] as usize,
                geo.start[y * w + x1 + 1] as usize,
            );
            // The record's fields in locals: the loop below writes only the row's sums.
            let test = Compatibility::of(r);
            let (cx, reach) = (r.pixel.0 as f32, r.radius_px + 0.5);
            let dy = y as f32 - r.pixel.1 as f32;
            let dy2 = dy * dy;
            let irradiance = r.value.irradiance;
            let directional = (r.value.directional.len() == floats).then_some(&r.value.directional);
            for i in s0..s1 {
                if !test.accepts(eye, i) {
                    continue;
                }
                let dx = (eye.pixel[i] as usize - y * w) as f32 - cx;
                let t = tent_at(dx, dy2, reach);
                if t <= 0.0 {
                    continue;
                }
                let j = i - a;
                e[j] += t * irradiance;
                wsum[j] += t;
                cov[j] += 1;
                if let Some(dir) = directional {
                    let g = glossy_index[i];
                    if g != u32::MAX {
                        let at = (g as usize - g0) * floats;
                        for (o, v) in d[at..at + floats].iter_mut().zip(dir) {
                            *o += t * v;
                        }
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
    for (i, v) in cache.own.iter().chain(&cache.from_world) {
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
