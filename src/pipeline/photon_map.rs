//! Photon mapping with K-NN density estimation (Jensen 2001), visualised directly at the eye
//! samples: the photon hit points of the same light pass in a balanced kd-tree, a global map
//! (direct and indirect photons) and a caustic map, each queried with its own K.

use crate::pipeline::photon::{PhotonClass, PhotonRay};
use crate::pipeline::radiance_map::{Accumulators, Channel};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A stored photon: where it landed, the direction it travelled, the power it carries.
#[derive(Clone, Copy, Debug)]
pub struct MapPhoton {
    /// Hit point (the photon ray's end).
    pub position: Vec3,
    /// Unit direction of travel (towards the surface).
    pub dir: Vec3,
    /// Power, averaged over batches and in the shading-normal cosine (see
    /// [`PhotonRay::end_shading_ratio`]).
    pub power: Vec3,
}

/// A balanced kd-tree in implicit layout: the node of range [lo, hi) is its median element.
pub struct PhotonMap {
    photons: Vec<MapPhoton>,
    axis: Vec<u8>,
}

/// A K-NN candidate, ordered by squared distance (a max-heap keeps the K nearest).
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    d2: f32,
    index: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, o: &Self) -> bool {
        self.d2 == o.d2
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    fn cmp(&self, o: &Self) -> Ordering {
        self.d2.total_cmp(&o.d2)
    }
}

/// A density estimate at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    /// Irradiance Σ Φ / (π r²).
    pub irradiance: Vec3,
    /// The gather radius used.
    pub radius: f32,
    /// Photons gathered (≤ K).
    pub found: u32,
}

impl PhotonMap {
    /// Build the balanced kd-tree over `photons` (reordered in place).
    pub fn build(mut photons: Vec<MapPhoton>) -> Self {
        let mut axis = vec![0u8; photons.len()];
        build(&mut photons, &mut axis);
        Self { photons, axis }
    }

    /// Photons stored.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// No photons stored.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Irradiance at `p` (surface normal `n`, facing the viewer) from the `k` nearest photons
    /// within `r_max` that arrived from the front. With fewer than `k` found, the disc of
    /// radius `r_max` is the area.
    pub fn estimate(
        &self,
        p: Vec3,
        n: Vec3,
        k: usize,
        r_max: f32,
        heap: &mut BinaryHeap<Candidate>,
    ) -> Estimate {
        heap.clear();
        if k == 0 || self.photons.is_empty() {
            return Estimate::default();
        }
        let mut r2 = r_max * r_max;
        self.search(0, self.photons.len(), p, n, k, heap, &mut r2);
        let found = heap.len();
        if found == 0 {
            return Estimate {
                irradiance: Vec3::ZERO,
                radius: r_max,
                found: 0,
            };
        }
        let r2 = if found == k {
            heap.peek().map(|c| c.d2).unwrap_or(r2)
        } else {
            r_max * r_max
        };
        // eq. 4 with a uniform kernel over the disc of the K-th neighbour: E ≈ ΣΦ / (π r²).
        let sum: Vec3 = heap
            .iter()
            .map(|c| self.photons[c.index as usize].power)
            .sum();
        Estimate {
            irradiance: sum / (std::f32::consts::PI * r2.max(f32::MIN_POSITIVE)),
            radius: r2.sqrt(),
            found: found as u32,
        }
    }

    /// The photons the last [`PhotonMap::estimate`] with `heap` gathered.
    pub fn gathered<'a>(
        &'a self,
        heap: &'a BinaryHeap<Candidate>,
    ) -> impl Iterator<Item = &'a MapPhoton> + 'a {
        heap.iter().map(|c| &self.photons[c.index as usize])
    }

    #[allow(clippy::too_many_arguments)]
    fn search(
        &self,
        lo: usize,
        hi: usize,
        p: Vec3,
        n: Vec3,
        k: usize,
        heap: &mut BinaryHeap<Candidate>,
        r2: &mut f32,
    ) {
        if lo >= hi {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        let ph = &self.photons[mid];
        let a = self.axis[mid] as usize;
        let delta = p[a] - ph.position[a];
        let (near, far) = if delta < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.search(near.0, near.1, p, n, k, heap, r2);
        let d2 = p.distance_squared(ph.position);
        if d2 < *r2 && ph.dir.dot(n) < 0.0 {
            heap.push(Candidate {
                d2,
                index: mid as u32,
            });
            if heap.len() > k {
                heap.pop();
            }
            if heap.len() == k {
                *r2 = heap.peek().map(|c| c.d2).unwrap_or(*r2);
            }
        }
        if delta * delta < *r2 {
            self.search(far.0, far.1, p, n, k, heap, r2);
        }
    }
}

/// Gather statistics of one photon-mapping pass (Table 2's "average/maximum K").
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PmStats {
    /// Photons in the global map.
    pub global_photons: usize,
    /// Photons in the caustic map.
    pub caustic_photons: usize,
    /// Mean photons gathered from the global map per splat target.
    pub mean_k_global: f64,
    /// Most photons gathered from the global map at one target.
    pub max_k_global: u32,
    /// Mean photons gathered from the caustic map per splat target.
    pub mean_k_caustic: f64,
    /// Most photons gathered from the caustic map at one target.
    pub max_k_caustic: u32,
}

/// Photon hits of `batches` (averaged over the batches) in a global map (direct photons when
/// `with_direct`, indirect photons) and a caustic map.
pub fn build_maps(batches: &[&[PhotonRay]], with_direct: bool) -> (PhotonMap, PhotonMap) {
    let scale = 1.0 / batches.len().max(1) as f32;
    let (mut global, mut caustic) = (Vec::new(), Vec::new());
    for rays in batches {
        for r in rays.iter().filter(|r| r.lands()) {
            let ph = MapPhoton {
                position: r.origin + r.dir * r.length,
                dir: r.dir,
                // Flux through the geometric surface, turned into the shading-normal cosine
                // the path tracer integrates (Veach 1997, §5.3; 1 on flat-shaded surfaces).
                power: r.power * (scale * r.end_shading_ratio),
            };
            match r.class() {
                PhotonClass::Caustic => caustic.push(ph),
                PhotonClass::Indirect => global.push(ph),
                PhotonClass::Direct if with_direct => global.push(ph),
                PhotonClass::Direct => {}
            }
        }
    }
    (PhotonMap::build(global), PhotonMap::build(caustic))
}

/// The largest directional record (histogram: 20 strata × 3 channels).
const MAX_RECORD: usize = 60;

/// Direct visualisation: the K-NN irradiance of both maps at every splat target, written into
/// `acc` (flux = E, weight = 1, weighted bandwidth = the global gather radius, count = photons
/// gathered), ready for [`crate::pipeline::radiance_map::RadianceMap::resolve_from`] with one batch.
/// Glossy targets with a directional record get the gathered photons' directions too (§8.1
/// applied to photon mapping: each photon's ΔΦ/(πr²) deposited from where it came).
#[allow(clippy::too_many_arguments)]
pub fn estimate_targets(
    global: &PhotonMap,
    caustic: &PhotonMap,
    positions: &[Vec3],
    normals: &[Vec3],
    target_slot: &[u32],
    k: (usize, usize),
    r_max: f32,
    acc: &mut Accumulators,
) -> PmStats {
    let mode = acc.mode;
    let floats = mode.record_floats();
    let has_record: Vec<bool> = target_slot
        .iter()
        .map(|&s| acc.record(s as usize).is_some())
        .collect();
    let results: Vec<(Estimate, Estimate, [f32; MAX_RECORD])> = positions
        .par_iter()
        .zip(normals)
        .zip(&has_record)
        .map_init(BinaryHeap::new, |heap, ((p, n), &directional)| {
            let mut rec = [0.0f32; MAX_RECORD];
            let mut gather = |map: &PhotonMap, k: usize, heap: &mut BinaryHeap<Candidate>| {
                let e = map.estimate(*p, *n, k, r_max, heap);
                if directional && e.found > 0 {
                    let area = std::f32::consts::PI * e.radius * e.radius;
                    for ph in map.gathered(heap) {
                        crate::pipeline::splat::RayDirection::new(ph.dir, mode).deposit(
                            &mut rec[..floats],
                            ph.power / area,
                            mode,
                        );
                    }
                }
                e
            };
            let g = gather(global, k.0, heap);
            let c = gather(caustic, k.1, heap);
            (g, c, rec)
        })
        .collect();
    acc.clear();
    let mut stats = PmStats {
        global_photons: global.len(),
        caustic_photons: caustic.len(),
        ..PmStats::default()
    };
    for (t, (g, c, rec)) in results.iter().enumerate() {
        let slot = target_slot[t] as usize;
        if let Some(dst) = acc.record_mut(slot) {
            dst.copy_from_slice(&rec[..floats]);
        }
        let e = g.irradiance + c.irradiance;
        acc.set(Channel::R, slot, e.x);
        acc.set(Channel::G, slot, e.y);
        acc.set(Channel::B, slot, e.z);
        acc.set(Channel::Weight, slot, 1.0);
        acc.set(Channel::WeightedH, slot, g.radius);
        acc.set(Channel::WeightedInvDist, slot, 0.0);
        acc.set(Channel::Count, slot, (g.found + c.found) as f32);
        stats.mean_k_global += g.found as f64;
        stats.mean_k_caustic += c.found as f64;
        stats.max_k_global = stats.max_k_global.max(g.found);
        stats.max_k_caustic = stats.max_k_caustic.max(c.found);
    }
    let n = results.len().max(1) as f64;
    stats.mean_k_global /= n;
    stats.mean_k_caustic /= n;
    stats
}

fn build(photons: &mut [MapPhoton], axis: &mut [u8]) {
    if photons.len() <= 1 {
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in photons.iter() {
        lo = lo.min(p.position);
        hi = hi.max(p.position);
    }
    let e = hi - lo;
    let a = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = photons.len() / 2;
    photons.select_nth_unstable_by(mid, |x, y| x.position[a].total_cmp(&y.position[a]));
    axis[mid] = a as u8;
    let (lp, rest) = photons.split_at_mut(mid);
    let (la, ra) = axis.split_at_mut(mid);
    build(lp, la);
    build(&mut rest[1..], &mut ra[1..]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn knn_matches_brute_force() {
        let mut rng = Rng::new(4, 4);
        let photons: Vec<MapPhoton> = (0..5000)
            .map(|_| MapPhoton {
                position: Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                dir: if rng.next_f32() < 0.8 {
                    -Vec3::Y
                } else {
                    Vec3::Y
                },
                power: Vec3::ONE,
            })
            .collect();
        let map = PhotonMap::build(photons.clone());
        let mut heap = BinaryHeap::new();
        for _ in 0..200 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let (k, r_max) = (
                1 + (rng.next_f32() * 60.0) as usize,
                0.05 + 0.3 * rng.next_f32(),
            );
            let e = map.estimate(p, Vec3::Y, k, r_max, &mut heap);
            let mut d: Vec<f32> = photons
                .iter()
                .filter(|q| q.dir.dot(Vec3::Y) < 0.0)
                .map(|q| q.position.distance_squared(p))
                .filter(|&d2| d2 < r_max * r_max)
                .collect();
            d.sort_by(f32::total_cmp);
            let found = d.len().min(k);
            assert_eq!(e.found as usize, found);
            let r2 = if found == k { d[k - 1] } else { r_max * r_max };
            let expect = found as f32 / (std::f32::consts::PI * r2);
            assert!((e.irradiance.x - expect).abs() <= 1e-4 * expect.max(1.0));
        }
    }
}
