//! Image-space filtering of the indirect light (§8.2): the incident-light images (irradiance
//! per colour, and each SH coefficient or stratum of glossy pixels — never the visible image)
//! are box-filtered within geometrically continuous regions, found by segmenting a
//! discontinuity buffer (position/depth, normal, material). Each pixel's box size follows the
//! noise its splats leave: the fewer splats (the kernel-weight statistics of SplatInfo), the
//! wider. Box sums come from summed-area tables, one per region over its bounding box.

use crate::pipeline::cache::PixelGeometry;
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::radiance_map::Interpolated;
use crate::scene::Camera;

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Settings of the image-space filter (§8.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilterParams {
    /// Filter the indirect light at all.
    pub enabled: bool,
    /// Scales every pixel's box radius (1 = as the noise estimate asks).
    pub strength: f32,
}

impl Default for FilterParams {
    fn default() -> Self {
        Self {
            enabled: false,
            strength: 1.0,
        }
    }
}

/// Largest box radius (pixels).
pub const MAX_RADIUS: u32 = 16;
/// Radius where no splat statistics exist (e.g. after radiance caching), times the strength.
pub const DEFAULT_RADIUS: f32 = 3.0;
/// Neighbours are continuous when their normals are within 25°, their plane distance within 1%
/// of the depth, and their materials the same.
const NORMAL_COS: f32 = 0.906;
const PLANE_FRACTION: f32 = 0.01;

/// The discontinuity buffer: one representative surface point per pixel.
#[derive(Clone, Debug)]
pub struct Discontinuity {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// World-space position of each pixel's surface point.
    pub position: Vec<Vec3>,
    /// Shading normal there.
    pub normal: Vec<Vec3>,
    /// Material index there (`u32::MAX` where the pixel holds no surface).
    pub material: Vec<u32>,
    /// Distance from the camera; pixels with depth ≤ 0 or non-finite hold no surface.
    pub depth: Vec<f32>,
}

impl Discontinuity {
    fn valid(&self, p: usize) -> bool {
        self.depth[p] > 0.0 && self.depth[p].is_finite()
    }

    fn continuous(&self, a: usize, b: usize) -> bool {
        self.valid(a)
            && self.valid(b)
            && self.material[a] == self.material[b]
            && self.normal[a].dot(self.normal[b]) >= NORMAL_COS
            && (self.position[b] - self.position[a])
                .dot(self.normal[a])
                .abs()
                <= PLANE_FRACTION * self.depth[a]
    }
}

/// No region (a pixel without a surface).
pub const NO_REGION: u32 = u32::MAX;

/// Label the continuous regions (4-connected) of the discontinuity buffer; labels are
/// 0..regions in order of first pixel.
#[allow(clippy::needless_range_loop)] // p addresses the buffer and the union-find
pub fn segment(d: &Discontinuity) -> (Vec<u32>, u32) {
    let (w, h) = (d.width as usize, d.height as usize);
    let mut parent: Vec<u32> = (0..(w * h) as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            for q in [(x + 1 < w).then(|| p + 1), (y + 1 < h).then(|| p + w)]
                .into_iter()
                .flatten()
            {
                if d.continuous(p, q) && d.continuous(q, p) {
                    let (a, b) = (find(&mut parent, p as u32), find(&mut parent, q as u32));
                    if a != b {
                        parent[a.max(b) as usize] = a.min(b);
                    }
                }
            }
        }
    }
    let mut label = vec![NO_REGION; w * h];
    let mut root_label = vec![NO_REGION; w * h];
    let mut n = 0;
    for p in 0..w * h {
        if !d.valid(p) {
            continue;
        }
        let r = find(&mut parent, p as u32) as usize;
        if root_label[r] == NO_REGION {
            root_label[r] = n;
            n += 1;
        }
        label[p] = root_label[r];
    }
    (label, n)
}

/// A summed-area table over a w × h window (f64 sums: exact enough for 10⁷ pixels).
pub struct Sat {
    w: usize,
    sums: Vec<f64>,
}

impl Sat {
    /// Sums of `value(x, y)` over the window, with a zero row and column in front.
    pub fn new(w: usize, h: usize, value: impl Fn(usize, usize) -> f64) -> Self {
        let mut sums = vec![0.0f64; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = 0.0;
            for x in 0..w {
                row += value(x, y);
                sums[(y + 1) * (w + 1) + x + 1] = sums[y * (w + 1) + x + 1] + row;
            }
        }
        Self { w, sums }
    }

    /// Σ over x0..=x1, y0..=y1 (inclusive, inside the window).
    #[inline]
    pub fn box_sum(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> f64 {
        let s = |x: usize, y: usize| self.sums[y * (self.w + 1) + x];
        s(x1 + 1, y1 + 1) - s(x0, y1 + 1) - s(x1 + 1, y0) + s(x0, y0)
    }
}

/// Per-pixel box radius from the splat statistics: the relative noise of a kernel estimate
/// over n splats is about 1/√n, so r = strength · 40/√n (n: photon-ray splats the pixel's
/// estimate averages, per batch times batches; 40 puts a pixel of 100 splats at a 4-pixel
/// box); clamped to [0, MAX_RADIUS]. Pixels without statistics get DEFAULT_RADIUS.
pub fn radii(splats: &[f32], batches: u32, strength: f32) -> Vec<f32> {
    splats
        .iter()
        .map(|&s| {
            let n = s * batches.max(1) as f32;
            let r = if n > 0.0 {
                40.0 / n.sqrt()
            } else {
                DEFAULT_RADIUS
            };
            (strength.max(0.0) * r).min(MAX_RADIUS as f32)
        })
        .collect()
}

/// Box-filter one channel in place: every pixel becomes the mean of the pixels of its own
/// region within its box of radius `radius[p]`. Pixels of other regions never contribute.
pub fn filter_channel(
    labels: &[u32],
    regions: u32,
    w: usize,
    h: usize,
    radius: &[f32],
    values: &mut [f32],
) {
    // Bounding box of every region.
    let mut bbox = vec![(usize::MAX, usize::MAX, 0usize, 0usize); regions as usize];
    for y in 0..h {
        for x in 0..w {
            let l = labels[y * w + x];
            if l != NO_REGION {
                let b = &mut bbox[l as usize];
                *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
            }
        }
    }
    let src = values.to_vec();
    for (l, &(x0, y0, x1, y1)) in bbox.iter().enumerate() {
        if x0 == usize::MAX {
            continue;
        }
        let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);
        let inside = |x: usize, y: usize| labels[(y0 + y) * w + x0 + x] == l as u32;
        let sum = Sat::new(bw, bh, |x, y| {
            if inside(x, y) {
                src[(y0 + y) * w + x0 + x] as f64
            } else {
                0.0
            }
        });
        let count = Sat::new(bw, bh, |x, y| inside(x, y) as u32 as f64);
        for y in 0..bh {
            for x in 0..bw {
                if !inside(x, y) {
                    continue;
                }
                let p = (y0 + y) * w + x0 + x;
                let r = radius[p].round() as usize;
                if r == 0 {
                    continue;
                }
                let (ax, ay) = (x.saturating_sub(r), y.saturating_sub(r));
                let (bx, by) = ((x + r).min(bw - 1), (y + r).min(bh - 1));
                let c = count.box_sum(ax, ay, bx, by);
                if c > 0.0 {
                    values[p] = (sum.box_sum(ax, ay, bx, by) / c) as f32;
                }
            }
        }
    }
}

/// The image-space filter (§8.2) over per-sample incident light: each pixel's first eye sample
/// stands for the pixel in the discontinuity buffer; every channel (irradiance RGB, then each
/// directional float) is filtered within continuous regions; samples of a pixel that lie on
/// its first sample's surface take the filtered values, others keep theirs.
#[allow(clippy::too_many_arguments)]
pub fn filter_samples(
    eye: &EyeSamples,
    geo: &PixelGeometry,
    camera: &Camera,
    splats: &[f32],
    batches: u32,
    params: FilterParams,
    values: &mut Interpolated,
) {
    let n = geo.first.len();
    let (w, h) = (geo.width as usize, geo.height as usize);
    let rep = |p: usize| (geo.first[p] != u32::MAX).then(|| geo.first[p] as usize);
    let d = Discontinuity {
        width: geo.width,
        height: geo.height,
        position: (0..n)
            .map(|p| rep(p).map_or(Vec3::ZERO, |i| eye.position[i]))
            .collect(),
        normal: (0..n)
            .map(|p| rep(p).map_or(Vec3::ZERO, |i| eye.normal[i].get()))
            .collect(),
        material: (0..n)
            .map(|p| rep(p).map_or(u32::MAX, |i| eye.material[i]))
            .collect(),
        depth: (0..n)
            .map(|p| rep(p).map_or(0.0, |i| (eye.position[i] - camera.position).length()))
            .collect(),
    };
    let (labels, regions) = segment(&d);
    let radius = radii(splats, batches, params.strength);
    let floats = values.floats;
    let mut channel = vec![0.0f32; n];
    // Samples that follow their pixel's filtered value: on its first primary sample's surface
    // (pixels seen only through specular chains have none and are not filtered).
    let follows: Vec<bool> = (0..eye.len())
        .map(|i| {
            let Some(f) = rep(eye.pixel[i] as usize) else {
                return false;
            };
            eye.target[i] == eye.target[f]
                || (eye.primary(i)
                    && eye.material[i] == eye.material[f]
                    && eye.normal[i].get().dot(eye.normal[f].get()) > 0.966)
        })
        .collect();
    for c in 0..3 + floats {
        let get = |i: usize| {
            if c < 3 {
                values.irradiance[i][c]
            } else {
                values.dir(i).map_or(0.0, |d| d[c - 3])
            }
        };
        for (p, v) in channel.iter_mut().enumerate() {
            *v = rep(p).map_or(0.0, get);
        }
        filter_channel(&labels, regions, w, h, &radius, &mut channel);
        for i in 0..eye.len() {
            if !follows[i] {
                continue;
            }
            let v = channel[eye.pixel[i] as usize];
            if c < 3 {
                values.irradiance[i][c] = v;
            } else if let Some(d) = values.dir_mut(i) {
                d[c - 3] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn sat_box_sums_equal_brute_force() {
        let (w, h) = (37, 23);
        let mut rng = Rng::new(5, 5);
        let v: Vec<f64> = (0..w * h)
            .map(|_| rng.next_f32() as f64 * 10.0 - 3.0)
            .collect();
        let sat = Sat::new(w, h, |x, y| v[y * w + x]);
        for _ in 0..500 {
            let (a, b) = ((rng.next_u32() as usize) % w, (rng.next_u32() as usize) % w);
            let (c, d) = ((rng.next_u32() as usize) % h, (rng.next_u32() as usize) % h);
            let (x0, x1, y0, y1) = (a.min(b), a.max(b), c.min(d), c.max(d));
            let mut brute = 0.0;
            for y in y0..=y1 {
                for x in x0..=x1 {
                    brute += v[y * w + x];
                }
            }
            assert!(
                (sat.box_sum(x0, y0, x1, y1) - brute).abs() < 1e-9,
                "{x0},{y0}..{x1},{y1}"
            );
        }
    }

    /// A floor and a box top (same normal and material, 0.3 m higher) meet in a vertical
    /// step, and a wall (other normal) on the right: three regions, and filtering a noisy
    /// image keeps each region's level exactly across the step.
    fn step_scene(w: u32, h: u32) -> (Discontinuity, Vec<f32>) {
        let (mut position, mut normal, mut material, mut depth) = (vec![], vec![], vec![], vec![]);
        let mut truth = vec![];
        for y in 0..h {
            for x in 0..w {
                let (p, n, level) = if x >= 3 * w / 4 {
                    (Vec3::new(1.0, y as f32 * 0.01, 3.0), Vec3::NEG_X, 5.0)
                } else if x < w / 2 {
                    (
                        Vec3::new(x as f32 * 0.01, 0.0, 3.0 + y as f32 * 0.01),
                        Vec3::Y,
                        1.0,
                    )
                } else {
                    (
                        Vec3::new(x as f32 * 0.01, 0.3, 3.0 + y as f32 * 0.01),
                        Vec3::Y,
                        2.0,
                    )
                };
                position.push(p);
                normal.push(n);
                material.push(0);
                depth.push(p.length());
                truth.push(level);
            }
        }
        (
            Discontinuity {
                width: w,
                height: h,
                position,
                normal,
                material,
                depth,
            },
            truth,
        )
    }

    #[test]
    fn the_filter_keeps_a_step_edge() {
        let (w, h) = (64, 40);
        let (d, truth) = step_scene(w, h);
        let (labels, n) = segment(&d);
        assert_eq!(n, 3);
        // Constant levels stay exactly constant, whatever the radius.
        let mut v = truth.clone();
        filter_channel(
            &labels,
            n,
            w as usize,
            h as usize,
            &vec![16.0; (w * h) as usize],
            &mut v,
        );
        for (a, b) in v.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
        // Noise is reduced within regions, and the step stays a step.
        let mut rng = Rng::new(1, 1);
        let mut noisy: Vec<f32> = truth.iter().map(|t| t + (rng.next_f32() - 0.5)).collect();
        let err = |v: &[f32]| {
            v.iter()
                .zip(&truth)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>()
        };
        let before = err(&noisy);
        filter_channel(
            &labels,
            n,
            w as usize,
            h as usize,
            &vec![4.0; (w * h) as usize],
            &mut noisy,
        );
        assert!(err(&noisy) < 0.2 * before);
        let y = (h / 2) as usize;
        let (left, right) = (
            noisy[y * w as usize + (w / 2 - 1) as usize],
            noisy[y * w as usize + (w / 2) as usize],
        );
        assert!(left < 1.2 && right > 1.8, "step blurred: {left} | {right}");
    }

    #[test]
    fn radius_follows_the_splat_count() {
        let r = radii(&[1600.0, 100.0, 25.0, 0.0], 1, 1.0);
        assert!((r[0] - 1.0).abs() < 1e-5, "{r:?}");
        assert!(
            (r[1] - 4.0).abs() < 1e-5 && (r[2] - 8.0).abs() < 1e-5,
            "{r:?}"
        );
        assert_eq!(r[3], DEFAULT_RADIUS);
        assert_eq!(radii(&[1.0], 1, 1.0)[0], MAX_RADIUS as f32);
        // More batches, smaller boxes.
        assert!((radii(&[100.0], 4, 1.0)[0] - 2.0).abs() < 1e-5);
    }
}
