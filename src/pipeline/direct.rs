//! Explicit direct light at eye samples (next-event estimation, `--direct nee`): per eye sample
//! one or more light samples with a shadow ray each, combined by multiple importance sampling
//! (Veach's power heuristic) with as many BSDF-sampled rays that may hit an emitter, exactly as
//! the path tracer's first bounce does. Light sampling alone is unbounded near an emitter (its
//! 1/r² has no limit where a wall or vault meets a light panel) and gave isolated pixels a
//! hundred times too bright in SIBENIK; BSDF sampling is bounded there (docs/deviations.md
//! §9). With `--direct photons` this is not used and direct photons are splatted instead (the
//! paper's way).

use crate::bsdf::Bsdf;
use crate::pipeline::eye::EyeSamples;
use crate::sampling::{NEE_BSDF_SET, NEE_LIGHT_SET, PixelPoints, power_heuristic};
use crate::scene::{Hit, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// The MIS weight (power heuristic, against light sampling) of emission at `hit`, found along
/// the BSDF-sampled direction `wi` with solid-angle density `pdf` from `from`, whose
/// viewer-side shading normal is `n`. Light sampling only produces directions above `n` (a
/// viewer below it, at a grazing view of a smooth-shaded mesh, can still reflect light from
/// below): there the BSDF sample takes the whole weight. Shared by NEE at eye samples and the
/// path tracer.
pub fn bsdf_emission_weight(
    scene: &Scene,
    from: Vec3,
    n: Vec3,
    wi: Vec3,
    pdf: f32,
    hit: &Hit,
) -> f32 {
    if n.dot(wi) <= 0.0 {
        return 1.0;
    }
    power_heuristic(
        pdf,
        scene.lights.pdf_direct(hit.triangle, from, hit.position),
    )
}

/// The MIS weight (power heuristic, against light sampling) of the environment seen along a
/// BSDF-sampled direction `wi` that escapes the scene, sampled with solid-angle density `pdf`
/// at a point whose viewer-side shading normal is `n` (below it the BSDF sample takes the
/// whole weight, as in [`bsdf_emission_weight`]), whose light samples were drawn for a
/// receiver facing `n` or, `two_sided`, for one lit from both sides (rough glass; as
/// [`crate::scene::Lights::sample_direct`] takes it). Shared by NEE at eye samples and the
/// path tracer.
pub fn escaped_weight(scene: &Scene, n: Vec3, two_sided: bool, wi: Vec3, pdf: f32) -> f32 {
    if n.dot(wi) <= 0.0 {
        return 1.0;
    }
    let facing = (!two_sided).then_some(n);
    power_heuristic(pdf, scene.lights.pdf_escaped(wi, facing))
}

/// Area lights tested one by one before a BSDF-sampled ray's full traversal (at most this
/// many): a ray that meets none of them cannot find an emitter.
const EMITTERS_TESTED_DIRECTLY: usize = 64;

/// Reflected direct radiance towards the eye at every sample (BSDF applied, eye weight not),
/// and the number of samples whose estimate was NaN or infinite (set to zero, not used).
pub fn direct_light(scene: &Scene, eye: &EyeSamples, samples: u32, seed: u64) -> (Vec<Vec3>, u64) {
    direct_light_through(scene, eye, samples, seed, |i| Some(eye.bsdf(i)))
}

/// Direct light reflected by the traced glossy lobes only (zero at other samples), for
/// `--direct photons`: splatted direct photons light a traced sample's diffuse part, and the
/// lobe's view of the emitters, which its traced direction does not count (the eye pass leaves
/// emission straight off a traced lobe to NEE), comes from here — light and BSDF samples under
/// MIS, as with `--direct nee` (docs/deviations.md §38).
pub fn traced_lobe_direct_light(
    scene: &Scene,
    eye: &EyeSamples,
    samples: u32,
    seed: u64,
) -> (Vec<Vec3>, u64) {
    direct_light_through(scene, eye, samples, seed, |i| {
        (eye.lobe_traced(i)).then(|| eye.bsdf(i).specular_layer())
    })
}

/// Each eye sample's rank among its pixel's samples (the samples are in pixel order): with the
/// pixel, it picks the sample's points of the pixel's stratified set ([`PixelPoints`]), so that
/// one pixel's count of samples (a traced lobe that leaves its surface at one scale and not at
/// another, by rounding) never shifts the points of the pixels after it.
fn sample_ranks(eye: &EyeSamples) -> Vec<u32> {
    let mut rank = 0u32;
    (0..eye.len())
        .map(|i| {
            rank = if i > 0 && eye.pixel[i - 1] == eye.pixel[i] {
                rank + 1
            } else {
                0
            };
            rank
        })
        .collect()
}

/// NEE at every eye sample through the BSDF `bsdf_of` gives it (none: no direct light).
fn direct_light_through(
    scene: &Scene,
    eye: &EyeSamples,
    samples: u32,
    seed: u64,
    bsdf_of: impl Fn(usize) -> Option<Bsdf> + Sync,
) -> (Vec<Vec3>, u64) {
    let samples = samples.max(1);
    // Emitting triangles, when few enough to test one by one: a BSDF-sampled ray that meets
    // none of them cannot find an emitter, so the full traversal is skipped for it (most such
    // rays miss every light). The same triangle test as the BVH's, so nothing changes.
    let emitters: Vec<u32> = scene.lights.area_triangles().collect();
    let few_emitters = (emitters.len() <= EMITTERS_TESTED_DIRECTLY).then_some(emitters.as_slice());
    // Rays that meet no emitter may still escape to the environment.
    let has_environment = scene.lights.has_environment();
    let ranks = sample_ranks(eye);
    let radiance: Vec<Vec3> = (0..eye.len())
        .into_par_iter()
        .map(|i| {
            let p = eye.position[i];
            let n = eye.normal[i].get();
            let ng = eye.geo_normal[i].get();
            let Some(bsdf) = bsdf_of(i) else {
                return Vec3::ZERO;
            };
            let points = PixelPoints::new(seed, eye.pixel[i], ranks[i], samples);
            let wo = eye.wo[i].get();
            let mut sum = Vec3::ZERO;
            for k in 0..samples {
                // The light's 2D sample in the set's first two dimensions, whose Sobol'
                // points are stratified in 2D; the choice among lights in the third.
                let [x, y, u, _] = points.point(k, NEE_LIGHT_SET);
                let Some(ls) = scene.lights.sample_direct(p, Some(n), u, Vec2::new(x, y)) else {
                    continue;
                };
                let cos = n.dot(ls.wi);
                // On the viewer's side of the geometric surface too (the shading normal can
                // lean past it): the path tracer and photons draw the same line.
                if cos <= 0.0 || !ls.value.is_finite() || ng.dot(ls.wi) <= 0.0 {
                    continue;
                }
                // Off the surface by the hit point's own error bound (never by a fraction of
                // the scene's size), on the light's side of the geometric surface.
                let origin = crate::scene::offset_ray_origin(p, ng, eye.offset[i].get(), ls.wi);
                if !scene.light_visible(origin, &ls) {
                    continue;
                }
                // A point light (infinite pdf) takes the whole weight: no BSDF sample finds it.
                let w = power_heuristic(ls.pdf, bsdf.pdf(wo, ls.wi, n));
                sum += bsdf.eval(wo, ls.wi, n) * ls.value * (cos * w);
            }
            // The BSDF-sampled half of the estimate: an emitter met along a sampled direction,
            // weighted against the light sampler's density for it.
            for k in 0..samples {
                let [x, y, lobe, _] = points.point(k, NEE_BSDF_SET);
                let Some(s) = bsdf.sample(wo, n, Vec2::new(x, y), lobe) else {
                    continue;
                };
                if s.specular || s.pdf <= 0.0 || ng.dot(s.wi) <= 0.0 {
                    continue;
                }
                let origin = crate::scene::offset_ray_origin(p, ng, eye.offset[i].get(), s.wi);
                if let Some(tris) = few_emitters
                    && !has_environment
                    && !scene.meets_any(origin, s.wi, tris)
                {
                    continue;
                }
                let Some(hit) = scene.intersect(origin, s.wi, f32::INFINITY) else {
                    // Escaped: the environment, weighted against its light sampling.
                    let le = scene.background(s.wi);
                    if le != Vec3::ZERO {
                        sum += s.weight * le * escaped_weight(scene, n, false, s.wi, s.pdf);
                    }
                    continue;
                };
                let le = scene.emitted(&hit, -s.wi);
                if le == Vec3::ZERO {
                    continue;
                }
                sum += s.weight * le * bsdf_emission_weight(scene, p, n, s.wi, s.pdf, &hit);
            }
            sum / samples as f32
        })
        .collect();
    let invalid = radiance.iter().filter(|l| !l.is_finite()).count() as u64;
    if invalid == 0 {
        return (radiance, 0);
    }
    let radiance = radiance
        .into_iter()
        .map(|l| if l.is_finite() { l } else { Vec3::ZERO })
        .collect();
    (radiance, invalid)
}
