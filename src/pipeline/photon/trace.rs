//! One photon path (§5): emission, BSDF sampling with Russian roulette, and eq. 7's clamped
//! path density p̃ at every vertex.

use super::guide::{EmissionGuide, NO_CELL};
use super::{D_TILDE_FRACTION, MAX_PATH_SEGMENTS, PhotonClass, PhotonRay, RayTag, SPECULAR_PDF};
use crate::bsdf::Bsdf;
use crate::pack::OctOrZero;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::Vec3;

/// The length unit of eq. 7 (the pilot's ⟨D⟩): p̃ is computed with lengths in this unit and
/// area densities per unit², so it has no units and a scene scaled by any factor gets the
/// same p̃, the same bandwidths relative to its size, and the same image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathUnits {
    /// ⟨D⟩ in scene units: eq. 7's lengths are divided by it.
    pub length: f32,
}

impl PathUnits {
    /// Units for the pilot's first look at a scene, before ⟨D⟩ is known (p̃ unused then).
    pub(super) const PROVISIONAL: PathUnits = PathUnits { length: 1.0 };
}

/// Segment under construction, with the index of the photon that made it.
#[derive(Clone, Copy)]
pub(super) struct TaggedRay {
    pub(super) photon: u64,
    pub(super) ray: PhotonRay,
    /// Share of the power the end vertex sends on (the Russian-roulette survival
    /// probability; 0 when the ray escapes or the path ends there): the pilot's weight.
    pub(super) onward: f32,
    /// The first segment of a directional light's photon, from a disc outside the scene.
    pub(super) parallel: bool,
}

/// D(x, y) = max(D̃², ‖x − y‖²) (eq. 7).
#[inline]
fn clamped_sq_distance(length: f32, d_tilde: f32) -> f32 {
    (length * length).max(d_tilde * d_tilde)
}

/// Trace one photon path, pushing its segments (of classes wanted by `keep`); emitted as
/// `guide` says, with its cell on every ray, when one is given.
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_photon(
    scene: &Scene,
    photon: u64,
    seed: u64,
    keep: [bool; 3],
    units: PathUnits,
    guide: Option<&EmissionGuide>,
    out: &mut Vec<TaggedRay>,
    invalid: &mut u64,
) -> bool {
    let mut rng = Rng::new(seed, photon);
    let emitted = match guide {
        Some(g) => g.sample(&scene.lights, &mut rng),
        None => scene.lights.sample_emission(&mut rng).map(|e| (e, NO_CELL)),
    };
    let Some((e, cell)) = emitted else {
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
            // A ray from afar has the same density all along (it does not spread from a
            // point): it starts with the bandwidth it ends with. Rays leaving a light in the
            // scene start as a point, h(x_0) = 0 (pdf_start 0 says so).
            PhotonClass::Direct => (if parallel { u_next } else { 0.0 }, u_next),
            PhotonClass::Indirect => (u_here, u_next),
            PhotonClass::Caustic => (c_here, c_next),
        };
        // The model at the hit, read once (a metallic-roughness texture is read here only).
        let bsdf = hit.as_ref().map(|h| scene.bsdf(h));
        // A photon lands where the surface can be seen: a reflecting one (glass, smooth or
        // rough, passes it on), or a partly transmissive one even where this hit drew its
        // glass (the eye's hits there draw their own).
        let lands = bsdf.is_some_and(|b| b.is_reflecting())
            || hit.as_ref().is_some_and(|h| scene.partly_transmissive(h));
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
        // Normals are stored octahedral, which has no NaN (a hit on degenerate geometry):
        // such a ray is counted invalid and not stored, as `PhotonRay::is_valid` did.
        let finite_normals = normal.is_finite() && end_normal.is_finite();
        if keep[class as usize] && !finite_normals {
            *invalid += 1;
        }
        let pushed = keep[class as usize] && finite_normals;
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
                    origin_normal: OctOrZero::new(normal),
                    end_shading_ratio,
                    pdf_start,
                    pdf_end,
                    tag: RayTag::new(bounce, class, lands).with_cell(cell),
                    end_normal: OctOrZero::new(end_normal),
                },
            });
        }
        let (Some(hit), Some(bsdf)) = (hit, bsdf) else {
            break;
        };
        let wo = -dir;
        // The reflecting models take the shading normal on the side the photon came from;
        // a dielectric the surface's own (crate::bsdf's docs).
        let n = if matches!(bsdf, Bsdf::Dielectric { .. }) || hit.geo_normal.dot(wo) >= 0.0 {
            hit.normal
        } else {
            -hit.normal
        };
        let Some(s) = bsdf.sample(wo, n, rng.next_2d(), rng.next_f32()) else {
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
        // The reflecting models are not reciprocal: glTF's glossy model in its diffuse layer
        // (bsdf::Bsdf::Glossy), and both where the shading normal leans past ωo (they
        // reflect into its hemisphere only: a photon arriving from below it goes no further,
        // as no path tracer's path comes that way; deviations §53). Light goes from ωi to
        // ωo, so a photon weighs by f(ωi, ωo): the adjoint BSDF of Veach 1997, §3.7.6 (the
        // sample's own weight holds f(ωo, ωi) and cannot be used; one more eval a bounce).
        let weight = match bsdf {
            Bsdf::Lambert { .. } | Bsdf::Glossy { .. } => {
                bsdf.eval(s.wi, wo, n) * s.wi.dot(n).abs() / s.pdf
            }
            _ => s.weight,
        };
        // The segment just travelled was absorbed inside a volume (KHR_materials_volume):
        // the stored ray keeps the power it entered with (it ends on the volume's specular
        // boundary, where nothing lands), the photon goes on with what came through.
        let mut new_power = power * weight * adjoint * scene.transmittance(&hit, dir);
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
        // Light that crossed only glass, smooth or rough, is a caustic (the paper's L S+
        // paths, blurred where the glass is rough): final gathering's gather rays stop at
        // glass and leave such light to the caustic photons (deviations §56).
        any_diffuse |= bsdf.is_reflecting();
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d_clamps_short_segments() {
        // eq. 7: D = max(D̃², ‖x − y‖²).
        assert_eq!(clamped_sq_distance(0.01, 0.1), 0.1f32 * 0.1);
        assert_eq!(clamped_sq_distance(2.0, 0.1), 4.0);
    }
}
