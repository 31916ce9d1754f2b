//! The argument groups of a render, flattened into [`RenderArgs`] (which `render` takes and
//! `compare` flattens in turn). Every default is read from the library's `Default` impls
//! ([`RenderSettings`], [`BandwidthParams`], [`CacheParams`], [`FilterParams`]), so that the
//! command line starts from the same settings as the window and the worker.

use super::choice;
use super::output::{Exposure, parse_exposure, parse_tonemap};
use clap::Args;
use raysplat::choice::Choice;
use raysplat::film::display::ToneMap;
use raysplat::methods::Budget;
use raysplat::pipeline::cache::CacheParams;
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::pipeline::filter::FilterParams;
use raysplat::pipeline::photon::BandwidthParams;
use raysplat::scene::{EnvironmentKind, EnvironmentSettings, Sun};
use raysplat::settings::{DirectMode, MethodKind, RenderSettings, limits, normalised_fractions};
use std::path::PathBuf;

/// Everything `render` takes: the settings, the method and the outputs.
#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub settings: SettingsArgs,
    /// The method: rs, rc, pm, pt, rs-fg or pm-fg.
    #[arg(long, default_value = RenderSettings::default().method.name(), value_parser = choice::<MethodKind>())]
    pub method: MethodKind,
    /// rs: stop once the error the render estimates from its own eye passes (relMSE, as
    /// `compare` reports it, read every 0.5 s from the fourth eye pass on) falls below this;
    /// with --time-budget, at whichever comes first; without it, it runs until then or until
    /// interrupted. Not with --batches (docs/deviations.md §51) [range: a finite relMSE above
    /// 0]
    #[arg(long, conflicts_with = "batches", allow_negative_numbers = true)]
    pub until_error: Option<f64>,
    #[command(flatten)]
    pub output: OutputArgs,
}

/// The render settings `render` and `compare` share: the scene and the groups below, in the
/// order `--help` lists them.
#[derive(Args, Clone, Debug)]
pub struct SettingsArgs {
    /// A .gltf/.glb file, or builtin:cornell1 | builtin:cornell2 | builtin:classic |
    /// builtin:glossy | builtin:glossy-sharp | builtin:outdoor | builtin:room | builtin:features.
    /// Without it, the embedded CORNELL BOX I.
    pub scene: Option<String>,
    #[command(flatten)]
    pub image: ImageArgs,
    #[command(flatten)]
    pub photons: PhotonArgs,
    /// The seed of every random stream: images depend on it and the settings only.
    #[arg(long, default_value_t = RenderSettings::default().seed, allow_negative_numbers = true)]
    pub seed: u64,
    #[command(flatten)]
    pub direct: DirectArgs,
    #[command(flatten)]
    pub run: RunArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    #[command(flatten)]
    pub cache_filter: CacheFilterArgs,
    #[command(flatten)]
    pub environment: EnvArgs,
}

/// The environment: light from infinitely far away, and the sun.
#[derive(Args, Clone, Debug, Default)]
pub struct EnvArgs {
    /// Light from every direction: none, uniform, sky (the CIE clear sky), or an
    /// equirectangular .hdr/.exr map. Without it: none when the file has lights, uniform when
    /// it has none.
    #[arg(long, value_name = "none|uniform|sky|FILE")]
    pub environment: Option<String>,
    /// The environment's (and sun's) strength: uniform has radiance (X, X, X).
    #[arg(long, value_name = "X", default_value_t = EnvironmentSettings::default().strength)]
    pub env_strength: f32,
    /// Turns the environment (and the sun) about +Y, degrees.
    #[arg(long, value_name = "DEG", default_value_t = EnvironmentSettings::default().rotation_deg, allow_negative_numbers = true)]
    pub env_rotation: f32,
    /// A sun of 0.53° at ELEVATION and AZIMUTH degrees (azimuth from -Z towards +X), giving
    /// STRENGTH W/m² on a surface facing it [default strength: 5π].
    #[arg(long, value_name = "ELEVATION,AZIMUTH[,STRENGTH]", value_parser = parse_sun, allow_hyphen_values = true)]
    pub sun: Option<Sun>,
}

impl EnvArgs {
    /// The environment settings these flags ask for.
    pub fn settings(&self) -> EnvironmentSettings {
        EnvironmentSettings {
            kind: self
                .environment
                .as_deref()
                .map_or(EnvironmentKind::Auto, EnvironmentKind::parse),
            strength: self.env_strength,
            rotation_deg: self.env_rotation,
            sun: self.sun,
        }
    }
}

fn parse_sun(s: &str) -> Result<Sun, String> {
    Sun::parse(s)
}

/// The image: its size and eye samples per pixel.
#[derive(Args, Clone, Debug)]
pub struct ImageArgs {
    /// Image width, pixels.
    #[arg(long, default_value_t = RenderSettings::default().width)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = RenderSettings::default().height)]
    pub height: u32,
    /// Eye samples per pixel, 4 unless given. For `render --method pt`: paths per pixel; with
    /// --time-budget or --batches, the most it traces (it stops at whichever comes first).
    /// `compare` takes the path tracer's from --pt-spp.
    #[arg(long)]
    pub spp: Option<u32>,
}

impl ImageArgs {
    /// Eye samples (or paths) per pixel: as given, or the default.
    pub fn spp(&self) -> u32 {
        self.spp.unwrap_or(RenderSettings::default().spp)
    }
}

/// The photons of a batch and their bandwidths (eq. 8).
#[derive(Args, Clone, Debug)]
pub struct PhotonArgs {
    /// M: stored photon rays per batch.
    #[arg(long, default_value_t = RenderSettings::default().photons)]
    pub photons: u64,
    /// Fractions of M for direct, indirect-diffuse and caustic photons (Table 2).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.3,0.6,0.1",
        allow_negative_numbers = true
    )]
    pub fractions: Vec<f32>,
    /// C: smoothness (eq. 8), or `auto`: rs chooses it between eye passes to minimise the
    /// error it estimates from its own passes (docs/deviations.md §51; starts at 1).
    #[arg(long, default_value = "1", allow_negative_numbers = true)]
    pub c: Smoothness,
    /// S: bandwidth sensitivity in [0.01, 1] (eq. 8).
    #[arg(long, default_value_t = BandwidthParams::default().sensitivity_s, allow_negative_numbers = true)]
    pub s: f32,
    /// R in [0.01, 1]: bandwidth range; every h lies within [R·h̄, h̄/R] of the typical bandwidth.
    #[arg(long, default_value_t = BandwidthParams::default().max_bandwidth_r, allow_negative_numbers = true)]
    pub r: f32,
    /// K of the floor from the photons stored: no ray's end bandwidth is narrower than C
    /// times the radius holding K rays of its class where it lands (docs/deviations.md §63);
    /// 0 turns it off.
    #[arg(long, default_value_t = BandwidthParams::default().floor_neighbours, allow_negative_numbers = true)]
    pub floor_k: f32,
}

/// How direct light reaches the eye samples.
#[derive(Args, Clone, Debug)]
pub struct DirectArgs {
    /// Direct light: nee (light and BSDF samples at eye samples) or photons (splatted).
    #[arg(long, default_value = RenderSettings::default().direct.name(), value_parser = choice::<DirectMode>())]
    pub direct: DirectMode,
    /// Light samples per eye sample for --direct nee.
    #[arg(long, default_value_t = raysplat::settings::FRONT_END_NEE_SAMPLES)]
    pub nee_samples: u32,
}

/// The files a render writes.
#[derive(Args, Clone, Debug)]
pub struct OutputArgs {
    /// The image to write; the format follows the extension: .exr (linear radiance), .png or
    /// .jpg (tone-mapped). Default: out.exr, unless --png names the only image.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// A tone-mapped image (.png or .jpg) besides --out, or instead of it.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    #[command(flatten)]
    pub tone: ToneArgs,
    /// Write timings and counters as JSON.
    #[arg(long, value_name = "FILE")]
    pub stats: Option<PathBuf>,
}

impl OutputArgs {
    /// The image files to write: --out and --png as given, out.exr when neither is.
    pub fn images(&self) -> Vec<PathBuf> {
        if self.out.is_none() && self.png.is_none() {
            return vec![PathBuf::from("out.exr")];
        }
        self.out.iter().chain(&self.png).cloned().collect()
    }
}

/// How linear radiance becomes an 8-bit image: the window's tone curves and exposure.
#[derive(Args, Clone, Debug)]
pub struct ToneArgs {
    /// Exposure of tone-mapped images in stops (negative darkens), or `auto` (the image's
    /// log-average luminance to middle grey).
    #[arg(long, default_value = "0", allow_negative_numbers = true, value_parser = parse_exposure)]
    pub exposure: Exposure,
    /// Tone curve of tone-mapped images: clamp, reinhard or aces (as in the window).
    #[arg(long, default_value = "aces", value_parser = parse_tonemap)]
    pub tonemap: ToneMap,
}

/// How long, from where and on how many threads.
#[derive(Args, Clone, Debug)]
pub struct RunArgs {
    /// Render progressively in batches of --photons until this many seconds are spent.
    #[arg(long, allow_negative_numbers = true)]
    pub time_budget: Option<f64>,
    /// Render exactly this many batches of --photons (passes of the path tracer, gathering
    /// passes): a deterministic multi-batch image, where a time budget's count varies.
    #[arg(long, conflicts_with = "time_budget")]
    pub batches: Option<u64>,
    /// rs: estimate the image's error from its own eye passes (variance from their spread,
    /// bias from a second splat at a quarter of the bandwidth) and report it in the stats
    /// (docs/deviations.md §51).
    #[arg(long)]
    pub estimate_error: bool,
    /// Camera by name (default: the scene's first).
    #[arg(long)]
    pub camera: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// The settings only some methods read.
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// K of the global photon map (--method pm).
    #[arg(long, default_value_t = RenderSettings::default().pm_k)]
    pub pm_k: usize,
    /// K of the caustic photon map (--method pm).
    #[arg(long, default_value_t = RenderSettings::default().pm_caustic_k)]
    pub pm_caustic_k: usize,
    /// Gather rays per eye sample (--method rs-fg, pm-fg).
    #[arg(long, default_value_t = RenderSettings::default().fg_rays)]
    pub fg_rays: u32,
    /// Splat onto every eye sample instead of sharing one splat target among the samples of
    /// a pixel that lie on the same surface.
    #[arg(long)]
    pub no_merge: bool,
    /// Let splat kernels reach through walls and lose the light of concave corners, as the
    /// paper's splatting does (§10), for about half the splat time: without it each kernel
    /// is kept to the part of its footprint its target sees, renormalised over it (visible
    /// kernel domains, docs/deviations.md §40).
    #[arg(long)]
    pub no_splat_visibility: bool,
    /// rs: emit every photon batch in proportion to power, as the paper does (§3), instead of
    /// where the batches so far found photons that reach the camera's eye samples, weighted to
    /// stay unbiased (docs/deviations.md §44; the first batch is by power either way)
    #[arg(long)]
    pub emission_by_power: bool,
    /// rs: keep the eye samples of the first eye pass for every batch instead of drawing
    /// them anew as batches go on (the paper's one eye pass per view; docs/deviations.md §41).
    #[arg(long)]
    pub fixed_eye_samples: bool,
    /// rs, rc: every photon batch keeps eq. 8's bandwidth for the total M (h ∝ M^(−1/6)), as
    /// in the paper, instead of shrinking it as M^(−1/3) beyond the first batch
    /// (docs/deviations.md §43)
    #[arg(long)]
    pub paper_bandwidth_rate: bool,
    /// Directional storage at glossy surfaces (§8.1): diffuse (irradiance only), sh
    /// (16 spherical-harmonic coefficients per channel) or histogram (20 strata).
    #[arg(long, default_value = RenderSettings::default().radiance_map.name(), value_parser = choice::<DirectionalMode>())]
    pub radiance_map: DirectionalMode,
}

/// The radiance cache (§8.3) and the image-space filter (§8.2).
#[derive(Args, Clone, Debug)]
pub struct CacheFilterArgs {
    /// ε, the radiance cache error (§8.3): records are valid up to ε × their harmonic mean
    /// distance. Used by --method rc, and by rs with --cache.
    #[arg(long, default_value_t = CacheParams::default().error, allow_negative_numbers = true)]
    pub cache_error: f32,
    /// Every pixel is covered by at least this many cache records.
    #[arg(long, default_value_t = CacheParams::default().min_records)]
    pub min_records: u32,
    /// rs: resolve the full radiance map through the radiance cache (as the previewer does).
    #[arg(long)]
    pub cache: bool,
    /// Filter the indirect light in image space within continuous regions (§8.2).
    #[arg(long)]
    pub filter: bool,
    /// Scale of the filter's box radius (1 = as the splat statistics ask).
    #[arg(long, default_value_t = FilterParams::default().strength, allow_negative_numbers = true)]
    pub filter_strength: f32,
}

impl RenderArgs {
    /// The settings the arguments describe for `--method`, or a one-line error naming the
    /// bad flag.
    pub fn settings(&self) -> Result<RenderSettings, String> {
        let (run, c) = (&self.settings.run, self.settings.photons.c);
        if self.method != MethodKind::Rs
            && (self.until_error.is_some() || run.estimate_error || c == Smoothness::Auto)
        {
            return Err(format!(
                "--until-error, --estimate-error and --c auto need --method rs (the error is \
                 estimated from its eye passes), not {}",
                self.method.name()
            ));
        }
        if let Some(e) = self.until_error
            && !(e > 0.0 && e.is_finite())
        {
            return Err(format!(
                "--until-error must be a finite relMSE above 0, got {e}"
            ));
        }
        let mut settings = self.settings.settings(self.method)?;
        // A stop at an error reads the estimate.
        settings.estimate_error |= self.until_error.is_some();
        Ok(settings)
    }

    /// `--time-budget` seconds, `--batches` units of work, one fixed batch, or no bound of
    /// its own under `--until-error` (it stops when the estimate says so).
    pub fn budget(&self) -> Budget {
        match self.settings.run.budget() {
            Budget::Fixed if self.until_error.is_some() => Budget::Seconds(f64::INFINITY),
            b => b,
        }
    }
}

impl SettingsArgs {
    /// The settings the arguments describe for `kind`, or a one-line error naming the bad
    /// flag.
    pub fn settings(&self, kind: MethodKind) -> Result<RenderSettings, String> {
        let bandwidth = self.photons.bandwidth()?;
        let fractions = self.photons.fractions()?;
        let (image, method) = (&self.image, &self.method);
        let spp = image.spp();
        if kind != MethodKind::Pt && !limits::SPP.contains(spp) {
            return Err(format!(
                "--spp must be in {}..={} (eye samples per pixel; only --method pt takes more), got {}",
                limits::SPP.min,
                limits::SPP.max,
                spp
            ));
        }
        Ok(RenderSettings {
            width: image.width,
            height: image.height,
            spp,
            photons: self.photons.photons,
            fractions,
            bandwidth,
            seed: self.seed,
            direct: self.direct.direct,
            nee_samples: self.direct.nee_samples,
            camera: self.run.camera.clone(),
            merge_targets: !method.no_merge,
            splat_visibility: !method.no_splat_visibility,
            guided_emission: !method.emission_by_power,
            // rs only (`compare` runs other methods beside it): auto C reads the estimate
            // (and `render`'s stop at an error, `RenderArgs::settings`).
            auto_c: kind == MethodKind::Rs && self.photons.c == Smoothness::Auto,
            estimate_error: kind == MethodKind::Rs
                && (self.run.estimate_error || self.photons.c == Smoothness::Auto),
            progressive_eye: !method.fixed_eye_samples,
            progressive_bandwidth: !method.paper_bandwidth_rate,
            method: kind,
            pm_k: method.pm_k,
            pm_caustic_k: method.pm_caustic_k,
            fg_rays: method.fg_rays,
            radiance_map: method.radiance_map,
            // With a time budget the path tracer adds one path per pixel per step, so the
            // budget bounds it (and a given --spp: `SettingsArgs::pt_path_cap`); otherwise
            // --spp paths in one step.
            pt_spp: if self.run.stepped() { 1 } else { spp },
            cache: self.cache_filter.cache(),
            cache_on: self.cache_filter.cache,
            filter: self.cache_filter.filter(),
            ..RenderSettings::default()
        })
    }
}

impl SettingsArgs {
    /// The most paths per pixel a path tracer under a time budget or a count of passes may
    /// trace: a --spp given with either (the render stops at whichever comes first). `None`
    /// without one, or when --spp was not given.
    pub fn pt_path_cap(&self) -> Option<u64> {
        self.image.spp.filter(|_| self.run.stepped()).map(u64::from)
    }
}

/// `--c`: a value, or chosen by the render itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Smoothness {
    /// This C.
    Value(f32),
    /// `auto`: chosen between eye passes from the estimated error, starting at the default.
    Auto,
}

/// Without the range (`with_ranges` in `cli` puts a parser with it in place).
impl std::str::FromStr for Smoothness {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(Smoothness::Auto);
        }
        s.trim()
            .parse()
            .map(Smoothness::Value)
            .map_err(|_| format!("'{s}' is neither a number nor auto"))
    }
}

impl Smoothness {
    /// The C a render starts with.
    pub fn start(self) -> f32 {
        match self {
            Smoothness::Value(c) => c,
            Smoothness::Auto => BandwidthParams::default().smoothness_c,
        }
    }
}

impl PhotonArgs {
    /// C, S and R (their ranges are checked by the parser).
    fn bandwidth(&self) -> Result<BandwidthParams, String> {
        Ok(BandwidthParams {
            smoothness_c: self.c.start(),
            sensitivity_s: self.s,
            max_bandwidth_r: self.r,
            floor_neighbours: self.floor_k,
        })
    }

    /// The three fractions, normalised to sum to 1 (`3,6,1` is `0.3,0.6,0.1`).
    fn fractions(&self) -> Result<[f32; 3], String> {
        let [f0, f1, f2] = self.fractions[..] else {
            return Err(format!(
                "--fractions takes three numbers (direct, indirect, caustic), got {}",
                self.fractions.len()
            ));
        };
        normalised_fractions([f0, f1, f2])
            .map_err(|_| "--fractions must be three non-negative numbers, not all zero".to_string())
    }
}

impl RunArgs {
    /// A render progressive over steps (`--time-budget` or `--batches`): the path tracer
    /// then adds one path per pixel a step.
    pub fn stepped(&self) -> bool {
        self.time_budget.is_some() || self.batches.is_some()
    }

    /// `--time-budget` seconds, `--batches` units of work, or one fixed batch.
    pub fn budget(&self) -> Budget {
        match (self.time_budget, self.batches) {
            (Some(b), _) => Budget::Seconds(b),
            (None, Some(n)) => Budget::Passes(n),
            (None, None) => Budget::Fixed,
        }
    }
}

impl CacheFilterArgs {
    fn cache(&self) -> CacheParams {
        CacheParams {
            error: self.cache_error,
            min_records: self.min_records,
        }
    }

    fn filter(&self) -> FilterParams {
        FilterParams {
            enabled: self.filter,
            strength: self.filter_strength,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Probe {
        #[command(flatten)]
        render: RenderArgs,
    }

    /// With no flags, the settings are the library's defaults (the path tracer takes --spp),
    /// but for the front ends' light samples per eye sample (docs/deviations.md §57).
    #[test]
    fn no_flags_give_the_default_settings() {
        let args = Probe::try_parse_from(["raysplat"]).unwrap().render;
        let d = RenderSettings::default();
        assert_eq!(
            args.settings().unwrap(),
            RenderSettings {
                pt_spp: d.spp,
                nee_samples: raysplat::settings::FRONT_END_NEE_SAMPLES,
                ..d
            }
        );
        assert_eq!(args.budget(), Budget::Fixed);
    }
}
