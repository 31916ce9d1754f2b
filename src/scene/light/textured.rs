//! Emissive textures as lights (glTF §3.9.3: emission = emissiveFactor × emissiveTexture).
//!
//! An emitting triangle whose material has an emissive texture is cut into n² congruent
//! sub-triangles (n from its size in texels, about one texel across each), and a point on
//! it is drawn by first choosing a sub-triangle in proportion to a bound on its emitted
//! luminance — the brightest texel any bilinear lookup inside it can read — then uniformly
//! inside it. The bound is never zero where the texture emits, so every emitting point can be
//! drawn (the estimate stays unbiased), and it is zero where every texel it can read is black,
//! so dark texels get no photons and no light samples. The area density of a point is
//! `relative_density / area`: the chosen sub-triangle's probability × n².

use super::Surfaces;
use crate::sampling::{cdf_pmf, cdf_sample_continuous, luminance, uniform_triangle};
use crate::scene::{NO_EXTRA, Texture, TextureRef};
use glam::{Vec2, Vec3, Vec4Swizzles};

/// Texels across a sub-triangle's longest edge that the subdivision aims for: one, so
/// that a sharp edge between dark and bright texels leaves few cells straddling it.
const TEXELS_PER_CELL: f32 = 1.0;
/// Most sub-triangles along an edge (n ≤ 64: 4,096 per triangle).
const MAX_SPLITS: u32 = 64;
/// Most sub-triangles in a scene: the subdivisions shrink together beyond it (16 MB of CDF).
const MAX_CELLS: u64 = 1 << 22;
/// A sub-triangle whose texture box covers more texels than this is bounded by the
/// texture's brightest texel instead.
const MAX_BOX_TEXELS: u64 = 4096;

/// One emitting triangle's texture: its texture coordinates (transformed), the factor, and
/// the distribution over its sub-triangles.
#[derive(Clone, Debug)]
pub(crate) struct Emitter {
    /// The scene triangle.
    pub(crate) triangle: u32,
    /// Its mean radiance (what its power and the statistics read).
    pub(crate) mean_radiance: Vec3,
    /// The mean of its sub-triangles' luminance bounds (its selection weight per area).
    pub(crate) mean_bound: f32,
    tex: TextureRef,
    uv: [Vec2; 3],
    factor: Vec3,
    n: u32,
    /// Offset of its CDF in [`TexturedEmitters::cdf`] (n² entries, the last 1).
    start: u32,
}

/// The scene's emissive-textured triangles that emit somewhere, in triangle order (their
/// textures are the scene's, which the lights hold). Built once per scene (in parallel) and shared by every rebuild of its
/// lights.
#[derive(Clone, Debug, Default)]
pub(crate) struct TexturedEmitters {
    pub(crate) emitters: Vec<Emitter>,
    cdf: Vec<f32>,
}

/// Index of sub-triangle (i, j, upper) in an n-split triangle: rows i of 2(n − i) − 1 cells,
/// lower cells first.
#[inline]
fn cell_index(n: u32, i: u32, j: u32, upper: bool) -> usize {
    let row = i * (2 * n - i);
    (row + if upper { (n - i) + j } else { j }) as usize
}

/// The three corners of sub-triangle `k` in grid units (b1·n, b2·n).
fn cell_corners(n: u32, k: u32) -> [Vec2; 3] {
    // Find the row: offsets i(2n − i) increase with i.
    let mut i = 0;
    while i + 1 < n && (i + 1) * (2 * n - i - 1) <= k {
        i += 1;
    }
    let r = k - i * (2 * n - i);
    let (fi, lower_count) = (i as f32, n - i);
    if r < lower_count {
        let j = r as f32;
        [
            Vec2::new(fi, j),
            Vec2::new(fi + 1.0, j),
            Vec2::new(fi, j + 1.0),
        ]
    } else {
        let j = (r - lower_count) as f32;
        [
            Vec2::new(fi + 1.0, j + 1.0),
            Vec2::new(fi, j + 1.0),
            Vec2::new(fi + 1.0, j),
        ]
    }
}

/// The sub-triangle holding barycentrics (b1, b2).
#[inline]
fn cell_of(n: u32, b1: f32, b2: f32) -> usize {
    let (u, v) = (b1.clamp(0.0, 1.0) * n as f32, b2.clamp(0.0, 1.0) * n as f32);
    let i = (u.floor() as u32).min(n - 1);
    let j = (v.floor() as u32).min(n - 1 - i);
    let upper = u - i as f32 + v - j as f32 > 1.0 && i + j + 2 <= n;
    cell_index(n, i, j, upper)
}

/// An emitting triangle before its subdivision is fixed.
struct Plan {
    triangle: u32,
    tex: TextureRef,
    uv: [Vec2; 3],
    factor: Vec3,
    n: u32,
}

/// The bounding box of texture coordinates.
fn uv_box(uv: &[Vec2; 3]) -> (Vec2, Vec2) {
    (uv[0].min(uv[1]).min(uv[2]), uv[0].max(uv[1]).max(uv[2]))
}

impl TexturedEmitters {
    /// The emitters of `surfaces`: every triangle whose material has an emissive texture and
    /// a positive factor, unless the texture is black wherever the triangle reads it.
    pub(crate) fn build(surfaces: &Surfaces) -> Self {
        use rayon::prelude::*;
        let textures = surfaces.textures;
        let plans: Vec<Plan> = (0..surfaces.triangles.len())
            .into_par_iter()
            .filter_map(|ti| {
                let sh = &surfaces.shading[ti];
                let m = &surfaces.materials[sh.material as usize];
                let tex = m.emissive_texture.as_ref().filter(|_| m.emits())?;
                let uv = match (tex.set, sh.extra) {
                    (0, _) => sh.uvs,
                    (_, NO_EXTRA) => [Vec2::ZERO; 3],
                    (_, e) => surfaces.extras[e as usize].uv1,
                };
                let t = &textures[tex.image];
                let uv = uv.map(|p| tex.transform.transform_point2(p));
                // Most triangles of a mostly dark emissive texture read only black: skip
                // them before cutting them up.
                let (lo, hi) = uv_box(&uv);
                if t.max_luminance_in(lo, hi, tex, m.emission, MAX_BOX_TEXELS) == Some(0.0) {
                    return None;
                }
                let size = Vec2::new(t.width as f32, t.height as f32);
                let edge = |a: Vec2, b: Vec2| ((b - a) * size).length();
                let longest = edge(uv[0], uv[1])
                    .max(edge(uv[1], uv[2]))
                    .max(edge(uv[2], uv[0]));
                let n = if longest.is_finite() {
                    ((longest / TEXELS_PER_CELL).ceil() as u32).clamp(1, MAX_SPLITS)
                } else {
                    1
                };
                Some(Plan {
                    triangle: ti as u32,
                    tex: tex.clone(),
                    uv,
                    factor: m.emission,
                    n,
                })
            })
            .collect();
        // The subdivisions shrink together when the scene would have too many cells.
        let cells: u64 = plans.iter().map(|p| (p.n as u64).pow(2)).sum();
        let shrink = if cells <= MAX_CELLS {
            1.0
        } else {
            (MAX_CELLS as f64 / cells as f64).sqrt() as f32
        };
        // The brightest texel of each image an emitter reads (only those: scanning every
        // image of a scene without emissive textures would be wasted).
        let brightest: Vec<f32> = (0..textures.len())
            .map(|i| {
                if plans.iter().any(|p| p.tex.image == i) {
                    textures[i].max_channel()
                } else {
                    0.0
                }
            })
            .collect();
        let built: Vec<(Emitter, Vec<f32>)> = plans
            .into_par_iter()
            .filter_map(|p| Self::subdivide(p, shrink, textures, &brightest))
            .collect();
        let mut out = Self {
            emitters: Vec::with_capacity(built.len()),
            cdf: Vec::with_capacity(built.iter().map(|b| b.1.len()).sum()),
        };
        for (mut e, cdf) in built {
            e.start = out.cdf.len() as u32;
            out.cdf.extend_from_slice(&cdf);
            out.emitters.push(e);
        }
        out
    }

    /// Cut a planned emitter into (n·`shrink`)² cells and tabulate their bounds; `None` when
    /// its texture is black wherever the triangle reads it.
    fn subdivide(
        p: Plan,
        shrink: f32,
        textures: &[Texture],
        brightest: &[f32],
    ) -> Option<(Emitter, Vec<f32>)> {
        let n = ((p.n as f32 * shrink).floor() as u32).max(1);
        let t = &textures[p.tex.image];
        let global = brightest[p.tex.image] * luminance(p.factor);
        let mut cdf = Vec::with_capacity((n * n) as usize);
        let mut sum_bound = 0.0f64;
        let mut sum_mean = Vec3::ZERO;
        let at = |g: Vec2| {
            let (b1, b2) = (g.x / n as f32, g.y / n as f32);
            p.uv[0] * (1.0 - b1 - b2) + p.uv[1] * b1 + p.uv[2] * b2
        };
        for k in 0..n * n {
            let c = cell_corners(n, k);
            let (lo, hi) = uv_box(&c.map(at));
            let bound = t
                .max_luminance_in(lo, hi, &p.tex, p.factor, MAX_BOX_TEXELS)
                .unwrap_or(global);
            // The mean radiance: the texture at the centroid and halfway to each corner.
            let centre = (c[0] + c[1] + c[2]) / 3.0;
            let mean = [
                centre,
                0.5 * (centre + c[0]),
                0.5 * (centre + c[1]),
                0.5 * (centre + c[2]),
            ]
            .iter()
            .map(|&g| t.lookup(at(g), &p.tex, true).xyz())
            .sum::<Vec3>()
                * 0.25;
            sum_mean += mean;
            sum_bound += bound as f64;
            cdf.push(sum_bound as f32);
        }
        if sum_bound <= 0.0 || !sum_bound.is_finite() {
            return None;
        }
        let total = sum_bound as f32;
        for c in cdf.iter_mut() {
            *c /= total;
        }
        *cdf.last_mut().expect("n ≥ 1") = 1.0;
        let cells = (n * n) as f32;
        Some((
            Emitter {
                triangle: p.triangle,
                mean_radiance: p.factor * sum_mean / cells,
                mean_bound: total / cells,
                tex: TextureRef {
                    transform: glam::Affine2::IDENTITY,
                    ..p.tex
                },
                uv: p.uv,
                factor: p.factor,
                n,
                start: 0,
            },
            cdf,
        ))
    }

    /// Emitter `e`'s CDF over its cells.
    #[inline]
    fn cdf(&self, e: &Emitter) -> &[f32] {
        &self.cdf[e.start as usize..(e.start + e.n * e.n) as usize]
    }

    /// A point on emitter `index` from `u`: barycentrics (b1, b2) and its area density
    /// relative to the uniform one (the area pdf is this over the triangle's area).
    #[inline]
    pub(crate) fn sample(&self, index: u32, u: Vec2) -> (f32, f32, f32) {
        let e = &self.emitters[index as usize];
        let (k, p, ux) = cdf_sample_continuous(self.cdf(e), u.x);
        let [a, b, c] = cell_corners(e.n, k as u32);
        let (s, t) = uniform_triangle(Vec2::new(ux, u.y));
        let g = a + s * (b - a) + t * (c - a);
        let n = e.n as f32;
        (g.x / n, g.y / n, p * n * n)
    }

    /// The relative area density [`TexturedEmitters::sample`] gives the point (b1, b2).
    #[inline]
    pub(crate) fn density(&self, index: u32, b1: f32, b2: f32) -> f32 {
        let e = &self.emitters[index as usize];
        cdf_pmf(self.cdf(e), cell_of(e.n, b1, b2)) * (e.n * e.n) as f32
    }

    /// Emitted radiance at barycentrics (b1, b2) of emitter `index`, whose texture is among
    /// `textures` (the scene's).
    #[inline]
    pub(crate) fn radiance(&self, textures: &[Texture], index: u32, b1: f32, b2: f32) -> Vec3 {
        let e = &self.emitters[index as usize];
        let uv = e.uv[0] * (1.0 - b1 - b2) + e.uv[1] * b1 + e.uv[2] * b2;
        e.factor * textures[e.tex.image].lookup(uv, &e.tex, true).xyz()
    }

    /// Bytes held (the emitters and their CDFs; the textures are the scene's).
    pub(crate) fn bytes(&self) -> usize {
        std::mem::size_of_val(&self.emitters[..]) + std::mem::size_of_val(&self.cdf[..])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_tile_the_triangle_and_are_found_again() {
        for n in [1, 2, 3, 7] {
            let mut area = 0.0;
            for k in 0..n * n {
                let [a, b, c] = cell_corners(n, k);
                area += 0.5 * (b - a).perp_dot(c - a).abs();
                let g = (a + b + c) / 3.0;
                assert_eq!(
                    cell_of(n, g.x / n as f32, g.y / n as f32),
                    k as usize,
                    "n {n} k {k}"
                );
            }
            assert!((area - 0.5 * (n * n) as f32).abs() < 1e-4, "n {n}: {area}");
        }
    }
}
