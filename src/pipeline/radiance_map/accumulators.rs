//! Per-slot splat sums in the splat tree's slot order, with directional records on glossy slots
//! (§8.1), and their disjoint per-subtree views for lock-free splatting.

use super::{Channel, NO_RECORD};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::splat_tree::{LANES, PADDING, SplatTree};

/// The sums of one chunk of [`LANES`] slots, channel-major inside the chunk.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct AccumChunk {
    /// `ch[c][l]`: channel `c` ([`Channel`]) of lane `l`.
    pub ch: [[f32; LANES]; Channel::COUNT],
}

/// Per-slot sums over all splats of all batches, one block per chunk of slots, and the
/// directional records of glossy slots.
#[derive(Clone, Debug, Default)]
pub struct Accumulators {
    pub(super) chunks: Vec<AccumChunk>,
    /// Which directional records glossy slots keep (§8.1).
    pub mode: DirectionalMode,
    /// Per slot: its directional record, or [`NO_RECORD`]. Records are numbered in slot order,
    /// so a subtree's records are contiguous.
    slot_record: Vec<u32>,
    /// Per chunk: whether any of its slots has a record.
    chunk_has_record: Vec<bool>,
    /// Records, [`DirectionalMode::record_floats`] each: SH channel-major (c·16 + k),
    /// histogram stratum-major (s·3 + c).
    records: Vec<f32>,
}

/// One subtree's disjoint share of the accumulators for lock-free parallel splatting.
pub struct AccView<'a> {
    /// The sums of the subtree's chunks.
    pub chunks: &'a mut [AccumChunk],
    /// The slot records of these chunks' slots (global record numbers).
    pub slot_record: &'a [u32],
    /// Per chunk: whether any of its slots has a record.
    pub chunk_has_record: &'a [bool],
    /// The records numbered from `first_record`.
    pub records: &'a mut [f32],
    /// Global number of the first record in `records`.
    pub first_record: u32,
}

impl Accumulators {
    /// Sums for `slots` slots, no directional records.
    pub fn new(slots: usize) -> Self {
        Self {
            chunks: vec![AccumChunk::default(); slots.div_ceil(LANES)],
            slot_record: vec![NO_RECORD; slots.div_ceil(LANES) * LANES],
            chunk_has_record: vec![false; slots.div_ceil(LANES)],
            ..Self::default()
        }
    }

    /// Sums for every slot of `tree` and, unless `mode` is diffuse, a directional record for
    /// each slot whose target is glossy.
    pub fn for_tree(tree: &SplatTree, glossy: &[bool], mode: DirectionalMode) -> Self {
        let mut acc = Self::new(tree.slots());
        acc.mode = mode;
        if mode == DirectionalMode::Diffuse {
            return acc;
        }
        let mut n = 0u32;
        for (slot, &t) in tree.slot_target.iter().enumerate() {
            if t != PADDING && glossy[t as usize] {
                acc.slot_record[slot] = n;
                acc.chunk_has_record[slot / LANES] = true;
                n += 1;
            }
        }
        acc.records = vec![0.0; n as usize * mode.record_floats()];
        acc
    }

    /// The directional record of `slot`, if it has one.
    #[inline]
    pub fn record(&self, slot: usize) -> Option<&[f32]> {
        let r = self.slot_record[slot];
        (r != NO_RECORD).then(|| {
            let f = self.mode.record_floats();
            &self.records[r as usize * f..(r as usize + 1) * f]
        })
    }

    /// Mutable directional record of `slot`, if it has one.
    #[inline]
    pub fn record_mut(&mut self, slot: usize) -> Option<&mut [f32]> {
        let r = self.slot_record[slot];
        let f = self.mode.record_floats();
        (r != NO_RECORD).then(|| &mut self.records[r as usize * f..(r as usize + 1) * f])
    }

    /// Slots held (a multiple of [`LANES`]).
    pub fn len(&self) -> usize {
        self.chunks.len() * LANES
    }

    /// No slots held.
    pub fn is_empty(&self) -> bool {
        self.chunks.is_empty()
    }

    /// Zero every sum and record, keeping the layout.
    pub fn clear(&mut self) {
        self.chunks.fill(AccumChunk::default());
        self.records.fill(0.0);
    }

    /// Zeroed accumulators of the same layout.
    pub fn zeroed(&self) -> Self {
        Self {
            chunks: vec![AccumChunk::default(); self.chunks.len()],
            mode: self.mode,
            slot_record: self.slot_record.clone(),
            chunk_has_record: self.chunk_has_record.clone(),
            records: vec![0.0; self.records.len()],
        }
    }

    /// Add the sums of `other` (same layout).
    pub fn add(&mut self, other: &Accumulators) {
        for (a, b) in self.chunks.iter_mut().zip(&other.chunks) {
            for (ca, cb) in a.ch.iter_mut().zip(&b.ch) {
                for (x, y) in ca.iter_mut().zip(cb) {
                    *x += y;
                }
            }
        }
        for (x, y) in self.records.iter_mut().zip(&other.records) {
            *x += y;
        }
    }

    /// Channel `c` of `slot`.
    #[inline]
    pub fn get(&self, c: Channel, slot: usize) -> f32 {
        self.chunks[slot / LANES].ch[c as usize][slot % LANES]
    }

    /// Set channel `c` of `slot`.
    #[inline]
    pub fn set(&mut self, c: Channel, slot: usize, value: f32) {
        self.chunks[slot / LANES].ch[c as usize][slot % LANES] = value;
    }

    /// Bytes held by the sums and the directional records.
    pub fn memory_bytes(&self) -> usize {
        self.chunks.len() * std::mem::size_of::<AccumChunk>() + self.directional_bytes()
    }

    /// Bytes of the directional records (and their slot index).
    pub fn directional_bytes(&self) -> usize {
        if self.mode == DirectionalMode::Diffuse {
            0
        } else {
            self.records.len() * 4 + self.slot_record.len() * 4
        }
    }

    /// Disjoint mutable views of increasing, non-overlapping slot ranges (start, len), both
    /// multiples of [`LANES`].
    pub fn split(&mut self, ranges: impl Iterator<Item = (usize, usize)>) -> Vec<AccView<'_>> {
        let f = self.mode.record_floats();
        let mut out = Vec::new();
        let mut rest: &mut [AccumChunk] = &mut self.chunks;
        let mut rest_rec: &mut [f32] = &mut self.records;
        let mut at = 0;
        let mut at_rec = 0usize;
        for (start, len) in ranges {
            debug_assert!(start % LANES == 0 && len % LANES == 0);
            let (_, tail) = rest.split_at_mut(start / LANES - at);
            let (mine, tail) = tail.split_at_mut(len / LANES);
            rest = tail;
            at = (start + len) / LANES;
            let slot_record = &self.slot_record[start..start + len];
            // Records of this range: numbered in slot order, so contiguous.
            let mut first = None;
            let mut last = 0;
            for &r in slot_record.iter().filter(|&&r| r != NO_RECORD) {
                first.get_or_insert(r);
                last = r;
            }
            let (first_record, count) = match first {
                Some(a) => (a as usize, (last - a + 1) as usize),
                None => (at_rec, 0),
            };
            let (_, tail) = rest_rec.split_at_mut((first_record - at_rec) * f);
            let (mine_rec, tail) = tail.split_at_mut(count * f);
            rest_rec = tail;
            at_rec = first_record + count;
            out.push(AccView {
                chunks: mine,
                slot_record,
                chunk_has_record: &self.chunk_has_record[start / LANES..(start + len) / LANES],
                records: mine_rec,
                first_record: first_record as u32,
            });
        }
        out
    }
}
