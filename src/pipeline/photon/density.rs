//! The density of the photon rays actually stored (issue 30, docs/deviations.md §63): a
//! running count of where every class's rays landed, over every batch so far, from which
//! each stored ray gets a floor on its end bandwidth.
//!
//! Eq. 8's p̃ (eq. 7) assumes every photon origin is visible (V = 1 in eq. 1). Inside a room
//! lit through a window the photons there are far fewer than p̃ says and the kernels
//! narrower than they support (in `builtin:room` the fifth of the inside rays with the
//! fewest neighbours held 12 or fewer landings within their radius). The floor is the
//! radius that holds K rays of the class's M, measured, not modelled:
//!
//! h_floor² = K / (π · M · ρ(x)),  ρ(x) = n(x) / (A · H),
//!
//! where n(x) is the count of landings of the class in a block of area A around the ray's
//! end x and H the class's rays counted so far, so ρ is the density of landings per stored
//! ray (Silverman 1986, §5.2's k-th nearest neighbour radius; a floor of the kind of
//! Abramson's square-root law). It is applied as h_end = max(eq. 8's, C·h_floor), so eq. 8
//! keeps its shape. Consistent: h_floor falls as M^(−1/2), faster than eq. 8's M^(−1/3) of
//! the progressive schedule (deviations §43), so once K rays lie within eq. 8's radius the
//! floor is gone.
//!
//! The count is a hash grid of cubes at [`LEVELS`] sizes, each twice the last, keyed also by
//! the class and by the dominant axis of the hit face's normal (facing the ray): the two
//! faces of a thin wall, and the sky-lit ground outside a room and its floor inside, do not
//! pool their counts where their normals differ. A ray's block is the 2 × 2 × 2 cubes nearest
//! its end at the finest level whose block holds enough landings for the density to be
//! resolved at the floor's own scale ([`RESOLVED`]); so a ray costs 8 look-ups where photons
//! are dense and up to 8 per level where they are few.

use super::bandwidth::typical_at_c1;
use super::{PhotonRay, Pilot};
use glam::{IVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// K of the floor, the default of [`super::BandwidthParams::floor_neighbours`]: the rays of
/// the class's M the floor's disc holds. At 32 the room lit through its window lost a third
/// of its error after one batch and the Cornell boxes nothing; 64 and 128 cut the room's
/// more but cost SIBENIK 4% (docs/deviations.md §63).
pub const FLOOR_NEIGHBOURS: f32 = 32.0;

/// Cube sizes counted: the finest is a quarter of the first batch's typical bandwidth, the
/// coarsest 2⁷ times that (32 typical bandwidths).
pub const LEVELS: u32 = 8;

/// A block resolves the density when it holds this many landings, (4/π)·K for the default K
/// (41): in a block of side 2s (A = 4s²) the floor of K rays at M = H is then
/// r² = K·A/(π·n) ≤ s², at most the block's half side, so the density is measured over about
/// the floor's own area, not a wider one.
const RESOLVED: u32 = (4.0 / std::f32::consts::PI * FLOOR_NEIGHBOURS) as u32 + 1;

/// Rays whose keys [`HitDensity::add_rays`] makes and sorts at once: 8 keys a landing, so
/// 64 K rays hold 4 MB of keys.
const ADD_CHUNK: usize = 1 << 16;

/// A multiplicative hash of the packed cell key (the keys are dense small integers; std's
/// SipHash costs more than the look-up).
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0 ^ b as u64);
        }
    }

    fn write_u64(&mut self, k: u64) {
        self.0 = crate::sampling::splitmix64(k);
    }
}

type CellMap = HashMap<u64, u32, BuildHasherDefault<CellHasher>>;

/// Landings of every class over every batch so far, counted in cubes of [`LEVELS`] sizes.
#[derive(Clone, Debug)]
pub struct HitDensity {
    /// Side of the finest cubes (scene units).
    cell: f32,
    counts: CellMap,
    /// Rays of each class counted (H: landing or not, as eq. 8's M counts them).
    rays: [u64; 3],
}

/// The face a ray lands on, by the dominant axis of its normal and that axis's sign (0..6).
#[inline]
fn face(n: Vec3) -> u64 {
    let a = n.abs();
    let (axis, sign) = if a.x >= a.y && a.x >= a.z {
        (0, n.x < 0.0)
    } else if a.y >= a.z {
        (1, n.y < 0.0)
    } else {
        (2, n.z < 0.0)
    };
    axis * 2 + sign as u64
}

/// The packed key of cube `c` at `level` for `class` and `face`: 18 bits a coordinate
/// (wrapping: a far cube may share a key, which only adds its count).
#[inline]
fn key(level: u32, class: usize, face: u64, c: IVec3) -> u64 {
    const M: u64 = (1 << 18) - 1;
    (c.x as u64 & M)
        | (c.y as u64 & M) << 18
        | (c.z as u64 & M) << 36
        | face << 54
        | (class as u64) << 57
        | (level as u64) << 59
}

impl HitDensity {
    /// An empty count with finest cubes of side `cell` (scene units; finite and positive,
    /// else 1).
    pub fn new(cell: f32) -> Self {
        Self {
            cell: if cell.is_finite() && cell > 0.0 {
                cell
            } else {
                1.0
            },
            counts: CellMap::default(),
            rays: [0; 3],
        }
    }

    /// An empty count whose finest cubes are a quarter of the typical bandwidth at C = 1 of
    /// a first batch of `m` rays ([`super::bandwidth::typical_at_c1`]): a length of the
    /// lights' own scale (the pilot's μC), never of the bounding box.
    pub fn for_pilot(pilot: &Pilot, m: u64) -> Self {
        Self::new(0.25 * typical_at_c1(pilot.mu_c(), m as f32))
    }

    /// Count where those of `rays` that land landed (the batch's rays, or a wave of them;
    /// each ray once; [`Self::add_stored`] counts the batch's rays per class). The keys are
    /// made and sorted in parallel, [`ADD_CHUNK`] rays at a time, and each run of equal keys
    /// is one insert: the light pass is parallel, and a serial insert per landing and level
    /// was a fifth of its time on CORNELL BOX I.
    pub fn add_rays(&mut self, rays: &[PhotonRay]) {
        let mut keys = Vec::new();
        let cell = self.cell;
        for chunk in rays.chunks(ADD_CHUNK) {
            keys.clear();
            keys.par_extend(
                chunk
                    .par_iter()
                    .filter_map(landing)
                    .flat_map_iter(|(p, class, f)| {
                        (0..LEVELS).map(move |level| key(level, class, f, cube(cell, p, level)))
                    }),
            );
            keys.par_sort_unstable();
            self.counts.reserve(keys.len() / 4);
            for run in keys.chunk_by(|a, b| a == b) {
                *self.counts.entry(run[0]).or_insert(0) += run.len() as u32;
            }
        }
    }

    /// Add a batch's stored rays per class to H (after its landings: [`Self::add_rays`]).
    pub fn add_stored(&mut self, stored: [u64; 3]) {
        for (h, s) in self.rays.iter_mut().zip(stored) {
            *h += s;
        }
    }

    /// Count a batch of `stored` rays per class of which `rays` are held (none for a
    /// streamed batch, whose landings its light pass's first trace counted), and give each
    /// of `rays` its φ in `phis` (cleared first).
    pub fn add_batch(&mut self, rays: &[PhotonRay], stored: [u64; 3], phis: &mut Vec<f32>) {
        self.add_rays(rays);
        self.add_stored(stored);
        self.phis(rays, phis);
    }

    /// φ of a ray: its floor at K = 1, C = 1 and M = 1, so that h_floor = C·√K·φ/√M
    /// ([`super::Bandwidth::cone`]); 0 for a ray that does not land (an escape, a mirror or
    /// glass: no kernel on its end) or of a class not counted.
    pub fn phi(&self, ray: &PhotonRay) -> f32 {
        let Some((p, class, f)) = landing(ray) else {
            return 0.0;
        };
        let h = self.rays[class];
        if h == 0 {
            return 0.0;
        }
        let mut n = 0;
        let mut area = 0.0;
        for level in 0..LEVELS {
            let side = side(self.cell, level);
            let q = p / side;
            let base = q.floor();
            // As `cube`: far coordinates saturate.
            let c0 = base.as_ivec3();
            let f_in = q - base;
            // The 2 × 2 × 2 cubes nearest the point: its own and the neighbour on the side
            // of the cube it is nearer, per axis.
            let step = IVec3::new(
                if f_in.x < 0.5 { -1 } else { 1 },
                if f_in.y < 0.5 { -1 } else { 1 },
                if f_in.z < 0.5 { -1 } else { 1 },
            );
            n = 0;
            for corner in 0..8 {
                let o = IVec3::new(corner & 1, corner >> 1 & 1, corner >> 2 & 1) * step;
                n += self
                    .counts
                    .get(&key(level, class, f, c0.wrapping_add(o)))
                    .copied()
                    .unwrap_or(0);
            }
            area = 4.0 * side * side;
            if n >= RESOLVED {
                break;
            }
        }
        (area * h as f32 / (std::f32::consts::PI * n.max(1) as f32)).sqrt()
    }

    /// φ of every ray of `rays` into `out` (cleared first), in order.
    pub fn phis(&self, rays: &[PhotonRay], out: &mut Vec<f32>) {
        out.clear();
        out.par_extend(rays.par_iter().map(|r| self.phi(r)));
    }

    /// Bytes held by the counts: the table's buckets (a power of two at least 8/7 of its
    /// capacity) of a key, a count and a control byte each. The cubes are fixed in size, so
    /// the count is bounded by the lit surface over the finest cube's side squared (times
    /// about 8/7 for the coarser sizes, per class and face), not by how long a render runs.
    pub fn bytes(&self) -> usize {
        let buckets = (self.counts.capacity() * 8 / 7).next_power_of_two();
        buckets * (std::mem::size_of::<(u64, u32)>() + 1)
    }
}

/// The side of the cubes at `level` when the finest are `cell`.
#[inline]
fn side(cell: f32, level: u32) -> f32 {
    cell * (1u32 << level) as f32
}

/// The cube holding `p` at `level` (far coordinates saturate; their keys wrap).
#[inline]
fn cube(cell: f32, p: Vec3, level: u32) -> IVec3 {
    (p / side(cell, level)).floor().as_ivec3()
}

/// Where a ray lands, its class's index and its face; `None` when it does not land on a
/// surface that holds eye samples.
#[inline]
fn landing(r: &PhotonRay) -> Option<(Vec3, usize, u64)> {
    if !r.lands() || r.escapes() {
        return None;
    }
    let p = r.origin + r.dir * r.length;
    p.is_finite()
        .then(|| (p, r.class() as usize, face(r.end_normal.get())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pack::OctOrZero;
    use crate::pipeline::photon::{PhotonClass, RayTag};
    use crate::sampling::Rng;

    /// A ray of `class` landing at `p` on a face with normal `n`, from above it.
    fn landing_at(p: Vec3, n: Vec3, class: PhotonClass) -> PhotonRay {
        PhotonRay {
            origin: p + n,
            dir: -n,
            length: 1.0,
            power: Vec3::ONE,
            origin_normal: OctOrZero::new(-n),
            end_shading_ratio: 1.0,
            pdf_start: 1.0,
            pdf_end: 1.0,
            tag: RayTag::new(1, class, true),
            end_normal: OctOrZero::new(n),
        }
    }

    /// `n` landings uniform on the square [0, size]² of the plane y = 0.
    fn plane(n: usize, size: f32, seed: u64) -> Vec<PhotonRay> {
        let mut rng = Rng::new(seed, 0);
        (0..n)
            .map(|_| {
                let p = Vec3::new(rng.next_f32() * size, 0.0, rng.next_f32() * size);
                landing_at(p, Vec3::Y, PhotonClass::Indirect)
            })
            .collect()
    }

    /// On a uniform plane the floor's disc holds K of the M rays: φ² = A·H/(π·n) reads the
    /// density n/(A·H) = 1/(size²) per ray, so φ ≈ size/√π, within 20% for the median ray
    /// away from the square's edges, at every cube size and density.
    #[test]
    fn the_floor_of_a_uniform_plane_holds_k_rays() {
        for (n, size, cell) in [
            (20_000, 10.0, 0.05),
            (2_000, 10.0, 0.05),
            (200_000, 3.0, 1.0),
        ] {
            let rays = plane(n, size, 3);
            let mut d = HitDensity::new(cell);
            d.add_rays(&rays);
            d.add_stored([0, n as u64, 0]);
            let mut phis: Vec<f32> = rays
                .iter()
                .filter(|r| {
                    let p = r.origin + r.dir;
                    p.x > 0.25 * size && p.x < 0.75 * size && p.z > 0.25 * size && p.z < 0.75 * size
                })
                .map(|r| d.phi(r))
                .collect();
            phis.sort_by(f32::total_cmp);
            let median = phis[phis.len() / 2];
            let want = size / std::f32::consts::PI.sqrt();
            assert!(
                (median / want - 1.0).abs() < 0.2,
                "{n} rays on {size}², cell {cell}: φ {median} against {want}"
            );
        }
    }

    /// Doubling the batches at the same density leaves φ (a density) where it was, so the
    /// floor C·√K·φ/√M falls as M^(−1/2): consistent.
    #[test]
    fn more_batches_at_the_same_density_keep_phi() {
        let one = plane(5_000, 4.0, 1);
        let two = plane(5_000, 4.0, 2);
        let mut d = HitDensity::new(0.1);
        d.add_rays(&one);
        d.add_stored([0, 5_000, 0]);
        let probe = landing_at(Vec3::new(2.0, 0.0, 2.0), Vec3::Y, PhotonClass::Indirect);
        let a = d.phi(&probe);
        d.add_rays(&two);
        d.add_stored([0, 5_000, 0]);
        let b = d.phi(&probe);
        assert!((b / a - 1.0).abs() < 0.15, "φ {a} → {b}");
    }

    /// The other face of a thin wall, another class and a ray that does not land count for
    /// nothing: a face with no landings of its own but the probe gets the coarsest,
    /// sparsest floor, not the dense face's.
    #[test]
    fn a_walls_other_face_and_other_classes_do_not_pool() {
        let mut rays = plane(20_000, 4.0, 5);
        // The same plane, lit from below, and caustic rays on the top face.
        rays.extend(plane(20_000, 4.0, 6).into_iter().map(|r| {
            let p = r.origin + r.dir;
            landing_at(p, -Vec3::Y, PhotonClass::Indirect)
        }));
        rays.extend(plane(20_000, 4.0, 7).into_iter().map(|r| {
            let p = r.origin + r.dir;
            landing_at(p, Vec3::Y, PhotonClass::Caustic)
        }));
        let mut escaping = landing_at(Vec3::new(2.0, 0.0, 2.0), Vec3::Y, PhotonClass::Indirect);
        escaping.end_normal = OctOrZero::new(Vec3::ZERO);
        let mut d = HitDensity::new(0.05);
        d.add_rays(&rays);
        d.add_stored([0, 40_000, 20_000]);
        assert_eq!(d.phi(&escaping), 0.0);
        let top = d.phi(&landing_at(
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::Y,
            PhotonClass::Indirect,
        ));
        // Against 40,000 indirect rays counted, the top face holds half: φ = 4/√π·√2.
        let want = 4.0 / std::f32::consts::PI.sqrt() * 2f32.sqrt();
        assert!((top / want - 1.0).abs() < 0.2, "top {top} against {want}");
        // Nothing of any class lands on a face turned along x there: the sparsest floor.
        let side = d.phi(&landing_at(
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::X,
            PhotonClass::Indirect,
        ));
        assert!(side > 10.0 * top, "side {side}, top {top}");
    }
}
