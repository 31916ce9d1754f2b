//! Eye pass (§3): camera rays, deterministic specular chains, and the eye samples stored at
//! the first non-specular hit (structure of arrays).
//!
//! Specular chains are followed deterministically: a mirror reflects, a dielectric splits into
//! its reflected and refracted branches weighted by Fresnel, up to `max_specular_depth`.
//! Emission seen directly or through a chain goes straight to the film (`emitted`).

use crate::bsdf::{Bsdf, fresnel_dielectric, reflect, refract};
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Branches whose weight falls below this are dropped (they cannot change a pixel visibly).
const MIN_BRANCH_WEIGHT: f32 = 1e-3;
/// Pending specular branches per camera ray.
const BRANCH_STACK: usize = 16;

#[derive(Clone, Copy, Debug)]
pub struct EyeSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_specular_depth: u32,
    pub seed: u64,
}

/// Eye samples, structure of arrays. Index order is the splat kd-tree's leaf order once
/// [`crate::splat_tree::SplatTree::build`] has permuted them.
#[derive(Clone, Debug, Default)]
pub struct EyeSamples {
    pub position: Vec<Vec3>,
    /// Shading normal, flipped to face the viewer.
    pub normal: Vec<Vec3>,
    /// Unit direction towards the viewer (the previous vertex of the eye path).
    pub wo: Vec<Vec3>,
    pub material: Vec<u32>,
    pub pixel: Vec<u32>,
    /// RGB path weight: specular-chain throughput / samples per pixel.
    pub weight: Vec<Vec3>,
    /// Diffuse albedo at the sample (texture applied).
    pub albedo: Vec<Vec3>,
}

impl EyeSamples {
    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Reorder every array by `order` (new index i takes old index order[i]).
    pub fn permute(&mut self, order: &[u32]) {
        fn apply<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            *v = order.iter().map(|&i| v[i as usize]).collect();
        }
        apply(&mut self.position, order);
        apply(&mut self.normal, order);
        apply(&mut self.wo, order);
        apply(&mut self.material, order);
        apply(&mut self.pixel, order);
        apply(&mut self.weight, order);
        apply(&mut self.albedo, order);
    }

    /// Bytes held by the sample arrays.
    pub fn memory_bytes(&self) -> usize {
        self.len() * (4 * 12 + 2 * 4 + 12)
    }

    fn push(&mut self, s: &RawSample) {
        self.position.push(s.position);
        self.normal.push(s.normal);
        self.wo.push(s.wo);
        self.material.push(s.material);
        self.pixel.push(s.pixel);
        self.weight.push(s.weight);
        self.albedo.push(s.albedo);
    }
}

#[derive(Clone, Copy)]
struct RawSample {
    position: Vec3,
    normal: Vec3,
    wo: Vec3,
    material: u32,
    pixel: u32,
    weight: Vec3,
    albedo: Vec3,
}

/// What the eye pass produced.
pub struct EyePass {
    pub samples: EyeSamples,
    /// Emitted radiance reaching each pixel directly or through specular chains.
    pub emitted: Vec<Vec3>,
}

/// Sub-pixel position of sample `s` of `spp`: stratified on a grid when spp is a square,
/// otherwise uniformly jittered.
fn jitter(s: u32, spp: u32, rng: &mut Rng) -> Vec2 {
    let g = (spp as f32).sqrt() as u32;
    if g * g == spp && g > 1 {
        let (i, j) = (s % g, s / g);
        (Vec2::new(i as f32, j as f32) + rng.next_2d()) / g as f32
    } else {
        rng.next_2d()
    }
}

/// Run the eye pass for `camera` over the whole image.
pub fn eye_pass(scene: &Scene, camera: &Camera, s: &EyeSettings) -> EyePass {
    let aspect = s.width as f32 / s.height as f32;
    let rows: Vec<(Vec<RawSample>, Vec<Vec3>)> = (0..s.height)
        .into_par_iter()
        .map(|y| {
            let mut out = Vec::with_capacity((s.width * s.spp) as usize);
            let mut emitted = vec![Vec3::ZERO; s.width as usize];
            for x in 0..s.width {
                let pixel = y * s.width + x;
                let mut rng = Rng::new(s.seed, 0x1000_0000_0000 + pixel as u64);
                for k in 0..s.spp {
                    let j = jitter(k, s.spp, &mut rng);
                    let dir = camera.direction(
                        (x as f32 + j.x) / s.width as f32,
                        (y as f32 + j.y) / s.height as f32,
                        aspect,
                    );
                    let w = Vec3::splat(1.0 / s.spp as f32);
                    emitted[x as usize] += trace_chain(
                        scene,
                        camera.position,
                        dir,
                        w,
                        pixel,
                        s.max_specular_depth,
                        &mut out,
                    );
                }
            }
            (out, emitted)
        })
        .collect();
    let total: usize = rows.iter().map(|r| r.0.len()).sum();
    let mut samples = EyeSamples::default();
    for v in [
        &mut samples.position,
        &mut samples.normal,
        &mut samples.wo,
        &mut samples.weight,
        &mut samples.albedo,
    ] {
        v.reserve_exact(total);
    }
    samples.material.reserve_exact(total);
    samples.pixel.reserve_exact(total);
    let mut emitted = Vec::with_capacity((s.width * s.height) as usize);
    for (row, em) in rows {
        for r in &row {
            samples.push(r);
        }
        emitted.extend(em);
    }
    EyePass { samples, emitted }
}

/// Follow one camera ray through specular chains; push eye samples, return emitted radiance.
fn trace_chain(
    scene: &Scene,
    origin: Vec3,
    dir: Vec3,
    weight: Vec3,
    pixel: u32,
    max_depth: u32,
    out: &mut Vec<RawSample>,
) -> Vec3 {
    let mut stack = [(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0u32); BRANCH_STACK];
    stack[0] = (origin, dir, weight, 0);
    let mut top = 1;
    let mut emitted = Vec3::ZERO;
    while top > 0 {
        top -= 1;
        let (o, d, w, depth) = stack[top];
        let Some(hit) = scene.intersect(o, d, f32::INFINITY) else {
            continue;
        };
        let wo = -d;
        emitted += w * scene.emitted(&hit, wo);
        let bsdf = scene.bsdf(&hit);
        let mut push = |o: Vec3, d: Vec3, w: Vec3, top: &mut usize| {
            if w.max_element() >= MIN_BRANCH_WEIGHT && *top < BRANCH_STACK {
                stack[*top] = (o, d, w, depth + 1);
                *top += 1;
            }
        };
        match bsdf {
            Bsdf::Lambert { albedo } => {
                // Face the viewer: flip both normals to the side the ray came from.
                let n = if hit.geo_normal.dot(wo) >= 0.0 {
                    hit.normal
                } else {
                    -hit.normal
                };
                out.push(RawSample {
                    position: hit.position,
                    normal: n,
                    wo,
                    material: hit.material,
                    pixel,
                    weight: w,
                    albedo,
                });
            }
            _ if depth >= max_depth => {}
            Bsdf::Mirror { color } => {
                let n = if hit.normal.dot(wo) >= 0.0 {
                    hit.normal
                } else {
                    -hit.normal
                };
                let r = reflect(wo, n);
                push(scene.offset(&hit, r), r, w * color, &mut top);
            }
            Bsdf::Dielectric { ior, tint } => {
                let cos_o = wo.dot(hit.normal);
                let (eta, n) = if cos_o > 0.0 {
                    (1.0 / ior, hit.normal)
                } else {
                    (ior, -hit.normal)
                };
                let f = fresnel_dielectric(cos_o.abs(), eta);
                let r = reflect(wo, n);
                push(scene.offset(&hit, r), r, w * f, &mut top);
                if let Some(t) = refract(wo, n, eta) {
                    push(scene.offset(&hit, t), t, w * tint * (1.0 - f), &mut top);
                }
            }
        }
    }
    emitted
}
