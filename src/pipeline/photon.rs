//! Light pass (§3, §6): photons leave the lights in proportion to power, scatter by BSDF
//! importance sampling with Russian roulette, and every segment x_i → x_{i+1} is stored as a
//! [`PhotonRay`] with the clamped path pdf p̃ of eq. 7 at both ends. A pilot phase estimates
//! ⟨D⟩ and ⟨r⟩ for the bandwidth normalisation w of eq. 8.
//!
//! Bandwidth (eq. 8) is a pure function of the stored ray, the parameters and the pilot
//! statistics, so moving C/S/R re-splats stored rays without re-tracing.

use crate::bsdf::Bsdf;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The paper's a in μC = a·⟨D⟩ (§6).
pub const MU_C_FACTOR: f32 = 0.2;
/// m0 = ⁶√(10⁵) = 10^(5/6) ≈ 6.8 (§6; DESIGN.md on the garbled root).
pub const M0: f32 = 6.812_921;
/// The clamp distance D̃ of eq. 7 as a fraction of the pilot's ⟨D⟩ (the paper leaves it
/// scene-dependent without a value; docs/deviations.md §3): D̃ = μC, the typical kernel
/// radius at M = 10⁵, since a segment shorter than a kernel says nothing about how the
/// density changes across one. A fraction of the light's own length scale, never of the
/// bounding box, so far-away geometry cannot change it.
pub const D_TILDE_FRACTION: f32 = MU_C_FACTOR;
/// Stand-in solid-angle density of a specular bounce for eq. 7 (a delta has none): about
/// that of a lobe 6° wide, so caustic paths get the small bandwidths §6 describes.
pub const SPECULAR_PDF: f32 = 100.0;
/// R is kept in [R_MIN, 1] (R = 1: one bandwidth for every ray).
pub const R_MIN: f32 = 1e-3;
/// Photon paths end after this many segments whatever Russian roulette says.
pub const MAX_PATH_SEGMENTS: u32 = 32;
/// Photons traced per pilot phase (§6).
pub const PILOT_PHOTONS: u32 = 8192;

/// Table 2's photon classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum PhotonClass {
    /// Light → first hit.
    Direct = 0,
    /// At least one non-specular bounce before the segment.
    Indirect = 1,
    /// Light, then only specular bounces, then the segment (caustic paths L S+ …).
    Caustic = 2,
}

impl PhotonClass {
    pub const ALL: [PhotonClass; 3] = [
        PhotonClass::Direct,
        PhotonClass::Indirect,
        PhotonClass::Caustic,
    ];
}

/// One stored photon ray (segment x_i → x_{i+1}).
#[derive(Clone, Copy, Debug)]
pub struct PhotonRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub length: f32,
    /// Power carried, already divided by the number of photons emitted for its class.
    pub power: Vec3,
    /// Normal of the surface at the origin on the side the ray leaves (zero for point lights).
    pub origin_normal: Vec3,
    /// |ω·n_s| / |ω·n_g| at the end vertex (1 if it escapes): converts the ray's flux through
    /// the geometric surface into the shading-normal cosine that the path tracer and the
    /// splat kernel use, for photon mapping's density estimate (Veach 1997, §5.3).
    pub end_shading_ratio: f32,
    /// p̃(x_i | x_{i−1}) (unused for bounce 0, where h(x_0) = 0).
    pub pdf_start: f32,
    /// p̃(x_{i+1} | x_i), eq. 7.
    pub pdf_end: f32,
    /// i: 0 for the segment leaving the light.
    pub bounce: u8,
    pub class: PhotonClass,
    /// The ray ends on a non-specular surface (where photon mapping stores a photon).
    pub lands: bool,
    /// Geometric normal of the surface the ray hits, facing the ray (zero if it escapes).
    pub end_normal: Vec3,
}

impl PhotonRay {
    /// The ray hits nothing (it was clipped where it leaves the scene's bounds).
    #[inline]
    pub fn escapes(&self) -> bool {
        self.end_normal == Vec3::ZERO
    }

    /// The ray ends on a mirror or glass surface: it splats nothing beyond its end, since the
    /// photon goes on from there (docs/deviations.md §23).
    #[inline]
    pub fn ends_specular(&self) -> bool {
        !self.lands && !self.escapes()
    }

    /// Every number finite (power non-negative): a ray that may be splatted.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.length.is_finite()
            && self.power.is_finite()
            && self.power.min_element() >= 0.0
            && self.origin_normal.is_finite()
            && self.end_shading_ratio.is_finite()
            && self.end_normal.is_finite()
            && self.pdf_start.is_finite()
            && self.pdf_end.is_finite()
    }
}

/// User bandwidth parameters (§6, eq. 8).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandwidthParams {
    /// C, smoothness.
    pub smoothness_c: f32,
    /// S ∈ (0, 1], sensitivity.
    pub sensitivity_s: f32,
    /// R ∈ (0, 1], the bandwidth range: every h lies within [R·h̄, h̄/R] of the typical
    /// bandwidth h̄ = C·(M/10⁵)^(−1/6)·μC (§6's bounds "from μC and R"; docs/deviations.md §5).
    pub max_bandwidth_r: f32,
}

impl Default for BandwidthParams {
    fn default() -> Self {
        Self {
            smoothness_c: 1.0,
            sensitivity_s: 0.4,
            max_bandwidth_r: 0.2,
        }
    }
}

/// Statistics of the pilot phase (§6).
///
/// Both statistics are weighted by the share of power a segment's end vertex sends on (the
/// Russian-roulette survival probability): segments that escape the scene or end on a black
/// surface carry no light further and say nothing about the scale of the lighting, so a black
/// ground plane far away, or an open side, cannot change the bandwidths (docs/deviations.md §2).
#[derive(Clone, Copy, Debug)]
pub struct Pilot {
    /// ⟨D⟩: weighted mean photon-segment length (a length, so that μC = a·⟨D⟩ is one;
    /// DESIGN.md). Eq. 7's lengths are measured in this unit.
    pub mean_length: f32,
    /// Weighted mean of ln p̃ (dimensionless, eq. 7) over the pilot's vertices: the geometric
    /// mean of r = p̃^(−S/2) for any S is exp(−S/2 · this).
    pub mean_log_pdf: f64,
    /// Pilot vertices that entered the statistics.
    pub vertices: usize,
}

impl Pilot {
    /// μC = a·⟨D⟩ (§6).
    pub fn mu_c(&self) -> f32 {
        MU_C_FACTOR * self.mean_length
    }

    /// The units of eq. 7 for the light pass.
    pub fn units(&self) -> PathUnits {
        PathUnits {
            length: self.mean_length,
        }
    }

    /// ⟨r⟩, r = 1/√(p̃^S) (§6), as a geometric mean: p̃ spans many orders of magnitude over
    /// bounces, and an arithmetic mean is then set by a few deep vertices
    /// (docs/deviations.md §5).
    pub fn mean_r(&self, s: f32) -> f32 {
        if self.vertices == 0 {
            return 1.0;
        }
        ((-0.5 * s as f64 * self.mean_log_pdf).exp() as f32).clamp(f32::MIN_POSITIVE, f32::MAX)
    }
}

/// The length unit of eq. 7 (the pilot's ⟨D⟩): p̃ is computed with lengths in this unit and
/// area densities per unit², so it has no units and a scene scaled by any factor gets the
/// same p̃, the same bandwidths relative to its size, and the same image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathUnits {
    pub length: f32,
}

impl PathUnits {
    /// Units for the pilot's first look at a scene, before ⟨D⟩ is known (p̃ unused then).
    const PROVISIONAL: PathUnits = PathUnits { length: 1.0 };
}

/// Eq. 8 evaluated for one parameter set and class size; cheap per-vertex evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Bandwidth {
    /// C·M^(−1/6)·w (eq. 8 without the per-vertex factor).
    scale: f32,
    half_s: f32,
    pub h_min: f32,
    pub h_max: f32,
}

impl Bandwidth {
    pub fn new(params: &BandwidthParams, pilot: &Pilot, m: u64, mean_r: f32) -> Self {
        let m = m.max(1) as f32;
        let mu_c = pilot.mu_c();
        let w = M0 * mu_c / mean_r; // w = m0·μC/⟨r⟩ (§6)
        let scale = params.smoothness_c * m.powf(-1.0 / 6.0) * w; // eq. 8: C/⁶√M · w
        // The typical bandwidth at this M, C·(M/10⁵)^(−1/6)·μC (the geometric mean of eq. 8
        // over the pilot); the bounds "from μC and R" (§6) keep h within a factor 1/R of it.
        let typical = (params.smoothness_c * (m / 1e5).powf(-1.0 / 6.0) * mu_c).max(1e-30);
        let r = params.max_bandwidth_r.clamp(R_MIN, 1.0);
        Self {
            scale,
            half_s: 0.5 * params.sensitivity_s,
            h_min: typical * r,
            h_max: typical / r,
        }
    }

    /// h(x_i) for i > 0 (eq. 8): C·M^(−1/6)·w / √(p̃^S), clamped.
    #[inline]
    pub fn h(&self, pdf: f32) -> f32 {
        (self.scale * pdf.max(f32::MIN_POSITIVE).powf(-self.half_s)).clamp(self.h_min, self.h_max)
    }

    /// (h0, dh) of a ray (§6): h0 = min(h(x_i), h(x_{i+1})), dh = max(0, h(x_{i+1}) − h(x_i))/|x_{i+1} − x_i|.
    /// A ray that escapes has no end vertex: it keeps its start bandwidth (a cylinder) up to
    /// where it leaves the scene, so the bounding box only clips it.
    #[inline]
    pub fn cone(&self, ray: &PhotonRay) -> (f32, f32) {
        let hi = if ray.bounce == 0 {
            0.0 // h(x_0) = 0 (eq. 8)
        } else {
            self.h(ray.pdf_start)
        };
        if ray.escapes() {
            return (hi, 0.0);
        }
        let hj = self.h(ray.pdf_end);
        let dh = (hj - hi).max(0.0) / ray.length.max(1e-12);
        (hi.min(hj), dh)
    }
}

/// Rays of one class whose cone sits at a bandwidth bound: `at_min` start at h_min (h0 =
/// h_min), `at_max` end at h_max. A healthy eq. 8 leaves few at either (docs/deviations.md §5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClampCounts {
    pub rays: u64,
    pub at_min: u64,
    pub at_max: u64,
}

impl ClampCounts {
    /// Count the rays of `class` in `rays` under the bandwidth `bw`.
    pub fn count(rays: &[PhotonRay], bw: &Bandwidth, class: PhotonClass) -> Self {
        rays.par_iter()
            .filter(|r| r.class == class)
            .fold(Self::default, |mut c, r| {
                let (h0, dh) = bw.cone(r);
                let h_end = h0 + dh * r.length;
                c.rays += 1;
                // h(x_0) = 0 is eq. 8's own start, not a clamp: a ray leaving the light is at
                // h_min when its end is.
                c.at_min += (if r.bounce == 0 { h_end } else { h0 } <= bw.h_min) as u64;
                c.at_max += (h_end >= bw.h_max) as u64;
                c
            })
            .reduce(Self::default, |a, b| Self {
                rays: a.rays + b.rays,
                at_min: a.at_min + b.at_min,
                at_max: a.at_max + b.at_max,
            })
    }

    pub fn fraction_min(&self) -> f64 {
        self.at_min as f64 / self.rays.max(1) as f64
    }

    pub fn fraction_max(&self) -> f64 {
        self.at_max as f64 / self.rays.max(1) as f64
    }
}

impl std::ops::AddAssign for ClampCounts {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.at_min += o.at_min;
        self.at_max += o.at_max;
    }
}

/// Photons per class for one light pass (Table 2's M split by its fractions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassBudgets(pub [u64; 3]);

impl ClassBudgets {
    pub fn from_fractions(m: u64, fractions: [f32; 3], splat_direct: bool) -> Self {
        let mut b = [0u64; 3];
        for (i, f) in fractions.iter().enumerate() {
            b[i] = (m as f64 * f.max(0.0) as f64).round() as u64;
        }
        if !splat_direct {
            b[PhotonClass::Direct as usize] = 0;
        }
        Self(b)
    }

    pub fn total(&self) -> u64 {
        self.0.iter().sum()
    }
}

/// Result of one light pass.
#[derive(Clone, Debug, Default)]
pub struct PhotonBatch {
    pub rays: Vec<PhotonRay>,
    /// Photons emitted while filling each class (the power normalisation of that class).
    pub emitted: [u64; 3],
    /// Photons traced in total (a statistic: it depends on how many threads traced).
    pub traced: u64,
    /// Rays stored per class.
    pub stored: [u64; 3],
    /// Photon paths cut short and rays dropped because a power, direction, length or p̃ was
    /// NaN or infinite (counted, never splatted).
    pub invalid: u64,
}

/// Settings of the light pass.
#[derive(Clone, Copy, Debug)]
pub struct LightPassSettings {
    pub budgets: ClassBudgets,
    /// Stop after this many photons per stored-photon budget even if a class never fills
    /// (a scene without specular objects has no caustic photons).
    pub max_emitted_factor: u64,
    pub seed: u64,
    /// Offset of this batch's photon indices (so batches use disjoint random streams); the next
    /// batch starts at `first_photon + max(emitted)`, which does not depend on thread count.
    pub first_photon: u64,
    /// Eq. 7's length unit, from the pilot ([`Pilot::units`]).
    pub units: PathUnits,
}

/// Segment under construction, with the index of the photon that made it.
#[derive(Clone, Copy)]
struct TaggedRay {
    photon: u64,
    ray: PhotonRay,
    /// Share of the power the end vertex sends on (the Russian-roulette survival
    /// probability; 0 when the ray escapes or the path ends there): the pilot's weight.
    onward: f32,
    /// The first segment of a directional light's photon, from a disc outside the scene.
    parallel: bool,
}

/// D(x, y) = max(D̃², ‖x − y‖²) (eq. 7).
#[inline]
fn clamped_sq_distance(length: f32, d_tilde: f32) -> f32 {
    (length * length).max(d_tilde * d_tilde)
}

/// Trace one photon path, pushing its segments (of classes wanted by `keep`).
fn trace_photon(
    scene: &Scene,
    photon: u64,
    seed: u64,
    keep: [bool; 3],
    units: PathUnits,
    out: &mut Vec<TaggedRay>,
    invalid: &mut u64,
) -> bool {
    let mut rng = Rng::new(seed, photon);
    let Some(e) = scene.lights.sample_emission(&mut rng) else {
        return false;
    };
    // Eq. 7 without units: lengths in ⟨D⟩, so D̃ is a fraction of it.
    let inv_unit = 1.0 / units.length.max(f32::MIN_POSITIVE);
    // Leave the emitting surface on the side the photon goes, so it cannot hit its own light
    // (a two-sided panel lies in the plane of its origin: t = 0 would count as a hit).
    let mut origin = if e.offset > 0.0 {
        crate::scene::offset_ray_origin(e.origin, e.normal, e.offset, e.direction)
    } else {
        e.origin
    };
    let mut dir = e.direction;
    let mut normal = e.normal;
    let mut power = e.power;
    // Eq. 7 is followed along two chains (docs/deviations.md §4). The caustic chain gives a
    // specular bounce the stand-in density SPECULAR_PDF, so caustic rays (L S+ …) get the
    // small bandwidths §6 describes. Direct and indirect rays use the unfolded chain: a
    // mirror or glass vertex adds no density factor and the segments on either side of it
    // count as one, so light already spread by a diffuse bounce keeps its spread through glass.
    let emit_density = if e.pdf_per_area {
        e.pdf * units.length * units.length
    } else {
        e.pdf
    };
    // Unfolded chain: p̃ at the last non-specular vertex (1 before the light), the density
    // of the direction sampled there, the length travelled since, and p̃ at the current vertex.
    let (mut u_base, mut u_density, mut u_len, mut u_here) = (1.0f32, emit_density, 0.0f32, 0.0f32);
    // Caustic chain: p̃ at the current vertex and the density of the next direction.
    let (mut c_here, mut c_density) = (1.0f32, emit_density);
    let mut any_diffuse = false;
    // The triangle the photon leaves (never its next hit).
    let mut leaving = e.triangle;
    for bounce in 0..MAX_PATH_SEGMENTS {
        if !power.is_finite() {
            *invalid += 1;
            break;
        }
        if power.max_element() <= 0.0 {
            break;
        }
        let hit = scene.intersect_except(origin, dir, f32::INFINITY, leaving);
        let length = match &hit {
            Some(h) => h.t,
            // Escaping photons still pass eye samples on their way out: keep the segment up
            // to where it leaves the scene bounds.
            None => exit_distance(scene, origin, dir),
        };
        if length.is_nan() || length <= 0.0 {
            break;
        }
        // eq. 7: p̃(x1|x0) = p_e/D(x0,x1); p̃(x_{i+1}|x_i) = p̃(x_i|x_{i−1})·p_s⊥/D(x_i,x_{i+1})
        // Long specular chains multiply p̃ past f32's range; it saturates (its bandwidth is
        // h_min either way) rather than becoming infinite.
        // A directional light's photons travel in parallel: their density does not fall with
        // distance, so the first segment has no D (and its length, from a disc outside the
        // scene, is no length of the scene's lighting: the pilot leaves it out).
        let parallel = bounce == 0 && e.parallel;
        let d_of = |l: f32| {
            if parallel {
                1.0
            } else {
                clamped_sq_distance(l * inv_unit, D_TILDE_FRACTION)
            }
        };
        let u_next = (u_base * u_density / d_of(u_len + length)).min(f32::MAX);
        let c_next = (c_here * c_density / d_of(length)).min(f32::MAX);
        let class = if bounce == 0 {
            PhotonClass::Direct
        } else if any_diffuse {
            PhotonClass::Indirect
        } else {
            PhotonClass::Caustic
        };
        let (pdf_start, pdf_end) = match class {
            PhotonClass::Direct => (0.0, u_next),
            PhotonClass::Indirect => (u_here, u_next),
            PhotonClass::Caustic => (c_here, c_next),
        };
        let lands = hit
            .as_ref()
            .is_some_and(|h| !scene.materials[h.material as usize].is_specular());
        let end_normal = hit.as_ref().map_or(Vec3::ZERO, |h| {
            if h.geo_normal.dot(dir) <= 0.0 {
                h.geo_normal
            } else {
                -h.geo_normal
            }
        });
        // The shading normal on the side the photon arrives from (geometric side): where it
        // faces away from the photon, the path tracer and the splat kernel see nothing.
        let end_shading_ratio = hit.as_ref().map_or(1.0, |h| {
            let cos_g = dir.dot(h.geo_normal).abs();
            let ns = if h.geo_normal.dot(dir) <= 0.0 {
                h.normal
            } else {
                -h.normal
            };
            if cos_g > 0.0 {
                (-dir.dot(ns)).max(0.0) / cos_g
            } else {
                0.0
            }
        });
        let pushed = keep[class as usize];
        if pushed {
            out.push(TaggedRay {
                photon,
                onward: 0.0,
                parallel,
                ray: PhotonRay {
                    origin,
                    dir,
                    length,
                    power,
                    origin_normal: normal,
                    end_shading_ratio,
                    pdf_start,
                    pdf_end,
                    bounce: bounce.min(255) as u8,
                    class,
                    lands,
                    end_normal,
                },
            });
        }
        let Some(hit) = hit else { break };
        let wo = -dir;
        let bsdf = scene.bsdf(&hit);
        let Some(s) = bsdf.sample(wo, hit.normal, rng.next_2d(), rng.next_f32()) else {
            break;
        };
        // Discard samples that leave through the geometric surface the wrong way.
        let cos_g_out = s.wi.dot(hit.geo_normal);
        let cos_g_in = wo.dot(hit.geo_normal);
        let transmitted = matches!(bsdf, Bsdf::Dielectric { .. }) && cos_g_out * cos_g_in < 0.0;
        if !Scene::leaves_correctly(&hit, wo, s.wi, transmitted) {
            break;
        }
        // Shading normals make the BSDF non-symmetric: a photon (importance transport) needs
        // Veach's adjoint factor |ωo·n_s||ωi·n_g| / (|ωo·n_g||ωi·n_s|) (Veach 1997, §5.3) on
        // top of f·|ωi·n_s|/pdf, so that photons and the path tracer agree on smooth-shaded
        // meshes. On a flat-shaded surface it is exactly 1.
        let adjoint = {
            let den = cos_g_in.abs() * s.wi.dot(hit.normal).abs();
            if den > 0.0 {
                wo.dot(hit.normal).abs() * cos_g_out.abs() / den
            } else {
                0.0
            }
        };
        let mut new_power = power * s.weight * adjoint;
        // Russian roulette keeping the photon power roughly constant.
        let q = (new_power.max_element() / power.max_element()).min(1.0);
        if pushed && let Some(last) = out.last_mut() {
            last.onward = if q.is_finite() { q.max(0.0) } else { 0.0 };
        }
        if rng.next_f32() >= q {
            break;
        }
        new_power /= q;
        power = new_power;
        // eq. 7's next factor: p̃ × p_s⊥ / D.
        if s.specular {
            u_len += length;
        } else {
            (u_base, u_density, u_len) = (u_next, s.pdf, 0.0);
        }
        u_here = u_next;
        (c_here, c_density) = (c_next, if s.specular { SPECULAR_PDF } else { s.pdf });
        any_diffuse |= !s.specular;
        normal = if cos_g_out >= 0.0 {
            hit.geo_normal
        } else {
            -hit.geo_normal
        };
        origin = scene.offset(&hit, s.wi);
        leaving = hit.triangle;
        dir = s.wi;
    }
    true
}

fn exit_distance(scene: &Scene, o: Vec3, d: Vec3) -> f32 {
    // A few ulps of the bounds' coordinates, so that a sample on the boundary is inside.
    let pad = Vec3::splat(
        8.0 * f32::EPSILON
            * scene
                .bounds_min
                .abs()
                .max(scene.bounds_max.abs())
                .max_element(),
    );
    crate::pipeline::splat_tree::clip(
        o.into(),
        d.into(),
        (scene.bounds_min - pad).into(),
        (scene.bounds_max + pad).into(),
        0.0,
        f32::INFINITY,
    )
    .map(|(_, t1)| t1)
    .unwrap_or(0.0)
}

/// The pilot shooting phase (§6): trace a few thousand photons, record segment lengths and
/// vertex pdfs. It runs twice over the same photons: once for ⟨D⟩, once for eq. 7's p̃ in
/// units of it.
pub fn pilot(scene: &Scene, seed: u64) -> Pilot {
    let trace = |units: PathUnits| -> Vec<TaggedRay> {
        (0..PILOT_PHOTONS as u64 / 512)
            .into_par_iter()
            .map(|c| {
                let mut out = Vec::new();
                let mut invalid = 0;
                for id in c * 512..(c + 1) * 512 {
                    trace_photon(
                        scene,
                        id,
                        seed ^ 0x005e_ed0f_9110,
                        [true; 3],
                        units,
                        &mut out,
                        &mut invalid,
                    );
                }
                out.retain(|r| r.ray.is_valid());
                out
            })
            .flatten_iter()
            .collect()
    };
    let first = trace(PathUnits::PROVISIONAL);
    let (mut len_sum, mut w_sum) = (0.0f64, 0.0f64);
    for r in first.iter().filter(|r| !r.parallel) {
        let w = r.onward as f64;
        len_sum += w * r.ray.length as f64;
        w_sum += w;
    }
    let mean_length = if w_sum > 0.0 && len_sum > 0.0 {
        (len_sum / w_sum) as f32
    } else {
        // No photon bounces anywhere (every surface black, or nothing to hit): the plain mean
        // length of what was traced, or the scene's size as a last resort.
        let n = first.len().max(1) as f64;
        let plain = first.iter().map(|r| r.ray.length as f64).sum::<f64>() / n;
        if plain > 0.0 {
            plain as f32
        } else {
            0.1 * scene.diagonal()
        }
    };
    let units = PathUnits {
        length: mean_length,
    };
    let second = trace(units);
    let (mut log_sum, mut w_sum, mut vertices) = (0.0f64, 0.0f64, 0usize);
    for r in &second {
        let p = r.ray.pdf_end;
        if r.onward > 0.0 && p.is_finite() && p > 0.0 {
            log_sum += r.onward as f64 * (p as f64).ln();
            w_sum += r.onward as f64;
            vertices += 1;
        }
    }
    Pilot {
        mean_length,
        mean_log_pdf: if w_sum > 0.0 { log_sum / w_sum } else { 0.0 },
        vertices,
    }
}

/// Trace photons until every class has its budget of stored rays (Table 2's fractions), or
/// until `max_emitted_factor × total budget` photons were emitted.
pub fn light_pass(scene: &Scene, s: &LightPassSettings) -> PhotonBatch {
    let budgets = s.budgets.0;
    let keep = [budgets[0] > 0, budgets[1] > 0, budgets[2] > 0];
    let total_budget = s.budgets.total();
    let mut batch = PhotonBatch::default();
    if total_budget == 0 {
        return batch;
    }
    let cap = total_budget.saturating_mul(s.max_emitted_factor.max(1));
    let chunk = 2048u64;
    let wave = chunk * 4 * rayon::current_num_threads().max(1) as u64;
    let mut counts = [0u64; 3];
    let mut full_at: [Option<u64>; 3] = [None; 3];
    let mut emitted = 0u64;
    let mut parts: Vec<Vec<TaggedRay>> = Vec::new();
    while emitted < cap && (0..3).any(|c| keep[c] && full_at[c].is_none()) {
        let start = emitted;
        let end = (start + wave).min(cap);
        // Only classes that still need rays are stored in this wave.
        let want = [
            keep[0] && full_at[0].is_none(),
            keep[1] && full_at[1].is_none(),
            keep[2] && full_at[2].is_none(),
        ];
        let wave_parts: Vec<Vec<TaggedRay>> = (start..end)
            .step_by(chunk as usize)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|c0| {
                let mut out = Vec::with_capacity(chunk as usize * 2);
                let mut invalid = 0u64;
                for id in c0..(c0 + chunk).min(end) {
                    trace_photon(
                        scene,
                        s.first_photon + id,
                        s.seed,
                        want,
                        s.units,
                        &mut out,
                        &mut invalid,
                    );
                }
                (out, invalid)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .map(|(out, invalid)| {
                batch.invalid += invalid;
                out
            })
            .collect();
        // Find, in photon order, where each class reaches its budget.
        for part in &wave_parts {
            for r in part {
                let c = r.ray.class as usize;
                if full_at[c].is_none() {
                    counts[c] += 1;
                    if counts[c] >= budgets[c] {
                        full_at[c] = Some(r.photon - s.first_photon + 1);
                    }
                }
            }
        }
        parts.extend(wave_parts);
        emitted = end;
    }
    for c in 0..3 {
        batch.emitted[c] = if keep[c] {
            full_at[c].unwrap_or(emitted)
        } else {
            0
        };
    }
    batch.traced = emitted;
    let total: usize = parts.iter().map(Vec::len).sum();
    batch.rays.reserve_exact(total);
    for r in parts.into_iter().flatten() {
        let c = r.ray.class as usize;
        let local = r.photon - s.first_photon;
        if keep[c] && local < batch.emitted[c] {
            let mut ray = r.ray;
            ray.power /= batch.emitted[c] as f32;
            if !ray.is_valid() {
                batch.invalid += 1;
                continue;
            }
            batch.stored[c] += 1;
            batch.rays.push(ray);
        }
    }
    batch
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pilot whose vertices had these p̃ (equal weights).
    fn pilot(pdfs: Vec<f32>) -> Pilot {
        let n = pdfs.len();
        Pilot {
            mean_length: 0.5,
            mean_log_pdf: pdfs.iter().map(|&p| (p as f64).ln()).sum::<f64>() / n.max(1) as f64,
            vertices: n,
        }
    }

    #[test]
    fn rays_with_non_finite_numbers_are_invalid() {
        let good = PhotonRay {
            origin: Vec3::ZERO,
            dir: Vec3::Y,
            length: 1.0,
            power: Vec3::ONE,
            origin_normal: Vec3::Y,
            end_shading_ratio: 1.0,
            pdf_start: 0.0,
            pdf_end: 1.0,
            bounce: 0,
            class: PhotonClass::Direct,
            lands: true,
            end_normal: -Vec3::Y,
        };
        assert!(good.is_valid());
        for bad in [
            PhotonRay {
                power: Vec3::new(1.0, f32::INFINITY, 0.0),
                ..good
            },
            PhotonRay {
                power: Vec3::new(-1.0, 0.0, 0.0),
                ..good
            },
            PhotonRay {
                length: f32::NAN,
                ..good
            },
            PhotonRay {
                pdf_end: f32::INFINITY,
                ..good
            },
            PhotonRay {
                dir: Vec3::new(f32::NAN, 0.0, 0.0),
                ..good
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }

    #[test]
    fn m0_is_the_sixth_root_of_ten_to_the_fifth() {
        assert!((M0 - 1e5f32.powf(1.0 / 6.0)).abs() < 1e-4);
    }

    #[test]
    fn eq8_bandwidth_formula() {
        let p = pilot(vec![0.5, 2.0, 8.0]);
        let params = BandwidthParams {
            smoothness_c: 0.7,
            sensitivity_s: 0.6,
            max_bandwidth_r: R_MIN,
        };
        let m = 50_000u64;
        let mean_r = p.mean_r(params.sensitivity_s);
        let bw = Bandwidth::new(&params, &p, m, mean_r);
        let w = M0 * p.mu_c() / mean_r;
        for pdf in [0.5f32, 2.0, 8.0] {
            // eq. 8: h = C / ⁶√M · w / √(p̃^S)
            let expect = 0.7 * (m as f32).powf(-1.0 / 6.0) * w / pdf.powf(0.6).sqrt();
            assert!((bw.h(pdf) - expect).abs() < 1e-6 * expect.max(1.0), "{pdf}");
        }
    }

    #[test]
    fn mean_bandwidth_is_mu_c_at_m_1e5_and_c_1() {
        // m0 calibrates the typical (unclamped) bandwidth to μC at M = 10⁵, C = 1 (§6); with
        // ⟨r⟩ a geometric mean, the geometric mean of h is μC.
        let pdfs: Vec<f32> = (1..200).map(|i| 0.05 * i as f32).collect();
        let p = pilot(pdfs.clone());
        let params = BandwidthParams {
            smoothness_c: 1.0,
            sensitivity_s: 0.4,
            max_bandwidth_r: R_MIN,
        };
        let bw = Bandwidth::new(&params, &p, 100_000, p.mean_r(0.4));
        let mean = (pdfs.iter().map(|&x| (bw.h(x) as f64).ln()).sum::<f64>() / pdfs.len() as f64)
            .exp() as f32;
        assert!(
            (mean - p.mu_c()).abs() < 1e-3 * p.mu_c(),
            "{mean} vs {}",
            p.mu_c()
        );
    }

    #[test]
    fn bandwidth_falls_with_the_sixth_root_of_m() {
        let p = pilot(vec![1.0]);
        let params = BandwidthParams {
            max_bandwidth_r: R_MIN,
            ..BandwidthParams::default()
        };
        let a = Bandwidth::new(&params, &p, 1_000, 1.0).h(1.0);
        let b = Bandwidth::new(&params, &p, 64_000, 1.0).h(1.0);
        assert!((a / b - 2.0).abs() < 1e-4);
    }

    #[test]
    fn bandwidth_is_clamped() {
        let p = pilot(vec![1.0]);
        let params = BandwidthParams::default();
        let bw = Bandwidth::new(&params, &p, 100_000, 1.0);
        assert_eq!(bw.h(1e-30), bw.h_max);
        assert_eq!(bw.h(1e30), bw.h_min);
        // [R·h̄, h̄/R] around h̄ = μC at M = 10⁵, C = 1.
        assert!((bw.h_max - p.mu_c() / 0.2).abs() < 1e-6);
        assert!((bw.h_min - p.mu_c() * 0.2).abs() < 1e-6);
        // R = 1: one bandwidth for every ray; R beyond 1 is taken as 1.
        for r in [1.0, 5.0] {
            let one = Bandwidth::new(
                &BandwidthParams {
                    max_bandwidth_r: r,
                    ..params
                },
                &p,
                100_000,
                1.0,
            );
            assert_eq!(one.h(1e-3), one.h(1e3));
        }
    }

    #[test]
    fn cone_from_the_two_end_bandwidths() {
        let p = pilot(vec![1.0]);
        let bw = Bandwidth::new(
            &BandwidthParams {
                max_bandwidth_r: R_MIN,
                ..BandwidthParams::default()
            },
            &p,
            100_000,
            1.0,
        );
        let mut ray = PhotonRay {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            length: 2.0,
            power: Vec3::ONE,
            origin_normal: Vec3::X,
            end_shading_ratio: 1.0,
            pdf_start: 4.0,
            pdf_end: 1.0,
            bounce: 1,
            class: PhotonClass::Indirect,
            lands: true,
            end_normal: -Vec3::X,
        };
        // §6: h0 = min(h(x_i), h(x_{i+1})), dh = max(0, h(x_{i+1}) − h(x_i)) / length.
        let (hi, hj) = (bw.h(4.0), bw.h(1.0));
        let (h0, dh) = bw.cone(&ray);
        assert_eq!(h0, hi.min(hj));
        assert!((dh - (hj - hi).max(0.0) / 2.0).abs() < 1e-7);
        // A shrinking bandwidth gives a cylinder of the smaller radius.
        ray.pdf_start = 1.0;
        ray.pdf_end = 4.0;
        assert_eq!(bw.cone(&ray), (bw.h(4.0), 0.0));
        // h(x_0) = 0: the segment leaving the light starts as a point (eq. 8).
        ray.bounce = 0;
        let (h0, dh) = bw.cone(&ray);
        assert_eq!(h0, 0.0);
        assert!((dh - bw.h(4.0) / 2.0).abs() < 1e-7);
    }

    #[test]
    fn d_clamps_short_segments() {
        // eq. 7: D = max(D̃², ‖x − y‖²).
        assert_eq!(clamped_sq_distance(0.01, 0.1), 0.1f32 * 0.1);
        assert_eq!(clamped_sq_distance(2.0, 0.1), 4.0);
    }
}
