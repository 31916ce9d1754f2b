//! Meshes of the built-in scenes: the bumpy floor, Cornell blocks, the icosahedron and UV spheres.

use super::cornell;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Height field of the bumpy floor: two crossed high-frequency ripples plus a finer diagonal one,
/// about ±6 mm, so photon mapping's tangent-plane assumption fails on it (paper Fig. 9a).
fn floor_height(x: f32, z: f32) -> (f32, Vec2) {
    let (k1, k2, k3) = (2.0 * PI / 0.045, 2.0 * PI / 0.05, 2.0 * PI / 0.023);
    let (a1, a3) = (0.004, 0.002);
    let s = (x + z) * k3;
    let h = a1 * (k1 * x).sin() * (k2 * z).cos() + a3 * s.sin();
    let dhdx = a1 * k1 * (k1 * x).cos() * (k2 * z).cos() + a3 * k3 * s.cos();
    let dhdz = -a1 * k2 * (k1 * x).sin() * (k2 * z).sin() + a3 * k3 * s.cos();
    (h, Vec2::new(dhdx, dhdz))
}

/// An n×n grid (2n² triangles) between two floor corners, displaced by `floor_height`.
pub(super) fn bumpy_floor_mesh(a: Vec3, b: Vec3, n: usize) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let (min, max) = (a.min(b), a.max(b));
    let mut p = Vec::with_capacity((n + 1) * (n + 1));
    let mut nn = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let x = min.x + (max.x - min.x) * i as f32 / n as f32;
            let z = min.z + (max.z - min.z) * j as f32 / n as f32;
            let (h, g) = floor_height(x, z);
            p.push(Vec3::new(x, h, z));
            nn.push(Vec3::new(-g.x, 1.0, -g.y).normalize());
        }
    }
    let mut idx = Vec::with_capacity(6 * n * n);
    let w = (n + 1) as u32;
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let (v00, v10, v01, v11) = (
                j * w + i,
                j * w + i + 1,
                (j + 1) * w + i,
                (j + 1) * w + i + 1,
            );
            // Counter-clockwise seen from above (+Y).
            idx.extend_from_slice(&[v00, v01, v10, v10, v01, v11]);
        }
    }
    (p, nn, idx)
}

/// Quads with flat normals, wound so the front face looks along `normal`.
#[derive(Default)]
pub(super) struct Quads {
    pub(super) p: Vec<Vec3>,
    pub(super) n: Vec<Vec3>,
    pub(super) i: Vec<u32>,
}

impl Quads {
    pub(super) fn add(&mut self, c: [Vec3; 4], normal: Vec3) {
        let base = self.p.len() as u32;
        let face = (c[1] - c[0]).cross(c[2] - c[0]);
        let order: [usize; 4] = if face.dot(normal) >= 0.0 {
            [0, 1, 2, 3]
        } else {
            [0, 3, 2, 1]
        };
        for k in order {
            self.p.push(c[k]);
            self.n.push(normal.normalize());
        }
        self.i
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
}

/// A Cornell block: top quad (x, z in mm) at `height`, sides down to the floor, outward normals.
pub(super) fn block(top: [[f32; 2]; 4], height: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let mut q = Quads::default();
    let t: Vec<Vec3> = top.iter().map(|v| cornell(v[0], height, v[1])).collect();
    let b: Vec<Vec3> = top.iter().map(|v| cornell(v[0], 0.0, v[1])).collect();
    let center = t.iter().chain(&b).sum::<Vec3>() / 8.0;
    q.add([t[0], t[1], t[2], t[3]], Vec3::Y);
    for k in 0..4 {
        let k1 = (k + 1) % 4;
        let quad = [b[k], b[k1], t[k1], t[k]];
        let mid = (b[k] + t[k1]) * 0.5;
        let e = t[k1] - t[k];
        let mut nrm = e.cross(Vec3::Y).normalize();
        if nrm.dot(mid - center) < 0.0 {
            nrm = -nrm;
        }
        q.add(quad, nrm);
    }
    (q.p, q.n, q.i)
}

/// A regular icosahedron with flat faces (20 triangles, unshared vertices).
pub(super) fn icosahedron(center: Vec3, radius: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let phi = (1.0 + 5f32.sqrt()) / 2.0;
    let v: Vec<Vec3> = [
        [-1.0, phi, 0.0],
        [1.0, phi, 0.0],
        [-1.0, -phi, 0.0],
        [1.0, -phi, 0.0],
        [0.0, -1.0, phi],
        [0.0, 1.0, phi],
        [0.0, -1.0, -phi],
        [0.0, 1.0, -phi],
        [phi, 0.0, -1.0],
        [phi, 0.0, 1.0],
        [-phi, 0.0, -1.0],
        [-phi, 0.0, 1.0],
    ]
    .iter()
    .map(|a| Vec3::from(*a).normalize())
    .collect();
    let faces: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let (mut p, mut n, mut i) = (Vec::new(), Vec::new(), Vec::new());
    for f in faces {
        let (a, b, c) = (v[f[0]], v[f[1]], v[f[2]]);
        let mut nrm = (b - a).cross(c - a).normalize();
        let (b, c) = if nrm.dot(a + b + c) < 0.0 {
            nrm = -nrm;
            (c, b)
        } else {
            (b, c)
        };
        for vert in [a, b, c] {
            i.push(p.len() as u32);
            p.push(center + vert * radius);
            n.push(nrm);
        }
    }
    (p, n, i)
}

/// A UV sphere with smooth normals: (positions, normals, indices).
pub fn uv_sphere(
    center: Vec3,
    radius: f32,
    segments: u32,
    rings: u32,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..=rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            p.push(center + d * radius);
            n.push(d);
        }
    }
    let w = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * w + s,
                r * w + s + 1,
                (r + 1) * w + s,
                (r + 1) * w + s + 1,
            );
            // Outward-facing (counter-clockwise seen from outside); skip the degenerate pole triangles.
            if r != 0 {
                idx.extend_from_slice(&[a, b, c]);
            }
            if r != rings - 1 {
                idx.extend_from_slice(&[b, d, c]);
            }
        }
    }
    (p, n, idx)
}
