//! Reading the cache (§8.3): records splatted in image space, and record values from the splat
//! accumulators.

use super::{Cache, Compatibility, PixelGeometry, Record, RecordValue, rows_of, span, tent_at};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::radiance_map::{Accumulators, Channel, Interpolated};
use glam::Vec3;
use rayon::prelude::*;

/// Splat the records in image space: per eye sample, the tent- and compatibility-weighted mean
/// of the covering records' irradiance (and directional floats); then the samples valued in
/// world space or on their own (`Cache::from_world`, `Cache::own`) take those values.
pub fn interpolate(
    cache: &Cache,
    eye: &EyeSamples,
    geo: &PixelGeometry,
    mode: DirectionalMode,
) -> Interpolated {
    let mut out = interpolate_records(&cache.records, eye, geo, mode);
    for (i, v) in cache.own.iter().chain(&cache.from_world) {
        set_value(&mut out, *i as usize, v);
    }
    out
}

/// Eye sample `i` takes value `v` (irradiance, and directional floats where both have them).
pub(super) fn set_value(out: &mut Interpolated, i: usize, v: &RecordValue) {
    out.irradiance[i] = v.irradiance;
    if let Some(d) = out.dir_mut(i)
        && v.directional.len() == d.len()
    {
        d.copy_from_slice(&v.directional);
    }
}

/// What eye samples share to share one interpolation: their splat target (one pixel, one
/// surface: `eye::assign_targets`), their kind (seen directly or through a chain) and whether
/// their lobe goes through the radiance map.
type LeadKey = (u32, bool, bool);

fn lead_key(eye: &EyeSamples, i: usize) -> LeadKey {
    (eye.target[i], eye.primary(i), eye.lobe_in_map(i))
}

/// The lead of eye sample `i`: the first sample of its pixel with its [`LeadKey`] (`i` itself
/// when none comes before it).
pub(super) fn lead_of(eye: &EyeSamples, geo: &PixelGeometry, i: usize) -> usize {
    let first = geo.start[eye.pixel[i] as usize] as usize;
    let key = lead_key(eye, i);
    (first..i).find(|&j| lead_key(eye, j) == key).unwrap_or(i)
}

/// The image-space half of [`interpolate`]: records only. Eye samples merged onto one splat
/// target share one interpolation, as they share one splatted value in rs: the record tests
/// are made at their lead ([`lead_of`]) and the others take its value, coverage included
/// (a quarter of the tests at 4 spp; docs/deviations.md §31 says what it changes).
#[allow(clippy::needless_range_loop)] // indices address several per-sample arrays
pub(super) fn interpolate_records(
    records: &[Record],
    eye: &EyeSamples,
    geo: &PixelGeometry,
    mode: DirectionalMode,
) -> Interpolated {
    let floats = mode.record_floats();
    let rows = rows_of(records, geo.height, None);
    let w = geo.width as usize;
    let mut out = Interpolated::zeroed(eye, floats);
    // Each row's samples, and their glossy ones, are contiguous ranges (samples are in pixel
    // order): split the outputs into per-row slices and fill them in parallel.
    // Glossy samples before each row's first (the rows' counts in parallel).
    let glossy_before: Vec<usize> = {
        let counts: Vec<usize> = (0..geo.height as usize)
            .into_par_iter()
            .map(|y| {
                let (a, b) = (geo.start[y * w] as usize, geo.start[(y + 1) * w] as usize);
                out.glossy_index[a..b]
                    .iter()
                    .filter(|&&g| g != u32::MAX)
                    .count()
            })
            .collect();
        let mut v = Vec::with_capacity(counts.len() + 1);
        v.push(0);
        for c in counts {
            v.push(v[v.len() - 1] + c);
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
            let (a, b) = (geo.start[y * w] as usize, geo.start[(y + 1) * w] as usize);
            let (e, et) = e_rest.split_at_mut(b - a);
            let (c, ct) = c_rest.split_at_mut(b - a);
            let nd = (glossy_before[y + 1] - glossy_before[y]) * floats;
            let (d, dt) = d_rest.split_at_mut(nd);
            (e_rest, c_rest, d_rest) = (et, ct, dt);
            jobs.push((y, a, e, d, c));
        }
    }
    let glossy_index = &out.glossy_index;
    jobs.into_par_iter().for_each(|(y, a, e, d, cov)| {
        let g0 = glossy_before[y];
        let dir_at = |i: usize| {
            let g = glossy_index[i];
            (g != u32::MAX).then(|| (g as usize - g0) * floats)
        };
        // The row's leading samples (row-local), each pixel's from lead_start[x]; every
        // sample's lead, itself where it leads (the first of its pixel with its key).
        let keys: Vec<LeadKey> = (a..a + e.len()).map(|i| lead_key(eye, i)).collect();
        let mut lead_of = vec![0u32; e.len()];
        let mut leads: Vec<u32> = Vec::with_capacity(e.len());
        let mut lead_start: Vec<u32> = Vec::with_capacity(w + 1);
        for x in 0..w {
            lead_start.push(leads.len() as u32);
            let p = y * w + x;
            let (s0, s1) = (geo.start[p] as usize - a, geo.start[p + 1] as usize - a);
            for j in s0..s1 {
                let lead = leads[lead_start[x] as usize..]
                    .iter()
                    .find(|&&l| keys[l as usize] == keys[j]);
                lead_of[j] = match lead {
                    Some(&l) => l,
                    None => {
                        leads.push(j as u32);
                        j as u32
                    }
                };
            }
        }
        lead_start.push(leads.len() as u32);
        // The leads' points, decoded once for all the records over the row.
        let points: Vec<(bool, u32, Vec3, Vec3)> = leads
            .iter()
            .map(|&j| {
                let i = a + j as usize;
                (
                    eye.primary(i),
                    eye.material[i],
                    eye.position[i],
                    eye.normal[i].get(),
                )
            })
            .collect();
        let mut wsum = vec![0.0f32; leads.len()];
        for &k in &rows[y] {
            let r = &records[k as usize];
            let Some((x0, x1)) = span(r, y as u32, w) else {
                continue;
            };
            // The record's fields in locals: the loop below writes only the row's sums.
            let test = Compatibility::of(r);
            let (cx, reach) = (r.pixel.0 as f32, r.radius_px + 0.5);
            let dy = y as f32 - r.pixel.1 as f32;
            let dy2 = dy * dy;
            let irradiance = r.value.irradiance;
            let directional = (r.value.directional.len() == floats).then_some(&r.value.directional);
            for x in x0..=x1 {
                let t = tent_at(x as f32 - cx, dy2, reach);
                if t <= 0.0 {
                    continue;
                }
                for l in lead_start[x] as usize..lead_start[x + 1] as usize {
                    let (primary, material, p, n) = points[l];
                    if !test.accepts_point(primary, material, p, n) {
                        continue;
                    }
                    let j = leads[l] as usize;
                    e[j] += t * irradiance;
                    wsum[l] += t;
                    cov[j] += 1;
                    if let (Some(dir), Some(at)) = (directional, dir_at(a + j)) {
                        for (o, v) in d[at..at + floats].iter_mut().zip(dir) {
                            *o += t * v;
                        }
                    }
                }
            }
        }
        for (l, &j) in leads.iter().enumerate() {
            let j = j as usize;
            if wsum[l] > 0.0 {
                e[j] /= wsum[l];
                if let Some(at) = dir_at(a + j) {
                    for v in &mut d[at..at + floats] {
                        *v /= wsum[l];
                    }
                }
            }
        }
        // The others take their lead's value (a lead and its samples agree on glossiness:
        // it is part of the key).
        for j in 0..e.len() {
            let l = lead_of[j] as usize;
            if l != j {
                e[j] = e[l];
                cov[j] = cov[l];
                if let (Some(from), Some(to)) = (dir_at(a + l), dir_at(a + j)) {
                    d.copy_within(from..from + floats, to);
                }
            }
        }
    });
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
