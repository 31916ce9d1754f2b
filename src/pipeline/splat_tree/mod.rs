//! The splat kd-tree over eye samples (§7.1) and its conical-frustum traversal (§7.2, Alg. 1).
//!
//! Layout: sliding-midpoint splits; a leaf below [`LEAF_SIZE`] samples or below 0.1% of the
//! targets' extent; four 8-byte node kinds (interior, leaf, empty, backface-cull), the left child
//! at index + 1.
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
//!
//! The build (`build`), the node encoding (`node`), the traversal (`traverse`) and the targets'
//! visible kernel domains (`domain`) are submodules; every public item is re-exported here.

mod build;
mod domain;
mod node;
mod traverse;

pub use domain::{
    AZIMUTHS, DomainCache, DomainChunk, FREE_NONE, FREE_STEPS_PER_OCTAVE, PROBE_ELEVATIONS_DEG,
    PROBES, SHARE_RADII, cell, cell_index, free_distance, planar_share, probe, quantise_free,
    share_from_row, share_position, visible_share,
};
pub use node::Node;
pub use traverse::{clip, sphere_in_cone};

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

/// Positions and normals of one chunk of [`LANES`] slots (structure of arrays inside the
/// chunk, chunks contiguous: one 192-byte block per 8 samples).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct PointChunk {
    /// x of each lane's position (world space).
    pub px: [f32; LANES],
    /// y of each lane's position.
    pub py: [f32; LANES],
    /// z of each lane's position.
    pub pz: [f32; LANES],
    /// x of each lane's unit normal (zero for padding, which is then never feasible).
    pub nx: [f32; LANES],
    /// y of each lane's unit normal.
    pub ny: [f32; LANES],
    /// z of each lane's unit normal.
    pub nz: [f32; LANES],
}

/// Splat-target positions and normals in slot order, leaves padded to whole chunks.
#[derive(Clone, Debug, Default)]
pub struct Points {
    /// The chunks, one per [`LANES`] slots.
    pub chunks: Vec<PointChunk>,
    len: usize,
}

impl Points {
    /// Slots filled (samples plus padding).
    pub fn len(&self) -> usize {
        self.len
    }

    /// No slot filled.
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
    /// First slot of the leaf (a multiple of [`LANES`]).
    pub first: u32,
    /// Real samples in the leaf, padding not counted.
    pub count: u32,
    /// Centre of the leaf's bounding sphere (the samples' centroid).
    pub center: Vec3A,
    /// Radius of the bounding sphere, grown a little so rounding never rejects a sample.
    pub radius: f32,
}

/// Bounding sphere of one 8-slot chunk (leaves are ordered so chunks are compact).
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    /// Centre of the sphere (the centroid of the chunk's samples).
    pub center: Vec3A,
    /// Radius of the sphere, grown a little so rounding never rejects a sample.
    pub radius: f32,
}

/// A subtree owning the slots `first .. first + len`; `min`/`max` bound its samples tightly.
#[derive(Clone, Copy, Debug)]
pub struct Subtree {
    /// Index of its root in [`SplatTree::nodes`].
    pub root: u32,
    /// First slot it owns.
    pub first: u32,
    /// Slots it owns (padding included).
    pub len: u32,
    /// Lower corner of its samples' bounding box.
    pub min: Vec3A,
    /// Upper corner of its samples' bounding box.
    pub max: Vec3A,
    leaf_begin: u32,
    leaf_end: u32,
}

/// A photon ray's splat volume: the conical frustum from `origin` to `origin + length·dir`
/// with radius `h0 + dh·t`, then a hemisphere of radius `h_end` beyond the hit point (Fig. 4).
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    /// Start of the photon ray, x_i.
    pub origin: Vec3A,
    /// Unit direction of the ray.
    pub dir: Vec3A,
    /// Length of the splat volume along the ray (scene units): to the hit point, or for an
    /// escaping ray to where it leaves the scene's bounds grown by its radius (past its
    /// stored end the radius stays h_end).
    pub length: f32,
    /// Splat radius at the origin, h0 of §6.
    pub h0: f32,
    /// Growth of the radius per unit length, dh of §6.
    pub dh: f32,
    /// Radius at the hit point, h0 + dh·length: the hemisphere's radius and the largest
    /// radius anywhere in the volume.
    pub h_end: f32,
}

impl Cone {
    /// Splat radius at ray parameter t.
    #[inline(always)]
    pub fn radius(&self, t: f32) -> f32 {
        (self.h0 + self.dh * t).min(self.h_end)
    }

    /// Bounding box of the whole splat volume.
    #[inline]
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let end = self.origin + self.dir * self.length;
        let r = Vec3A::splat(self.h_end);
        (self.origin.min(end) - r, self.origin.max(end) + r)
    }
}

/// The splat kd-tree (§7.1): nodes, leaves, and the splat targets' positions and normals
/// in slot order, cut into subtrees for parallel splatting.
pub struct SplatTree {
    /// All nodes, depth first (each interior node's left child follows it).
    pub nodes: Vec<Node>,
    /// Leaf records, in slot order.
    pub leaves: Vec<Leaf>,
    /// One bounding sphere per [`LANES`] slots.
    pub chunks: Vec<Chunk>,
    /// Positions and normals of the slots.
    pub points: Points,
    /// Visible kernel domains of the slots, one chunk per [`LANES`] slots, or empty when the
    /// tree was built without a scene to probe ([`SplatTree::probe_domains`]).
    pub domains: Vec<DomainChunk>,
    /// Per chunk of [`domains`](Self::domains), the lanes probed as their pixel's first
    /// target when the probes had a [`DomainCache`] to consult (what
    /// [`DomainCache::keep`] keeps); empty otherwise.
    pub domain_fresh: Vec<u8>,
    /// Splat target held by each slot (`u32::MAX` for padding).
    pub slot_target: Vec<u32>,
    /// Slot of each splat target.
    pub target_slot: Vec<u32>,
    /// Subtrees owning disjoint, increasing slot ranges that together cover every slot.
    pub subtrees: Vec<Subtree>,
    /// Lower corner of the splat targets' bounding box.
    pub min: Vec3A,
    /// Upper corner of the splat targets' bounding box.
    pub max: Vec3A,
    /// Number of real (unpadded) splat targets.
    pub samples: usize,
}

/// Marks a padding slot in [`SplatTree::slot_target`].
pub const PADDING: u32 = u32::MAX;

impl SplatTree {
    /// The position of the target in `slot`, as the tree holds it.
    pub fn position(&self, slot: u32) -> Vec3 {
        let (k, l) = (slot as usize / LANES, slot as usize % LANES);
        let c = &self.points.chunks[k];
        Vec3::new(c.px[l], c.py[l], c.pz[l])
    }

    /// Slots (samples plus padding).
    pub fn slots(&self) -> usize {
        self.slot_target.len()
    }

    /// Free all but `target_slot`, which is all that resolving the accumulators needs: the
    /// tree cannot be searched or splatted onto afterwards ([`SplatTree::is_released`]). A
    /// finished headless render does this before its film is resolved (docs/benchmarks.md,
    /// "Memory").
    pub fn release_search(&mut self) {
        self.nodes = Vec::new();
        self.leaves = Vec::new();
        self.chunks = Vec::new();
        self.points = Points::default();
        self.domains = Vec::new();
        self.slot_target = Vec::new();
        self.subtrees = Vec::new();
    }

    /// [`SplatTree::release_search`] freed the search structure of a tree that had targets.
    pub fn is_released(&self) -> bool {
        self.slot_target.is_empty() && !self.target_slot.is_empty()
    }

    /// Bytes held by the tree's arrays.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * 8
            + self.leaves.len() * std::mem::size_of::<Leaf>()
            + self.chunks.len() * std::mem::size_of::<Chunk>()
            + self.points.chunks.len() * std::mem::size_of::<PointChunk>()
            + self.domains.len() * std::mem::size_of::<DomainChunk>()
            + self.domain_fresh.len()
            + self.slots() * 4
            + self.target_slot.len() * 4
    }
}
