//! Eye pass (§3): camera rays, deterministic specular chains, and the eye samples stored at
//! the first non-specular hit (structure of arrays).
//!
//! Specular chains are followed deterministically: a mirror reflects, a dielectric splits into
//! its reflected and refracted branches weighted by Fresnel, up to `max_specular_depth`.
//! Emission seen directly or through a chain goes straight to the film (`emitted`), and so
//! does the environment seen where a ray escapes.
//!
//! The stored samples and their splat targets are in `samples`, one camera ray's chain (and
//! the sampled directions of traced lobes) in `chain`, the bands of rows and each pixel's splat
//! targets in `bands`, and the traced lobes drawn anew ([`trace_lobes`]) in `lobes`; unit tests
//! in `tests`.

mod bands;
mod chain;
mod lobes;
mod samples;
#[cfg(test)]
mod tests;

pub use lobes::trace_lobes;
pub use samples::{EYE_SAMPLE_BYTES, EyeSample, EyeSamples, SplatTargets};

use crate::pipeline::Stop;
use crate::sampling::{PixelPoints, Rng};
use crate::scene::{Camera, Scene};
use bands::{assign_targets, collect_bands};
use chain::{BRANCH_STACK, Branch, trace_chain};
use glam::{Vec2, Vec3};

/// Settings of the eye pass.
#[derive(Clone, Copy, Debug)]
pub struct EyeSettings {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Camera rays per pixel (stratified when a square number).
    pub spp: u32,
    /// Most specular bounces a camera ray's chain follows.
    pub max_specular_depth: u32,
    /// Seed of the sub-pixel jitter (one random stream per pixel).
    pub seed: u64,
    /// Let eye samples of one pixel on the same surface share one splat target.
    pub merge_targets: bool,
    /// Glossy lobes with a Phong exponent above this are traced by the eye path (one sampled
    /// direction per eye sample, like a specular chain) instead of going through the radiance
    /// map: the directional mode's [`lobe_limit`]. Infinite: none are traced.
    ///
    /// [`lobe_limit`]: crate::pipeline::directional::DirectionalMode::lobe_limit
    pub lobe_limit: f32,
    /// Continue traced lobes in this pass (one direction per eye sample, drawn once per view);
    /// when false they are only marked, and [`trace_lobes`] draws their directions, anew per
    /// call (rs draws them per photon batch so that the previewer's reflections converge).
    pub follow_lobes: bool,
    /// Light samples at each rough glass vertex of a chain (the render's light samples per
    /// eye sample), weighted against the vertex's branches; 0: none (the branches alone).
    pub light_samples: u32,
}

/// What the eye pass produced.
pub struct EyePass {
    /// The eye samples, in pixel order.
    pub samples: EyeSamples,
    /// Their splat targets (`EyeSamples::target` indexes these).
    pub targets: SplatTargets,
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
    eye_pass_until(scene, camera, s, None).expect("an eye pass without a stop runs to its end")
}

/// [`eye_pass`], given up (None) once `stop` is raised, between bands of rows.
pub fn eye_pass_until(
    scene: &Scene,
    camera: &Camera,
    s: &EyeSettings,
    stop: Stop,
) -> Option<EyePass> {
    let aspect = s.width as f32 / s.height as f32;
    // Angle subtended by one pixel (vertically), for the footprint of merged targets.
    let pixel_angle = 2.0 * (0.5 * camera.yfov).tan() / s.height as f32;
    let pixels = s.width * s.height;
    // Specular branches add samples beyond spp per pixel: an eighth more is reserved
    // (reserved pages that are never written take no memory).
    let expect = (pixels * s.spp) as usize;
    collect_bands(s.height, pixels, expect + expect / 8, stop, |y| {
        let mut out = Vec::with_capacity((s.width * s.spp) as usize);
        let mut emitted = vec![Vec3::ZERO; s.width as usize];
        let mut targets = SplatTargets::default();
        let mut stack = Vec::with_capacity(BRANCH_STACK);
        for x in 0..s.width {
            let pixel = y * s.width + x;
            let first = out.len();
            let mut rng = Rng::new(s.seed, 0x1000_0000_0000 + pixel as u64);
            // Directions of traced glossy lobes: a stream of their own, so that scenes
            // without them keep their jitter.
            let mut lobe_rng = Rng::new(s.seed, 0x3000_0000_0000 + pixel as u64);
            for k in 0..s.spp {
                let j = jitter(k, s.spp, &mut rng);
                let dir = camera.direction(
                    (x as f32 + j.x) / s.width as f32,
                    (y as f32 + j.y) / s.height as f32,
                    aspect,
                );
                let w = Vec3::splat(1.0 / s.spp as f32);
                let start = Branch {
                    origin: camera.position,
                    dir,
                    weight: w,
                    depth: 0,
                    travelled: 0.0,
                    leaving: u32::MAX,
                    from_lobe: false,
                    lobe_pdf: 0.0,
                    vertex: camera.position,
                    points: PixelPoints::new(s.seed, pixel, k, s.light_samples),
                };
                emitted[x as usize] +=
                    trace_chain(scene, start, pixel, s, &mut lobe_rng, &mut stack, &mut out);
            }
            assign_targets(
                &mut out[first..],
                &mut targets,
                s.merge_targets,
                pixel_angle,
            );
        }
        (out, emitted, targets)
    })
}
