//! Eye pass (§3): camera rays, deterministic specular chains, and the eye samples stored at
//! the first non-specular hit (structure of arrays).
//!
//! Specular chains are followed deterministically: a mirror reflects, a dielectric splits into
//! its reflected and refracted branches weighted by Fresnel, up to `max_specular_depth`.
//! Emission seen directly or through a chain goes straight to the film (`emitted`), and so
//! does the environment seen where a ray escapes.

use crate::bsdf::{Bsdf, fresnel_dielectric, reflect, refract, specular_probability};
use crate::pack::{Bound16, Oct, Rgb16};
use crate::sampling::Rng;
use crate::scene::{Camera, Scene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Samples of one pixel share a splat target when their normals are this close ...
const MERGE_COS: f32 = 0.966; // cos 15°
/// ... and they lie within this many pixel footprints of each other.
const MERGE_FOOTPRINTS: f32 = 4.0;
/// Branches whose weight falls below this are dropped (they cannot change a pixel visibly).
const MIN_BRANCH_WEIGHT: f32 = 1e-3;
/// Pending specular branches per camera ray.
const BRANCH_STACK: usize = 16;

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
}

/// Eye samples, structure of arrays, in pixel order. Photon rays splat onto their splat
/// targets (`target`), whose positions and normals the splat tree copies into slot order.
#[derive(Clone, Debug, Default)]
pub struct EyeSamples {
    /// World-space position.
    pub position: Vec<Vec3>,
    /// Shading normal, flipped to face the viewer (octahedral, 32 bits).
    pub normal: Vec<Oct>,
    /// Geometric normal, facing the viewer (rays leave the surface on its side; octahedral:
    /// its ≤ 10⁻⁴ rad error moves an offset origin by a relative 10⁻⁸ along the true normal,
    /// see docs/benchmarks.md, "Memory").
    pub geo_normal: Vec<Oct>,
    /// Error bound of `position` along `geo_normal` ([`crate::scene::Hit::offset`]), rounded
    /// up to f16.
    pub offset: Vec<Bound16>,
    /// Unit direction towards the viewer (the previous vertex of the eye path; octahedral).
    pub wo: Vec<Oct>,
    /// Material index.
    pub material: Vec<u32>,
    /// Pixel index, y·width + x.
    pub pixel: Vec<u32>,
    /// RGB path weight: specular-chain throughput / samples per pixel (f16).
    pub weight: Vec<Rgb16>,
    /// Diffuse albedo at the sample (texture applied); kd of a glossy sample (f16).
    pub albedo: Vec<Rgb16>,
    /// Glossy-lobe reflectance ks (zero for Lambertian samples; f16).
    pub specular: Vec<Rgb16>,
    /// [`EyeSamples::primary`] and [`EyeSamples::lobe_traced`], one bit each.
    pub flags: Vec<u8>,
    /// The splat target whose splatted irradiance this sample uses.
    pub target: Vec<u32>,
}

/// The points photon rays splat onto: one per eye sample, or one per group of eye samples of
/// a pixel that lie on the same surface within a few pixel footprints (see docs/deviations.md).
/// Each target stands at its first sample's position with that sample's normal.
#[derive(Clone, Debug, Default)]
pub struct SplatTargets {
    /// World-space position (its first eye sample's).
    pub position: Vec<Vec3>,
    /// Shading normal facing the viewer (its first eye sample's).
    pub normal: Vec<Vec3>,
    /// Geometric normal facing the viewer (its first eye sample's): the plane the visibility
    /// test's probes and shadow rays leave from (docs/deviations.md §40).
    pub geo_normal: Vec<Vec3>,
    /// The target lies on a glossy surface and needs directional storage (§8.1).
    pub glossy: Vec<bool>,
}

impl SplatTargets {
    /// Bytes held by the target arrays.
    pub fn memory_bytes(&self) -> usize {
        self.position.len() * 3 * 12 + self.glossy.len()
    }

    /// Number of splat targets.
    pub fn len(&self) -> usize {
        self.glossy.len()
    }

    /// No splat targets.
    pub fn is_empty(&self) -> bool {
        self.glossy.is_empty()
    }

    /// Free the positions and normals (the splat tree holds its own copy in slot order),
    /// keeping which targets are glossy: for methods that read the targets only through
    /// the tree (rs).
    pub fn drop_geometry(&mut self) {
        self.position = Vec::new();
        self.normal = Vec::new();
        self.geo_normal = Vec::new();
    }
}

/// [`EyeSamples::flags`]: seen directly from the camera.
const PRIMARY: u8 = 1;
/// [`EyeSamples::flags`]: the glossy lobe is traced by the eye path.
const LOBE_TRACED: u8 = 2;

/// Bytes of one eye sample in [`EyeSamples`]: position 12, the shading and geometric normals
/// and wo 4 (octahedral), three colours 6 (f16), the offset 2 (f16), material, pixel and
/// target 4, one byte of flags (102 with every vector and colour in f32).
pub const EYE_SAMPLE_BYTES: usize = 12 + 3 * 4 + 3 * 6 + 2 + 3 * 4 + 1;

impl EyeSamples {
    /// Number of eye samples.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// No eye samples.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Bytes held by the sample arrays.
    pub fn memory_bytes(&self) -> usize {
        self.len() * EYE_SAMPLE_BYTES
    }

    /// The shading normals, decoded (for code that wants them as a slice).
    pub fn normals(&self) -> Vec<Vec3> {
        self.normal.iter().map(|n| n.get()).collect()
    }

    /// True when the sample's BSDF has a glossy lobe.
    #[inline]
    pub fn is_glossy(&self, i: usize) -> bool {
        self.specular[i].get() != Vec3::ZERO
    }

    /// Sample `i` is seen directly from the camera (no specular bounce on the way).
    #[inline]
    pub fn primary(&self, i: usize) -> bool {
        self.flags[i] & PRIMARY != 0
    }

    /// Sample `i`'s glossy lobe is traced by the eye path (too sharp for the radiance map):
    /// the splatted light is reflected by the diffuse part only, the lobe's light comes from
    /// the eye samples further along the path and from NEE.
    #[inline]
    pub fn lobe_traced(&self, i: usize) -> bool {
        self.flags[i] & LOBE_TRACED != 0
    }

    /// Some sample's lobe is traced.
    pub fn any_lobe_traced(&self) -> bool {
        self.flags.iter().any(|&f| f & LOBE_TRACED != 0)
    }

    /// True when the sample's glossy lobe goes through the radiance map (a directional record
    /// at its splat target, §8.1): glossy and not traced.
    #[inline]
    pub fn lobe_in_map(&self, i: usize) -> bool {
        self.is_glossy(i) && !self.lobe_traced(i)
    }

    /// Glossy eye samples whose lobe goes through the radiance map, and those whose lobe is
    /// traced (the stats' two kinds of glossy eye sample).
    pub fn glossy_counts(&self) -> (usize, usize) {
        (0..self.len()).fold((0, 0), |(m, t), i| {
            if !self.is_glossy(i) {
                (m, t)
            } else if self.lobe_traced(i) {
                (m, t + 1)
            } else {
                (m + 1, t)
            }
        })
    }

    /// Per pixel, the share of the eye-sample weight on glossy samples whose lobe went
    /// through the radiance map and on those whose lobe was traced ([`crate::film::Film`]'s
    /// `glossy_source`), written into `out` (one entry per pixel).
    pub fn glossy_sources(&self, out: &mut [[f32; 2]]) {
        let mut total = vec![0.0f32; out.len()];
        out.fill([0.0; 2]);
        for i in 0..self.len() {
            let (px, w) = (self.pixel[i] as usize, self.weight[i].get().max_element());
            total[px] += w;
            if self.is_glossy(i) {
                out[px][usize::from(self.lobe_traced(i))] += w;
            }
        }
        for (o, t) in out.iter_mut().zip(total) {
            if t > 0.0 {
                o[0] /= t;
                o[1] /= t;
            }
        }
    }

    /// The sample's BSDF: Lambertian, or glossy with the material's Phong exponent.
    #[inline]
    pub fn bsdf(&self, i: usize, scene: &Scene) -> Bsdf {
        if self.is_glossy(i) {
            Bsdf::Glossy {
                kd: self.albedo[i].get(),
                ks: self.specular[i].get(),
                exponent: scene.glossy_exponent(self.material[i]),
            }
        } else {
            Bsdf::Lambert {
                albedo: self.albedo[i].get(),
            }
        }
    }

    /// Append one sample whose splat target is `target`.
    pub fn push_sample(&mut self, s: &EyeSample, target: u32) {
        let s = PackedSample::new(s);
        self.target.push(target);
        self.position.push(s.position);
        self.normal.push(s.normal);
        self.geo_normal.push(s.geo_normal);
        self.offset.push(s.offset);
        self.wo.push(s.wo);
        self.material.push(s.material);
        self.pixel.push(s.pixel);
        self.weight.push(s.weight);
        self.albedo.push(s.albedo);
        self.specular.push(s.specular);
        self.flags.push(s.flags);
    }
}

/// An eye sample in its stored form (quantised normals and colours, flags in one byte): made
/// in parallel by the eye pass's rows, so that the append only copies (encoding there kept
/// every other thread idle: docs/benchmarks.md, "Radiance caching").
#[derive(Clone, Copy, Debug)]
struct PackedSample {
    position: Vec3,
    normal: Oct,
    geo_normal: Oct,
    offset: Bound16,
    wo: Oct,
    material: u32,
    pixel: u32,
    weight: Rgb16,
    albedo: Rgb16,
    specular: Rgb16,
    flags: u8,
}

impl PackedSample {
    fn new(s: &EyeSample) -> Self {
        Self {
            position: s.position,
            normal: Oct::new(s.normal),
            geo_normal: Oct::new(s.geo_normal),
            offset: Bound16::new(s.offset),
            wo: Oct::new(s.wo),
            material: s.material,
            pixel: s.pixel,
            weight: Rgb16::new(s.weight),
            albedo: Rgb16::new(s.albedo),
            specular: Rgb16::new(s.specular),
            flags: (u8::from(s.primary) * PRIMARY) | (u8::from(s.lobe_traced) * LOBE_TRACED),
        }
    }
}

/// One eye sample (§3): position, normal facing the viewer, direction to the viewer, material,
/// pixel, RGB path weight, diffuse albedo and glossy reflectance.
#[derive(Clone, Copy, Debug)]
pub struct EyeSample {
    /// World-space position.
    pub position: Vec3,
    /// Shading normal, facing the viewer.
    pub normal: Vec3,
    /// Geometric normal facing the viewer, and the position's error bound along it.
    pub geo_normal: Vec3,
    /// Error bound of `position` along `geo_normal` ([`crate::scene::Hit::offset`]).
    pub offset: f32,
    /// Unit direction towards the viewer.
    pub wo: Vec3,
    /// Material index.
    pub material: u32,
    /// Pixel index, y·width + x.
    pub pixel: u32,
    /// RGB path weight: specular-chain throughput / samples per pixel.
    pub weight: Vec3,
    /// Diffuse albedo (texture applied); kd of a glossy sample.
    pub albedo: Vec3,
    /// Glossy-lobe reflectance ks (zero for Lambertian samples).
    pub specular: Vec3,
    /// Seen directly from the camera (no specular bounce on the way).
    pub primary: bool,
    /// The glossy lobe is traced by the eye path ([`EyeSamples::lobe_traced`]).
    pub lobe_traced: bool,
}

#[derive(Clone, Copy)]
struct RawSample {
    sample: EyeSample,
    /// Length of the eye path to the sample (for the pixel footprint).
    path_length: f32,
    /// Target index within the row during the pass.
    target: u32,
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
    let aspect = s.width as f32 / s.height as f32;
    // Angle subtended by one pixel (vertically), for the footprint of merged targets.
    let pixel_angle = 2.0 * (0.5 * camera.yfov).tan() / s.height as f32;
    let pixels = s.width * s.height;
    // Specular branches add samples beyond spp per pixel: an eighth more is reserved
    // (reserved pages that are never written take no memory).
    let expect = (pixels * s.spp) as usize;
    collect_bands(s.height, pixels, expect + expect / 8, |y| {
        let mut out = Vec::with_capacity((s.width * s.spp) as usize);
        let mut emitted = vec![Vec3::ZERO; s.width as usize];
        let mut targets = SplatTargets::default();
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
                let start = (camera.position, dir, w, 0, 0.0, u32::MAX, false);
                emitted[x as usize] += trace_chain(scene, start, pixel, s, &mut lobe_rng, &mut out);
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

/// One row's eye samples (targets row-local), emission per pixel and splat targets.
type Row = (Vec<RawSample>, Vec<Vec3>, SplatTargets);

/// A [`Row`] with its samples packed (and their row-local targets).
type PackedRow = (Vec<(PackedSample, u32)>, Vec<Vec3>, SplatTargets);

/// The rows of an eye pass over `height` rows and `pixels` pixels, made by `row` in parallel
/// a band of rows at a time and appended into the pass's arrays (reserved for `expect`
/// samples; reserved pages that are never written take no memory), each band's rows freed
/// before the next is made. Collecting every row before concatenating them held the whole
/// pass twice: +70 MB at 500×500×4 (docs/benchmarks.md, "Memory").
fn collect_bands(
    height: u32,
    pixels: u32,
    expect: usize,
    row: impl Fn(u32) -> Row + Sync + Send,
) -> EyePass {
    let mut samples = EyeSamples::default();
    samples.position.reserve_exact(expect);
    samples.geo_normal.reserve_exact(expect);
    samples.normal.reserve_exact(expect);
    samples.wo.reserve_exact(expect);
    for v in [
        &mut samples.weight,
        &mut samples.albedo,
        &mut samples.specular,
    ] {
        v.reserve_exact(expect);
    }
    samples.material.reserve_exact(expect);
    samples.offset.reserve_exact(expect);
    samples.flags.reserve_exact(expect);
    samples.pixel.reserve_exact(expect);
    samples.target.reserve_exact(expect);
    let mut pass = EyePass {
        samples,
        targets: SplatTargets::default(),
        emitted: Vec::with_capacity(pixels as usize),
    };
    // Enough rows per band to keep every thread busy despite rows of unequal cost.
    let band = (8 * rayon::current_num_threads() as u32).max(16);
    let mut y0 = 0;
    while y0 < height {
        let y1 = (y0 + band).min(height);
        // Rows made and their samples packed in parallel; the append only copies.
        let rows: Vec<PackedRow> = (y0..y1)
            .into_par_iter()
            .map(|y| {
                let (raw, em, targets) = row(y);
                let packed = raw
                    .iter()
                    .map(|r| (PackedSample::new(&r.sample), r.target))
                    .collect();
                (packed, em, targets)
            })
            .collect();
        // Two threads append, each to half of the arrays (the first touch of their reserved
        // pages is most of the append's cost).
        let mut offsets = Vec::with_capacity(rows.len());
        let mut next = pass.targets.len() as u32;
        for r in &rows {
            offsets.push(next);
            next += r.2.len() as u32;
        }
        let EyeSamples {
            position,
            normal,
            geo_normal,
            offset,
            wo,
            material,
            pixel,
            weight,
            albedo,
            specular,
            flags,
            target,
        } = &mut pass.samples;
        let (targets, emitted) = (&mut pass.targets, &mut pass.emitted);
        rayon::join(
            || {
                for (r, &first) in rows.iter().zip(&offsets) {
                    for (s, t) in &r.0 {
                        target.push(first + t);
                        position.push(s.position);
                        normal.push(s.normal);
                        geo_normal.push(s.geo_normal);
                        offset.push(s.offset);
                        wo.push(s.wo);
                    }
                    targets.position.extend_from_slice(&r.2.position);
                    targets.normal.extend_from_slice(&r.2.normal);
                }
            },
            || {
                for r in &rows {
                    for (s, _) in &r.0 {
                        material.push(s.material);
                        pixel.push(s.pixel);
                        weight.push(s.weight);
                        albedo.push(s.albedo);
                        specular.push(s.specular);
                        flags.push(s.flags);
                    }
                    targets.geo_normal.extend_from_slice(&r.2.geo_normal);
                    targets.glossy.extend_from_slice(&r.2.glossy);
                    emitted.extend_from_slice(&r.1);
                }
            },
        );
        y0 = y1;
    }
    pass
}

/// Give the samples of one pixel their splat targets: a new target per sample, or, when
/// merging, the first earlier target of the pixel on the same material, glossy in the map
/// alike (a target's directional record serves all its samples or none), with a normal within
/// 15° and a position within a few pixel footprints.
fn assign_targets(px: &mut [RawSample], targets: &mut SplatTargets, merge: bool, pixel_angle: f32) {
    let base = targets.len();
    for i in 0..px.len() {
        let reach = MERGE_FOOTPRINTS * pixel_angle * px[i].path_length;
        let s = px[i].sample;
        let glossy = s.specular != Vec3::ZERO && !s.lobe_traced;
        let found = if merge {
            px[..i].iter().find(|o| {
                let t = o.target as usize;
                t >= base
                    && o.sample.material == s.material
                    && targets.glossy[t] == glossy
                    && targets.normal[t].dot(s.normal) >= MERGE_COS
                    && targets.position[t].distance_squared(s.position) <= reach * reach
            })
        } else {
            None
        };
        px[i].target = match found {
            Some(o) => o.target,
            None => {
                targets.position.push(s.position);
                targets.normal.push(s.normal);
                targets.geo_normal.push(s.geo_normal);
                targets.glossy.push(glossy);
                (targets.len() - 1) as u32
            }
        };
    }
}

/// Follow one camera ray through specular chains and traced glossy lobes; push eye samples,
/// return emitted radiance.
fn trace_chain(
    scene: &Scene,
    start: Branch,
    pixel: u32,
    s: &EyeSettings,
    rng: &mut Rng,
    out: &mut Vec<RawSample>,
) -> Vec3 {
    let max_depth = s.max_specular_depth;
    let mut stack = [(
        Vec3::ZERO,
        Vec3::ZERO,
        Vec3::ZERO,
        0u32,
        0f32,
        u32::MAX,
        false,
    ); BRANCH_STACK];
    stack[0] = start;
    let mut top = 1;
    let mut emitted = Vec3::ZERO;
    while top > 0 {
        top -= 1;
        let (o, d, w, depth, travelled, leaving, from_lobe) = stack[top];
        let Some(hit) = scene.intersect_except(o, d, f32::INFINITY, leaving) else {
            // Escaped: the environment seen directly or through the chain (off a traced lobe
            // it is NEE's at the lobe's eye sample, as emission below).
            if !from_lobe {
                emitted += w * scene.background(d);
            }
            continue;
        };
        let path_length = travelled + hit.t;
        let wo = -d;
        // Light met straight off a traced lobe is NEE's at the lobe's eye sample (its BSDF
        // sample under MIS holds this path), so it is not counted twice.
        if !from_lobe {
            emitted += w * scene.emitted(&hit, wo);
        }
        let bsdf = scene.bsdf(&hit);
        let surface = match bsdf {
            Bsdf::Lambert { albedo } => Some((albedo, Vec3::ZERO)),
            Bsdf::Glossy { kd, ks, .. } => Some((kd, ks)),
            _ => None,
        };
        if let Some((albedo, specular)) = surface {
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
                && top < BRANCH_STACK
            {
                out.last_mut().expect("just pushed").sample.lobe_traced = true;
                stack[top] = (
                    scene.offset(&hit, d),
                    d,
                    w * lobe_w,
                    depth + 1,
                    path_length,
                    hit.triangle,
                    true,
                );
                top += 1;
            } else if depth < max_depth && traces_lobe(bsdf, s.lobe_limit) {
                // The lobe is traced, but its sampled direction left through the surface or
                // carries too little: it adds nothing (f = 0 below the surface).
                out.last_mut().expect("just pushed").sample.lobe_traced = true;
            }
            continue;
        }
        // A branch that leaves through the geometric surface the wrong way (a shading normal
        // can send it there) is dropped, as photons and the path tracer drop it.
        let mut push = |d: Vec3, w: Vec3, transmit: bool, top: &mut usize| {
            if w.max_element() >= MIN_BRANCH_WEIGHT
                && *top < BRANCH_STACK
                && Scene::leaves_correctly(&hit, wo, d, transmit)
            {
                stack[*top] = (
                    scene.offset(&hit, d),
                    d,
                    w,
                    depth + 1,
                    path_length,
                    hit.triangle,
                    false,
                );
                *top += 1;
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
                push(r, w * color, false, &mut top);
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
                push(r, w * f, false, &mut top);
                if let Some(t) = refract(wo, n, eta) {
                    push(t, w * tint * (1.0 - f), true, &mut top);
                }
            }
        }
    }
    emitted
}

/// A branch of an eye path: origin, direction, weight, depth (specular and traced glossy
/// bounces so far), length so far, the triangle it leaves, and whether it leaves a traced lobe.
type Branch = (Vec3, Vec3, Vec3, u32, f32, u32, bool);

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
/// targets and the emission they see, in pixel order as [`eye_pass`] gives them.
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
    collect_bands(s.height, s.width * s.height, 0, |y| {
        let mut out = Vec::new();
        let mut emitted = vec![Vec3::ZERO; s.width as usize];
        let mut targets = SplatTargets::default();
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
                let bsdf = eye.bsdf(k, scene);
                if let Some((d, lobe_w)) =
                    sample_traced_lobe(bsdf, eye.wo[k].get(), n, ng, s.lobe_limit, &mut rng)
                {
                    let origin = crate::scene::offset_ray_origin(p, ng, eye.offset[k].get(), d);
                    let w = eye.weight[k].get() * lobe_w * scale;
                    // The length from the camera stands in for the path's (merging reach).
                    let start = (origin, d, w, 1, p.distance(camera.position), u32::MAX, true);
                    if w.max_element() >= MIN_BRANCH_WEIGHT {
                        emitted[(pixel - y * s.width) as usize] +=
                            trace_chain(scene, start, pixel, &s, &mut rng, &mut out);
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
}

/// True when `bsdf` is glossy with a lobe sharper than `limit` (traced by the eye path).
#[inline]
fn traces_lobe(bsdf: Bsdf, limit: f32) -> bool {
    matches!(bsdf, Bsdf::Glossy { ks, exponent, .. } if exponent > limit && ks != Vec3::ZERO)
}

/// One direction of a glossy lobe too sharp for the radiance map, sampled from the normalised
/// Phong lobe about the mirror direction of `wo` (`n` the shading normal facing the viewer,
/// `ng` the geometric one): the direction and its weight ks·g·cos θ/(pdf·p) = ks·(e+2)/(e+1)·
/// cos θ/p, an unbiased one-sample estimate of the lobe's reflection. The lobe is traced with
/// the probability p the BSDF's own sampling gives it (its share of the reflectance by
/// luminance: 1 for a metal, 0.11 for a white plastic), a Russian roulette that spends rays
/// where the lobe carries light. `None` when the lobe is not traced, the roulette ends it, or
/// the direction leaves below the surface (where f = 0).
#[inline]
fn sample_traced_lobe(
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
    let Bsdf::Glossy { kd, ks, exponent } = bsdf else {
        return None;
    };
    let p = specular_probability(kd, ks);
    if rng.next_f32() >= p {
        return None;
    }
    let u = rng.next_2d();
    let cos_a = u.x.powf(1.0 / (exponent + 1.0));
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let local = Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
    let d = crate::sampling::to_world(local, reflect(wo, n));
    let cos = d.dot(n);
    if cos <= 0.0 || d.dot(ng) <= 0.0 {
        return None;
    }
    Some((d, ks * ((exponent + 2.0) / (exponent + 1.0) * cos / p)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glossy sample on a plane facing +z at the origin, its lobe traced or not.
    fn raw(lobe_traced: bool) -> RawSample {
        RawSample {
            sample: EyeSample {
                position: Vec3::ZERO,
                normal: Vec3::Z,
                geo_normal: Vec3::Z,
                offset: 0.0,
                wo: Vec3::Z,
                material: 0,
                pixel: 0,
                weight: Vec3::ONE,
                albedo: Vec3::splat(0.5),
                specular: Vec3::splat(0.3),
                primary: true,
                lobe_traced,
            },
            path_length: 1.0,
            target: 0,
        }
    }

    /// Samples on one spot of one material merge, but not a traced lobe's with an untraced
    /// one's (a max-depth sample the eye path did not continue): the target's directional
    /// record must serve all its samples or none.
    #[test]
    fn merged_samples_are_glossy_in_the_map_alike() {
        let mut px = vec![raw(false), raw(true), raw(false), raw(true)];
        let mut targets = SplatTargets::default();
        assign_targets(&mut px, &mut targets, true, 0.01);
        assert_eq!(targets.len(), 2);
        assert_eq!(px[0].target, px[2].target);
        assert_eq!(px[1].target, px[3].target);
        assert_ne!(px[0].target, px[1].target);
        assert!(targets.glossy[px[0].target as usize]);
        assert!(!targets.glossy[px[1].target as usize]);
    }
}
