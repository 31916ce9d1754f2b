//! The 8-byte kd-tree node and its encodings: octahedral normals and quantised C_max.

use crate::pack::Oct;
use glam::{Vec3, Vec3A};

pub(super) const KIND_INTERIOR: u32 = 0;
pub(super) const KIND_LEAF: u32 = 1;
pub(super) const KIND_EMPTY: u32 = 2;
pub(super) const KIND_CULL: u32 = 3;

/// 8-byte node. `word` holds the kind in bits 0–1 and:
/// interior: axis in bits 2–3, right-child index in bits 4–31; `data` = split plane (f32 bits).
/// leaf: sample count in bits 2–31; `data` = index of its [`Leaf`](super::Leaf) record.
/// cull: C_max (quantised, rounded up) in bits 2–31; `data` = octahedral reference normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Node {
    word: u32,
    data: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 8);

impl Node {
    pub(super) fn interior(axis: usize, split: f32) -> Self {
        Self {
            word: KIND_INTERIOR | ((axis as u32) << 2),
            data: split.to_bits(),
        }
    }
    pub(super) fn set_right(&mut self, right: usize) {
        assert!(right < (1 << 28), "splat tree too large");
        self.word |= (right as u32) << 4;
    }
    pub(super) fn leaf(leaf: usize, count: usize) -> Self {
        assert!(count < (1 << 30));
        Self {
            word: KIND_LEAF | ((count as u32) << 2),
            data: leaf as u32,
        }
    }
    pub(super) fn empty() -> Self {
        Self {
            word: KIND_EMPTY,
            data: 0,
        }
    }
    pub(super) fn cull(normal: Vec3, cmax: f32) -> Self {
        // Quantise C_max ∈ [-1, 1] to 24 bits (exact in f32), rounding up so the test stays
        // conservative.
        let mut q = (((cmax as f64 + 1.0) * 0.5) * CMAX_LEVELS as f64).ceil() as u32;
        q = q.min(CMAX_LEVELS);
        while q < CMAX_LEVELS && decode_cmax(q) < cmax {
            q += 1;
        }
        Self {
            word: KIND_CULL | (q << 2),
            data: Oct::new(normal).bits(),
        }
    }
    /// The node's kind: interior, leaf, empty or backface-cull (bits 0–1 of `word`).
    #[inline(always)]
    pub fn kind(&self) -> u32 {
        self.word & 3
    }
    #[inline(always)]
    pub(super) fn axis(&self) -> usize {
        ((self.word >> 2) & 3) as usize
    }
    #[inline(always)]
    pub(super) fn right(&self) -> usize {
        (self.word >> 4) as usize
    }
    #[inline(always)]
    pub(super) fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }
    #[inline(always)]
    pub(super) fn count(&self) -> usize {
        (self.word >> 2) as usize
    }
    #[inline(always)]
    pub(super) fn leaf_index(&self) -> usize {
        self.data as usize
    }
    #[inline(always)]
    pub(super) fn cmax(&self) -> f32 {
        decode_cmax(self.word >> 2)
    }
    #[inline(always)]
    pub(super) fn normal(&self) -> Vec3A {
        Oct::from_bits(self.data).get_a()
    }
}

/// Quantisation levels of a cull node's C_max.
const CMAX_LEVELS: u32 = (1 << 24) - 1;

#[inline(always)]
fn decode_cmax(q: u32) -> f32 {
    q as f32 / CMAX_LEVELS as f32 * 2.0 - 1.0
}

/// Angle between unit vectors from their chord (accurate for tiny angles, unlike acos).
pub(super) fn small_angle(a: Vec3, b: Vec3) -> f32 {
    2.0 * (0.5 * (a - b).length()).min(1.0).asin()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cull_cmax_rounds_up() {
        for c in [-0.9f32, -0.1, 0.0, 0.3, 0.86] {
            assert!(Node::cull(Vec3::Z, c).cmax() >= c);
            assert!(Node::cull(Vec3::Z, c).cmax() - c < 1e-6);
        }
    }
}
