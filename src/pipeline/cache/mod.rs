//! Radiance caching in image space (§8.3, after Gautron et al.'s radiance cache splatting
//! \[GKBP05\]): records at sparse eye samples, chosen in several passes over ever finer pixel
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
//!
//! Record placement is in `build`, the image-space interpolation and the record values from
//! the accumulators in `interpolate`; both are re-exported here.

mod build;
mod interpolate;

pub use build::build;
pub use interpolate::{interpolate, record_value, sample_values};

use crate::pipeline::eye::EyeSamples;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Cache parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CacheParams {
    /// ε: a record is valid up to ε × its harmonic mean distance (world space).
    pub error: f32,
    /// Every pixel is covered by at least this many compatible records (4–7 in \[GKBP05\]).
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
    /// The pixel (x, y) of that eye sample: the centre of the record's image-space disc.
    pub pixel: (u32, u32),
    /// World-space position of the eye sample.
    pub position: Vec3,
    /// Shading normal at the eye sample.
    pub normal: Vec3,
    /// Material index; records serve eye samples of the same material only.
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
    /// The incident light at the record.
    pub value: RecordValue,
}

/// The per-pixel geometry the cache works with: each pixel's first primary eye sample.
pub struct PixelGeometry {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// First eye sample of each pixel seen directly from the camera, or u32::MAX where the
    /// pixel has none (only specular chains, or nothing).
    pub first: Vec<u32>,
    /// The eye samples of pixel p are `start[p]..start[p + 1]` (samples are in pixel order).
    pub start: Vec<u32>,
}

impl PixelGeometry {
    /// Index the eye samples (in pixel order) of a `width` × `height` image by pixel.
    pub fn new(eye: &EyeSamples, width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        let mut first = vec![u32::MAX; n];
        let mut start = vec![0u32; n + 1];
        for i in (0..eye.len()).rev() {
            if eye.primary(i) {
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
    /// Records in creation order (pass by pass).
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
                if compatible(r, eye.position[s], eye.normal[s].get(), eye.material[s]) {
                    *c += 1;
                }
            }
        }
    });
    cov
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::directional::DirectionalMode;
    use crate::pipeline::eye::EyeSample;
    use crate::scene::Camera;

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
