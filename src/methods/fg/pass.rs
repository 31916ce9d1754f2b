//! One final-gathering pass: its eye side, direct light and caustics, then gather rays a band
//! of rows per step, and the estimates where they land.

use super::FgSettings;
use crate::methods::Timings;
use crate::pipeline::direct::direct_light;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::{EyePass, EyeSample, EyeSamples, EyeSettings, eye_pass};
use crate::pipeline::photon::{
    Bandwidth, ClassBudgets, HitDensity, LightPassSettings, PhotonBatch, PhotonClass, light_pass,
    pilot,
};
use crate::pipeline::photon_map::{PhotonMap, build_maps, estimate_targets};
use crate::pipeline::radiance_map::{Accumulators, RadianceMap};
use crate::pipeline::splat::{SplatBatch, prepare, splat};
use crate::pipeline::splat_tree::SplatTree;
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};
use crate::settings::RenderSettings;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// A gathering pass under way: the eye side, direct light and caustics are done; gather rays
/// are cast a band of rows per step.
pub(super) struct Pass {
    /// The pass's settings (its own seed).
    s: RenderSettings,
    fg: FgSettings,
    /// Eye samples, each its own target.
    eye: EyeSamples,
    /// Emission, direct light and caustics, plus the indirect light of the bands so far.
    pub(super) image: Vec<Vec3>,
    /// Photon maps (pm-fg) or the prepared photon rays (rs-fg).
    maps: Option<(PhotonMap, PhotonMap)>,
    /// rs-fg: the caustic photon rays, and every photon ray, prepared for splatting.
    caustic_rays: Option<SplatBatch>,
    all_rays: Option<SplatBatch>,
    r_max: f32,
    rows_per_band: u32,
    /// The first row not gathered yet.
    next_row: u32,
    pub(super) photons: u64,
}

impl Pass {
    /// Eye pass, direct light and one light pass with every class (gather hits need direct
    /// photons too).
    pub(super) fn start(
        scene: &Scene,
        camera: &Camera,
        splatting: bool,
        s: RenderSettings,
        fg: FgSettings,
        timings: &mut Timings,
    ) -> Self {
        let (w, h) = (s.width, s.height);
        let t = Instant::now();
        let EyePass {
            samples: eye,
            emitted,
            ..
        } = eye_pass(
            scene,
            camera,
            &EyeSettings {
                width: w,
                height: h,
                spp: s.spp,
                max_specular_depth: s.max_specular_depth,
                seed: s.seed,
                merge_targets: false,
                // Gather rays sample every eye sample's whole BSDF, its lobe included (§8.4):
                // that traces the lobe already.
                lobe_limit: f32::INFINITY,
                follow_lobes: true,
                light_samples: s.nee_samples,
            },
        );
        timings.t_eye += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let mut image = emitted;
        for (i, l) in direct_light(scene, &eye, s.nee_samples, s.seed)
            .0
            .iter()
            .enumerate()
        {
            image[eye.pixel[i] as usize] += eye.weight[i].get() * *l;
        }
        timings.t_direct += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let pilot = pilot(scene, s.seed);
        let batch: PhotonBatch = light_pass(
            scene,
            &LightPassSettings {
                budgets: ClassBudgets::from_fractions(s.photons, s.fractions, true),
                max_emitted_factor: s.max_emitted_factor,
                seed: s.seed,
                first_photon: 0,
                units: pilot.units(),
                guide: None,
            },
        );
        timings.t_light += t.elapsed().as_secs_f64();
        // The floor from the photons stored (docs/deviations.md §63), from this one batch.
        let mut phis = Vec::new();
        if splatting {
            HitDensity::for_pilot(&pilot, batch.stored.iter().sum()).add_batch(
                &batch.rays,
                batch.stored,
                &mut phis,
            );
        }
        let mean_r = pilot.mean_r(s.bandwidth.sensitivity_s);
        let bw = PhotonClass::ALL
            .map(|c| Bandwidth::new(&s.bandwidth, &pilot, batch.stored[c as usize], mean_r));
        let maps = (!splatting).then(|| build_maps(&[&batch.rays], true));
        // The same largest radius as rs's h_max (docs/deviations.md §18).
        let r_max = PhotonClass::ALL
            .iter()
            .filter(|&&c| batch.stored[c as usize] > 0)
            .map(|&c| bw[c as usize].h_max)
            .fold(0.0f32, f32::max);

        let t = Instant::now();
        let own_targets: Vec<u32> = (0..eye.len() as u32).collect();
        let eye = EyeSamples {
            target: own_targets,
            ..eye
        };
        let caustic_rays = splatting.then(|| {
            prepare(
                &batch.rays,
                &phis,
                &bw,
                [false, false, true],
                DirectionalMode::Diffuse,
                scene,
            )
        });
        let per_row = (eye.len() / h.max(1) as usize).max(1) * fg.rays as usize;
        let rows_per_band = (fg.max_band_samples / per_row.max(1)).clamp(1, h as usize) as u32;
        let all_rays = splatting.then(|| {
            prepare(
                &batch.rays,
                &phis,
                &bw,
                [true, true, true],
                DirectionalMode::Diffuse,
                scene,
            )
        });
        timings.t_splat += t.elapsed().as_secs_f64();
        Self {
            s,
            fg,
            eye,
            image,
            maps,
            caustic_rays,
            all_rays,
            r_max,
            rows_per_band,
            next_row: 0,
            photons: batch.traced,
        }
    }

    /// True when every row has been gathered.
    pub(super) fn done(&self) -> bool {
        self.next_row >= self.s.height
    }

    /// The caustics at the eye samples of the next band of rows, then its gather rays.
    pub(super) fn gather_band(&mut self, scene: &Scene, timings: &mut Timings) {
        let (w, h, s) = (self.s.width, self.s.height, &self.s);
        let n_pixels = (w * h) as usize;
        let y0 = self.next_row;
        let y1 = (y0 + self.rows_per_band).min(h);
        let (lo, hi) = (y0 * w, y1 * w);
        let t = Instant::now();
        let band_eye = eye_range(&self.eye, lo, hi);
        let (maps, caustic_rays, r_max) = (&self.maps, &self.caustic_rays, self.r_max);
        let caustic = estimate_at(&band_eye, n_pixels, w, h, |tree, acc| {
            if let Some((_, caustic_map)) = maps {
                let empty = PhotonMap::build(Vec::new());
                estimate_targets(
                    &empty,
                    caustic_map,
                    &band_eye.position,
                    &band_eye.normals(),
                    &tree.target_slot,
                    (0, s.pm_caustic_k),
                    r_max,
                    acc,
                );
            } else if let Some(rays) = caustic_rays {
                splat(tree, rays, acc, None);
            }
        });
        for (p, c) in self.image.iter_mut().zip(&caustic) {
            *p += *c;
        }
        timings.t_splat += t.elapsed().as_secs_f64();
        let tg = Instant::now();
        let band = gather_hits(scene, &self.eye, lo, hi, self.fg.rays, s.seed);
        timings.t_eye += tg.elapsed().as_secs_f64();
        let t = Instant::now();
        let (maps, all_rays, r_max) = (&self.maps, &self.all_rays, self.r_max);
        let indirect = estimate_at(&band, n_pixels, w, h, |tree, acc| {
            if let Some((global, caustic_map)) = maps {
                estimate_targets(
                    global,
                    caustic_map,
                    &band.position,
                    &band.normals(),
                    &tree.target_slot,
                    (s.pm_k, s.pm_caustic_k),
                    r_max,
                    acc,
                );
            } else if let Some(rays) = all_rays {
                splat(tree, rays, acc, None);
            }
        });
        for (p, c) in self.image.iter_mut().zip(&indirect) {
            *p += *c;
        }
        timings.t_splat += t.elapsed().as_secs_f64();
        self.next_row = y1;
    }
}

/// The eye samples of pixels `lo..hi` (pixel order), each its own target.
fn eye_range(eye: &EyeSamples, lo: u32, hi: u32) -> EyeSamples {
    let first = eye.pixel.partition_point(|&p| p < lo);
    let last = eye.pixel.partition_point(|&p| p < hi);
    let r = first..last;
    EyeSamples {
        position: eye.position[r.clone()].to_vec(),
        normal: eye.normal[r.clone()].to_vec(),
        geo_normal: eye.geo_normal[r.clone()].to_vec(),
        offset: eye.offset[r.clone()].to_vec(),
        wo: eye.wo[r.clone()].to_vec(),
        material: eye.material[r.clone()].to_vec(),
        pixel: eye.pixel[r.clone()].to_vec(),
        weight: eye.weight[r.clone()].to_vec(),
        albedo: eye.albedo[r.clone()].to_vec(),
        specular: eye.specular[r.clone()].to_vec(),
        alpha: eye.alpha[r.clone()].to_vec(),
        f90: eye.f90[r.clone()].to_vec(),
        flags: eye.flags[r.clone()].to_vec(),
        target: (0..r.len() as u32).collect(),
    }
}

/// Build a splat tree over `samples` (each its own target), fill accumulators with `fill`,
/// and resolve them into per-pixel radiance.
fn estimate_at(
    samples: &EyeSamples,
    n_pixels: usize,
    w: u32,
    h: u32,
    fill: impl FnOnce(&SplatTree, &mut Accumulators),
) -> Vec<Vec3> {
    if samples.is_empty() {
        return vec![Vec3::ZERO; n_pixels];
    }
    let tree = SplatTree::build(&samples.position, &samples.normals());
    let mut acc = Accumulators::new(tree.slots());
    fill(&tree, &mut acc);
    let mut map = RadianceMap::new(w, h);
    map.resolve_from(samples, &tree.target_slot, &acc, 1);
    map.radiance
}

/// Gather hits of the eye samples of pixels `lo..hi` (pixel order): each carries
/// weight · (f·cos/pdf) / N towards its pixel (BSDF sampling; f·cos/pdf = ρ for a Lambertian).
fn gather_hits(scene: &Scene, eye: &EyeSamples, lo: u32, hi: u32, n: u32, seed: u64) -> EyeSamples {
    let first = eye.pixel.partition_point(|&p| p < lo);
    let last = eye.pixel.partition_point(|&p| p < hi);
    // One vector per chunk of eye samples, not per sample.
    let per_chunk: Vec<Vec<EyeSample>> = (first..last)
        .collect::<Vec<usize>>()
        .par_chunks(256)
        .map(|chunk| {
            let mut out = Vec::with_capacity(chunk.len() * n as usize);
            for &i in chunk {
                gather_from(scene, eye, i, n, seed, &mut out);
            }
            out
        })
        .collect();
    let mut band = EyeSamples::default();
    for s in per_chunk.iter().flatten() {
        let t = band.len() as u32;
        band.push_sample(s, t);
    }
    band
}

/// Cast eye sample `i`'s `n` gather rays and push their non-specular hits.
fn gather_from(
    scene: &Scene,
    eye: &EyeSamples,
    i: usize,
    n: u32,
    seed: u64,
    out: &mut Vec<EyeSample>,
) {
    let mut rng = Rng::new(seed ^ 0xf1a1_9a7e, i as u64);
    let (p, nrm) = (eye.position[i], eye.normal[i].get());
    let bsdf = eye.bsdf(i);
    let (ng, offset) = (eye.geo_normal[i].get(), eye.offset[i].get());
    for _ in 0..n {
        // BSDF sampling (cosine sampling for a Lambertian: f·cos/pdf = ρ).
        let Some(s) = bsdf.sample(eye.wo[i].get(), nrm, rng.next_2d(), rng.next_f32()) else {
            continue;
        };
        let (dir, weight) = (s.wi, eye.weight[i].get() * s.weight / n as f32);
        if ng.dot(dir) <= 0.0 {
            continue; // through the geometric surface (deviations §36)
        }
        let origin = crate::scene::offset_ray_origin(p, ng, offset, dir);
        let Some(hit) = scene.intersect(origin, dir, f32::INFINITY) else {
            continue;
        };
        // One read of the hit's textures for both the test and the shading below.
        let bsdf = scene.bsdf(&hit);
        if !bsdf.is_reflecting() {
            continue;
        }
        let (facing, geo_facing) = if hit.geo_normal.dot(dir) <= 0.0 {
            (hit.normal, hit.geo_normal)
        } else {
            (-hit.normal, -hit.geo_normal)
        };
        out.push(EyeSample {
            position: hit.position,
            normal: facing,
            geo_normal: geo_facing,
            offset: hit.offset,
            wo: -dir,
            material: hit.material,
            pixel: eye.pixel[i],
            weight,
            // Gather hits are shaded as matte with the BSDF's whole reflectance (§8.4 uses no
            // radiance map there; docs/deviations.md).
            albedo: match bsdf {
                crate::bsdf::Bsdf::Glossy { .. } => {
                    let (diffuse, specular) = bsdf.layer_albedos(-dir.dot(facing));
                    diffuse + specular
                }
                _ => scene.albedo(&hit),
            },
            specular: Vec3::ZERO,
            alpha: 1.0,
            f90: 0.0,
            primary: false,
            lobe_traced: false,
        });
    }
}
