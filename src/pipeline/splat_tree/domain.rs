//! Visible kernel domains (after Perrot et al. 2018, "Photon mapping with visible kernel
//! domains", adapted to ray splatting; docs/deviations.md §40): the part of a splat kernel's
//! footprint that a target can see, and the renormalisation that makes up for the rest.
//!
//! **The footprint's points.** A photon ray splats onto a target x through the point v of the
//! ray that stands for the pair: the foot of x on the ray's line (extended past its end, as
//! the hemisphere of Fig. 4 reaches past the hit) when it lies in front of x's own tangent
//! plane, otherwise the point where the line crosses that plane. On an open plane this is
//! where the ray lands, and every v lies within the splat radius r of x; on a convex surface
//! a ray passing just behind the tangent plane stands for the ray that would have landed on
//! the plane there, so columns and spheres keep their light.
//!
//! **What the target sees.** When the tree is built, each target casts [`PROBES`] rays: 8
//! azimuths in each of two elevation rings above its geometric tangent plane. Each cell of
//! directions (an azimuth sector of 45° in one ring) keeps the free distance its probe met.
//! A pair whose v lies beyond its cell's free distance, or behind the tangent plane with a
//! crossing farther than r, splats nothing: light outside a 10 cm wall stays out.
//!
//! **The renormalisation.** Where a cell's free distance is shorter than r, part of the kernel
//! is cut off (a concave corner: the rays that would pass behind the other wall do not
//! exist). Each kept pair is divided by N(x, r), the share of the kernel's mass whose v is
//! visible, computed for a diffuse field over an open plane ([`planar_share`]) and cut by the
//! same cells; on an open plane N = 1. Where a cell says "hidden" for a point that is in fact
//! visible, the estimate only loses samples, not its mean: the same cell cuts N.

use super::{LANES, PADDING, SplatTree};
use crate::pipeline::{Stop, stopped};
use crate::sampling::onb;
use crate::scene::{Scene, offset_ray_origin, surface_offset};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::OnceLock;

/// Azimuth sectors per ring.
pub const AZIMUTHS: usize = 8;
/// Elevations of the two rings' probes above the tangent plane, degrees. The low ring covers
/// 0–30° (a point on the target's own plane looks along it), the high ring 30–90°.
pub const PROBE_ELEVATIONS_DEG: [f32; 2] = [10.0, 50.0];
/// sin 30°: a direction above this elevation is in the high ring.
const RING_SPLIT: f32 = 0.5;
/// cos 30°: a probe passes over a surface whose normal lies this close to the target's (a
/// facet of its own bumpy floor, the gentle curve of its own surface) and goes on; a wall,
/// a ceiling or the other side of a corner stops it.
const SAME_SURFACE_COS: f32 = 0.866;
/// Surfaces of the target's own kind a probe passes over before it gives up (free).
const PASS_OVER: usize = 4;
/// Cells (and probe rays) per target.
pub const PROBES: usize = AZIMUTHS * PROBE_ELEVATIONS_DEG.len();
/// Steps of the planar shares' table in τ = distance / r.
const SHARE_STEPS: usize = 64;
/// Radii at which each target's N(x, r) is tabulated: r_j = free_min · 2^(j/2).
pub const SHARE_RADII: usize = 12;

/// Steps per octave of the quantised free distances ([`DomainChunk::free`]).
pub const FREE_STEPS_PER_OCTAVE: f32 = 16.0;
/// The quantised free distance that stands for "nothing met" (INFINITY).
pub const FREE_NONE: u8 = u8::MAX;

/// The visible domains of one chunk of [`LANES`] slots. The first two cache lines (normals,
/// smallest free distances) are read for every splatted chunk; the quantised cells and share
/// tables (one line pair each) only for pairs near walls. 384 bytes for 8 targets: the first,
/// f32 layout (1,120 bytes, the tangent frame stored, the cells gathered across 14 lines) made
/// the near-wall test memory-bound (docs/benchmarks.md).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct DomainChunk {
    /// The lanes' geometric normals (x, y, z), facing the viewer (zero for padding); the
    /// cells' frame is [`onb`] of it.
    pub normal: [[f32; LANES]; 3],
    /// The smallest of a lane's free distances: for r at most this, nothing is cut.
    pub free_min: [f32; LANES],
    /// Free distance of each cell, per lane (low ring first, sector k covering azimuths
    /// 45°k–45°(k+1)), as q with free = free_min · 2^(q/16), rounded down ([`FREE_NONE`]:
    /// nothing met); [`free_distance`] decodes it.
    pub free: [[u8; PROBES]; LANES],
    /// N(x, r_j)·255, rounded, at r_j = free_min · 2^(j/2) ([`visible_share`] of the
    /// quantised cells), per lane, so that a pair near a wall reads its renormalisation
    /// instead of summing 16 cells; beyond the last, the last. 4 bytes of padding per lane.
    pub share: [[u8; 16]; LANES],
}

const _: () = assert!(SHARE_RADII <= 16 && std::mem::size_of::<DomainChunk>() == 384);

impl Default for DomainChunk {
    fn default() -> Self {
        Self {
            normal: [[0.0; LANES]; 3],
            free_min: [f32::INFINITY; LANES],
            free: [[FREE_NONE; PROBES]; LANES],
            share: [[255; 16]; LANES],
        }
    }
}

/// 2^(k/16), k = 0..15, as f32: the fractional steps of [`free_distance`].
const FREE_STEPS: [f32; 16] = [
    1.0,
    1.044_273_7,
    1.090_507_7,
    1.138_788_6,
    1.189_207_1,
    1.241_857_8,
    1.296_839_6,
    1.354_255_6,
    std::f32::consts::SQRT_2,
    1.476_826_1,
    1.542_210_8,
    1.610_490_3,
    1.681_792_9,
    1.756_252_2,
    1.834_008_1,
    1.915_206_6,
];

/// The quantised free distance q of a cell ([`DomainChunk::free`]) for a lane whose smallest
/// is `free_min`: rounded down, so that the decoded distance ([`free_distance`]) never lies
/// beyond the surface.
pub fn quantise_free(free: f32, free_min: f32) -> u8 {
    if !free.is_finite() {
        return FREE_NONE;
    }
    let q = (FREE_STEPS_PER_OCTAVE * (free / free_min).log2()).floor();
    // The last code below FREE_NONE stands for anything farther (2^15.9 × free_min).
    let mut q = q.clamp(0.0, (FREE_NONE - 1) as f32) as u8;
    while q > 0 && free_distance(q, free_min) > free {
        q -= 1;
    }
    q
}

/// The distance quantised as q ([`quantise_free`]) for a lane whose smallest is `free_min`:
/// free_min · 2^(q/16) (INFINITY for [`FREE_NONE`]). The power of two is set in the exponent
/// bits and the fraction read from a 16-entry table: integer work that the splat pass's
/// per-lane reads do in a few instructions.
#[inline(always)]
pub fn free_distance(q: u8, free_min: f32) -> f32 {
    let octave = f32::from_bits((127 + (q as u32 >> 4)) << 23);
    let d = free_min * octave * FREE_STEPS[(q & 15) as usize];
    if q == FREE_NONE { f32::INFINITY } else { d }
}

/// The cell of direction `u` (not necessarily unit) in the frame (t, b, n): [`cell_index`].
#[inline(always)]
pub fn cell(u: Vec3, t: Vec3, b: Vec3, n: Vec3) -> usize {
    cell_index(u.dot(t), u.dot(b), u.dot(n)) as usize
}

/// The cell of the direction with frame components (x, y, z), below [`PROBES`]: the ring
/// from its elevation (z > sin 30° · |u|, compared squared), the sector from the signs and
/// sizes of x and y. Branch-free, in u32 (selects only), so that the splat pass's near-wall
/// test vectorises: the lower half-plane is turned by 180° onto the upper one, where sectors
/// 0–3 are counted by x < y, x < 0 and x < −y.
#[inline(always)]
pub fn cell_index(x: f32, y: f32, z: f32) -> u32 {
    let high = (z > 0.0) & (z * z > RING_SPLIT * RING_SPLIT * (x * x + y * y + z * z));
    let lower = y < 0.0;
    let (x, y) = if lower { (-x, -y) } else { (x, y) };
    let sector = 4 * lower as u32 + (x < y) as u32 + (x < 0.0) as u32 + (x < -y) as u32;
    high as u32 * AZIMUTHS as u32 + sector
}

/// Free distances of the [`PROBES`] cells around `p` (unit geometric normal `n`): each cell's
/// probe at the middle of its sector, at its ring's elevation; INFINITY where nothing is met.
/// A probe passes over surfaces facing the way the target's does (within 30°): their
/// kernels' planar model holds there, and a bumpy floor would otherwise cut every kernel.
pub fn probe(scene: &Scene, p: Vec3, n: Vec3) -> [f32; PROBES] {
    let mut free = [f32::INFINITY; PROBES];
    if !n.is_finite() || n == Vec3::ZERO || !p.is_finite() {
        return free;
    }
    let (t, b) = onb(n);
    // Just off the surface, on its front: the target's position carries the rounding of the
    // triangle it lies on, a few ulps of its largest coordinate.
    let origin = p + n * surface_offset(p.abs().max_element());
    for (ring, elevation) in PROBE_ELEVATIONS_DEG.iter().enumerate() {
        let (se, ce) = elevation.to_radians().sin_cos();
        for k in 0..AZIMUTHS {
            let phi = std::f32::consts::TAU * (k as f32 + 0.5) / AZIMUTHS as f32;
            let (s, c) = phi.sin_cos();
            let dir = t * (c * ce) + b * (s * ce) + n * se;
            let (mut from, mut travelled) = (origin, 0.0);
            for _ in 0..PASS_OVER {
                let Some((t, g)) = scene.intersect_geometry(from, dir, f32::INFINITY) else {
                    break;
                };
                travelled += t;
                let facing = if g.dot(dir) < 0.0 { g } else { -g };
                if facing.dot(n) < SAME_SURFACE_COS {
                    free[ring * AZIMUTHS + k] = travelled;
                    break;
                }
                let position = from + dir * t;
                let off = surface_offset(position.abs().max_element());
                from = offset_ray_origin(position, g, off, dir);
                travelled += (from - position).length();
            }
        }
    }
    free
}

/// The share of a splat kernel's mass, for a diffuse field over an open plane, whose point v
/// (module docs) lies in one given cell of `ring` within τ·r of the target: the planar
/// model's cumulative share, 1/8 of the ring's. Sampled once (2¹⁸ pairs: cosine-distributed
/// directions, offsets from the Epanechnikov kernel across the ray, each landing pair
/// weighted by the end gain as the splat weights it: each direction's kept pairs share one unit), tabulated in
/// [`SHARE_STEPS`] steps of τ ∈ [0, 1]; τ ≥ 1 is the cell's whole share.
pub fn planar_share(ring: usize, tau: f32) -> f32 {
    static TABLE: OnceLock<[[f32; SHARE_STEPS + 1]; 2]> = OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let (dirs, offsets) = (1usize << 12, 64usize);
        let mut hist = [[0.0f64; SHARE_STEPS]; 2];
        let mut total = 0.0f64;
        // Two-dimensional low-discrepancy points (Kronecker sequences), deterministic.
        let kr =
            |i: usize, a: f64, b: f64| ((0.5 + a * i as f64).fract(), (0.5 + b * i as f64).fract());
        let mut kept: Vec<(usize, usize)> = Vec::with_capacity(offsets);
        for i in 0..dirs {
            let (u0, u1) = kr(i, 0.754_877_7, 0.569_840_3);
            kept.clear();
            for j in 0..offsets {
                let (u2, u3) = kr(j + 7 * i, 0.618_034_0, 0.381_966_0);
                let u = [u0, u1, u2, u3];
                // Direction towards the light, cosine-distributed: the photon travels along −w.
                let (sr, phi) = (u[0].sqrt(), std::f64::consts::TAU * u[1]);
                let w = glam::DVec3::new(sr * phi.cos(), sr * phi.sin(), (1.0 - u[0]).sqrt());
                if w.z < 1e-4 {
                    break;
                }
                let d = -w;
                // Offset across the ray from the 2D Epanechnikov kernel: ρ² = 1 − √(1 − u).
                let rho = (1.0 - (1.0 - u[2]).sqrt()).sqrt();
                let psi = std::f64::consts::TAU * u[3];
                let a = if d.x.abs() < 0.9 {
                    glam::DVec3::X
                } else {
                    glam::DVec3::Y
                };
                let e1 = d.cross(a).normalize();
                let e2 = d.cross(e1);
                let z = e1 * (rho * psi.cos()) + e2 * (rho * psi.sin());
                let v = if z.z >= 0.0 {
                    z
                } else {
                    // The line lands on the plane before reaching z: its hit, kept within r.
                    let p = z - d * (z.z / d.z);
                    if p.length() >= 1.0 {
                        continue;
                    }
                    p
                };
                let len = v.length();
                let ring = (v.z > RING_SPLIT as f64 * len) as usize;
                let bin = ((len * SHARE_STEPS as f64) as usize).min(SHARE_STEPS - 1);
                kept.push((ring, bin));
            }
            // The end gain: the direction's kept pairs carry its whole weight.
            let gain = 1.0 / kept.len().max(1) as f64;
            for &(ring, bin) in &kept {
                hist[ring][bin] += gain;
                total += gain;
            }
        }
        let mut out = [[0.0f32; SHARE_STEPS + 1]; 2];
        for ring in 0..2 {
            let mut acc = 0.0;
            for (k, h) in hist[ring].iter().enumerate() {
                acc += h;
                out[ring][k + 1] = (acc / total / AZIMUTHS as f64) as f32;
            }
        }
        out
    });
    let x = tau.clamp(0.0, 1.0) * SHARE_STEPS as f32;
    let i = (x as usize).min(SHARE_STEPS - 1);
    let f = x - i as f32;
    let row = &table[ring];
    row[i] * (1.0 - f) + row[i + 1] * f
}

/// N(x, r): the share of the kernel's mass visible from a target whose cells have the free
/// distances `free` (one lane's), for splat radius `r`. 1 on an open plane.
#[inline]
pub fn visible_share(free: impl Fn(usize) -> f32, r: f32) -> f32 {
    let inv = 1.0 / r;
    let mut sum = 0.0;
    for c in 0..PROBES {
        sum += planar_share(c / AZIMUTHS, free(c) * inv);
    }
    sum
}

/// N(x, r) from a lane's share row ([`DomainChunk::share`]) at position `x`
/// ([`share_position`]; for r > free_min).
#[inline(always)]
pub fn share_from_row(row: &[u8; 16], x: f32) -> f32 {
    // x lies in [0, SHARE_RADII − 1] (share_position clamps it): a plain truncation.
    let j = ((x as i32) as usize).min(SHARE_RADII - 2);
    let f = x - j as f32;
    (row[j] as f32 * (1.0 - f) + row[j + 1] as f32 * f) * (1.0 / 255.0)
}

/// Where radius `r` falls in a lane's share table of smallest free distance `free_min`:
/// 2·log₂(r / free_min) clamped to [0, SHARE_RADII − 1], from a bit-level logarithm (within
/// 0.01 of the true one; arithmetic only, so that it vectorises). 0 for r ≤ free_min.
#[inline(always)]
pub fn share_position(r: f32, free_min: f32) -> f32 {
    let q = (r / free_min).max(1.0);
    let bits = q.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000) - 1.0;
    let log2 = e as f32 + m * (1.3466 - 0.3466 * m);
    (2.0 * log2).clamp(0.0, (SHARE_RADII - 1) as f32)
}

/// The visible domains probed for each pixel's first splat target, kept across eye passes
/// and views (docs/deviations.md §40, "Probes kept across eye passes"): a later pass's first
/// target of the pixel that lies on the same plane within a quarter of the nearest free
/// distance of where the probes left takes the cells instead of casting its 16 probes again,
/// its distances shrunk by how far it lies from there. The test is geometric, so the pixel
/// only says where to look: a view of another size (the window's dragged views are at half
/// size) looks at the entry of the same place in the image ([`DomainCache::set_view`]), and a
/// moved camera's pixels find the points near where they looked before.
#[derive(Default)]
pub struct DomainCache {
    /// Per pixel of `grid` (index y·width + x); `free_min` NaN where nothing was probed yet.
    entries: Vec<CachedDomain>,
    /// The width and height the entries are laid out for: the view that kept the first.
    grid: (u32, u32),
    /// The width and height of the view whose pixels are looked up and kept.
    view: (u32, u32),
    /// Pixels' first targets that took a cached domain since the cache was made.
    pub reused: u64,
    /// Pixels' first targets that were probed (and cached) since the cache was made.
    pub probed: u64,
}

/// One pixel's probed domain ([`DomainCache`]): where the probes left, the plane's normal and
/// the lane's quantised cells as [`DomainChunk`] holds them (44 bytes; its share table is
/// computed again from them, 192 table reads against 16 probe rays).
#[derive(Clone, Copy)]
struct CachedDomain {
    origin: Vec3,
    normal: Vec3,
    free_min: f32,
    free: [u8; PROBES],
}

impl CachedDomain {
    const NONE: Self = Self {
        origin: Vec3::ZERO,
        normal: Vec3::ZERO,
        free_min: f32::NAN,
        free: [FREE_NONE; PROBES],
    };
}

/// The normals of a target and of its pixel's cached domain agree to this cosine (0.5°).
const REUSE_COS: f32 = 0.999_96;
/// A cached domain serves a target within this share of its nearest free distance of the
/// probes' origin.
const REUSE_REACH: f32 = 0.25;

impl DomainCache {
    /// Bytes a pixel's entry takes (the memory estimate counts them per pixel).
    pub const BYTES_PER_PIXEL: usize = std::mem::size_of::<CachedDomain>();

    /// Keep the domains `tree` probed for its pixels' first targets (those
    /// [`SplatTree::probe_domains`] marked; `pixels`: each target's pixel), before the eye
    /// pass that made them is released. Entries another pass took stay as they were, so a
    /// pixel's entry keeps the origin its probes left from. One entry a pixel of the largest
    /// view so far, allocated on the first call (a second eye pass or a second view): a
    /// headless render of one pass holds none. `pixels` are of the view given to
    /// [`DomainCache::set_view`].
    pub fn keep(&mut self, tree: &SplatTree, pixels: &[u32]) {
        if pixels.is_empty() || self.view.0 == 0 || self.view.1 == 0 {
            return;
        }
        // Laid out for the largest view so far (the window's first image is at a quarter of
        // the size): a larger one spreads the entries over its pixels.
        let ((w, h), (gw, gh)) = (self.view, self.grid);
        if self.entries.is_empty() || (w as u64) * (h as u64) > (gw as u64) * (gh as u64) {
            let mut entries = Vec::with_capacity(w as usize * h as usize);
            entries.extend(
                (0..h as u64)
                    .flat_map(|y| {
                        (0..w as u64)
                            .map(move |x| (x * gw as u64 / w as u64, y * gh as u64 / h as u64))
                    })
                    .map(|(gx, gy)| {
                        self.entries
                            .get((gy * gw as u64 + gx) as usize)
                            .copied()
                            .unwrap_or(CachedDomain::NONE)
                    }),
            );
            self.entries = entries;
            self.grid = self.view;
        }
        let chunks = tree.domain_fresh.iter().zip(&tree.domains);
        for (k, ((&fresh, d), c)) in chunks.zip(&tree.points.chunks).enumerate() {
            for l in (0..LANES).filter(|l| fresh & (1 << l) != 0) {
                let Some(&target) = tree.slot_target.get(k * LANES + l) else {
                    continue;
                };
                let entry = CachedDomain {
                    origin: Vec3::new(c.px[l], c.py[l], c.pz[l]),
                    normal: Vec3::new(d.normal[0][l], d.normal[1][l], d.normal[2][l]),
                    free_min: d.free_min[l],
                    free: d.free[l],
                };
                for slot in self.slots(pixels[target as usize]) {
                    self.entries[slot] = entry;
                }
            }
        }
    }

    /// Forget every entry, keeping the counts.
    pub fn clear(&mut self) {
        self.entries = Vec::new();
    }

    /// The pixels looked up and kept from now on are of a view `width` × `height`.
    pub fn set_view(&mut self, width: u32, height: u32) {
        self.view = (width, height);
    }

    /// The entries for pixel `pixel` of the view: the grid's cells under it (one where the
    /// view is the grid's size, 2 × 2 for the window's dragged views at half size).
    #[inline]
    fn slots(&self, pixel: u32) -> impl Iterator<Item = usize> + use<> {
        let ((w, h), (gw, gh)) = (self.view, self.grid);
        let ok = w > 0 && h > 0 && !self.entries.is_empty() && (pixel as u64) < w as u64 * h as u64;
        let (w, h) = (w.max(1) as u64, h.max(1) as u64);
        let (gw, gh) = (gw as u64, gh as u64);
        let (x, y) = (pixel as u64 % w, pixel as u64 / w);
        let span = |i: u64, n: u64, g: u64| (i * g / n, ((i + 1) * g / n).max(i * g / n + 1));
        let ((x0, x1), (y0, y1)) = (span(x, w, gw), span(y, h, gh));
        let (y0, y1) = if ok { (y0, y1.min(gh)) } else { (0, 0) };
        (y0..y1).flat_map(move |gy| (x0..x1.min(gw)).map(move |gx| (gy * gw + gx) as usize))
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.entries.capacity() * std::mem::size_of::<CachedDomain>()
    }

    /// The smallest free distance a target at `p` with geometric normal `n` takes from
    /// `pixel`'s cached domain, with its quantised cells, or None where it must probe: the
    /// cached one's, shrunk by the distance δ from the probes' origin. All cells are
    /// distances of at least free_min scaled by (1 − δ/free_min), so each shrinks by at least
    /// δ (no cell reaches farther from the target than the origin's reached, less the
    /// offset; against what the moved point itself would see, the error is of the order of
    /// the probes' own, one ray per cell), and N(x, r), tabulated at radii relative to
    /// free_min over distances relative to it, is the same table.
    /// Of the pixel's cells (more than one for a smaller view), the one that leaves the
    /// largest distance.
    fn fit(&self, pixel: u32, p: Vec3, n: Vec3) -> Option<(f32, [u8; PROBES])> {
        self.slots(pixel)
            .filter_map(|slot| fit_entry(&self.entries[slot], p, n))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }
}

/// [`DomainCache::fit`] for one cached domain `c`.
#[inline]
fn fit_entry(c: &CachedDomain, p: Vec3, n: Vec3) -> Option<(f32, [u8; PROBES])> {
    // A "nothing met" has no distance to bound the move by (a target through rough
    // glass, whose normals are drawn anew each pass, lands anywhere on the plane): probed
    // again. The cells' frame is `onb` of the normal, which turns by 180° with the sign
    // of its z (two triangles of one wall can give +0 and −0): the signs must agree.
    if !c.free_min.is_finite()
        || c.normal.dot(n) < REUSE_COS
        || c.normal.z.is_sign_negative() != n.z.is_sign_negative()
    {
        return None;
    }
    let d = p - c.origin;
    // On the same plane: off it by no more than the positions' own rounding.
    let tolerance = 2.0 * surface_offset(p.abs().max_element().max(c.origin.abs().max_element()));
    if d.dot(n).abs() > tolerance {
        return None;
    }
    let delta = d.length();
    (delta <= REUSE_REACH * c.free_min)
        .then(|| ((c.free_min - delta).max(f32::MIN_POSITIVE), c.free))
}

/// Lane `l`'s smallest free distance, quantised cells and N(x, r_j), computed from the
/// distances as the splat pass decodes them (so that the cut and the renormalisation agree).
fn set_cells(out: &mut DomainChunk, l: usize, free_min: f32, codes: [u8; PROBES]) {
    out.free_min[l] = free_min;
    if !free_min.is_finite() {
        return;
    }
    out.free[l] = codes;
    let free: [f32; PROBES] = std::array::from_fn(|c| free_distance(codes[c], free_min));
    for j in 0..SHARE_RADII {
        let r = free_min * (j as f32 * 0.5).exp2();
        let n = visible_share(|c| free[c], r);
        out.share[l][j] = (n.clamp(0.0, 1.0) * 255.0).round() as u8;
    }
}

impl SplatTree {
    /// Probe every target's visible domain (module docs), so that splatting with a scene
    /// keeps each kernel on its target's side of the walls. `geo_normals` are the targets'
    /// geometric normals, in target order: the probes leave from that plane (a shading normal
    /// can lean away from the surface). With `cache` (and each target's pixel, in target
    /// order) a pixel's first target takes the cached domain of its pixel where it fits
    /// ([`DomainCache`]); the ones probed instead are marked for [`DomainCache::keep`].
    /// Returns how many pixels' first targets took a cached domain and how many probed.
    pub fn probe_domains(
        &mut self,
        scene: &Scene,
        geo_normals: &[Vec3],
        cache: Option<(&DomainCache, &[u32])>,
    ) -> (u64, u64) {
        self.probe_domains_until(scene, geo_normals, cache, None)
            .expect("probes without a stop run to their end")
    }

    /// [`SplatTree::probe_domains`], given up (None, the tree's domains then unusable) once
    /// `stop` is raised: each chunk of targets looks at it before it probes.
    pub fn probe_domains_until(
        &mut self,
        scene: &Scene,
        geo_normals: &[Vec3],
        cache: Option<(&DomainCache, &[u32])>,
        stop: Stop,
    ) -> Option<(u64, u64)> {
        assert_eq!(geo_normals.len(), self.samples);
        // The table is built once, outside the parallel loop (see `kept_fraction`).
        planar_share(0, 1.0);
        let (pts, slot_target) = (&self.points.chunks, &self.slot_target);
        // Each chunk's domains, and its lanes probed as their pixel's first target (to be
        // cached) and those that took a cached domain.
        // Written in place (an indexed unzip): a collected copy of the domains was 15 MB
        // at 500×500.
        let (mut domains, mut marks) = (Vec::new(), Vec::<(u8, u8)>::new());
        pts.par_iter()
            .enumerate()
            .map(|(k, c)| {
                let mut out = DomainChunk::default();
                let (mut fresh, mut reused) = (0u8, 0u8);
                if stopped(stop) {
                    return (out, (fresh, reused));
                }
                for l in 0..LANES {
                    let target = slot_target[k * LANES + l];
                    if target == PADDING {
                        continue;
                    }
                    let n = geo_normals[target as usize];
                    let p = Vec3::new(c.px[l], c.py[l], c.pz[l]);
                    (out.normal[0][l], out.normal[1][l], out.normal[2][l]) = (n.x, n.y, n.z);
                    // A pixel's first target (targets come in pixel order).
                    let first = cache.and_then(|(_, px)| {
                        let t = target as usize;
                        (t == 0 || px[t - 1] != px[t]).then_some(px[t])
                    });
                    if let Some(pixel) = first
                        && let Some((cache, _)) = cache
                        && let Some((free_min, free)) = cache.fit(pixel, p, n)
                    {
                        set_cells(&mut out, l, free_min, free);
                        reused |= 1 << l;
                        continue;
                    }
                    let exact = probe(scene, p, n);
                    // A probe that met a surface at once (a target in a crease) closes its
                    // cell: the smallest distance quantised against stays positive.
                    let free_min = exact
                        .iter()
                        .copied()
                        .fold(f32::INFINITY, f32::min)
                        .max(f32::MIN_POSITIVE);
                    let mut codes = [FREE_NONE; PROBES];
                    if free_min.is_finite() {
                        for (q, f) in codes.iter_mut().zip(exact) {
                            *q = quantise_free(f, free_min);
                        }
                    }
                    set_cells(&mut out, l, free_min, codes);
                    if first.is_some() {
                        fresh |= 1 << l;
                    }
                }
                (out, (fresh, reused))
            })
            .unzip_into_vecs(&mut domains, &mut marks);
        if stopped(stop) {
            self.domains = Vec::new();
            return None;
        }
        self.domains = domains;
        let count = |f: fn(&(u8, u8)) -> u8| marks.iter().map(|m| f(m).count_ones() as u64).sum();
        let counts = (count(|m| m.1), count(|m| m.0));
        self.domain_fresh = if cache.is_some() {
            marks.into_iter().map(|m| m.0).collect()
        } else {
            Vec::new()
        };
        Some(counts)
    }

    /// The tree knows its targets' visible domains ([`SplatTree::probe_domains`]).
    pub fn has_domains(&self) -> bool {
        !self.domains.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_planar_shares_sum_to_one_and_grow_with_distance() {
        let total: f32 = (0..PROBES).map(|c| planar_share(c / AZIMUTHS, 1.0)).sum();
        assert!((total - 1.0).abs() < 1e-5, "{total}");
        assert_eq!(visible_share(|_| f32::INFINITY, 0.3), total);
        for ring in 0..2 {
            assert_eq!(planar_share(ring, 0.0), 0.0);
            let mut last = 0.0;
            for k in 1..=20 {
                let s = planar_share(ring, k as f32 / 20.0);
                assert!(s >= last, "ring {ring}: not monotone at {k}");
                last = s;
            }
        }
        // Both rings carry mass: the low one (landing points, grazing feet) and the high one.
        assert!(planar_share(0, 1.0) > 0.02 && planar_share(1, 1.0) > 0.02);
    }

    #[test]
    fn the_branch_free_cell_is_the_octant_and_the_ring_of_the_angles() {
        // Against atan2 and asin on 20,000 directions off the sector boundaries.
        let mut seed = 0x9e37_79b9_u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        let mut checked = 0;
        for _ in 0..20_000 {
            let u = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 7.0;
            let phi = u.y.atan2(u.x).rem_euclid(std::f32::consts::TAU);
            let sector_f = phi / (std::f32::consts::TAU / AZIMUTHS as f32);
            let elevation = (u.z / u.length()).asin().to_degrees();
            if (sector_f - sector_f.round()).abs() < 1e-3 || (elevation - 30.0).abs() < 1e-3 {
                continue;
            }
            let ring = (elevation > 30.0) as usize;
            let expected = ring * AZIMUTHS + (sector_f as usize) % AZIMUTHS;
            assert_eq!(cell_index(u.x, u.y, u.z) as usize, expected, "{u}");
            checked += 1;
        }
        assert!(checked > 19_000);
    }

    #[test]
    fn quantised_free_distances_never_lie_beyond_the_surface() {
        let free_min = 0.37f32;
        for k in 0..2000 {
            let f = free_min * (k as f32 * 0.01).exp2();
            let q = quantise_free(f, free_min);
            let back = free_distance(q, free_min);
            assert!(back <= f * (1.0 + 1e-6), "{f} -> {back}");
            // Within one step (2^(1/16), 4.4%) up to the farthest code.
            if f < free_min * 60_000.0 {
                assert!(back >= f / 2f32.powf(1.0 / FREE_STEPS_PER_OCTAVE) * (1.0 - 1e-5));
            }
        }
        assert_eq!(
            free_distance(quantise_free(free_min, free_min), free_min),
            free_min
        );
        assert_eq!(quantise_free(f32::INFINITY, free_min), FREE_NONE);
        assert_eq!(free_distance(FREE_NONE, free_min), f32::INFINITY);
        assert_eq!(free_distance(FREE_NONE, f32::MIN_POSITIVE), f32::INFINITY);
    }

    #[test]
    fn cells_follow_their_probes() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let (t, b) = onb(n);
        for (ring, elevation) in PROBE_ELEVATIONS_DEG.iter().enumerate() {
            let (se, ce) = elevation.to_radians().sin_cos();
            for k in 0..AZIMUTHS {
                let phi = std::f32::consts::TAU * (k as f32 + 0.5) / AZIMUTHS as f32;
                let dir = t * (phi.cos() * ce) + b * (phi.sin() * ce) + n * se;
                assert_eq!(cell(dir * 3.0, t, b, n), ring * AZIMUTHS + k);
            }
        }
    }
}
