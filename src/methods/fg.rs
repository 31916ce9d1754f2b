//! Final gathering (§8.4): N gather rays per eye sample, cosine-distributed; photon density is
//! estimated where they land instead of at the eye samples. Ray splatting stores the gather hits
//! as eye samples and splats the same photon rays onto them, a band of image rows at a time to
//! bound memory (the paper's tiles); photon mapping queries its maps there.
//!
//! Paths are split without overlap: emission seen directly; direct light by NEE at the eye
//! sample; caustics (L S+ D E) by splatting caustic photons (rs-fg) or the caustic map (pm-fg)
//! at the eye sample; everything else through a gather ray that lands on a non-specular surface
//! (gather rays that meet emitters or specular surfaces add nothing: the terms above hold them).

use crate::film::Film;
use crate::methods::{Method, MethodStats, Step, Timings};
use crate::pipeline::direct::direct_light;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::eye::{EyePass, EyeSample, EyeSamples, EyeSettings, eye_pass};
use crate::pipeline::photon::{
    Bandwidth, ClassBudgets, LightPassSettings, PhotonBatch, PhotonClass, light_pass, pilot,
};
use crate::pipeline::photon_map::{PhotonMap, build_maps, estimate_targets};
use crate::pipeline::radiance_map::{Accumulators, RadianceMap};
use crate::pipeline::splat::{SplatBatch, prepare, splat};
use crate::pipeline::splat_tree::SplatTree;
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};
use crate::settings::{MethodKind, RenderSettings};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// How final gathering bounds its work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FgSettings {
    /// Gather rays per eye sample.
    pub rays: u32,
    /// At most this many gather hits are splatted or gathered at once (a band of rows).
    pub max_band_samples: usize,
}

impl Default for FgSettings {
    fn default() -> Self {
        Self {
            rays: 64,
            // About a second of gathering per band on two cores: small enough that a time
            // budget or Ctrl-C is honoured within a step, large enough to amortise the tree.
            max_band_samples: 1 << 17,
        }
    }
}

/// Final gathering as a progressive method: every step is one independent pass (fresh
/// photons and gather rays, seed advanced per pass) and the film is their mean.
pub struct FinalGathering {
    scene: Arc<Scene>,
    settings: RenderSettings,
    camera: Camera,
    sum: Vec<Vec3>,
    /// Completed passes.
    passes: u64,
    /// The pass under way.
    current: Option<Pass>,
    photons: u64,
    timings: Timings,
}

impl FinalGathering {
    /// Final gathering over splatted rays (`settings.method` = rs-fg) or photon maps (pm-fg).
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
    ) -> Result<Self, String> {
        if !matches!(settings.method, MethodKind::RsFg | MethodKind::PmFg) {
            return Err(format!(
                "{:?} is not a final-gathering method",
                settings.method
            ));
        }
        let n = (settings.width * settings.height) as usize;
        Ok(Self {
            scene,
            settings,
            camera,
            sum: vec![Vec3::ZERO; n],
            passes: 0,
            current: None,
            photons: 0,
            timings: Timings::default(),
        })
    }
}

impl Method for FinalGathering {
    fn kind(&self) -> MethodKind {
        self.settings.method
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Start a pass (eye side, direct light, photons, caustics), or gather one band of rows
    /// of the pass under way; a finished pass joins the mean.
    fn step(&mut self) -> Step {
        match self.current.as_mut() {
            None => {
                let s = RenderSettings {
                    seed: self.settings.seed.wrapping_add(self.passes * 0x9e37),
                    ..self.settings.clone()
                };
                let fg = FgSettings {
                    rays: s.fg_rays.max(1),
                    ..FgSettings::default()
                };
                let splatting = self.settings.method == MethodKind::RsFg;
                let pass = Pass::start(
                    &self.scene,
                    &self.camera,
                    splatting,
                    s,
                    fg,
                    &mut self.timings,
                );
                self.photons += pass.photons;
                self.current = Some(pass);
            }
            Some(pass) => pass.gather_band(&self.scene, &mut self.timings),
        }
        if self.current.as_ref().is_some_and(Pass::done) {
            let pass = self.current.take().expect("a pass under way");
            for (a, x) in self.sum.iter_mut().zip(&pass.image) {
                *a += *x;
            }
            self.passes += 1;
        }
        Step::Traced
    }

    /// Gathering depends on the view: a new one starts from no passes.
    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), String> {
        let settings = self.settings.with_view(width, height, spp);
        crate::methods::check(&settings)?;
        self.settings = settings;
        self.camera = camera;
        self.sum = vec![Vec3::ZERO; (width * height) as usize];
        self.passes = 0;
        self.current = None;
        Ok(())
    }

    fn update(&mut self, settings: &RenderSettings) -> Result<(), String> {
        self.settings.photons = settings.photons;
        self.settings.bandwidth = settings.bandwidth;
        Ok(())
    }

    /// The mean of the completed passes; before the first completes, the pass under way
    /// (rows not gathered yet hold direct light and caustics only).
    fn film(&mut self) -> Film {
        let mut film = Film::new(self.settings.width, self.settings.height);
        match (&self.current, self.passes) {
            (Some(pass), 0) => film.rgb.copy_from_slice(&pass.image),
            _ => {
                let inv = 1.0 / self.passes.max(1) as f32;
                for (o, a) in film.rgb.iter_mut().zip(&self.sum) {
                    *o = *a * inv;
                }
            }
        }
        film
    }

    fn passes(&self) -> u64 {
        self.passes
    }

    fn timings(&self) -> Timings {
        self.timings
    }

    fn stats(&mut self) -> MethodStats {
        MethodStats {
            photons_traced: self.photons,
            passes: self.passes,
            ..MethodStats::default()
        }
    }
}

/// A gathering pass under way: the eye side, direct light and caustics are done; gather rays
/// are cast a band of rows per step.
struct Pass {
    /// The pass's settings (its own seed).
    s: RenderSettings,
    fg: FgSettings,
    /// Eye samples, each its own target.
    eye: EyeSamples,
    /// Emission, direct light and caustics, plus the indirect light of the bands so far.
    image: Vec<Vec3>,
    /// Photon maps (pm-fg) or the prepared photon rays (rs-fg).
    maps: Option<(PhotonMap, PhotonMap)>,
    /// rs-fg: the caustic photon rays, and every photon ray, prepared for splatting.
    caustic_rays: Option<SplatBatch>,
    all_rays: Option<SplatBatch>,
    r_max: f32,
    rows_per_band: u32,
    /// The first row not gathered yet.
    next_row: u32,
    photons: u64,
}

impl Pass {
    /// Eye pass, direct light and one light pass with every class (gather hits need direct
    /// photons too).
    fn start(
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
            },
        );
        timings.t_light += t.elapsed().as_secs_f64();
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
    fn done(&self) -> bool {
        self.next_row >= self.s.height
    }

    /// The caustics at the eye samples of the next band of rows, then its gather rays.
    fn gather_band(&mut self, scene: &Scene, timings: &mut Timings) {
        let (w, h, s) = (self.s.width, self.s.height, &self.s);
        let n_pixels = (w * h) as usize;
        let y0 = self.next_row;
        let y1 = (y0 + self.rows_per_band).min(h);
        let (lo, hi) = (y0 * w, y1 * w);
        let t = Instant::now();
        let band_eye = eye_range(&self.eye, lo, hi);
        let (maps, caustic_rays, r_max) = (&self.maps, &self.caustic_rays, self.r_max);
        let caustic = estimate_at(&band_eye, n_pixels, w, h, scene, |tree, acc| {
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
        let indirect = estimate_at(&band, n_pixels, w, h, scene, |tree, acc| {
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
    scene: &Scene,
    fill: impl FnOnce(&SplatTree, &mut Accumulators),
) -> Vec<Vec3> {
    if samples.is_empty() {
        return vec![Vec3::ZERO; n_pixels];
    }
    let tree = SplatTree::build(&samples.position, &samples.normals());
    let mut acc = Accumulators::new(tree.slots());
    fill(&tree, &mut acc);
    let mut map = RadianceMap::new(w, h);
    map.resolve_from(scene, samples, &tree.target_slot, &acc, 1);
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
    let bsdf = eye.bsdf(i, scene);
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
        if scene.materials[hit.material as usize].is_specular() {
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
            albedo: match scene.bsdf(&hit) {
                crate::bsdf::Bsdf::Glossy { kd, ks, .. } => kd + ks,
                _ => scene.albedo(&hit),
            },
            specular: Vec3::ZERO,
            primary: false,
            lobe_traced: false,
        });
    }
}
