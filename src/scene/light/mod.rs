//! Light sources and their two samplers: photon emission (light pass) and point sampling for
//! explicit direct light (next-event estimation at eye samples).
//!
//! Lights are chosen in proportion to their power (§3: "photons emitted in proportion to power"),
//! so every emitted photon carries about the same luminous power.
//!
//! The lights, their power and the selection are here; drawing photons and light samples from
//! them is in `sample`.

mod sample;
mod textured;

use super::environment::{Environment, SunLight};
use super::{AlphaMode, Material, NO_EXTRA, Texture, TextureRef, TriExtra, TriShading};
use crate::sampling::{Distribution1D, luminance};
use glam::Vec2;
use glam::Vec3;
use obvhs::triangle::Triangle;
use std::f32::consts::PI;
use std::sync::Arc;
use textured::TexturedEmitters;

/// A light source: an emissive triangle, or a KHR_lights_punctual light.
#[derive(Clone, Debug)]
pub enum Light {
    /// An emissive triangle; `normal` follows the winding.
    Area {
        /// First vertex.
        v0: Vec3,
        /// Edge v1 − v0.
        e1: Vec3,
        /// Edge v2 − v0.
        e2: Vec3,
        /// Unit normal, e1 × e2 normalised.
        normal: Vec3,
        /// Area (scene units²).
        area: f32,
        /// Emitted radiance (W/(m²·sr)), the material's emission; with an emissive texture,
        /// its mean over the triangle (what the power and the statistics read).
        radiance: Vec3,
        /// Emits from both faces (a double-sided material), not only along `normal`.
        two_sided: bool,
        /// The scene triangle it is.
        triangle: u32,
        /// Its emissive texture's entry in the lights' textured emitters ([`NO_TEXTURE`]
        /// without one): points are then drawn by the texture and their radiance read there.
        texture: u32,
    },
    /// KHR_lights_punctual point light (glTF candela taken as radiometric).
    Point {
        /// Where it is.
        position: Vec3,
        /// Intensity in every direction (W/sr).
        intensity: Vec3,
    },
    /// KHR_lights_punctual spot light.
    Spot {
        /// Apex of the cone.
        position: Vec3,
        /// Unit axis of the cone.
        direction: Vec3,
        /// Intensity on the axis (W/sr).
        intensity: Vec3,
        /// Cosine of the inner cone angle: full intensity inside it.
        cos_inner: f32,
        /// Cosine of the outer cone angle: nothing outside it (a quadratic ramp between,
        /// `spot_falloff`).
        cos_outer: f32,
    },
    /// The environment's radiance from every direction ([`Lights::environment`] holds it).
    Environment {
        /// ∫ L dω over the sphere (RGB).
        integral: Vec3,
    },
    /// The sun: a small disc of constant radiance infinitely far away.
    Sun(SunLight),
    /// Parallel light travelling along `direction` with `irradiance` (W/m²) on a facing surface.
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance on a surface facing the light (W/m²).
        irradiance: Vec3,
    },
}

/// [`Light::Area`]'s `texture` when the material has no emissive texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// What emits in a scene's surfaces: its triangles with their shading data, extra vertex
/// data, materials and textures.
pub(crate) struct Surfaces<'a> {
    pub(crate) triangles: &'a [Triangle],
    pub(crate) shading: &'a [TriShading],
    pub(crate) extras: &'a [TriExtra],
    pub(crate) materials: &'a [Material],
    pub(crate) textures: &'a Arc<[Texture]>,
}

/// A photon leaving a light (before division by the number of emitted photons).
#[derive(Clone, Copy, Debug)]
pub struct EmittedPhoton {
    /// Start point on the light (a directional light's: on a disc outside the scene).
    pub origin: Vec3,
    /// Unit direction of travel.
    pub direction: Vec3,
    /// Normal of the emitting surface on the side the photon leaves (zero for point lights).
    pub normal: Vec3,
    /// Emitted radiance (or intensity) × cosine over the selection and sampling pdfs (`pdf`):
    /// its mean over photons is the lights' total power (W).
    pub power: Vec3,
    /// Emission pdf p_e(x0, x1) without the distance term: area pdf × solid-angle pdf (eq. 7).
    pub pdf: f32,
    /// `pdf` includes an area density (1/m²: area and directional lights), which eq. 7 must
    /// express in the pilot's length unit to be free of units; point and spot lights' pdfs are
    /// per steradian only.
    pub pdf_per_area: bool,
    /// Error bound of `origin` along `normal` (zero for punctual lights): the photon leaves
    /// this far off its emitter ([`crate::scene::offset_ray_origin`]).
    pub offset: f32,
    /// The emitting triangle (`u32::MAX` for punctual lights): the photon never hits it.
    pub triangle: u32,
    /// A photon from infinitely far away (a directional light, the sun, the environment): it
    /// starts on a disc outside the scene, and its density does not fall with distance.
    pub parallel: bool,
}

/// A point on a light for explicit direct lighting.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Distance to the sampled point (a directional light's: beyond the scene).
    pub distance: f32,
    /// Incident radiance × geometry / pdf: multiply by f_r·cos θ at the receiver.
    pub value: Vec3,
    /// Solid-angle pdf of this sample (for MIS); infinite for point, spot and directional lights.
    pub pdf: f32,
    /// The emitting triangle sampled (`u32::MAX` for punctual lights): a shadow ray never
    /// counts it as its own occluder.
    pub triangle: u32,
}

/// Every light of a scene, with the power-proportional light selection (§3).
#[derive(Clone, Debug)]
pub struct Lights {
    /// The lights: area lights first (in triangle order), then the punctual lights.
    pub lights: Vec<Light>,
    dist: Option<Distribution1D>,
    /// Total emitted power (RGB, W).
    pub total_power: Vec3,
    scene_center: Vec3,
    scene_radius: f32,
    /// The area light of each triangle (`u32::MAX` for triangles that do not emit).
    light_of_triangle: Vec<u32>,
    /// Light from infinitely far away: what escaping rays see.
    pub environment: Environment,
    /// Selection probability of the environment's light and of the sun (0 without them).
    p_environment: f32,
    p_sun: f32,
    /// The emissive-textured triangles' point distributions.
    textured: Arc<TexturedEmitters>,
    /// The alpha of emitting triangles whose material is alpha-tested, and each triangle's
    /// entry in it (`u32::MAX` for none; empty when no emitter is alpha-tested).
    covers: Vec<Cover>,
    cover_of_triangle: Vec<u32>,
    textures: Arc<[Texture]>,
}

/// The alpha of an alpha-tested emitting triangle (glTF §3.9.4: factor × base-colour texture
/// × COLOR_0), read where a light sample or a photon is drawn, so that light sampling sees
/// the same cut-outs (MASK) and coverage (BLEND) as the rays that hit the triangle.
#[derive(Clone, Debug)]
pub(crate) struct Cover {
    mode: AlphaMode,
    base: f32,
    color: [f32; 3],
    tex: Option<(TextureRef, [Vec2; 3])>,
}

impl Cover {
    /// The share of the emission that leaves at barycentrics (b1, b2): 0 or 1 for MASK,
    /// alpha for BLEND.
    #[inline]
    fn at(&self, textures: &[Texture], b1: f32, b2: f32) -> f32 {
        let b0 = 1.0 - b1 - b2;
        let mut alpha = self.base * (self.color[0] * b0 + self.color[1] * b1 + self.color[2] * b2);
        if let Some((t, uv)) = &self.tex {
            let uv = t
                .transform
                .transform_point2(uv[0] * b0 + uv[1] * b1 + uv[2] * b2);
            alpha *= textures[t.image].lookup(uv, t, false).w;
        }
        match self.mode {
            AlphaMode::Mask(cutoff) => f32::from(u8::from(alpha >= cutoff)),
            AlphaMode::Blend => alpha.clamp(0.0, 1.0),
            AlphaMode::Opaque => 1.0,
        }
    }
}

impl Lights {
    /// The lights of `surfaces` (its emitting triangles; `textured` their emissive-textured
    /// ones, [`Lights::textured_emitters`] of an earlier build or built anew), the punctual
    /// lights and the environment, chosen in proportion to power.
    pub(crate) fn build(
        surfaces: &Surfaces,
        textured: Option<Arc<TexturedEmitters>>,
        punctual: Vec<Light>,
        environment: Environment,
        bmin: Vec3,
        bmax: Vec3,
    ) -> Self {
        let scene_center = 0.5 * (bmin + bmax);
        let scene_radius = 0.5 * (bmax - bmin).length() * 1.01;
        let mut lights = Vec::new();
        let mut light_of_triangle = vec![u32::MAX; surfaces.triangles.len()];
        let textured = textured.unwrap_or_else(|| Arc::new(TexturedEmitters::build(surfaces)));
        // Selection weights of the textured area lights (a bound on their power, see
        // `textured`), by light index.
        let mut bounds: Vec<(usize, f32)> = Vec::new();
        for (ti, (t, sh)) in surfaces.triangles.iter().zip(surfaces.shading).enumerate() {
            let m = &surfaces.materials[sh.material as usize];
            if !m.emits() || m.emissive_texture.is_some() {
                continue;
            }
            if let Some(light) = Self::area(t, ti as u32, m.emission, m.double_sided) {
                light_of_triangle[ti] = lights.len() as u32;
                lights.push(light);
            }
        }
        for (k, e) in textured.emitters.iter().enumerate() {
            let t = &surfaces.triangles[e.triangle as usize];
            let m = &surfaces.materials[surfaces.shading[e.triangle as usize].material as usize];
            let Some(mut light) = Self::area(t, e.triangle, e.mean_radiance, m.double_sided) else {
                continue;
            };
            if let Light::Area {
                area,
                two_sided,
                texture,
                ..
            } = &mut light
            {
                *texture = k as u32;
                let sides = if *two_sided { 2.0 } else { 1.0 };
                bounds.push((lights.len(), e.mean_bound * PI * *area * sides));
            }
            light_of_triangle[e.triangle as usize] = lights.len() as u32;
            lights.push(light);
        }
        let (covers, cover_of_triangle) = Self::covers(surfaces, &lights);
        if let Some(env) = &environment.light {
            lights.push(Light::Environment {
                integral: env.integral(),
            });
        }
        if let Some(sun) = environment.sun {
            lights.push(Light::Sun(sun));
        }
        lights.extend(punctual.into_iter().filter(|l| {
            let p = Self::power_of(l, scene_radius);
            p.is_finite() && p.max_element() > 0.0
        }));
        let mut powers: Vec<f64> = lights
            .iter()
            .map(|l| luminance(Self::power_of(l, scene_radius)).max(0.0) as f64)
            .collect();
        // A textured emitter is chosen by its bound, never zero where it emits.
        for (i, b) in bounds {
            powers[i] = b as f64;
        }
        let total_power = lights
            .iter()
            .map(|l| Self::power_of(l, scene_radius))
            .sum::<Vec3>();
        let dist = Distribution1D::new(&powers);
        if dist.is_none() {
            lights.clear();
            light_of_triangle.fill(u32::MAX);
        }
        let pmf_of = |want: fn(&Light) -> bool| {
            lights
                .iter()
                .position(want)
                .zip(dist.as_ref())
                .map_or(0.0, |(i, d)| d.pmf(i))
        };
        let p_environment = pmf_of(|l| matches!(l, Light::Environment { .. }));
        let p_sun = pmf_of(|l| matches!(l, Light::Sun(_)));
        Self {
            lights,
            dist,
            total_power,
            scene_center,
            scene_radius,
            light_of_triangle,
            environment,
            p_environment,
            p_sun,
            textured,
            covers,
            cover_of_triangle,
            textures: surfaces.textures.clone(),
        }
    }

    /// The alpha of each alpha-tested area light among `lights`.
    fn covers(surfaces: &Surfaces, lights: &[Light]) -> (Vec<Cover>, Vec<u32>) {
        let mut covers = Vec::new();
        let mut of = Vec::new();
        for l in lights {
            let Light::Area { triangle, .. } = *l else {
                continue;
            };
            let sh = &surfaces.shading[triangle as usize];
            let m = &surfaces.materials[sh.material as usize];
            if !m.alpha_tested() {
                continue;
            }
            let extra = (sh.extra != NO_EXTRA).then(|| &surfaces.extras[sh.extra as usize]);
            let tex = m.base_texture.as_ref().map(|t| {
                let uv = match (t.set, extra) {
                    (1, Some(e)) => e.uv1,
                    (1, None) => [Vec2::ZERO; 3],
                    _ => sh.uvs,
                };
                (t.clone(), uv)
            });
            if of.is_empty() {
                of = vec![u32::MAX; surfaces.triangles.len()];
            }
            of[triangle as usize] = covers.len() as u32;
            covers.push(Cover {
                mode: m.alpha,
                base: m.base_alpha,
                color: extra.map_or([1.0; 3], |e| e.color.map(|c| c.w)),
                tex,
            });
        }
        (covers, of)
    }

    /// The share of triangle `triangle`'s emission that leaves at barycentrics (b1, b2): its
    /// alpha coverage where its material is alpha-tested, 1 elsewhere.
    #[inline]
    pub(crate) fn coverage(&self, triangle: u32, b1: f32, b2: f32) -> f32 {
        match self.cover_of_triangle.get(triangle as usize) {
            Some(&c) if c != u32::MAX => self.covers[c as usize].at(&self.textures, b1, b2),
            _ => 1.0,
        }
    }

    /// Bytes held by the textured emitters' distributions.
    pub fn memory_bytes(&self) -> usize {
        self.textured.bytes()
    }

    /// The emissive-textured triangles' distributions, for a rebuild of these lights.
    pub(crate) fn textured_emitters(&self) -> Arc<TexturedEmitters> {
        self.textured.clone()
    }

    /// The area light of triangle `t` (index `ti`) emitting `radiance`; `None` for a
    /// degenerate triangle.
    fn area(t: &Triangle, ti: u32, radiance: Vec3, two_sided: bool) -> Option<Light> {
        let v0: Vec3 = t.v0.into();
        let e1 = Vec3::from(t.v1) - v0;
        let e2 = Vec3::from(t.v2) - v0;
        let c = e1.cross(e2);
        let area = 0.5 * c.length();
        if area.is_nan() || area <= 0.0 || !area.is_finite() {
            return None;
        }
        Some(Light::Area {
            v0,
            e1,
            e2,
            normal: c.normalize(),
            area,
            radiance,
            two_sided,
            triangle: ti,
            texture: NO_TEXTURE,
        })
    }

    /// Solid-angle pdf with which [`Lights::sample_direct`] picks direction `d` towards the
    /// environment or the sun (selection included) for a receiver `facing` that way (as
    /// `sample_direct` takes it): the light-sampling side of MIS for a BSDF-sampled ray that
    /// escapes.
    #[inline]
    pub fn pdf_escaped(&self, d: Vec3, facing: Option<Vec3>) -> f32 {
        let mut p = 0.0;
        if let Some(e) = &self.environment.light {
            p += self.p_environment * e.pdf(d, facing);
        }
        if let Some(s) = &self.environment.sun {
            p += self.p_sun * s.pdf(d);
        }
        p
    }

    /// Light arrives from infinitely far away (escaping rays may carry some).
    #[inline]
    pub fn has_environment(&self) -> bool {
        !self.environment.is_empty()
    }

    /// Radius of the disc that photons from infinitely far away start on (the scene's
    /// bounding sphere, 1% larger).
    pub fn scene_radius(&self) -> f32 {
        self.scene_radius
    }

    /// Solid-angle pdf with which [`Lights::sample_direct`] from `from` picks the point `at`
    /// on emissive triangle `triangle` (0 for triangles that do not emit).
    pub fn pdf_direct(&self, triangle: u32, from: Vec3, at: Vec3) -> f32 {
        let Some(&li) = self.light_of_triangle.get(triangle as usize) else {
            return 0.0;
        };
        let (
            Some(dist),
            Some(&Light::Area {
                v0,
                e1,
                e2,
                normal,
                area,
                texture,
                ..
            }),
        ) = (self.dist.as_ref(), self.lights.get(li as usize))
        else {
            return 0.0;
        };
        let d = at - from;
        let dist2 = d.length_squared();
        let cos = (d.dot(normal) / dist2.sqrt()).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        let relative = if texture == NO_TEXTURE {
            1.0
        } else {
            let (b1, b2) = barycentrics(at - v0, e1, e2);
            self.textured.density(texture, b1, b2)
        };
        dist.pmf(li as usize) * relative * dist2 / (area * cos)
    }

    /// No light (or none with positive power).
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The scene triangles that emit (every triangle with non-zero emission and area is an
    /// area light).
    pub fn area_triangles(&self) -> impl Iterator<Item = u32> + '_ {
        self.lights.iter().filter_map(|l| match l {
            Light::Area { triangle, .. } => Some(*triangle),
            _ => None,
        })
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// Emitted power of one light (RGB watts); a directional light's is what crosses a disc of
    /// radius `scene_radius` (its photons start on such a disc).
    pub fn power_of(light: &Light, scene_radius: f32) -> Vec3 {
        match *light {
            Light::Area {
                area,
                radiance,
                two_sided,
                ..
            } => radiance * PI * area * if two_sided { 2.0 } else { 1.0 },
            Light::Point { intensity, .. } => intensity * 4.0 * PI,
            Light::Spot {
                intensity,
                cos_inner,
                cos_outer,
                ..
            } => {
                // ∫ I·falloff dω over the cone: 2π[(1 − cos_i) + (cos_i − cos_o)/3] for the t² ramp.
                intensity * 2.0 * PI * ((1.0 - cos_inner) + (cos_inner - cos_outer) / 3.0)
            }
            Light::Directional { irradiance, .. } => irradiance * PI * scene_radius * scene_radius,
            // What crosses a disc of radius r facing each direction: ∫ L dω · πr².
            Light::Environment { integral } => integral * PI * scene_radius * scene_radius,
            Light::Sun(sun) => sun.radiance * sun.solid_angle * PI * scene_radius * scene_radius,
        }
    }

    /// Emitted power of `light` in this scene (RGB watts; [`Lights::power_of`]).
    pub fn power(&self, light: &Light) -> Vec3 {
        Self::power_of(light, self.scene_radius)
    }
}

/// Barycentrics (b1, b2) of the point `v0 + p` on the triangle with edges `e1`, `e2`.
#[inline]
pub(crate) fn barycentrics(p: Vec3, e1: Vec3, e2: Vec3) -> (f32, f32) {
    let c = e1.cross(e2);
    let inv = 1.0 / c.length_squared().max(f32::MIN_POSITIVE);
    (p.cross(e2).dot(c) * inv, e1.cross(p).dot(c) * inv)
}
