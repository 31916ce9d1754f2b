//! Every render setting in one place: [`RenderSettings`] (what the CLI, the worker and the
//! window configure), the method and direct-light choices, and [`limits`], the one table of
//! accepted ranges that the window's sliders, the worker's clamps and the command line's
//! value parsers all read.

use crate::choice::Choice;
use crate::pipeline::cache::CacheParams;
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::filter::FilterParams;
use crate::pipeline::photon::BandwidthParams;
use serde::{Deserialize, Serialize};
use std::ops::RangeInclusive;

/// Which rendering method; `methods::build` turns it into a running method.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodKind {
    /// Photon ray splatting (the paper), with the optional radiance cache and filter.
    #[default]
    Rs,
    /// Radiance caching (§8.3): indirect-diffuse photon rays are splatted onto sparse cache
    /// records only, which are interpolated in image space.
    Rc,
    /// Photon mapping with K-NN density estimation, visualised directly (Jensen).
    Pm,
    /// Unbiased path tracing with next-event estimation and MIS.
    Pt,
    /// Ray splatting with final gathering (§8.4).
    RsFg,
    /// Photon mapping with final gathering.
    PmFg,
}

impl Choice for MethodKind {
    const ALL: &'static [Self] = &[
        MethodKind::Rs,
        MethodKind::Rc,
        MethodKind::Pm,
        MethodKind::Pt,
        MethodKind::RsFg,
        MethodKind::PmFg,
    ];

    fn name(self) -> &'static str {
        match self {
            MethodKind::Rs => "rs",
            MethodKind::Rc => "rc",
            MethodKind::Pm => "pm",
            MethodKind::Pt => "pt",
            MethodKind::RsFg => "rs-fg",
            MethodKind::PmFg => "pm-fg",
        }
    }
}

/// How direct light reaches eye samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DirectMode {
    /// Explicit light sampling at eye samples (a light and a BSDF sample, MIS).
    #[default]
    Nee,
    /// Direct photons splatted in cones from the lights (the paper's way).
    Photons,
}

impl Choice for DirectMode {
    const ALL: &'static [Self] = &[DirectMode::Nee, DirectMode::Photons];

    fn name(self) -> &'static str {
        match self {
            DirectMode::Nee => "nee",
            DirectMode::Photons => "photons",
        }
    }
}

/// Everything a render depends on, besides the scene and the camera's pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Image width in pixels ([`limits::RESOLUTION`]).
    pub width: u32,
    /// Image height in pixels ([`limits::RESOLUTION`]).
    pub height: u32,
    /// Eye samples per pixel (paths per pixel and pass for the path tracer).
    pub spp: u32,
    /// M: stored photon rays per batch, split by `fractions` (Table 2).
    pub photons: u64,
    /// Fractions of M for direct, indirect-diffuse and caustic photons (Table 2).
    pub fractions: [f32; 3],
    /// C, S and R of eq. 8.
    pub bandwidth: BandwidthParams,
    /// Seed of every random stream (images depend on it and the settings only).
    pub seed: u64,
    /// Direct light by NEE or by splatted direct photons.
    pub direct: DirectMode,
    /// Longest specular chain followed by eye and photon paths.
    pub max_specular_depth: u32,
    /// Light samples per eye sample for NEE.
    pub nee_samples: u32,
    /// Give up filling a photon class after this many emitted photons per stored-photon budget.
    pub max_emitted_factor: u64,
    /// Camera by name; the scene's first camera when absent.
    pub camera: Option<String>,
    /// Eye samples of a pixel on the same surface share one splat target (docs/deviations.md).
    pub merge_targets: bool,
    /// Splat only where the target sees the photon ray (blocker planes and shadow rays,
    /// docs/deviations.md §40). Off by default, which is the paper's splatting: the test
    /// halves little of the leak it was built for and costs 1.7× T_S.
    pub splat_visibility: bool,
    /// The rendering method.
    pub method: MethodKind,
    /// K of the global photon map (`--method pm`).
    pub pm_k: usize,
    /// K of the caustic photon map (`--method pm`).
    pub pm_caustic_k: usize,
    /// Gather rays per eye sample for the final-gathering methods (§8.4).
    pub fg_rays: u32,
    /// Paths per pixel that one step of the path tracer adds.
    #[serde(default = "one")]
    pub pt_spp: u32,
    /// Directional storage at glossy samples (§8.1).
    #[serde(default)]
    pub radiance_map: DirectionalMode,
    /// Radiance cache parameters (§8.3): used by `--method rc`, and by rs when `cache_on`.
    #[serde(default)]
    pub cache: CacheParams,
    /// rs: resolve the full radiance map through the cache (the previewer's ε slider).
    #[serde(default)]
    pub cache_on: bool,
    /// Image-space filter of the indirect light (§8.2).
    #[serde(default)]
    pub filter: FilterParams,
    /// rs: draw the eye samples anew as photon batches go on (issue 16), so that
    /// anti-aliasing, NEE and traced branches converge with the batches too.
    #[serde(default = "yes")]
    pub progressive_eye: bool,
    /// rs, rc: beyond the first photon batch the bandwidth shrinks as M^(−1/3) instead of
    /// eq. 8's M^(−1/6) (issue 16, docs/deviations.md §43); off, every batch keeps eq. 8's
    /// bandwidth for the total M, as in the paper.
    #[serde(default = "yes")]
    pub progressive_bandwidth: bool,
}

fn yes() -> bool {
    true
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 500,
            height: 500,
            spp: 4,
            photons: 200_000,
            fractions: [0.3, 0.6, 0.1],
            bandwidth: BandwidthParams::default(),
            seed: 1,
            direct: DirectMode::Nee,
            max_specular_depth: 8,
            nee_samples: 1,
            max_emitted_factor: 4,
            camera: None,
            merge_targets: true,
            splat_visibility: false,
            method: MethodKind::Rs,
            pm_k: 400,
            pm_caustic_k: 250,
            fg_rays: 64,
            pt_spp: 1,
            radiance_map: DirectionalMode::Sh,
            cache: CacheParams::default(),
            cache_on: false,
            progressive_eye: true,
            progressive_bandwidth: true,
            filter: FilterParams::default(),
        }
    }
}

impl RenderSettings {
    /// These settings for another view: `width` × `height` pixels at `spp` eye samples per
    /// pixel.
    pub fn with_view(&self, width: u32, height: u32, spp: u32) -> Self {
        Self {
            width,
            height,
            spp,
            ..self.clone()
        }
    }

    /// Every numeric setting moved into its range of [`limits`] (NaN goes to the lower
    /// bound); fractions that are negative, NaN or all zero fall back to the defaults, others
    /// are normalised to sum to 1.
    pub fn within_limits(mut self) -> Self {
        use limits::*;
        self.width = RESOLUTION.clamp(self.width);
        self.height = RESOLUTION.clamp(self.height);
        self.spp = SPP.clamp(self.spp);
        self.photons = PHOTONS.clamp(self.photons);
        self.bandwidth.smoothness_c = SMOOTHNESS_C.clamp(self.bandwidth.smoothness_c);
        self.bandwidth.sensitivity_s = SENSITIVITY_S.clamp(self.bandwidth.sensitivity_s);
        self.bandwidth.max_bandwidth_r = MAX_BANDWIDTH_R.clamp(self.bandwidth.max_bandwidth_r);
        self.max_specular_depth = SPECULAR_DEPTH.clamp(self.max_specular_depth);
        self.nee_samples = NEE_SAMPLES.clamp(self.nee_samples);
        self.pm_k = PM_K.clamp(self.pm_k);
        self.pm_caustic_k = PM_K.clamp(self.pm_caustic_k);
        self.fg_rays = FG_RAYS.clamp(self.fg_rays);
        self.pt_spp = PT_SPP.clamp(self.pt_spp);
        self.cache.error = CACHE_ERROR.clamp(self.cache.error);
        self.cache.min_records = MIN_RECORDS.clamp(self.cache.min_records);
        self.filter.strength = FILTER_STRENGTH.clamp(self.filter.strength);
        self.fractions = normalised_fractions(self.fractions)
            .unwrap_or_else(|_| RenderSettings::default().fractions);
        self
    }
}

fn one() -> u32 {
    1
}

impl RenderSettings {
    /// An error naming the first setting outside its range of [`limits`] (or fractions that
    /// cannot be normalised), for settings that must be right before any work starts.
    pub fn validate(&self) -> Result<(), String> {
        use limits::*;
        fn check<T: Copy + PartialOrd + std::fmt::Display>(
            name: &str,
            limit: Limit<T>,
            v: T,
        ) -> Result<(), String> {
            if limit.contains(v) {
                Ok(())
            } else {
                Err(format!(
                    "{name} must be in {}..={}, got {v}",
                    limit.min, limit.max
                ))
            }
        }
        check("width", RESOLUTION, self.width)?;
        check("height", RESOLUTION, self.height)?;
        // The path tracer takes no eye samples (`pt_spp` is its count).
        if self.method != MethodKind::Pt {
            check("samples per pixel", SPP, self.spp)?;
        }
        check("paths per pixel", PT_SPP, self.pt_spp)?;
        check("photons per batch", PHOTONS, self.photons)?;
        check("C", SMOOTHNESS_C, self.bandwidth.smoothness_c)?;
        check("S", SENSITIVITY_S, self.bandwidth.sensitivity_s)?;
        check("R", MAX_BANDWIDTH_R, self.bandwidth.max_bandwidth_r)?;
        check("specular depth", SPECULAR_DEPTH, self.max_specular_depth)?;
        check("NEE samples", NEE_SAMPLES, self.nee_samples)?;
        check("K", PM_K, self.pm_k)?;
        check("caustic K", PM_K, self.pm_caustic_k)?;
        check("gather rays", FG_RAYS, self.fg_rays)?;
        check("cache error", CACHE_ERROR, self.cache.error)?;
        check("cache records", MIN_RECORDS, self.cache.min_records)?;
        check("filter strength", FILTER_STRENGTH, self.filter.strength)?;
        normalised_fractions(self.fractions).map(|_| ())
    }
}

/// Photon fractions scaled to sum to 1; an error when one is negative or not finite, or all
/// are zero.
pub fn normalised_fractions(f: [f32; 3]) -> Result<[f32; 3], String> {
    let sum: f32 = f.iter().sum();
    if f.iter().any(|x| !x.is_finite() || *x < 0.0) || sum <= 0.0 {
        return Err("the photon fractions must be three non-negative numbers, not all zero".into());
    }
    // Fractions that already sum to 1 (up to rounding) stay exactly as given.
    if (sum - 1.0).abs() <= 1e-5 {
        return Ok(f);
    }
    Ok(f.map(|x| x / sum))
}

/// The accepted range of one numeric setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit<T> {
    /// Smallest accepted value.
    pub min: T,
    /// Largest accepted value.
    pub max: T,
}

impl<T: Copy + PartialOrd> Limit<T> {
    /// `v` moved into the range (an unordered value such as NaN goes to `min`).
    pub fn clamp(self, v: T) -> T {
        if v > self.max {
            self.max
        } else if v >= self.min {
            v
        } else {
            self.min
        }
    }

    /// True when `v` lies in the range (never for NaN).
    pub fn contains(self, v: T) -> bool {
        v >= self.min && v <= self.max
    }

    /// The range, for sliders.
    pub fn range(self) -> RangeInclusive<T> {
        self.min..=self.max
    }
}

/// The one table of accepted ranges.
pub mod limits {
    use super::Limit;
    use crate::scene::environment::{ANGLE_RANGE, STRENGTH_RANGE};

    /// Environment (and sun) strength, a multiplier of radiance.
    pub const ENV_STRENGTH: Limit<f32> = Limit {
        min: *STRENGTH_RANGE.start(),
        max: *STRENGTH_RANGE.end(),
    };
    /// Environment rotation about +Y, degrees.
    pub const ENV_ROTATION: Limit<f32> = Limit {
        min: *ANGLE_RANGE.start(),
        max: *ANGLE_RANGE.end(),
    };

    /// Image width and height, pixels.
    pub const RESOLUTION: Limit<u32> = Limit { min: 8, max: 4096 };
    /// Eye samples per pixel.
    pub const SPP: Limit<u32> = Limit { min: 1, max: 64 };
    /// Paths per pixel of a fixed-budget path-traced image.
    pub const PT_SPP: Limit<u32> = Limit {
        min: 1,
        max: 1 << 20,
    };
    /// M, stored photon rays per batch.
    pub const PHOTONS: Limit<u64> = Limit {
        min: 100,
        max: 100_000_000,
    };
    /// C, eq. 8's smoothness.
    pub const SMOOTHNESS_C: Limit<f32> = Limit {
        min: 0.05,
        max: 5.0,
    };
    /// S, eq. 8's sensitivity.
    pub const SENSITIVITY_S: Limit<f32> = Limit {
        min: 0.01,
        max: 1.0,
    };
    /// R, the bandwidth range: every h within [R·h̄, h̄/R].
    pub const MAX_BANDWIDTH_R: Limit<f32> = Limit {
        min: 0.01,
        max: 1.0,
    };
    /// Longest specular chain.
    pub const SPECULAR_DEPTH: Limit<u32> = Limit { min: 0, max: 64 };
    /// Light samples per eye sample (NEE).
    pub const NEE_SAMPLES: Limit<u32> = Limit { min: 1, max: 256 };
    /// K of the photon maps.
    pub const PM_K: Limit<usize> = Limit {
        min: 1,
        max: 100_000,
    };
    /// Gather rays per eye sample (final gathering).
    pub const FG_RAYS: Limit<u32> = Limit { min: 1, max: 4096 };
    /// ε, the radiance cache's error.
    pub const CACHE_ERROR: Limit<f32> = Limit {
        min: 0.05,
        max: 2.0,
    };
    /// Cache records covering every pixel.
    pub const MIN_RECORDS: Limit<u32> = Limit { min: 1, max: 16 };
    /// Scale of the image-space filter's radius.
    pub const FILTER_STRENGTH: Limit<f32> = Limit { min: 0.0, max: 4.0 };
    /// Photon rays kept for re-splatting in the window.
    pub const RAY_BUDGET: Limit<usize> = Limit {
        min: 50_000,
        max: 100_000_000,
    };
    /// Wall-clock budget of a headless render, seconds.
    pub const TIME_BUDGET: Limit<f64> = Limit {
        min: 0.001,
        max: 1e6,
    };
    /// Batches (or passes) of a headless render with `--batches`.
    pub const BATCHES: Limit<u64> = Limit {
        min: 1,
        max: 1_000_000,
    };
    /// Worker threads.
    pub const THREADS: Limit<usize> = Limit { min: 1, max: 1024 };
    /// Repetitions of a benchmark row.
    pub const RUNS: Limit<u32> = Limit { min: 1, max: 1000 };
    /// Display exposure, stops.
    pub const EXPOSURE: Limit<f32> = Limit {
        min: -16.0,
        max: 16.0,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_clamp_and_reject_nan() {
        assert_eq!(limits::SPP.clamp(0), 1);
        assert_eq!(limits::SPP.clamp(1000), 64);
        assert_eq!(limits::SMOOTHNESS_C.clamp(f32::NAN), 0.05);
        assert!(!limits::SMOOTHNESS_C.contains(f32::NAN));
        assert!(limits::SENSITIVITY_S.contains(1.0));
    }

    #[test]
    fn fractions_are_normalised_or_refused() {
        assert_eq!(
            normalised_fractions([3.0, 6.0, 1.0]).unwrap(),
            [0.3, 0.6, 0.1]
        );
        assert!(normalised_fractions([0.0; 3]).is_err());
        assert!(normalised_fractions([-1.0, 1.0, 1.0]).is_err());
        assert!(normalised_fractions([f32::NAN, 1.0, 1.0]).is_err());
        let s = RenderSettings {
            spp: 0,
            fractions: [0.0; 3],
            ..RenderSettings::default()
        }
        .within_limits();
        assert_eq!(s.spp, 1);
        assert_eq!(s.fractions, RenderSettings::default().fractions);
    }

    #[test]
    fn validate_names_the_setting_and_its_range() {
        assert!(RenderSettings::default().validate().is_ok());
        let e = RenderSettings {
            width: 4_294_967_295,
            ..RenderSettings::default()
        }
        .validate()
        .unwrap_err();
        assert_eq!(e, "width must be in 8..=4096, got 4294967295");
        let e = RenderSettings {
            cache: CacheParams {
                error: f32::NAN,
                min_records: 4,
            },
            ..RenderSettings::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.starts_with("cache error must be in"), "{e}");
        // Whatever within_limits gives is valid.
        let wild = RenderSettings {
            spp: 0,
            photons: u64::MAX,
            fractions: [f32::NAN, 0.0, 0.0],
            ..RenderSettings::default()
        };
        assert!(wild.within_limits().validate().is_ok());
    }

    #[test]
    fn method_names_round_trip() {
        for &m in MethodKind::ALL {
            assert_eq!(MethodKind::from_name(m.name()), Some(m));
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{}\"", m.name()));
        }
    }
}
