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
//! the accumulators in `interpolate`; both are re-exported here. Unit tests are in `tests`.

mod build;
mod interpolate;
#[cfg(test)]
mod tests;

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
/// A chained record's world reach over the world size of its image disc: room for grazing
/// views and mild minification (a plane mirror's image needs 1).
const CHAIN_REACH: f32 = 4.0;

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
    /// Stands at a primary eye sample (seen directly); records serve samples of their own
    /// kind only, those seen directly or those reached through specular chains and traced
    /// lobes.
    pub primary: bool,
    /// Distance from the camera.
    pub depth: f32,
    /// World size of one pixel at that distance (m): with the image radius, a chained
    /// record's reach in world space ([`Record::reach`]).
    pub pixel_size: f32,
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

/// The per-pixel geometry the cache works with: each pixel's first eye sample of each kind
/// (seen directly, reached through a specular chain or a traced lobe).
pub struct PixelGeometry {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// First eye sample of each pixel seen directly from the camera, or u32::MAX where the
    /// pixel has none (only specular chains, or nothing).
    pub first: Vec<u32>,
    /// First eye sample of each pixel reached through a specular chain or a traced lobe, or
    /// u32::MAX.
    pub first_chained: Vec<u32>,
    /// The eye samples of pixel p are `start[p]..start[p + 1]` (samples are in pixel order).
    pub start: Vec<u32>,
}

impl PixelGeometry {
    /// Index the eye samples (in pixel order) of a `width` × `height` image by pixel.
    pub fn new(eye: &EyeSamples, width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        let mut first = vec![u32::MAX; n];
        let mut first_chained = vec![u32::MAX; n];
        let mut start = vec![0u32; n + 1];
        for i in (0..eye.len()).rev() {
            if eye.primary(i) {
                first[eye.pixel[i] as usize] = i as u32;
            } else {
                first_chained[eye.pixel[i] as usize] = i as u32;
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
            first_chained,
            start,
        }
    }

    /// Each pixel's first eye sample of one kind: seen directly (`primary`) or not;
    /// u32::MAX where it has none.
    pub fn first_of(&self, primary: bool) -> &[u32] {
        if primary {
            &self.first
        } else {
            &self.first_chained
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
    /// Eye samples that no record covers in image space and none holds in world space
    /// (`from_world`): each is valued on its own (full splat accuracy), not interpolated.
    /// Leads first, in sample order, then their followers (`interpolate::lead_of`), which
    /// take their lead's value.
    pub own: Vec<(u32, RecordValue)>,
    /// Eye samples no image-space record covers (their lead's tests found none), valued from
    /// the records around them in world space (within ε·R, Ward's test) instead; ordered as
    /// `own`.
    pub from_world: Vec<(u32, RecordValue)>,
}

impl Cache {
    /// Values nothing: no records, and no sample valued otherwise.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty() && self.own.is_empty() && self.from_world.is_empty()
    }
}

impl Record {
    /// The world distance within which the record serves points, for an image radius of
    /// `radius_px`. Unbounded for a record seen directly: on a surface seen directly, image
    /// distance bounds world distance. A record seen through a specular chain serves points
    /// within CHAIN_REACH times the world size of its image disc at its depth: through a
    /// curved mirror or a glass sphere neighbouring pixels can see points far apart on one
    /// plane (the image is minified), which the plane and normal tests would let through.
    #[inline]
    fn reach(&self, radius_px: f32) -> f32 {
        if self.primary {
            f32::INFINITY
        } else {
            CHAIN_REACH * (radius_px + 0.5) * self.pixel_size
        }
    }
}

/// A record's validity tests, its fields in locals for loops over many samples: same
/// material, plane distance within COMPAT_PLANE of its depth, normals within Ward's angle for
/// ε (`cos_min`), and, for eye samples, the same kind within its reach ([`Record::reach`]).
#[derive(Clone, Copy)]
struct Compatibility {
    primary: bool,
    material: u32,
    position: Vec3,
    normal: Vec3,
    plane: f32,
    reach2: f32,
    cos_min: f32,
}

impl Compatibility {
    #[inline]
    fn of(r: &Record) -> Self {
        let reach = r.reach(r.radius_px);
        Self {
            primary: r.primary,
            material: r.material,
            position: r.position,
            normal: r.normal,
            plane: COMPAT_PLANE * r.depth,
            reach2: reach * reach,
            cos_min: r.cos_min,
        }
    }

    /// Eye sample `i` is of the record's kind, within its reach and valid.
    #[inline]
    fn accepts(&self, eye: &EyeSamples, i: usize) -> bool {
        self.primary == eye.primary(i)
            && self.test(eye.material[i], eye.position[i], self.reach2, || {
                eye.normal[i].get()
            })
    }

    /// [`Compatibility::accepts`] for a point already read from the eye samples.
    #[inline]
    fn accepts_point(&self, primary: bool, material: u32, p: Vec3, n: Vec3) -> bool {
        self.primary == primary && self.test(material, p, self.reach2, || n)
    }

    /// A point at (p, n, material) is valid, whatever its kind and distance.
    #[inline]
    fn on_surface(&self, p: Vec3, n: Vec3, material: u32) -> bool {
        self.test(material, p, f32::INFINITY, || n)
    }

    /// The tests cheapest first: the normal (octahedral in the eye samples) comes last.
    #[inline]
    fn test(&self, material: u32, p: Vec3, reach2: f32, normal: impl FnOnce() -> Vec3) -> bool {
        if material != self.material {
            return false;
        }
        let d = p - self.position;
        d.dot(self.normal).abs() <= self.plane
            && d.length_squared() <= reach2
            && normal().dot(self.normal) >= self.cos_min
    }
}

/// Image-space tent weight of record `r` at pixel (x, y); 0 outside its radius.
#[inline]
fn tent(r: &Record, x: u32, y: u32) -> f32 {
    let dy = y as f32 - r.pixel.1 as f32;
    tent_at(x as f32 - r.pixel.0 as f32, dy * dy, r.radius_px + 0.5).max(0.0)
}

/// The tent at offset (dx, dy) from a record's pixel, `reach` its radius + ½, before the clamp
/// at 0: positive inside the disc. The one formula of the interpolation, the coverage counts
/// and the spans, which must agree to the last bit.
#[inline]
fn tent_at(dx: f32, dy2: f32, reach: f32) -> f32 {
    1.0 - (dx * dx + dy2).sqrt() / reach
}

/// The pixels x of row `y` (inclusive range, within an image `w` wide) where `r`'s tent is
/// positive; None where its disc misses the row.
#[inline]
fn span(r: &Record, y: u32, w: usize) -> Option<(usize, usize)> {
    let reach = r.radius_px + 0.5;
    let dy = y as f32 - r.pixel.1 as f32;
    let h2 = reach * reach - dy * dy;
    if h2 <= 0.0 {
        return None;
    }
    let h = h2.sqrt();
    let cx = r.pixel.0 as f32;
    // One pixel more on each side, then the ends by the tent itself: rounding neither lets
    // in a pixel it weighs 0 nor leaves out one it weighs more.
    let mut x0 = (cx - h - 1.0).ceil().max(0.0) as usize;
    let mut x1 = ((cx + h + 1.0).floor().max(0.0) as usize).min(w - 1);
    while x0 <= x1 && tent(r, x0 as u32, y) <= 0.0 {
        x0 += 1;
    }
    while x1 >= x0 && tent(r, x1 as u32, y) <= 0.0 {
        if x1 == 0 {
            return None;
        }
        x1 -= 1;
    }
    (x0 <= x1).then_some((x0, x1))
}

/// Records bucketed by image row for row-parallel splatting: for each row, the records whose
/// disc reaches it (of one kind only with `Some(primary)`).
fn rows_of(records: &[Record], height: u32, kind: Option<bool>) -> Vec<Vec<u32>> {
    let mut rows = vec![Vec::new(); height as usize];
    for (k, r) in records.iter().enumerate() {
        if kind.is_some_and(|primary| r.primary != primary) {
            continue;
        }
        let y0 = (r.pixel.1 as f32 - r.radius_px - 1.0).max(0.0) as u32;
        let y1 = ((r.pixel.1 as f32 + r.radius_px + 1.0) as u32).min(height - 1);
        for row in &mut rows[y0 as usize..=y1 as usize] {
            row.push(k as u32);
        }
    }
    rows
}

/// A pixel's first eye sample of one kind, decoded once for the coverage counts: material,
/// position and normal; None where the pixel has none.
type FirstPoint = Option<(u32, Vec3, Vec3)>;

/// The [`FirstPoint`] of every pixel for one kind.
fn first_points(eye: &EyeSamples, geo: &PixelGeometry, primary: bool) -> Vec<FirstPoint> {
    geo.first_of(primary)
        .par_iter()
        .map(|&s| {
            let i = s as usize;
            (s != u32::MAX).then(|| (eye.material[i], eye.position[i], eye.normal[i].get()))
        })
        .collect()
}

/// Add to `cov` the count of compatible `records` covering every pixel's first eye sample of
/// one kind (`points`, [`first_points`]); records of the other kind are skipped without a
/// look at their discs.
fn add_coverage(
    records: &[Record],
    points: &[FirstPoint],
    geo: &PixelGeometry,
    primary: bool,
    cov: &mut [u32],
) {
    if records.is_empty() {
        return;
    }
    let rows = rows_of(records, geo.height, Some(primary));
    let w = geo.width as usize;
    cov.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        for &k in &rows[y] {
            let r = &records[k as usize];
            let Some((x0, x1)) = span(r, y as u32, w) else {
                continue;
            };
            let row = &points[y * w..(y + 1) * w];
            let test = Compatibility::of(r);
            for (c, point) in out[x0..=x1].iter_mut().zip(&row[x0..=x1]) {
                if let Some((m, p, n)) = *point
                    && test.accepts_point(primary, m, p, n)
                {
                    *c += 1;
                }
            }
        }
    });
}
