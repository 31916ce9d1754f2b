//! Building the splat tree (§7.1): sliding-midpoint splits, empty-space cut-offs, backface-cull
//! nodes, subtrees for parallel splatting, and the padded slot layout.

use super::node::{Node, small_angle};
use super::{
    CULL_MARGIN, CULL_MAX_ANGLE, Chunk, LANES, LEAF_SIZE, Leaf, MAX_DEPTH, MIN_CELL_FRACTION,
    PADDING, Points, SplatTree, Subtree,
};
use crate::pack::Oct;
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

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
        // Each leaf's samples grouped into compact chunks of LANES, with the chunks' and the
        // leaf's bounding spheres, in parallel: the leaves' ranges of `order` are disjoint and
        // in order (depth first), and they cover it.
        let mut slices: Vec<&mut [u32]> = Vec::with_capacity(b.leaves.len());
        let mut rest = &mut b.order[..];
        let mut at = 0;
        for leaf in &b.leaves {
            let lo = leaf.first as usize;
            debug_assert!(lo >= at, "leaves out of order");
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(lo - at);
            let (mine, tail) = tail.split_at_mut(leaf.count as usize);
            slices.push(mine);
            rest = tail;
            at = lo + leaf.count as usize;
        }
        let grouped: Vec<(Vec<Chunk>, Chunk)> = slices
            .into_par_iter()
            .map(|idx| {
                median_groups(idx, positions);
                let chunks = idx
                    .chunks(LANES)
                    .map(|g| bounding_sphere(g, positions))
                    .collect();
                (chunks, bounding_sphere(idx, positions))
            })
            .collect();
        // Lay the leaves out in slots, each padded to a multiple of LANES.
        let mut points = Points::default();
        let mut slot_target = Vec::with_capacity(n + n / 2);
        let mut chunks = Vec::with_capacity(n / LANES + b.leaves.len());
        for (leaf, (leaf_chunks, sphere)) in b.leaves.iter_mut().zip(grouped) {
            let lo = leaf.first as usize;
            let cnt = leaf.count as usize;
            chunks.extend(leaf_chunks);
            leaf.first = slot_target.len() as u32;
            for &i in &b.order[lo..lo + cnt] {
                points.push(positions[i as usize], normals[i as usize]);
                slot_target.push(i);
            }
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
            domains: Vec::new(),
            domain_fresh: Vec::new(),
            slot_target,
            target_slot,
            subtrees,
            min,
            max,
            samples: n,
        }
    }
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
        let decoded = Oct::new(mean).get();
        let alpha = alpha + small_angle(decoded, mean);
        Some((mean, alpha.sin()))
    }
}
