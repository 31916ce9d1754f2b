//! Traced glossy lobes drawn anew: new directions for the lobes an eye pass marked (rs draws
//! them per photon batch), from a random stream of their own.

use super::bands::{assign_targets, collect_bands};
use super::chain::{BRANCH_STACK, Branch, MIN_BRANCH_WEIGHT, sample_traced_lobe, trace_chain};
use super::{EyePass, EyeSamples, EyeSettings, SplatTargets};
use crate::sampling::{PixelPoints, Rng};
use crate::scene::{Camera, Scene};
use glam::Vec3;

/// A draw of [`trace_lobes`] gives new directions to ⌈t / LOBE_SHARE⌉ of a pixel's t traced
/// eye samples. Measured one batch, rs, SH, against the path tracer (docs/deviations.md
/// §38): one path per pixel left CORNELL BOX I's brass noisier than shading it matte (relMSE
/// 0.0075 against 0.0066); one per traced sample 0.0058 at 1.24× that time, but
/// `builtin:glossy-sharp` took 1.52× diffuse's time; half the samples 0.0062 at 1.16×, and
/// 1.36× on glossy-sharp, about as much accuracy per second as every sample.
const LOBE_SHARE: usize = 2;

/// Stream ranges of [`trace_lobes`]: the random first sample per pixel, and each lobe path.
const LOBE_PICK_STREAMS: u64 = 0x4000_0000_0000_0000;
const LOBE_PATH_STREAMS: u64 = 0x5000_0000_0000_0000;

/// New directions for the traced glossy lobes of `eye` (its samples with `lobe_traced`): for
/// ⌈t / [`LOBE_SHARE`]⌉ of each pixel's t traced samples, a circular run from a random one,
/// weighted by t over their number (unbiased), from the random stream `draw` (another stream,
/// other directions): the eye samples they
/// reach (further traced lobes followed, all within `max_specular_depth`), their splat
/// targets and the emission they see, in pixel order as [`eye_pass`](super::eye_pass) gives them.
pub fn trace_lobes(
    scene: &Scene,
    camera: &Camera,
    eye: &EyeSamples,
    s: &EyeSettings,
    draw: u64,
) -> EyePass {
    let s = EyeSettings {
        follow_lobes: true,
        ..*s
    };
    let pixel_angle = 2.0 * (0.5 * camera.yfov).tan() / s.height as f32;
    collect_bands(s.height, s.width * s.height, 0, None, |y| {
        let mut out = Vec::new();
        let mut emitted = vec![Vec3::ZERO; s.width as usize];
        let mut targets = SplatTargets::default();
        let mut stack = Vec::with_capacity(BRANCH_STACK);
        let hi = eye.pixel.partition_point(|&p| p < (y + 1) * s.width);
        let mut i = eye.pixel.partition_point(|&p| p < y * s.width);
        while i < hi {
            let pixel = eye.pixel[i];
            let end = i + eye.pixel[i..hi].partition_point(|&p| p == pixel);
            let first = out.len();
            // m = ⌈traced / LOBE_SHARE⌉ of the pixel's traced samples, a circular run
            // from a random one: each is followed with probability m / traced and
            // weighted by its inverse (unbiased).
            let traced = (i..end).filter(|&k| eye.lobe_traced(k)).count();
            let m = traced.div_ceil(LOBE_SHARE);
            // Streams of their own (high bits), apart from the light pass's photon
            // streams and from each other.
            let lobe_seed = s.seed ^ draw.wrapping_mul(0x9e37_79b9);
            let mut pick = Rng::new(lobe_seed, LOBE_PICK_STREAMS | pixel as u64);
            let from = ((pick.next_f32() * traced as f32) as usize).min(traced.max(1) - 1);
            let scale = traced as f32 / m.max(1) as f32;
            for (j, k) in (i..end).filter(|&k| eye.lobe_traced(k)).enumerate() {
                if (j + traced - from) % traced >= m {
                    continue;
                }
                let mut rng = Rng::new(lobe_seed, LOBE_PATH_STREAMS | k as u64);
                let (p, n, ng) = (
                    eye.position[k],
                    eye.normal[k].get(),
                    eye.geo_normal[k].get(),
                );
                let bsdf = eye.bsdf(k);
                if let Some((d, lobe_w)) =
                    sample_traced_lobe(bsdf, eye.wo[k].get(), n, ng, s.lobe_limit, &mut rng)
                {
                    let origin = crate::scene::offset_ray_origin(p, ng, eye.offset[k].get(), d);
                    let w = eye.weight[k].get() * lobe_w * scale;
                    // The length from the camera stands in for the path's (merging reach).
                    let start = Branch {
                        origin,
                        dir: d,
                        weight: w,
                        depth: 1,
                        travelled: p.distance(camera.position),
                        leaving: u32::MAX,
                        from_lobe: true,
                        lobe_pdf: 0.0,
                        vertex: p,
                        points: PixelPoints::new(lobe_seed, pixel, j as u32, s.light_samples),
                    };
                    if w.max_element() >= MIN_BRANCH_WEIGHT {
                        emitted[(pixel - y * s.width) as usize] +=
                            trace_chain(scene, start, pixel, &s, &mut rng, &mut stack, &mut out);
                    }
                }
            }
            assign_targets(
                &mut out[first..],
                &mut targets,
                s.merge_targets,
                pixel_angle,
            );
            i = end;
        }
        (out, emitted, targets)
    })
    .expect("traced lobes without a stop are drawn whole")
}
