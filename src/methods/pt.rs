//! The built-in reference: an unbiased path tracer with next-event estimation and multiple
//! importance sampling (power heuristic) over the same BSDFs and lights as the splatter.
//! Progressive: each call adds samples per pixel; every sample has its own random stream.

use crate::film::Film;
use crate::film::estimate::of_independent_samples;
use crate::methods::{Method, MethodError, MethodStats, Step, Timings};
use crate::pipeline::direct::{bsdf_emission_weight, escaped_weight};
use crate::sampling::{Rng, luminance, power_heuristic};
use crate::scene::{Camera, Scene};
use crate::settings::{MethodKind, RenderSettings};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Russian roulette starts after this many bounces.
const RR_DEPTH: u32 = 3;

/// The path tracer's own settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PtSettings {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Path length limit (Russian roulette ends almost all paths long before).
    pub max_depth: u32,
    /// Seed of every path's random stream.
    pub seed: u64,
    /// Paths end at their non-specular vertex after this many (emission found there still
    /// counts): `u32::MAX` for full global illumination, 1 for direct light and caustics only
    /// (E S* D S* L), the transport that photon classes (direct, 0, caustic) carry
    /// ([`max_diffuse_vertices_for`]).
    pub max_diffuse_vertices: u32,
}

impl PtSettings {
    /// The path tracer as a reference for a render of `width` × `height` with these photon
    /// `fractions`: the same transport ([`max_diffuse_vertices_for`]) and paths long enough
    /// for Russian roulette to end them.
    pub fn matching(width: u32, height: u32, seed: u64, fractions: [f32; 3]) -> Self {
        Self {
            width,
            height,
            max_depth: 64,
            seed,
            max_diffuse_vertices: max_diffuse_vertices_for(fractions),
        }
    }
}

/// The path tracer's [`PtSettings::max_diffuse_vertices`] for the transport that the photon
/// fractions (direct, indirect, caustic) of Table 2 carry: with no indirect-diffuse photons
/// (CORNELL BOX II's row) the splatting methods render direct light and caustics only, and a
/// reference of full global illumination would count the missing indirect light as their
/// error (docs/deviations.md §6).
pub fn max_diffuse_vertices_for(fractions: [f32; 3]) -> u32 {
    if fractions[1] > 0.0 { u32::MAX } else { 1 }
}

/// The progressive path tracer: per-pixel sums of independent paths.
pub struct PathTracer {
    /// The scene.
    pub scene: Arc<Scene>,
    /// The camera.
    pub camera: Camera,
    /// Its own settings.
    pub settings: PtSettings,
    /// The render settings it was built from (`pt_spp` paths per pixel per step).
    render: RenderSettings,
    sum: Vec<Vec3>,
    /// Σ of each path's squared luminance per pixel: the image's own variance
    /// ([`crate::film::estimate::of_independent_samples`]).
    sum_sq: Vec<f64>,
    spp: u32,
    /// Contributions dropped because they were NaN or infinite.
    pub invalid: u64,
    timings: Timings,
    /// The window's flag for a new view ([`Method::set_stop`]): a pass under way stops
    /// between rows, since the new view starts the paths again.
    stop: Option<Arc<AtomicBool>>,
    /// With a stop flag, the pass being traced (sum and squared luminance per pixel), added
    /// to the sums once whole; kept between passes.
    pass: (Vec<Vec3>, Vec<f64>),
}

/// What one pass of the path tracer reads.
#[derive(Clone, Copy)]
struct View<'a> {
    scene: &'a Scene,
    camera: &'a Camera,
    settings: PtSettings,
    /// Paths per pixel already traced: the pass's streams start after them.
    first: u32,
}

/// Add `n` paths per pixel of `view` into `sum` and `sum_sq` (row by row, in parallel);
/// the count of NaN or infinite contributions dropped, or None when `stop` was raised before
/// the last row (the rows are then part of a pass).
fn trace_rows(
    view: View,
    sum: &mut [Vec3],
    sum_sq: &mut [f64],
    n: u32,
    stop: Option<&AtomicBool>,
) -> Option<u64> {
    let View {
        scene,
        camera,
        settings: s,
        first,
    } = view;
    let cut = AtomicBool::new(false);
    let aspect = s.width as f32 / s.height as f32;
    let w = s.width as usize;
    let invalid: u64 = sum
        .par_chunks_mut(w)
        .zip(sum_sq.par_chunks_mut(w))
        .enumerate()
        .map(|(y, (row, row_sq))| {
            let mut bad = 0;
            if stop.is_some_and(|f| f.load(Ordering::Relaxed)) {
                cut.store(true, Ordering::Relaxed);
                return bad;
            }
            for (x, (acc, acc_sq)) in row.iter_mut().zip(row_sq.iter_mut()).enumerate() {
                let pixel = (y as u64) * s.width as u64 + x as u64;
                for k in first..first + n {
                    let mut rng = Rng::new(s.seed ^ 0x7074_7261_6365, (pixel << 32) | k as u64);
                    let j = rng.next_2d();
                    let d = camera.direction(
                        (x as f32 + j.x) / s.width as f32,
                        (y as f32 + j.y) / s.height as f32,
                        aspect,
                    );
                    let l = radiance(
                        scene,
                        camera.position,
                        d,
                        &mut rng,
                        s.max_depth,
                        s.max_diffuse_vertices,
                    );
                    if l.is_finite() {
                        *acc += l;
                        let lum = luminance(l) as f64;
                        *acc_sq += lum * lum;
                    } else {
                        bad += 1;
                    }
                }
            }
            bad
        })
        .sum();
    (!cut.into_inner()).then_some(invalid)
}

impl PathTracer {
    /// A path tracer with no paths yet.
    pub fn new(scene: Arc<Scene>, camera: Camera, settings: PtSettings) -> Self {
        let render = RenderSettings {
            method: MethodKind::Pt,
            width: settings.width,
            height: settings.height,
            seed: settings.seed,
            ..RenderSettings::default()
        };
        Self::with_render(scene, camera, settings, render)
    }

    /// The reference for a render with `settings`: the same size, seed and transport
    /// ([`PtSettings::matching`]); each step adds `settings.pt_spp` paths per pixel.
    pub fn for_render(scene: Arc<Scene>, camera: Camera, settings: &RenderSettings) -> Self {
        let pt = PtSettings::matching(
            settings.width,
            settings.height,
            settings.seed,
            settings.fractions,
        );
        let render = RenderSettings {
            method: MethodKind::Pt,
            ..settings.clone()
        };
        Self::with_render(scene, camera, pt, render)
    }

    fn with_render(
        scene: Arc<Scene>,
        camera: Camera,
        settings: PtSettings,
        render: RenderSettings,
    ) -> Self {
        let n = (settings.width * settings.height) as usize;
        Self {
            scene,
            camera,
            settings,
            render,
            sum: vec![Vec3::ZERO; n],
            sum_sq: vec![0.0; n],
            spp: 0,
            invalid: 0,
            timings: Timings::default(),
            stop: None,
            pass: (Vec::new(), Vec::new()),
        }
    }

    /// Trace `n` more paths through every pixel. With the window's stop flag
    /// ([`Method::set_stop`]) a pass is traced into sums of its own and added only once whole:
    /// raised, it is given up between rows and the paths so far stay as they were (part of a
    /// pass in some rows would show as bands).
    pub fn add_samples(&mut self, n: u32) {
        let stop = self.stop.clone();
        // Taken out for the pass, so that the pass can read the rest of `self`.
        let (mut sum, mut sum_sq) = match stop {
            None => (
                std::mem::take(&mut self.sum),
                std::mem::take(&mut self.sum_sq),
            ),
            Some(_) => {
                let (mut sum, mut sum_sq) = std::mem::take(&mut self.pass);
                sum.clear();
                sum.resize(self.sum.len(), Vec3::ZERO);
                sum_sq.clear();
                sum_sq.resize(self.sum.len(), 0.0);
                (sum, sum_sq)
            }
        };
        let invalid = trace_rows(self.view(), &mut sum, &mut sum_sq, n, stop.as_deref());
        match stop {
            None => (self.sum, self.sum_sq) = (sum, sum_sq),
            Some(_) => {
                if invalid.is_some() {
                    self.sum.iter_mut().zip(&sum).for_each(|(a, b)| *a += *b);
                    self.sum_sq
                        .iter_mut()
                        .zip(&sum_sq)
                        .for_each(|(a, b)| *a += *b);
                }
                self.pass = (sum, sum_sq);
            }
        }
        if let Some(invalid) = invalid {
            self.invalid += invalid;
            self.spp += n;
        }
    }

    /// What a pass reads: the scene, camera, settings and the paths already traced.
    fn view(&self) -> View<'_> {
        View {
            scene: &self.scene,
            camera: &self.camera,
            settings: self.settings,
            first: self.spp,
        }
    }

    /// The mean radiance per pixel so far, with its own variance as the film's estimate (from
    /// two paths per pixel on).
    pub fn film(&self) -> Film {
        let mut f = Film::new(self.settings.width, self.settings.height);
        let inv = 1.0 / self.spp.max(1) as f32;
        for (o, s) in f.rgb.iter_mut().zip(&self.sum) {
            *o = *s * inv;
        }
        f.invalid_contributions = self.invalid;
        let mut map = Vec::new();
        f.estimate = of_independent_samples(&f.rgb, &self.sum_sq, self.spp, &mut map);
        f.estimated_error = map;
        f
    }
}

impl Method for PathTracer {
    fn kind(&self) -> MethodKind {
        MethodKind::Pt
    }

    fn settings(&self) -> &RenderSettings {
        &self.render
    }

    fn camera(&self) -> &Camera {
        &self.camera
    }

    fn set_stop(&mut self, stop: Arc<AtomicBool>) {
        self.stop = Some(stop);
    }

    fn step(&mut self) -> Step {
        let t = Instant::now();
        let before = self.spp;
        self.add_samples(self.render.pt_spp.max(1));
        self.timings.t_splat += t.elapsed().as_secs_f64();
        if self.spp == before {
            // Given up for a new view: nothing new to show.
            Step::Side
        } else {
            Step::Traced
        }
    }

    /// Paths depend on the view: a new one starts from no paths.
    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), MethodError> {
        let render = crate::methods::checked_view(&self.render, width, height, spp)?;
        self.render = render;
        self.settings.width = width;
        self.settings.height = height;
        self.camera = camera;
        self.sum = vec![Vec3::ZERO; (width * height) as usize];
        self.sum_sq = vec![0.0; (width * height) as usize];
        self.spp = 0;
        self.invalid = 0;
        Ok(())
    }

    /// Nothing the path tracer uses changes without a rebuild.
    fn update(&mut self, _settings: &RenderSettings) -> Result<(), MethodError> {
        Ok(())
    }

    fn film(&mut self) -> Film {
        PathTracer::film(self)
    }

    fn passes(&self) -> u64 {
        self.spp as u64
    }

    fn timings(&self) -> Timings {
        self.timings
    }

    fn stats(&mut self) -> MethodStats {
        MethodStats {
            passes: self.spp as u64,
            ..MethodStats::default()
        }
    }
}

/// Radiance arriving at `o` from direction `d` along one path with at most `max_diffuse`
/// non-specular scattering vertices (`u32::MAX`: full global illumination).
pub fn radiance(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    rng: &mut Rng,
    max_depth: u32,
    max_diffuse: u32,
) -> Vec3 {
    let mut diffuse = 0u32;
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let (mut origin, mut dir) = (o, d);
    // Camera rays and specular bounces see emission with full weight.
    let mut specular = true;
    let mut prev_pdf = 0.0f32;
    let mut prev_pos = o;
    // The viewer-side normal at the previous vertex (for `bsdf_emission_weight`).
    let mut prev_n = Vec3::ZERO;
    // The previous vertex was glass, whose light samples come from both sides.
    let mut prev_glass = false;
    let mut leaving = u32::MAX;
    for depth in 0..max_depth {
        let Some(hit) = scene.intersect_except(origin, dir, f32::INFINITY, leaving) else {
            // Escaped: the environment, MIS-weighted like emission after a non-specular bounce.
            let le = scene.background(dir);
            if le != Vec3::ZERO {
                let w = if specular {
                    1.0
                } else {
                    escaped_weight(scene, prev_n, prev_glass, dir, prev_pdf)
                };
                l += beta * le * w;
            }
            break;
        };
        // Absorbed along the segment inside a volume (KHR_materials_volume).
        beta *= scene.transmittance(&hit, dir);
        let wo = -dir;
        let le = scene.emitted(&hit, wo);
        if le != Vec3::ZERO {
            let w = if specular {
                1.0
            } else {
                bsdf_emission_weight(scene, prev_pos, prev_n, dir, prev_pdf, &hit)
            };
            l += beta * le * w;
        }
        let bsdf = scene.bsdf(&hit);
        // Glass, smooth or rough, is no diffuse vertex (the eye passes go on through both).
        if bsdf.is_reflecting() {
            diffuse += 1;
            if diffuse > max_diffuse {
                break;
            }
        }
        // `n`: the shading normal on the viewer's side of the geometric surface, for the NEE
        // cosine and the reflecting BSDFs; a dielectric takes the surface's own and tells
        // inside from outside by the sign of wo·n (crate::bsdf's docs).
        let n = if hit.geo_normal.dot(wo) >= 0.0 {
            hit.normal
        } else {
            -hit.normal
        };
        let glass = matches!(bsdf, crate::bsdf::Bsdf::Dielectric { .. });
        let ns = if glass { hit.normal } else { n };
        if !bsdf.is_specular() {
            // Next-event estimation, MIS-weighted against BSDF sampling.
            let u = rng.next_f32();
            let facing = (!glass).then_some(n);
            if let Some(ls) = scene
                .lights
                .sample_direct(hit.position, facing, u, rng.next_2d())
            {
                // Rough glass is lit from both sides (its BSDF samples reach lights beyond
                // it, so NEE must too, or MIS would lose their share); the reflecting models
                // from the viewer's side.
                let through = glass && n.dot(ls.wi) < 0.0;
                let cos = if through { -n.dot(ls.wi) } else { n.dot(ls.wi) };
                // The light must also lie on that side of the geometric surface (as for
                // photons and NEE at eye samples): a shading normal can lean past it.
                if cos > 0.0
                    && ls.value.is_finite()
                    && Scene::leaves_correctly(&hit, wo, ls.wi, through)
                {
                    let from = scene.offset(&hit, ls.wi);
                    if scene.light_visible(from, &ls) {
                        let f = bsdf.eval(wo, ls.wi, ns) * bsdf.radiance_scale(wo, ls.wi, ns);
                        // Point lights (infinite pdf) take the whole weight.
                        let w = power_heuristic(ls.pdf, bsdf.pdf(wo, ls.wi, ns));
                        l += beta * f * ls.value * (cos * w);
                    }
                }
            }
        } else {
            // Next-event estimation cannot reach through a delta lobe.
            rng.next_f32();
            rng.next_2d();
        }
        let Some(s) = bsdf.sample(wo, ns, rng.next_2d(), rng.next_f32()) else {
            break;
        };
        // A sample through the geometric surface the wrong way ends the path, as it ends a
        // photon (the light pass): both sides then treat shading normals alike.
        let transmitted = glass && Scene::leaves_correctly(&hit, wo, s.wi, true);
        if !Scene::leaves_correctly(&hit, wo, s.wi, transmitted) {
            break;
        }
        // Radiance through a dielectric scales by η² (it cancels on every path that leaves
        // the volume it entered; not on one from a light or camera inside it).
        beta *= s.weight * bsdf.radiance_scale(wo, s.wi, ns);
        if !beta.is_finite() || beta.max_element() <= 0.0 {
            break;
        }
        if depth >= RR_DEPTH {
            let q = beta.max_element().min(0.95);
            if rng.next_f32() >= q {
                break;
            }
            beta /= q;
        }
        specular = s.specular;
        prev_pdf = s.pdf;
        prev_pos = hit.position;
        // The MIS weights below treat a direction below `prev_n` as one NEE cannot draw;
        // rough glass's NEE draws both sides, so its normal is the one on the sample's side.
        prev_n = if glass && s.wi.dot(n) < 0.0 { -n } else { n };
        prev_glass = glass;
        origin = scene.offset(&hit, s.wi);
        leaving = hit.triangle;
        dir = s.wi;
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::BuiltinScene;

    /// A pass under way with the window's stop flag raised is given up and leaves the paths
    /// as they were (no rows of part of a pass); lowered, the next pass is the one a
    /// never-stopped tracer draws next, pixel for pixel; and a tracer without the flag (a
    /// headless render) renders as before.
    #[test]
    fn a_pass_given_up_for_a_new_view_leaves_the_paths_as_they_were() {
        let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
        let camera = scene.cameras[0].clone();
        let settings = PtSettings::matching(24, 16, 3, [1.0; 3]);
        let mut plain = PathTracer::new(scene.clone(), camera.clone(), settings);
        let mut stopped = PathTracer::new(scene, camera, settings);
        let stop = Arc::new(AtomicBool::new(true));
        stopped.set_stop(stop.clone());
        stopped.step();
        assert_eq!(stopped.passes(), 0);
        assert!(stopped.film().rgb.iter().all(|c| *c == Vec3::ZERO));
        stop.store(false, Ordering::Relaxed);
        stopped.step();
        plain.step();
        assert_eq!(stopped.passes(), 1);
        assert_eq!(stopped.film().rgb, plain.film().rgb);
        // A second pass given up: the first pass's image stays.
        stop.store(true, Ordering::Relaxed);
        stopped.step();
        assert_eq!(stopped.passes(), 1);
        assert_eq!(stopped.film().rgb, plain.film().rgb);
        stop.store(false, Ordering::Relaxed);
        stopped.step();
        plain.step();
        assert_eq!(stopped.passes(), 2);
        assert_eq!(stopped.film().rgb, plain.film().rgb);
    }
}
