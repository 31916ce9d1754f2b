//! One camera ray's eye path (§3): specular chains (split deterministically, rough glass about
//! drawn microfacet normals, four at a path's first rough vertex; alpha-BLEND surfaces into
//! their share and the share passing on) and traced glossy lobes,
//! the eye samples it leaves and the emission it sees, and the sampled directions of lobes too
//! sharp for the radiance map.

use super::{EyeSample, EyeSettings};
use crate::bsdf::{
    Bsdf, ggx_g1, ggx_g2, glass_lobes, phong_equivalent, reflect, sample_ggx_visible, schlick,
    schlick_to,
};
use crate::sampling::{GLASS_LIGHT_SETS, GLASS_SPLIT_SET, PixelPoints, Rng, power_heuristic};
use crate::scene::{Hit, Scene};
use glam::{Vec2, Vec3};

/// Branches whose weight falls below this are dropped (they cannot change a pixel visibly).
pub(super) const MIN_BRANCH_WEIGHT: f32 = 1e-3;
/// Pending specular branches per camera ray.
pub(super) const BRANCH_STACK: usize = 32;
/// The paths an eye path splits into at the first rough glass it meets, each about a
/// microfacet normal of its own drawn from the pixel's stratified points (docs/deviations.md
/// §60): what is seen through frosted glass varies with the drawn normals far more than what
/// a diffuse surface's eye sample gathers.
pub(super) const GLASS_SPLIT: u32 = 4;
/// The alpha-BLEND surfaces one camera ray passes through, at most (a bound for pathological
/// stacks of them; the share past it is dropped).
const BLEND_LAYERS: u32 = 64;

/// A branch of an eye path: origin, direction, weight, depth (specular and traced glossy
/// bounces so far), length so far, the triangle it leaves, and whether it leaves a traced lobe.
#[derive(Clone, Copy)]
pub(super) struct Branch {
    /// Origin of the ray.
    pub(super) origin: Vec3,
    /// Unit direction of the ray.
    pub(super) dir: Vec3,
    /// RGB path weight.
    pub(super) weight: Vec3,
    /// Specular and traced glossy bounces so far.
    pub(super) depth: u32,
    /// Length of the eye path so far.
    pub(super) travelled: f32,
    /// The triangle the ray leaves (`u32::MAX`: none).
    pub(super) leaving: u32,
    /// The ray leaves a traced lobe.
    pub(super) from_lobe: bool,
    /// The density with which a rough glass vertex's branch drew `dir`
    /// ([`crate::bsdf::GlassLobe`]'s `pdf`) times the paths the vertex split into: the emission
    /// it meets is weighted against that vertex's light samples (multiple importance
    /// sampling). Zero: whole weight.
    pub(super) lobe_pdf: f32,
    /// That vertex's position (where its light samples were drawn from), when `lobe_pdf` > 0.
    pub(super) vertex: Vec3,
    /// The pixel's stratified points of this path (its own rank once it has split at rough
    /// glass, which it does once: [`PixelPoints::is_split`]).
    pub(super) points: PixelPoints,
}

/// An eye sample as a chain leaves it, before it is packed.
#[derive(Clone, Copy)]
pub(super) struct RawSample {
    pub(super) sample: EyeSample,
    /// Length of the eye path to the sample (for the pixel footprint).
    pub(super) path_length: f32,
    /// Target index within the row during the pass.
    pub(super) target: u32,
}

/// Follow one camera ray through specular chains and traced glossy lobes; push eye samples,
/// return emitted radiance. Random numbers come from `rng`, and rough glass's split normals
/// and light samples from the branch's stratified points. `stack` is the caller's scratch for
/// pending branches (reused from ray to ray: nothing is allocated or initialised per ray).
pub(super) fn trace_chain(
    scene: &Scene,
    start: Branch,
    pixel: u32,
    s: &EyeSettings,
    rng: &mut Rng,
    stack: &mut Vec<Branch>,
    out: &mut Vec<RawSample>,
) -> Vec3 {
    let max_depth = s.max_specular_depth;
    stack.clear();
    stack.push(start);
    let mut emitted = Vec3::ZERO;
    let mut layers = BLEND_LAYERS;
    while let Some(branch) = stack.pop() {
        let Branch {
            origin: o,
            dir: d,
            weight: w,
            depth,
            travelled,
            leaving,
            from_lobe,
            lobe_pdf,
            vertex,
            points,
        } = branch;
        let Some(hit) = scene.intersect_layers(o, d, f32::INFINITY, leaving) else {
            // Escaped: the environment seen directly or through the chain (off a traced lobe
            // it is NEE's at the lobe's eye sample, as emission below; off rough glass it is
            // weighted against that vertex's light samples).
            if !from_lobe {
                let le = scene.background(d);
                if le != Vec3::ZERO {
                    let m = branch_weight(lobe_pdf, s.light_samples, || {
                        scene.lights.pdf_escaped(d, None)
                    });
                    emitted += w * le * m;
                }
            }
            continue;
        };
        // Light from this hit crossed the segment: absorbed inside a volume (glass with
        // KHR_materials_volume), whole elsewhere.
        let mut w = w * scene.transmittance(&hit, d);
        let path_length = travelled + hit.t;
        // An alpha-BLEND surface is met whole and split: its share α is the surface, the rest
        // passes on as the same branch (its depth kept: what is seen through a pane is still
        // seen directly), instead of a coverage drawn per ray (docs/deviations.md §61).
        if let Some(alpha) = scene.coverage(&hit) {
            let through = w * (1.0 - alpha);
            // Both shares are kept whenever the branch itself is (the cutoff judges the
            // branch, not its split into shares).
            if alpha < 1.0 && layers > 0 && stack.len() < BRANCH_STACK {
                layers -= 1;
                stack.push(Branch {
                    origin: scene.offset(&hit, d),
                    weight: through,
                    travelled: path_length,
                    leaving: hit.triangle,
                    ..branch
                });
            }
            w *= alpha;
            if alpha <= 0.0 {
                continue;
            }
        }
        let wo = -d;
        // Light met straight off a traced lobe is NEE's at the lobe's eye sample (its BSDF
        // sample under MIS holds this path), so it is not counted twice.
        if !from_lobe {
            let le = scene.emitted(&hit, wo);
            if le != Vec3::ZERO {
                let m = branch_weight(lobe_pdf, s.light_samples, || {
                    scene.lights.pdf_direct(hit.triangle, vertex, hit.position)
                });
                emitted += w * le * m;
            }
        }
        let bsdf = scene.bsdf(&hit);
        // A glossy sample keeps its diffuse layer's albedo towards the eye, kd·(1 − E_d).
        let surface = match bsdf {
            Bsdf::Lambert { albedo } => Some((albedo, Vec3::ZERO, 1.0, 0.0)),
            Bsdf::Glossy { f0, f90, alpha, .. } => {
                Some((bsdf.layer_albedos(wo.dot(hit.normal)).0, f0, alpha, f90))
            }
            _ => None,
        };
        if let Some((albedo, specular, alpha, f90)) = surface {
            // Face the viewer: flip both normals to the side the ray came from.
            let (n, ng) = if hit.geo_normal.dot(wo) >= 0.0 {
                (hit.normal, hit.geo_normal)
            } else {
                (-hit.normal, -hit.geo_normal)
            };
            out.push(RawSample {
                sample: EyeSample {
                    position: hit.position,
                    normal: n,
                    geo_normal: ng,
                    offset: hit.offset,
                    wo,
                    material: hit.material,
                    pixel,
                    weight: w,
                    albedo,
                    specular,
                    alpha,
                    f90,
                    primary: depth == 0,
                    lobe_traced: false,
                },
                path_length,
                target: 0,
            });
            if depth < max_depth
                && s.follow_lobes
                && let Some((d, lobe_w)) = sample_traced_lobe(bsdf, wo, n, ng, s.lobe_limit, rng)
                && (w * lobe_w).max_element() >= MIN_BRANCH_WEIGHT
                && stack.len() < BRANCH_STACK
            {
                out.last_mut().expect("just pushed").sample.lobe_traced = true;
                stack.push(Branch {
                    origin: scene.offset(&hit, d),
                    dir: d,
                    weight: w * lobe_w,
                    depth: depth + 1,
                    travelled: path_length,
                    leaving: hit.triangle,
                    from_lobe: true,
                    lobe_pdf: 0.0,
                    vertex: hit.position,
                    points,
                });
            } else if depth < max_depth && traces_lobe(bsdf, s.lobe_limit) {
                // The lobe is traced, but its sampled direction left through the surface or
                // carries too little: it adds nothing (f = 0 below the surface).
                out.last_mut().expect("just pushed").sample.lobe_traced = true;
            }
            continue;
        }
        // A branch that leaves through the geometric surface the wrong way (a shading normal
        // can send it there) is dropped, as photons and the path tracer drop it.
        // A branch of one of the `ways` paths the vertex split into (1: none), of density
        // `lobe_pdf` per path (0: not drawn at rough glass), judged by the cutoff at its
        // weight before the split's 1/ways.
        let mut push = |d: Vec3, w: Vec3, transmit: bool, lobe_pdf: f32, ways: u32, points| {
            if w.max_element() * ways as f32 >= MIN_BRANCH_WEIGHT
                && stack.len() < BRANCH_STACK
                && Scene::leaves_correctly(&hit, wo, d, transmit)
            {
                stack.push(Branch {
                    origin: scene.offset(&hit, d),
                    dir: d,
                    weight: w,
                    depth: depth + 1,
                    travelled: path_length,
                    leaving: hit.triangle,
                    from_lobe: false,
                    lobe_pdf: lobe_pdf * ways as f32,
                    vertex: hit.position,
                    points,
                });
            }
        };
        match bsdf {
            // Non-specular surfaces were handled above.
            Bsdf::Lambert { .. } | Bsdf::Glossy { .. } => {}
            _ if depth >= max_depth => {}
            Bsdf::Mirror { color } => {
                let n = if hit.normal.dot(wo) >= 0.0 {
                    hit.normal
                } else {
                    -hit.normal
                };
                let r = reflect(wo, n);
                // The conductor's Fresnel, as `Bsdf::sample` gives photons and the path tracer.
                push(r, w * schlick(color, wo.dot(n)), false, 0.0, 1, points);
            }
            Bsdf::Dielectric { ior, tint, alpha } => {
                // Both lobes are followed about one microfacet normal (drawn for rough glass
                // only, so that smooth glass keeps its streams), each an unbiased one-sample
                // estimate of its lobe (`bsdf::glass_lobes`; `Bsdf::sample` draws one of the
                // two by Fresnel instead). A rough lobe that lands on the wrong side of the
                // macrosurface carries nothing. At the first rough glass of the path, the
                // path splits into GLASS_SPLIT such pairs about normals drawn from the pixel's
                // stratified points (deviations §60), each of weight 1/GLASS_SPLIT.
                let ways = if alpha > 0.0 && !points.is_split() {
                    GLASS_SPLIT
                } else {
                    1
                };
                if alpha > 0.0 {
                    let draws = (&points, depth, ways);
                    emitted += w * rough_glass_light(scene, &hit, bsdf, wo, s.light_samples, draws);
                }
                let w = w / ways as f32;
                for j in 0..ways {
                    let (u, points) = if ways > 1 {
                        let [x, y, ..] = points.per_sample(ways).point(j, GLASS_SPLIT_SET);
                        (Vec2::new(x, y), points.split(ways, j))
                    } else if alpha > 0.0 {
                        (rng.next_2d(), points)
                    } else {
                        (Vec2::ZERO, points)
                    };
                    let lobes = glass_lobes(wo, hit.normal, ior, alpha, u);
                    let f = lobes.fresnel;
                    // (Each rough branch carries its direction's density, for the emission it
                    // meets; smooth glass's branches take the whole weight.)
                    let lobe_pdf = |pdf: f32| if alpha > 0.0 { pdf } else { 0.0 };
                    if let Some(r) = lobes.reflected {
                        let weight = w * (f * r.masking);
                        push(r.dir, weight, false, lobe_pdf(r.pdf), ways, points);
                    }
                    if let Some(t) = lobes.refracted {
                        // Radiance crossing into glass falls by η² (Bsdf::radiance_scale): an
                        // eye sample inside a volume sees light that photons delivered as flux.
                        let scale = bsdf.radiance_scale(wo, t.dir, hit.normal);
                        let weight = w * tint * ((1.0 - f) * t.masking * scale);
                        push(t.dir, weight, true, lobe_pdf(t.pdf), ways, points);
                    }
                }
            }
        }
    }
    emitted
}

/// The multiple-importance weight of emission met by a branch drawn with density `lobe_pdf`
/// at a rough glass vertex, against that vertex's `light_samples` light samples, whose
/// density for the same direction `light_pdf` gives: Veach's power heuristic with each
/// technique's density times its count of samples (Veach 1997, §9.2.2: the vertex's branches
/// of one lobe, whose count `lobe_pdf` already includes, against n light samples). A branch
/// with `lobe_pdf` zero did not leave rough glass: whole weight.
#[inline]
fn branch_weight(lobe_pdf: f32, light_samples: u32, light_pdf: impl FnOnce() -> f32) -> f32 {
    if lobe_pdf > 0.0 && light_samples > 0 {
        power_heuristic(lobe_pdf, light_samples as f32 * light_pdf())
    } else {
        1.0
    }
}

/// Light seen through and off rough glass at `hit`, by `light_samples` light samples from
/// both sides (next-event estimation, as the path tracer's at rough glass), drawn from the
/// path's stratified `points` (docs/deviations.md §59) at the vertex's chain `depth`: the
/// radiance towards ωo before the branch's weight, each sample weighted against the `ways`
/// branches of its lobe by [`branch_weight`]'s heuristic (n·p_light against `ways` times the
/// lobe's density), so that the branches and the light samples together count every light
/// once. Point, spot and
/// directional lights, which no branch can meet, are reached this way only.
fn rough_glass_light(
    scene: &Scene,
    hit: &Hit,
    bsdf: Bsdf,
    wo: Vec3,
    light_samples: u32,
    (points, depth, ways): (&PixelPoints, u32, u32),
) -> Vec3 {
    let n = hit.normal;
    let mut sum = Vec3::ZERO;
    // The pixel's stratified points, a set per chain depth (vertices at one depth share it).
    let set = GLASS_LIGHT_SETS + depth;
    for k in 0..light_samples {
        let [x, y, u, _] = points.point(k, set);
        let Some(ls) = scene
            .lights
            .sample_direct(hit.position, None, u, Vec2::new(x, y))
        else {
            continue;
        };
        // Across the shading normal from ωo: the refracted lobe; on its side: the reflected.
        let through = (wo.dot(n) > 0.0) != (ls.wi.dot(n) > 0.0);
        if !ls.value.is_finite() || !Scene::leaves_correctly(hit, wo, ls.wi, through) {
            continue;
        }
        let (f, lobe_pdf) = bsdf.rough_glass(wo, ls.wi, n);
        if f == Vec3::ZERO || !scene.light_visible(scene.offset(hit, ls.wi), &ls) {
            continue;
        }
        let m = power_heuristic(light_samples as f32 * ls.pdf, ways as f32 * lobe_pdf);
        let cos = ls.wi.dot(n).abs();
        sum += f * ls.value * (cos * bsdf.radiance_scale(wo, ls.wi, n) * m);
    }
    sum / light_samples.max(1) as f32
}

/// True when `bsdf` is glossy with a lobe sharper than `limit` (the directional mode's
/// [`lobe_limit`](crate::pipeline::directional::DirectionalMode::lobe_limit)): traced by the
/// eye path. An infinite limit (diffuse mode, the paper without §8.1) traces none.
#[inline]
fn traces_lobe(bsdf: Bsdf, limit: f32) -> bool {
    matches!(bsdf, Bsdf::Glossy { f0, f90, alpha, .. }
        if phong_equivalent(alpha) > limit && (f0 != Vec3::ZERO || f90 > 0.0))
}

/// One direction of a glossy lobe too sharp for the radiance map (its width as a Phong
/// exponent above `limit`), drawn from GGX's visible normals at `wo` (`n` the shading normal
/// facing the viewer, `ng` the geometric one): the direction and its weight
/// F(ωo·h)·G₂/G₁(ωo)/p, an unbiased one-sample estimate of the specular layer's reflection
/// (f·cos θi over the visible-normal pdf D_ωo(h)/(4|ωo·h|) of Heitz 2018, JCGT 7(4), eq. 17,
/// leaves F·G₂/G₁ of glTF's microfacet BRDF, appendix B).
/// The lobe is traced with the probability p the BSDF's own sampling gives it (its share of
/// the reflectance towards ωo, [`Bsdf::specular_probability`]), a Russian roulette that spends
/// rays where the lobe carries light. `None` when the lobe is not traced, the roulette ends it,
/// or the direction leaves below the surface (where f = 0).
#[inline]
pub(super) fn sample_traced_lobe(
    bsdf: Bsdf,
    wo: Vec3,
    n: Vec3,
    ng: Vec3,
    limit: f32,
    rng: &mut Rng,
) -> Option<(Vec3, Vec3)> {
    if !traces_lobe(bsdf, limit) {
        return None;
    }
    let Bsdf::Glossy { f0, f90, alpha, .. } = bsdf else {
        return None;
    };
    let cos_o = wo.dot(n);
    // Seen from behind its shading normal (a normal texture at a grazing view) the specular
    // layer reflects nothing (`Bsdf::eval` keeps the diffuse layer alone there, deviations
    // §53), and the visible normals need ωo above it.
    if cos_o <= 0.0 {
        return None;
    }
    let p = bsdf.specular_probability(cos_o);
    if rng.next_f32() >= p {
        return None;
    }
    let h = sample_ggx_visible(wo, n, alpha, rng.next_2d());
    let d = reflect(wo, h);
    let cos = d.dot(n);
    if cos <= 0.0 || d.dot(ng) <= 0.0 {
        return None;
    }
    let w = schlick_to(f0, f90, wo.dot(h)) * (ggx_g2(cos_o, cos, alpha) / ggx_g1(cos_o, alpha) / p);
    Some((d, w))
}
