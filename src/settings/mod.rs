//! Every render setting in one place: [`RenderSettings`] (what the CLI, the worker and the
//! window configure), the method and direct-light choices, [`limits`], the one table of
//! accepted ranges that the window's sliders, the worker's clamps and the command line's
//! value parsers all read, and `table` ([`SETTINGS`]: every field with what a change of it
//! asks of a running render, [`Effect`], and its range; [`Changes`] between two settings).

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

/// Light samples per eye sample in the window and on the command line: 4 light samples per
/// eye sample cost little beside the eye pass and its photons and cut the noise of direct
/// light where it is the eye side's largest part (docs/deviations.md §50, §57).
pub const FRONT_END_NEE_SAMPLES: u32 = 4;

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
    /// Light samples per eye sample for NEE (1 here, the library's and the benchmarks'
    /// Table 2 rows; the window and the command line draw [`FRONT_END_NEE_SAMPLES`]).
    pub nee_samples: u32,
    /// Give up filling a photon class after this many emitted photons per stored-photon budget.
    pub max_emitted_factor: u64,
    /// Camera by name; the scene's first camera when absent.
    pub camera: Option<String>,
    /// Eye samples of a pixel on the same surface share one splat target (docs/deviations.md).
    pub merge_targets: bool,
    /// Keep each kernel to the part of its footprint its target sees, renormalised over it
    /// (visible kernel domains, docs/deviations.md §40). On by default; off is the paper's
    /// splatting, whose kernels reach through walls thinner than the bandwidth and lose the
    /// light of concave corners, for about half the splat time (2.2× T_S on CORNELL BOX I).
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
    /// rs: draw the eye samples anew as photon batches go on (docs/deviations.md §41), so that
    /// anti-aliasing, NEE and traced branches converge with the batches too.
    #[serde(default = "yes")]
    pub progressive_eye: bool,
    /// rs, rc: beyond the first photon batch the bandwidth shrinks as M^(−1/3) instead of
    /// eq. 8's M^(−1/6) (docs/deviations.md §43); off, every batch keeps eq. 8's
    /// bandwidth for the total M, as in the paper.
    #[serde(default = "yes")]
    pub progressive_bandwidth: bool,
    /// rs: emit photons where the camera looks, learned from the batches so far
    /// (docs/deviations.md §44; on by default); off, every batch emits in proportion to
    /// power (§3).
    #[serde(default = "yes")]
    pub guided_emission: bool,
    /// rs: estimate the image's error from its own eye passes (variance from their spread,
    /// kernel bias from a second splat of each batch at a quarter of the bandwidth;
    /// docs/deviations.md §51). Needed by `--c auto` and `--until-error`; costs that splat.
    #[serde(default)]
    pub estimate_error: bool,
    /// rs: choose C between eye passes to minimise the estimated error (`--c auto`;
    /// docs/deviations.md §51); the chosen value replaces `bandwidth.smoothness_c`.
    #[serde(default)]
    pub auto_c: bool,
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
            splat_visibility: true,
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
            guided_emission: true,
            estimate_error: false,
            auto_c: false,
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
    /// are normalised to sum to 1. Reads the one table of settings ([`SETTINGS`]).
    pub fn within_limits(mut self) -> Self {
        for setting in SETTINGS {
            setting.range.clamp(&mut self);
        }
        // Automatic C chooses from the error estimate: it needs one.
        self.estimate_error |= self.auto_c;
        self
    }
}

fn one() -> u32 {
    1
}

impl RenderSettings {
    /// An error naming the first setting outside its range of [`limits`] (or fractions that
    /// cannot be normalised), for settings that must be right before any work starts. Reads
    /// the one table of settings ([`SETTINGS`]).
    pub fn validate(&self) -> Result<(), SettingsError> {
        // The rows' accessors take `&mut`: one copy serves them all.
        let mut copy = self.clone();
        for setting in SETTINGS {
            // The path tracer takes no eye samples (`pt_spp` is its count).
            if setting.name == "spp" && self.method == MethodKind::Pt {
                continue;
            }
            setting.range.check(setting.label, &mut copy)?;
        }
        Ok(())
    }
}

/// A setting that cannot be used as given.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// A number outside its range of [`limits`].
    #[error("{label} must be in {range}, got {value}")]
    OutOfRange {
        /// The setting, as the window and the messages name it.
        label: &'static str,
        /// The accepted range, `min..=max`.
        range: String,
        /// The value given.
        value: String,
    },
    /// Photon fractions that cannot be normalised.
    #[error("the photon fractions must be three non-negative numbers, not all zero")]
    Fractions,
}

/// Photon fractions scaled to sum to 1; an error when one is negative or not finite, or all
/// are zero.
pub fn normalised_fractions(f: [f32; 3]) -> Result<[f32; 3], SettingsError> {
    let sum: f32 = f.iter().sum();
    if f.iter().any(|x| !x.is_finite() || *x < 0.0) || sum <= 0.0 {
        return Err(SettingsError::Fractions);
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
pub mod limits;

mod table;

pub use table::{Changes, Effect, Range, SETTINGS, Setting};

#[cfg(test)]
mod tests;
