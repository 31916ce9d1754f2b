//! Partial visibility inside the splat footprint (the paper's §10 limitation: "light leakage due
//! to the neglected visibility in the splat footprint"; docs/deviations.md §40).
//!
//! A splat target looks around itself once, when the tree is built: [`PROBES`] rays at
//! [`PROBE_ELEVATION_DEG`] above its tangent plane, evenly spread in azimuth. The planes of the
//! nearest two distinct surfaces they hit are kept, each facing the target: a wall beside a
//! floor sample, the floor beside a wall sample. While splatting, a photon ray's point nearest
//! to the target that lies behind one of these planes marks the pair as a *candidate* for
//! leakage, and a shadow ray from the target to that point decides (`splat::pass`). Pairs in
//! front of every plane are splatted as before without a ray, so the planes only choose which
//! pairs are tested, never reject one themselves: a chair leg's plane costs shadow rays, not
//! light. A wall the probes miss (a probe leaving through a window) is not tested, which is the
//! remaining leak.

use super::{LANES, PADDING, SplatTree};
use crate::sampling::onb;
use crate::scene::{Scene, surface_offset};
use glam::Vec3;
use rayon::prelude::*;

/// Azimuths probed per splat target.
pub const AZIMUTHS: usize = 8;
/// Elevations of the probes above the target's tangent plane, degrees. A plane counts as a
/// blocker only when probes at both elevations meet it: a wall or a ceiling, which rises
/// from near the target's tangent plane, is met by both; the facets of a bumpy floor (met
/// only low), the target's own gently curved surface (left by both) and a sphere nearby
/// (met at two different tangent planes) are not. Those would otherwise turn the whole
/// kernel into shadow rays and cut it short where nothing separates two regions of light.
pub const PROBE_ELEVATIONS_DEG: [f32; 2] = [20.0, 45.0];
/// Probe rays per splat target.
pub const PROBES: usize = AZIMUTHS * PROBE_ELEVATIONS_DEG.len();
/// Planes kept per target.
pub const BLOCKERS: usize = 4;

/// The blocker planes of one chunk of [`LANES`] slots, structure of arrays: plane `j` of lane
/// `l` is {x : m·x = d} with m = (`plane[j][0][l]`, `plane[j][1][l]`, `plane[j][2][l]`) facing the
/// target and d = `plane[j][3][l]`. A lane without that plane holds zeros, for which m·q − d = 0
/// is never behind.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct BlockerChunk {
    /// `plane[j]` = [m.x, m.y, m.z, d] of the lanes' j-th plane.
    pub plane: [[[f32; LANES]; 4]; BLOCKERS],
    /// The triangle a probe met on plane `j` (meaningless where the plane is zero): a shadow
    /// ray is first tested against it alone, which settles many blocked pairs without the BVH.
    pub triangle: [[u32; LANES]; BLOCKERS],
    /// The lanes' geometric normals (x, y, z), facing the viewer: shadow rays leave the target
    /// on that side (a shading normal can lean away from the surface).
    pub own: [[f32; LANES]; 3],
}

/// A plane {x : m·x = d} with m facing the target, and the triangle on it a probe met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocker {
    /// Unit normal facing the target (zero: no plane).
    pub m: Vec3,
    /// Offset: m·x = d on the plane.
    pub d: f32,
    /// The triangle met.
    pub triangle: u32,
}

impl Blocker {
    const NONE: Self = Self {
        m: Vec3::ZERO,
        d: 0.0,
        triangle: 0,
    };

    /// Another triangle of the same plane (10°, and 0.1% of the distance `dist` it was met at).
    fn same_plane(&self, o: &Self, dist: f32) -> bool {
        self.m.dot(o.m) > 0.985 && (self.d - o.d).abs() <= 1e-3 * dist
    }
}

/// The planes of the nearest [`BLOCKERS`] distinct surfaces around `p` (unit normal `n`) met
/// by probes at every elevation; the rest [`Blocker::NONE`]-like zeros.
pub fn probe(scene: &Scene, p: Vec3, n: Vec3) -> [Blocker; BLOCKERS] {
    let mut out = [Blocker::NONE; BLOCKERS];
    if !n.is_finite() || n == Vec3::ZERO || !p.is_finite() {
        return out;
    }
    let (t, b) = onb(n);
    // Just off the surface, on its front: the target's position carries the rounding of the
    // triangle it lies on, a few ulps of its largest coordinate.
    let origin = p + n * surface_offset(p.abs().max_element());
    // (distance, plane, bit of the elevation that met it)
    let mut hits = [(f32::INFINITY, Blocker::NONE, 0u8); PROBES];
    for (e, elevation) in PROBE_ELEVATIONS_DEG.iter().enumerate() {
        let (se, ce) = elevation.to_radians().sin_cos();
        for k in 0..AZIMUTHS {
            let phi = std::f32::consts::TAU * k as f32 / AZIMUTHS as f32;
            let (s, c) = phi.sin_cos();
            let dir = t * (c * ce) + b * (s * ce) + n * se;
            if let Some(hit) = scene.intersect(origin, dir, f32::INFINITY) {
                let g = hit.geo_normal;
                let m = if g.dot(dir) < 0.0 { g } else { -g };
                let plane = Blocker {
                    m,
                    d: m.dot(hit.position),
                    triangle: hit.triangle,
                };
                hits[e * AZIMUTHS + k] = (hit.t, plane, 1 << e);
            }
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Group the hits by plane, nearest first, noting which elevations met each.
    let mut planes = [(Blocker::NONE, 0u8); PROBES];
    let mut count = 0;
    for &(dist, plane, bit) in hits.iter().take_while(|h| h.0.is_finite()) {
        match planes[..count]
            .iter_mut()
            .find(|(o, _)| plane.same_plane(o, dist))
        {
            Some((_, bits)) => *bits |= bit,
            None => {
                planes[count] = (plane, bit);
                count += 1;
            }
        }
    }
    let every = (1u8 << PROBE_ELEVATIONS_DEG.len()) - 1;
    let confirmed = planes[..count].iter().filter(|(_, bits)| *bits == every);
    for (slot, (plane, _)) in out.iter_mut().zip(confirmed) {
        *slot = *plane;
    }
    out
}

impl SplatTree {
    /// Probe every target's surroundings for blocker planes (module docs), so that splatting
    /// with `scene` tests visibility where a photon ray passes behind one of them.
    /// `geo_normals` are the targets' geometric normals, in target order: the probes and the
    /// shadow rays leave from that plane (a shading normal can lean away from the surface).
    pub fn find_blockers(&mut self, scene: &Scene, geo_normals: &[Vec3]) {
        assert_eq!(geo_normals.len(), self.samples);
        let (pts, slot_target) = (&self.points.chunks, &self.slot_target);
        self.blockers = pts
            .par_iter()
            .enumerate()
            .map(|(k, c)| {
                let mut out = BlockerChunk::default();
                for l in 0..LANES {
                    let target = slot_target[k * LANES + l];
                    if target == PADDING {
                        continue;
                    }
                    let n = geo_normals[target as usize];
                    (out.own[0][l], out.own[1][l], out.own[2][l]) = (n.x, n.y, n.z);
                    let p = Vec3::new(c.px[l], c.py[l], c.pz[l]);
                    for (j, b) in probe(scene, p, n).into_iter().enumerate() {
                        out.plane[j][0][l] = b.m.x;
                        out.plane[j][1][l] = b.m.y;
                        out.plane[j][2][l] = b.m.z;
                        out.plane[j][3][l] = b.d;
                        out.triangle[j][l] = b.triangle;
                    }
                }
                out
            })
            .collect();
    }

    /// The tree knows its targets' blocker planes ([`SplatTree::find_blockers`]).
    pub fn has_blockers(&self) -> bool {
        !self.blockers.is_empty()
    }
}
