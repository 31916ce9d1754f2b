//! The eye samples in their stored form (structure of arrays; octahedral normals, f16
//! colours and offset bound, one byte of flags) and the splat targets they share.

use crate::bsdf::Bsdf;
use crate::pack::{Bound16, Oct, Rgb16};
use glam::Vec3;
use half::f16;

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
    /// Diffuse albedo towards the eye (texture applied); kd·(1 − E_d) of a glossy sample (f16).
    pub albedo: Vec<Rgb16>,
    /// The glossy layer's reflectance at normal incidence f0 (zero for Lambertian samples; f16).
    pub specular: Vec<Rgb16>,
    /// The glossy lobe's GGX α at the sample (its material's roughness², or its
    /// metallic-roughness texture's there; 1 for Lambertian samples; f16).
    pub alpha: Vec<f16>,
    /// The glossy layer's reflectance at grazing incidence f90 (1 but where
    /// KHR_materials_specular scales a dielectric's layer; 0 for Lambertian samples; f16).
    pub f90: Vec<f16>,
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
/// and wo 4 (octahedral), three colours 6 (f16), the offset, the GGX α and f90 2 (f16),
/// material, pixel and target 4, one byte of flags (110 with every vector, colour and number
/// in f32).
pub const EYE_SAMPLE_BYTES: usize = 12 + 3 * 4 + 3 * 6 + 3 * 2 + 3 * 4 + 1;

impl EyeSamples {
    /// The pixel of each of the pass's `targets` splat targets, read from the samples that
    /// use them (a target never spans two pixels; in pixel order, as the targets are): the
    /// key of the visible domains kept across eye passes
    /// ([`crate::pipeline::splat_tree::DomainCache`]).
    pub fn target_pixels(&self, targets: usize) -> Vec<u32> {
        let mut out = vec![0; targets];
        for (&t, &p) in self.target.iter().zip(&self.pixel) {
            out[t as usize] = p;
        }
        out
    }

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

    /// True when the sample's BSDF has a glossy lobe (its Schlick Fresnel is not zero at
    /// every angle: a KHR_materials_specular colour of black leaves f0 = 0 and f90 > 0).
    #[inline]
    pub fn is_glossy(&self, i: usize) -> bool {
        self.specular[i].get() != Vec3::ZERO || self.f90[i].to_f32() > 0.0
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

    /// The sample's BSDF: Lambertian, or glTF's glossy model with its α, f0, f90 towards the
    /// sample's own ωo. Its stored albedo is already the diffuse layer's kd·(1 − E_d) there
    /// ([`crate::bsdf::diffuse_share`]), so the model takes it as kd with the dielectric's
    /// weights f0_d = f90_d = 0 (a share of 1): the same diffuse term at ωo to the bit, without
    /// the material's IOR and KHR_materials_specular, which its textures vary per hit.
    #[inline]
    pub fn bsdf(&self, i: usize) -> Bsdf {
        if self.is_glossy(i) {
            Bsdf::Glossy {
                kd: self.albedo[i].get(),
                f0: self.specular[i].get(),
                f90: self.f90[i].to_f32(),
                f0_d: 0.0,
                f90_d: 0.0,
                alpha: self.alpha[i].to_f32(),
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
        self.alpha.push(s.alpha);
        self.f90.push(s.f90);
        self.flags.push(s.flags);
    }
}

/// An eye sample in its stored form (quantised normals and colours, flags in one byte): made
/// in parallel by the eye pass's rows, so that the append only copies (encoding there kept
/// every other thread idle: docs/benchmarks.md, "Radiance caching").
#[derive(Clone, Copy, Debug)]
pub(super) struct PackedSample {
    pub(super) position: Vec3,
    pub(super) normal: Oct,
    pub(super) geo_normal: Oct,
    pub(super) offset: Bound16,
    pub(super) wo: Oct,
    pub(super) material: u32,
    pub(super) pixel: u32,
    pub(super) weight: Rgb16,
    pub(super) albedo: Rgb16,
    pub(super) specular: Rgb16,
    pub(super) alpha: f16,
    pub(super) f90: f16,
    pub(super) flags: u8,
}

impl PackedSample {
    pub(super) fn new(s: &EyeSample) -> Self {
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
            alpha: f16::from_f32(s.alpha),
            f90: f16::from_f32(s.f90),
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
    /// The glossy lobe's GGX α (1 for Lambertian samples).
    pub alpha: f32,
    /// The glossy lobe's reflectance at grazing incidence (0 for Lambertian samples).
    pub f90: f32,
    /// Seen directly from the camera (no specular bounce on the way).
    pub primary: bool,
    /// The glossy lobe is traced by the eye path ([`EyeSamples::lobe_traced`]).
    pub lobe_traced: bool,
}

impl EyeSample {
    /// Its BSDF has a glossy lobe ([`EyeSamples::is_glossy`], before packing).
    pub fn is_glossy(&self) -> bool {
        self.specular != Vec3::ZERO || self.f90 > 0.0
    }
}
