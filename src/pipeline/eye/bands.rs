//! The eye pass's rows, made in parallel a band at a time and appended into one set of arrays,
//! and the splat targets of each pixel's samples.

use super::chain::RawSample;
use super::samples::PackedSample;
use super::{EyePass, EyeSamples, SplatTargets};
use crate::pipeline::{Stop, stopped};
use glam::Vec3;
use rayon::prelude::*;

/// Samples of one pixel share a splat target when their normals are this close ...
const MERGE_COS: f32 = 0.966; // cos 15°
/// ... and they lie within this many pixel footprints of each other.
const MERGE_FOOTPRINTS: f32 = 4.0;

/// One row's eye samples (targets row-local), emission per pixel and splat targets.
type Row = (Vec<RawSample>, Vec<Vec3>, SplatTargets);

/// A [`Row`] with its samples packed (and their row-local targets).
type PackedRow = (Vec<(PackedSample, u32)>, Vec<Vec3>, SplatTargets);

/// The rows of an eye pass over `height` rows and `pixels` pixels, made by `row` in parallel
/// a band of rows at a time and appended into the pass's arrays (reserved for `expect`
/// samples; reserved pages that are never written take no memory), each band's rows freed
/// before the next is made. Collecting every row before concatenating them held the whole
/// pass twice: +70 MB at 500×500×4 (docs/benchmarks.md, "Memory"). None when `stop` is
/// raised before a band (the caller no longer wants the pass: [`crate::pipeline::Stop`]).
pub(super) fn collect_bands(
    height: u32,
    pixels: u32,
    expect: usize,
    stop: Stop,
    row: impl Fn(u32) -> Row + Sync + Send,
) -> Option<EyePass> {
    let mut samples = EyeSamples::default();
    samples.position.reserve_exact(expect);
    samples.geo_normal.reserve_exact(expect);
    samples.normal.reserve_exact(expect);
    samples.wo.reserve_exact(expect);
    for v in [
        &mut samples.weight,
        &mut samples.albedo,
        &mut samples.specular,
    ] {
        v.reserve_exact(expect);
    }
    samples.material.reserve_exact(expect);
    samples.alpha.reserve_exact(expect);
    samples.f90.reserve_exact(expect);
    samples.offset.reserve_exact(expect);
    samples.flags.reserve_exact(expect);
    samples.pixel.reserve_exact(expect);
    samples.target.reserve_exact(expect);
    let mut pass = EyePass {
        samples,
        targets: SplatTargets::default(),
        emitted: Vec::with_capacity(pixels as usize),
    };
    // Enough rows per band to keep every thread busy despite rows of unequal cost.
    let band = (8 * rayon::current_num_threads() as u32).max(16);
    let mut y0 = 0;
    while y0 < height {
        if stopped(stop) {
            return None;
        }
        let y1 = (y0 + band).min(height);
        // Rows made and their samples packed in parallel; the append only copies.
        let rows: Vec<PackedRow> = (y0..y1)
            .into_par_iter()
            .map(|y| {
                let (raw, em, targets) = row(y);
                let packed = raw
                    .iter()
                    .map(|r| (PackedSample::new(&r.sample), r.target))
                    .collect();
                (packed, em, targets)
            })
            .collect();
        // Two threads append, each to half of the arrays (the first touch of their reserved
        // pages is most of the append's cost).
        let mut offsets = Vec::with_capacity(rows.len());
        let mut next = pass.targets.len() as u32;
        for r in &rows {
            offsets.push(next);
            next += r.2.len() as u32;
        }
        let EyeSamples {
            position,
            normal,
            geo_normal,
            offset,
            wo,
            material,
            pixel,
            weight,
            albedo,
            specular,
            alpha,
            f90,
            flags,
            target,
        } = &mut pass.samples;
        let (targets, emitted) = (&mut pass.targets, &mut pass.emitted);
        rayon::join(
            || {
                for (r, &first) in rows.iter().zip(&offsets) {
                    for (s, t) in &r.0 {
                        target.push(first + t);
                        position.push(s.position);
                        normal.push(s.normal);
                        geo_normal.push(s.geo_normal);
                        offset.push(s.offset);
                        wo.push(s.wo);
                    }
                    targets.position.extend_from_slice(&r.2.position);
                    targets.normal.extend_from_slice(&r.2.normal);
                }
            },
            || {
                for r in &rows {
                    for (s, _) in &r.0 {
                        material.push(s.material);
                        pixel.push(s.pixel);
                        weight.push(s.weight);
                        albedo.push(s.albedo);
                        specular.push(s.specular);
                        alpha.push(s.alpha);
                        f90.push(s.f90);
                        flags.push(s.flags);
                    }
                    targets.geo_normal.extend_from_slice(&r.2.geo_normal);
                    targets.glossy.extend_from_slice(&r.2.glossy);
                    emitted.extend_from_slice(&r.1);
                }
            },
        );
        y0 = y1;
    }
    Some(pass)
}

/// Give the samples of one pixel their splat targets: a new target per sample, or, when
/// merging, the first earlier target of the pixel on the same material, glossy in the map
/// alike (a target's directional record serves all its samples or none), with a normal within
/// 15° and a position within a few pixel footprints.
pub(super) fn assign_targets(
    px: &mut [RawSample],
    targets: &mut SplatTargets,
    merge: bool,
    pixel_angle: f32,
) {
    let base = targets.len();
    for i in 0..px.len() {
        let reach = MERGE_FOOTPRINTS * pixel_angle * px[i].path_length;
        let s = px[i].sample;
        let glossy = s.is_glossy() && !s.lobe_traced;
        let found = if merge {
            px[..i].iter().find(|o| {
                let t = o.target as usize;
                t >= base
                    && o.sample.material == s.material
                    && targets.glossy[t] == glossy
                    && targets.normal[t].dot(s.normal) >= MERGE_COS
                    && targets.position[t].distance_squared(s.position) <= reach * reach
            })
        } else {
            None
        };
        px[i].target = match found {
            Some(o) => o.target,
            None => {
                targets.position.push(s.position);
                targets.normal.push(s.normal);
                targets.geo_normal.push(s.geo_normal);
                targets.glossy.push(glossy);
                (targets.len() - 1) as u32
            }
        };
    }
}
