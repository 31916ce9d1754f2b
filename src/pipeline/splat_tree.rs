//! The splat kd-tree over eye samples (§7.1) and its conical-frustum traversal (§7.2, Alg. 1).
//!
//! Layout: sliding-midpoint splits; a leaf below 16 samples or below 0.1% of the targets' extent;
//! four 8-byte node kinds (interior, leaf, empty, backface-cull), the left child at index + 1.
//!
//! Parallel splatting: the tree is cut into *subtrees* that own disjoint, contiguous ranges of
//! eye samples (a few hundred of them). Each rayon task takes one subtree and splats every photon
//! ray into it, so no two threads ever write the same accumulator — no locks, no atomics, no
//! per-thread copies of the radiance map — and the sum for each sample runs in ray order,
//! which makes the result independent of the thread count.
//!
//! Storage for speed: sample positions and normals are structure-of-arrays in tree order, each
//! leaf padded to a multiple of [`LANES`] so a leaf is tested in whole 8-wide chunks (the
//! padding has a zero normal and is never feasible). A leaf node refers to a [`Leaf`] record
//! holding its first slot and a bounding sphere, tested against the cone before its samples.

use glam::{Vec3, Vec3A};

/// A node is a leaf below this many samples (§7.1).
pub const LEAF_SIZE: usize = 128;
/// Leaves are padded to a multiple of this many slots (one AVX2 register of f32).
pub const LANES: usize = 8;
/// ... or when its cell's diagonal is below this fraction of the targets' extent (§7.1: of the scene's).
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
/// leaf: sample count in bits 2–31; `data` = index of its [`Leaf`] record.
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
    fn leaf(leaf: usize, count: usize) -> Self {
        assert!(count < (1 << 30));
        Self {
            word: KIND_LEAF | ((count as u32) << 2),
            data: leaf as u32,
        }
    }
    fn empty() -> Self {
        Self {
            word: KIND_EMPTY,
            data: 0,
        }
    }
    fn cull(normal: Vec3, cmax: f32) -> Self {
        // Quantise C_max ∈ [-1, 1] to 24 bits (exact in f32), rounding up so the test stays
        // conservative.
        let mut q = (((cmax as f64 + 1.0) * 0.5) * CMAX_LEVELS as f64).ceil() as u32;
        q = q.min(CMAX_LEVELS);
        while q < CMAX_LEVELS && decode_cmax(q) < cmax {
            q += 1;
        }
        Self {
            word: KIND_CULL | (q << 2),
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
    fn leaf_index(&self) -> usize {
        self.data as usize
    }
    #[inline(always)]
    fn cmax(&self) -> f32 {
        decode_cmax(self.word >> 2)
    }
    #[inline(always)]
    fn normal(&self) -> Vec3A {
        oct_decode(self.data)
    }
}

/// Quantisation levels of a cull node's C_max.
const CMAX_LEVELS: u32 = (1 << 24) - 1;

#[inline(always)]
fn decode_cmax(q: u32) -> f32 {
    q as f32 / CMAX_LEVELS as f32 * 2.0 - 1.0
}

/// Angle between unit vectors from their chord (accurate for tiny angles, unlike acos).
fn small_angle(a: Vec3, b: Vec3) -> f32 {
    2.0 * (0.5 * (a - b).length()).min(1.0).asin()
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

/// Positions and normals of one chunk of [`LANES`] slots (structure of arrays inside the
/// chunk, chunks contiguous: one 192-byte block per 8 samples).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct PointChunk {
    pub px: [f32; LANES],
    pub py: [f32; LANES],
    pub pz: [f32; LANES],
    pub nx: [f32; LANES],
    pub ny: [f32; LANES],
    pub nz: [f32; LANES],
}

/// Splat-target positions and normals in slot order, leaves padded to whole chunks.
#[derive(Clone, Debug, Default)]
pub struct Points {
    pub chunks: Vec<PointChunk>,
    len: usize,
}

impl Points {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn push(&mut self, p: Vec3, n: Vec3) {
        let l = self.len % LANES;
        if l == 0 {
            self.chunks.push(PointChunk::default());
        }
        let c = self.chunks.last_mut().expect("pushed above");
        (c.px[l], c.py[l], c.pz[l]) = (p.x, p.y, p.z);
        (c.nx[l], c.ny[l], c.nz[l]) = (n.x, n.y, n.z);
        self.len += 1;
    }
}

/// A leaf: its samples occupy slots `first .. first + count` (then padding up to a multiple
/// of [`LANES`]); every sample lies within `radius` of `center`.
#[derive(Clone, Copy, Debug)]
pub struct Leaf {
    pub first: u32,
    pub count: u32,
    pub center: Vec3A,
    pub radius: f32,
}

/// Bounding sphere of one 8-slot chunk (leaves are ordered so chunks are compact).
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    pub center: Vec3A,
    pub radius: f32,
}

/// A subtree owning the slots `first .. first + len`; `min`/`max` bound its samples tightly.
#[derive(Clone, Copy, Debug)]
pub struct Subtree {
    pub root: u32,
    pub first: u32,
    pub len: u32,
    pub min: Vec3A,
    pub max: Vec3A,
    leaf_begin: u32,
    leaf_end: u32,
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
    pub leaves: Vec<Leaf>,
    /// One bounding sphere per [`LANES`] slots.
    pub chunks: Vec<Chunk>,
    pub points: Points,
    /// Splat target held by each slot (`u32::MAX` for padding).
    pub slot_target: Vec<u32>,
    /// Slot of each splat target.
    pub target_slot: Vec<u32>,
    pub subtrees: Vec<Subtree>,
    pub min: Vec3A,
    pub max: Vec3A,
    /// Number of real (unpadded) splat targets.
    pub samples: usize,
}

/// Marks a padding slot in [`SplatTree::slot_target`].
pub const PADDING: u32 = u32::MAX;

impl SplatTree {
    /// Build over splat-target `positions` and `normals`. Cells stop splitting below
    /// [`MIN_CELL_FRACTION`] of the targets' own extent (§7.1 says of the scene's; the targets'
    /// extent does not grow with geometry nobody sees).
    pub fn build(positions: &[Vec3], normals: &[Vec3]) -> Self {
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
            leaves: Vec::with_capacity(n / 8 + 1),
            subtrees: Vec::new(),
            min_diag: MIN_CELL_FRACTION * (max - min).length(),
            subtree_max,
        };
        b.build(0, n, min, max, false, false, 0);
        // Lay the leaves out in slots, each padded to a multiple of LANES.
        let mut points = Points::default();
        let mut slot_target = Vec::with_capacity(n + n / 2);
        let mut chunks = Vec::with_capacity(n / LANES + b.leaves.len());
        for leaf in &mut b.leaves {
            let lo = leaf.first as usize;
            let cnt = leaf.count as usize;
            median_groups(&mut b.order[lo..lo + cnt], positions);
            for group in b.order[lo..lo + cnt].chunks(LANES) {
                chunks.push(bounding_sphere(group, positions));
            }
            leaf.first = slot_target.len() as u32;
            for &i in &b.order[lo..lo + cnt] {
                points.push(positions[i as usize], normals[i as usize]);
                slot_target.push(i);
            }
            let sphere = bounding_sphere(&b.order[lo..lo + cnt], positions);
            leaf.center = sphere.center;
            leaf.radius = sphere.radius;
            let pad_pos = positions[b.order[lo] as usize];
            while slot_target.len() % LANES != 0 {
                points.push(pad_pos, Vec3::ZERO);
                slot_target.push(PADDING);
            }
        }
        let mut target_slot = vec![0u32; n];
        for (slot, &t) in slot_target.iter().enumerate() {
            if t != PADDING {
                target_slot[t as usize] = slot as u32;
            }
        }
        let mut subtrees = b.subtrees;
        for st in &mut subtrees {
            let first = b.leaves[st.leaf_begin as usize].first;
            let end = b
                .leaves
                .get(st.leaf_end as usize)
                .map(|l| l.first)
                .unwrap_or(slot_target.len() as u32);
            st.first = first;
            st.len = end - first;
        }
        Self {
            nodes: b.nodes,
            leaves: b.leaves,
            chunks,
            points,
            slot_target,
            target_slot,
            subtrees,
            min,
            max,
            samples: n,
        }
    }

    /// Slots (samples plus padding).
    pub fn slots(&self) -> usize {
        self.slot_target.len()
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * 8
            + self.leaves.len() * std::mem::size_of::<Leaf>()
            + self.chunks.len() * std::mem::size_of::<Chunk>()
            + self.points.chunks.len() * std::mem::size_of::<PointChunk>()
            + self.slots() * 4
            + self.target_slot.len() * 4
    }

    /// Collect every leaf of `subtree` the cone may reach into `out` as (first slot, count)
    /// (Alg. 1, iterative, near child first). `out` is cleared first; reuse it across rays.
    #[inline(always)]
    pub fn traverse(&self, subtree: &Subtree, cone: &Cone, out: &mut Vec<(u32, u32)>) {
        out.clear();
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
        let inv_dir = Vec3A::ONE / cone.dir;
        let mut stack = [(0u32, 0f32, 0f32); STACK];
        let mut sp = 0;
        let (mut idx, mut t0, mut t1) = (subtree.root as usize, t0, t1);
        loop {
            let node = self.nodes[idx];
            let mut descend = false;
            match node.kind() {
                KIND_INTERIOR => {
                    let a = node.axis();
                    // Splat radius at t1, the largest on [t0, t1] (Alg. 1: R1).
                    let r1 = (cone.h0 + cone.dh * t1).min(cone.h_end);
                    let (o, inv) = (cone.origin[a], inv_dir[a]);
                    let split = node.split();
                    let (left, right) = (idx + 1, node.right());
                    if inv.is_finite() && inv.abs() < 1e9 {
                        // Distances to the virtual planes split ± r1 (Alg. 1: tα, tβ).
                        let t = (split - o) * inv;
                        let dt = r1 * inv.abs();
                        let (near, far) = if inv > 0.0 {
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
                            idx = near;
                            t1 = near_end;
                            descend = true;
                        }
                    } else {
                        // The ray runs parallel to the plane.
                        let go_left = o - r1 <= split;
                        let go_right = o + r1 >= split;
                        if go_left && go_right {
                            stack[sp] = (right as u32, t0, t1);
                            sp += 1;
                        }
                        if go_left || go_right {
                            idx = if go_left { left } else { right };
                            descend = true;
                        }
                    }
                }
                KIND_LEAF => {
                    let lf = &self.leaves[node.leaf_index()];
                    // Bounding-sphere test: skip leaves the cone cannot reach.
                    if sphere_in_cone(cone, lf.center, lf.radius) {
                        out.push((lf.first, node.count() as u32));
                    }
                }
                // Cull node: every sample below faces away from rays with dir·n > C_max (§7.1).
                KIND_CULL if cone.dir.dot(node.normal()) <= node.cmax() => {
                    idx += 1;
                    descend = true;
                }
                _ => {}
            }
            if !descend {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (i, a, b) = stack[sp];
                (idx, t0, t1) = (i as usize, a, b);
            }
        }
    }
}

/// Could the cone reach a point within `radius` of `center`? (Conservative: the radius is
/// taken at the sphere's far end along the ray.)
#[inline(always)]
pub fn sphere_in_cone(cone: &Cone, center: Vec3A, radius: f32) -> bool {
    let v = center - cone.origin;
    let t = v.dot(cone.dir);
    let dist2 = (v.length_squared() - t * t).max(0.0);
    let reach = (cone.h0 + cone.dh * (t + radius)).min(cone.h_end) + radius;
    t + radius >= 0.0 && t - radius <= cone.length + cone.h_end && dist2 < reach * reach
}

/// Order `idx` so that consecutive groups of [`LANES`] are compact: recursive splits at a
/// multiple of LANES near the median of the longest axis.
fn median_groups(idx: &mut [u32], positions: &[Vec3]) {
    if idx.len() <= LANES {
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &i in idx.iter() {
        lo = lo.min(positions[i as usize]);
        hi = hi.max(positions[i as usize]);
    }
    let e = hi - lo;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let k = idx.len().div_ceil(2 * LANES) * LANES;
    idx.select_nth_unstable_by(k, |a, b| {
        positions[*a as usize][axis].total_cmp(&positions[*b as usize][axis])
    });
    let (left, right) = idx.split_at_mut(k);
    median_groups(left, positions);
    median_groups(right, positions);
}

/// Centroid-centred bounding sphere, grown by a relative epsilon so rounding never rejects a
/// point on its surface.
fn bounding_sphere(idx: &[u32], positions: &[Vec3]) -> Chunk {
    let mut c = Vec3A::ZERO;
    for &i in idx {
        c += Vec3A::from(positions[i as usize]);
    }
    c /= idx.len().max(1) as f32;
    let r = idx
        .iter()
        .map(|&i| Vec3A::from(positions[i as usize]).distance(c))
        .fold(0.0f32, f32::max);
    Chunk {
        center: c,
        radius: r * (1.0 + 1e-5) + 1e-7 * (1.0 + c.abs().max_element()),
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
    /// During the build `first` is an index into `order`; slots are assigned afterwards.
    leaves: Vec<Leaf>,
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
        in_cull: bool,
        in_subtree: bool,
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
            let at = self.subtrees.len();
            self.subtrees.push(Subtree {
                root: self.nodes.len() as u32,
                first: 0,
                len: 0,
                min: tmin,
                max: tmax,
                leaf_begin: self.leaves.len() as u32,
                leaf_end: 0,
            });
            // A subtree is entered directly, so it needs its own cull node.
            self.build_node(
                lo, hi, cell_min, cell_max, false, true, depth, is_leaf, tmin, tmax,
            );
            self.subtrees[at].leaf_end = self.leaves.len() as u32;
            return;
        }
        self.build_node(
            lo, hi, cell_min, cell_max, in_cull, in_subtree, depth, is_leaf, tmin, tmax,
        );
    }

    #[allow(clippy::too_many_arguments)]
    fn build_node(
        &mut self,
        lo: usize,
        hi: usize,
        cell_min: Vec3A,
        cell_max: Vec3A,
        mut in_cull: bool,
        in_subtree: bool,
        depth: u32,
        is_leaf: bool,
        tmin: Vec3A,
        tmax: Vec3A,
    ) {
        let n = hi - lo;
        if !in_cull
            && n >= LEAF_SIZE
            && let Some((normal, cmax)) = self.normal_cone(lo, hi)
        {
            self.nodes.push(Node::cull(normal, cmax));
            in_cull = true;
        }
        if is_leaf {
            self.nodes.push(Node::leaf(self.leaves.len(), n));
            self.leaves.push(Leaf {
                first: lo as u32,
                count: n as u32,
                center: Vec3A::ZERO,
                radius: 0.0,
            });
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
        let alpha = alpha + small_angle(decoded, mean);
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
            assert!(small_angle(d, n) < 1e-4, "{n} -> {d}");
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
