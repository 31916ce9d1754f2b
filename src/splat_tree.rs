//! The splat kd-tree over eye samples (§7.1) and its conical-frustum traversal (§7.2, Alg. 1).
//!
//! Layout: sliding-midpoint splits; a leaf below 16 samples or below 0.1% of the scene diagonal;
//! four 8-byte node kinds (interior, leaf, empty, backface-cull), the left child at index + 1.
//!
//! Parallel splatting: the tree is cut into *subtrees* that own disjoint, contiguous ranges of
//! eye samples (a few hundred of them). Each rayon task takes one subtree and splats every photon
//! ray into it, so no two threads ever write the same accumulator — no locks, no atomics, no
//! per-thread copies of the radiance map — and the sum for each sample runs in ray order,
//! which makes the result independent of the thread count.

use glam::{Vec3, Vec3A};

/// A node is a leaf below this many samples (§7.1).
pub const LEAF_SIZE: usize = 16;
/// ... or when its cell's diagonal is below this fraction of the scene diagonal (§7.1).
pub const MIN_CELL_FRACTION: f32 = 1e-3;
/// Recursion bound for pathological inputs (sliding midpoint can degenerate on clustered data).
const MAX_DEPTH: u32 = 60;
/// A backface-cull node is inserted above subtrees whose normals deviate at most this much.
const CULL_MAX_ANGLE: f32 = 60.0 * std::f32::consts::PI / 180.0;
/// Extra angle for the quantised reference normal (16-bit octahedral: < 1e-4 rad error).
const CULL_MARGIN: f32 = 2e-3;
/// Traversal stack depth: tree depth + cull nodes, with room to spare.
const STACK: usize = 2 * MAX_DEPTH as usize + 8;

const KIND_INTERIOR: u32 = 0;
const KIND_LEAF: u32 = 1;
const KIND_EMPTY: u32 = 2;
const KIND_CULL: u32 = 3;

/// 8-byte node. `word` holds the kind in bits 0–1 and:
/// interior: axis in bits 2–3, right-child index in bits 4–31; `data` = split plane (f32 bits).
/// leaf: sample count in bits 2–31; `data` = first sample index.
/// cull: C_max (quantised, rounded up) in bits 2–31; `data` = octahedral reference normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Node {
    word: u32,
    data: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 8);

impl Node {
    fn interior(axis: usize, split: f32) -> Self {
        Self {
            word: KIND_INTERIOR | ((axis as u32) << 2),
            data: split.to_bits(),
        }
    }
    fn set_right(&mut self, right: usize) {
        assert!(right < (1 << 28), "splat tree too large");
        self.word |= (right as u32) << 4;
    }
    fn leaf(first: usize, count: usize) -> Self {
        assert!(count < (1 << 30));
        Self {
            word: KIND_LEAF | ((count as u32) << 2),
            data: first as u32,
        }
    }
    fn empty() -> Self {
        Self {
            word: KIND_EMPTY,
            data: 0,
        }
    }
    fn cull(normal: Vec3, cmax: f32) -> Self {
        // Quantise C_max ∈ [-1, 1] upwards so the test stays conservative.
        let q = (((cmax + 1.0) * 0.5) * ((1u32 << 30) - 1) as f32).ceil() as u32;
        Self {
            word: KIND_CULL | (q.min((1 << 30) - 1) << 2),
            data: oct_encode(normal),
        }
    }
    #[inline(always)]
    pub fn kind(&self) -> u32 {
        self.word & 3
    }
    #[inline(always)]
    fn axis(&self) -> usize {
        ((self.word >> 2) & 3) as usize
    }
    #[inline(always)]
    fn right(&self) -> usize {
        (self.word >> 4) as usize
    }
    #[inline(always)]
    fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }
    #[inline(always)]
    fn count(&self) -> usize {
        (self.word >> 2) as usize
    }
    #[inline(always)]
    fn first(&self) -> usize {
        self.data as usize
    }
    #[inline(always)]
    fn cmax(&self) -> f32 {
        (self.word >> 2) as f32 / ((1u32 << 30) - 1) as f32 * 2.0 - 1.0
    }
    #[inline(always)]
    fn normal(&self) -> Vec3A {
        oct_decode(self.data)
    }
}

/// Octahedral unit-vector encoding, 16 bits per coordinate.
fn oct_encode(n: Vec3) -> u32 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    let (mut x, mut y) = (n.x, n.y);
    if n.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * ox.signum();
        y = (1.0 - ox.abs()) * oy.signum();
    }
    let q = |v: f32| (((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).round() as u32) & 0xffff;
    q(x) | (q(y) << 16)
}

#[inline(always)]
fn oct_decode(c: u32) -> Vec3A {
    let x = (c & 0xffff) as f32 / 65535.0 * 2.0 - 1.0;
    let y = (c >> 16) as f32 / 65535.0 * 2.0 - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let x = x + if x >= 0.0 { -t } else { t };
    let y = y + if y >= 0.0 { -t } else { t };
    Vec3A::new(x, y, z).normalize()
}

/// Position and normal of an eye sample, in tree order (one cache stream in the hot loop).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct SplatPoint {
    pub position: Vec3A,
    pub normal: Vec3A,
}

/// A subtree owning the samples `first .. first + count`; `min`/`max` bound them tightly.
#[derive(Clone, Copy, Debug)]
pub struct Subtree {
    pub root: u32,
    pub first: u32,
    pub count: u32,
    pub min: Vec3A,
    pub max: Vec3A,
}

/// A photon ray's splat volume: the conical frustum from `origin` to `origin + length·dir`
/// with radius `h0 + dh·t`, then a hemisphere of radius `h_end` beyond the hit point (Fig. 4).
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub length: f32,
    pub h0: f32,
    pub dh: f32,
    pub h_end: f32,
}

impl Cone {
    /// Splat radius at ray parameter t.
    #[inline(always)]
    pub fn radius(&self, t: f32) -> f32 {
        if t <= self.length {
            self.h0 + self.dh * t
        } else {
            self.h_end
        }
    }

    /// Bounding box of the whole splat volume.
    #[inline]
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let end = self.origin + self.dir * self.length;
        let r = Vec3A::splat(self.h_end);
        (self.origin.min(end) - r, self.origin.max(end) + r)
    }
}

pub struct SplatTree {
    pub nodes: Vec<Node>,
    pub points: Vec<SplatPoint>,
    pub subtrees: Vec<Subtree>,
    pub min: Vec3A,
    pub max: Vec3A,
}

impl SplatTree {
    /// Build over `positions`/`normals`; returns the tree and the permutation applied
    /// (tree index i holds input sample `order[i]`).
    pub fn build(positions: &[Vec3], normals: &[Vec3], scene_diagonal: f32) -> (Self, Vec<u32>) {
        let n = positions.len();
        let mut min = Vec3A::splat(f32::INFINITY);
        let mut max = Vec3A::splat(f32::NEG_INFINITY);
        for p in positions {
            min = min.min((*p).into());
            max = max.max((*p).into());
        }
        if n == 0 {
            min = Vec3A::ZERO;
            max = Vec3A::ZERO;
        }
        // A few hundred subtrees balance the load on any thread count.
        let subtree_max = (n / 256).max(2048);
        let mut b = Builder {
            pos: positions,
            nrm: normals,
            order: (0..n as u32).collect(),
            nodes: Vec::with_capacity(2 * n / LEAF_SIZE + 16),
            subtrees: Vec::new(),
            min_diag: MIN_CELL_FRACTION * scene_diagonal,
            subtree_max,
        };
        b.build(0, n, min, max, false, false, 0);
        let points = b
            .order
            .iter()
            .map(|&i| SplatPoint {
                position: positions[i as usize].into(),
                normal: normals[i as usize].into(),
            })
            .collect();
        (
            Self {
                nodes: b.nodes,
                points,
                subtrees: b.subtrees,
                min,
                max,
            },
            b.order,
        )
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * 8 + self.points.len() * std::mem::size_of::<SplatPoint>()
    }

    /// Visit every leaf of `subtree` that the cone may reach (Alg. 1, iterative).
    /// `leaf(first, count)` gets sample ranges in tree order.
    #[inline]
    pub fn traverse<F: FnMut(usize, usize)>(&self, subtree: &Subtree, cone: &Cone, mut leaf: F) {
        // Clip the ray against the subtree's bounds grown by the largest splat radius (§7.2).
        let grow = Vec3A::splat(cone.h_end);
        let Some((t0, t1)) = clip(
            cone.origin,
            cone.dir,
            subtree.min - grow,
            subtree.max + grow,
            0.0,
            cone.length + cone.h_end,
        ) else {
            return;
        };
        let mut stack = [(0u32, 0f32, 0f32); STACK];
        let mut sp = 0;
        let mut cur = (subtree.root as usize, t0, t1);
        loop {
            let (idx, t0, t1) = cur;
            let node = self.nodes[idx];
            let mut next = None;
            match node.kind() {
                KIND_INTERIOR => {
                    let a = node.axis();
                    let r1 = cone.radius(t1); // splat radius at t1 (the largest on [t0, t1])
                    let (o, d) = (cone.origin[a], cone.dir[a]);
                    let split = node.split();
                    let (left, right) = (idx + 1, node.right());
                    if d.abs() < 1e-9 {
                        let go_left = o - r1 <= split;
                        let go_right = o + r1 >= split;
                        if go_left && go_right {
                            stack[sp] = (right as u32, t0, t1);
                            sp += 1;
                            next = Some((left, t0, t1));
                        } else if go_left {
                            next = Some((left, t0, t1));
                        } else if go_right {
                            next = Some((right, t0, t1));
                        }
                    } else {
                        // Distances to the virtual planes split ± r1 (Alg. 1: tα, tβ).
                        let t = (split - o) / d;
                        let dt = r1 / d.abs();
                        let (near, far) = if d > 0.0 {
                            (left, right)
                        } else {
                            (right, left)
                        };
                        let near_end = t1.min(t + dt);
                        let far_start = t0.max(t - dt);
                        if far_start <= t1 {
                            stack[sp] = (far as u32, far_start, t1);
                            sp += 1;
                        }
                        if t0 <= near_end {
                            next = Some((near, t0, near_end));
                        }
                    }
                }
                KIND_LEAF => leaf(node.first(), node.count()),
                KIND_CULL => {
                    // Every sample below faces away from the ray (§7.1 backface-culling node).
                    if cone.dir.dot(node.normal()) <= node.cmax() {
                        next = Some((idx + 1, t0, t1));
                    }
                }
                _ => {}
            }
            match next {
                Some(n) => cur = n,
                None => {
                    if sp == 0 {
                        return;
                    }
                    sp -= 1;
                    let (i, a, b) = stack[sp];
                    cur = (i as usize, a, b);
                }
            }
        }
    }
}

/// Ray/box clipping (slab test) restricted to [tmin, tmax].
#[inline]
pub fn clip(
    o: Vec3A,
    d: Vec3A,
    min: Vec3A,
    max: Vec3A,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (tmin, tmax);
    for a in 0..3 {
        if d[a].abs() < 1e-12 {
            if o[a] < min[a] || o[a] > max[a] {
                return None;
            }
        } else {
            let inv = 1.0 / d[a];
            let (mut ta, mut tb) = ((min[a] - o[a]) * inv, (max[a] - o[a]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((t0, t1))
}

struct Builder<'a> {
    pos: &'a [Vec3],
    nrm: &'a [Vec3],
    order: Vec<u32>,
    nodes: Vec<Node>,
    subtrees: Vec<Subtree>,
    min_diag: f32,
    subtree_max: usize,
}

impl Builder<'_> {
    fn p(&self, i: usize) -> Vec3A {
        self.pos[self.order[i] as usize].into()
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        &mut self,
        lo: usize,
        hi: usize,
        cell_min: Vec3A,
        cell_max: Vec3A,
        mut in_cull: bool,
        mut in_subtree: bool,
        depth: u32,
    ) {
        let n = hi - lo;
        if n == 0 {
            self.nodes.push(Node::empty());
            return;
        }
        let (mut tmin, mut tmax) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for i in lo..hi {
            let p = self.p(i);
            tmin = tmin.min(p);
            tmax = tmax.max(p);
        }
        let cell_diag = (cell_max - cell_min).length();
        let is_leaf = n < LEAF_SIZE
            || cell_diag < self.min_diag
            || depth >= MAX_DEPTH
            || (tmax - tmin).max_element() <= 0.0;
        if !in_subtree && (n <= self.subtree_max || is_leaf) {
            self.subtrees.push(Subtree {
                root: self.nodes.len() as u32,
                first: lo as u32,
                count: n as u32,
                min: tmin,
                max: tmax,
            });
            in_subtree = true;
            // A subtree is entered directly, so it needs its own cull node.
            in_cull = false;
        }
        if !in_cull && n >= LEAF_SIZE {
            if let Some((normal, cmax)) = self.normal_cone(lo, hi) {
                self.nodes.push(Node::cull(normal, cmax));
                in_cull = true;
            }
        }
        if is_leaf {
            self.nodes.push(Node::leaf(lo, n));
            return;
        }
        // Cut off large empty space first: an empty child ends traversal early (§7.1).
        let ext = cell_max - cell_min;
        let gap_lo = tmin - cell_min;
        let gap_hi = cell_max - tmax;
        let mut best = (0.0f32, 0usize, false);
        for a in 0..3 {
            if ext[a] > 0.0 {
                if gap_lo[a] / ext[a] > best.0 {
                    best = (gap_lo[a] / ext[a], a, false);
                }
                if gap_hi[a] / ext[a] > best.0 {
                    best = (gap_hi[a] / ext[a], a, true);
                }
            }
        }
        if best.0 > 0.3 {
            let (_, a, high) = best;
            let split = if high { tmax[a] } else { tmin[a] };
            let at = self.nodes.len();
            self.nodes.push(Node::interior(a, split));
            let (mut lmax, mut rmin) = (cell_max, cell_min);
            lmax[a] = split;
            rmin[a] = split;
            if high {
                // All samples left (p ≤ split), the right is empty.
                self.build(lo, hi, cell_min, lmax, in_cull, in_subtree, depth + 1);
                let r = self.nodes.len();
                self.nodes[at].set_right(r);
                self.nodes.push(Node::empty());
            } else {
                self.nodes.push(Node::empty());
                let r = self.nodes.len();
                self.nodes[at].set_right(r);
                self.build(lo, hi, rmin, cell_max, in_cull, in_subtree, depth + 1);
            }
            return;
        }
        // Sliding midpoint (§7.1): the cell's spatial median on its longest axis, slid to the
        // nearest sample when one side would be empty.
        let mut a = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        if tmax[a] - tmin[a] <= 0.0 {
            let te = tmax - tmin;
            a = if te.x >= te.y && te.x >= te.z {
                0
            } else if te.y >= te.z {
                1
            } else {
                2
            };
        }
        let mut split = 0.5 * (cell_min[a] + cell_max[a]);
        let mut mid = self.partition(lo, hi, a, |x| x < split);
        if mid == lo {
            split = tmin[a];
            mid = self.partition(lo, hi, a, |x| x <= split);
        } else if mid == hi {
            split = tmax[a];
            mid = self.partition(lo, hi, a, |x| x < split);
        }
        let at = self.nodes.len();
        self.nodes.push(Node::interior(a, split));
        let (mut lmax, mut rmin) = (cell_max, cell_min);
        lmax[a] = split;
        rmin[a] = split;
        self.build(lo, mid, cell_min, lmax, in_cull, in_subtree, depth + 1);
        let r = self.nodes.len();
        self.nodes[at].set_right(r);
        self.build(mid, hi, rmin, cell_max, in_cull, in_subtree, depth + 1);
    }

    /// Move samples with `pred(p[axis])` to the front of lo..hi; returns the boundary.
    fn partition(
        &mut self,
        lo: usize,
        hi: usize,
        axis: usize,
        pred: impl Fn(f32) -> bool,
    ) -> usize {
        let mut m = lo;
        for i in lo..hi {
            if pred(self.p(i)[axis]) {
                self.order.swap(i, m);
                m += 1;
            }
        }
        m
    }

    /// Reference normal and C_max = sin(max deviation) when the normals are coherent enough.
    fn normal_cone(&self, lo: usize, hi: usize) -> Option<(Vec3, f32)> {
        let sum: Vec3 = (lo..hi).map(|i| self.nrm[self.order[i] as usize]).sum();
        let len = sum.length();
        if len < 0.5 * (hi - lo) as f32 {
            return None;
        }
        let mean = sum / len;
        let mut cos_min = 1.0f32;
        for i in lo..hi {
            cos_min = cos_min.min(self.nrm[self.order[i] as usize].dot(mean));
        }
        let alpha = cos_min.clamp(-1.0, 1.0).acos() + CULL_MARGIN;
        if alpha > CULL_MAX_ANGLE {
            return None;
        }
        // Rays with dir·n > sin(α) meet every sample from behind.
        let decoded: Vec3 = oct_decode(oct_encode(mean)).into();
        let alpha = alpha + decoded.angle_between(mean);
        Some((mean, alpha.sin()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedral_roundtrip_is_accurate() {
        let mut rng = crate::sampling::Rng::new(5, 5);
        for _ in 0..10_000 {
            let n = crate::sampling::uniform_sphere(rng.next_2d());
            let d: Vec3 = oct_decode(oct_encode(n)).into();
            assert!(d.angle_between(n) < 1e-4, "{n} -> {d}");
        }
    }

    #[test]
    fn cull_cmax_rounds_up() {
        for c in [-0.9f32, -0.1, 0.0, 0.3, 0.86] {
            assert!(Node::cull(Vec3::Z, c).cmax() >= c);
            assert!(Node::cull(Vec3::Z, c).cmax() - c < 1e-6);
        }
    }
}
