//! [`UiSettings`]: what the window persists between runs — the render settings the worker
//! starts from, and the display-only choices beside them.

use crate::film::display::{ToneMap, ViewMode};
use crate::scene::EnvironmentSettings;
use crate::session::SessionConfig;
use crate::settings::{RenderSettings, limits};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The window's settings, persisted between runs in eframe's storage. Every field has a default
/// (`#[serde(default)]`), so a stored value missing fields still loads; one that does not parse
/// is dropped for the defaults ([`UiSettings::from_storage`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct UiSettings {
    /// What the worker renders: resolution, spp, photons per batch, C/S/R, direct light,
    /// radiance map, radiance cache and image filter.
    pub render: RenderSettings,
    /// Photon rays the worker keeps for re-splatting ([`limits::RAY_BUDGET`]).
    pub ray_budget: usize,
    /// What the viewport shows of the film.
    pub view_mode: ViewMode,
    /// Display exposure, stops ([`limits::EXPOSURE`]).
    pub exposure: f32,
    /// Tone mapping of the displayed image.
    pub tone_map: ToneMap,
    /// Where snapshots are written.
    pub snapshot_dir: PathBuf,
    /// The environment scenes are lit by.
    pub environment: EnvironmentSettings,
    /// Pause when the estimated relMSE falls below [`UiSettings::pause_below`].
    pub pause_below_on: bool,
    /// The pause threshold (estimated relMSE), kept while the pause is off.
    pub pause_below: f64,
    /// The split view: the image left of the divider, the path-traced reference right of it.
    pub split: bool,
    /// Where the divider is, as a fraction of the image's width.
    pub split_at: f32,
    /// The defaults these settings were saved under ([`UiSettings::DEFAULTS`]; 0 before
    /// the field existed): a stored value from older defaults takes the newer ones where
    /// they changed ([`UiSettings::from_storage`]). Missing: 0, not today's version.
    #[serde(default)]
    pub defaults: u32,
}

impl Default for UiSettings {
    fn default() -> Self {
        let s = SessionConfig::default();
        Self {
            render: s.settings,
            ray_budget: s.max_stored_rays,
            view_mode: ViewMode::Final,
            exposure: 0.0,
            tone_map: ToneMap::Aces,
            snapshot_dir: std::env::current_dir().unwrap_or_else(|_| PathBuf::from(".")),
            environment: EnvironmentSettings::default(),
            pause_below_on: false,
            pause_below: 0.002,
            split: false,
            split_at: 0.5,
            defaults: Self::DEFAULTS,
        }
    }
}

impl UiSettings {
    /// The key of the settings in eframe's storage.
    pub const STORAGE_KEY: &'static str = "raysplat-ui";

    /// The defaults' version. 1 (2026-11-26): emission guided by what reached the eye samples
    /// and 4 light samples per eye sample (docs/deviations.md §44, §50); a window saved
    /// before had them off and 1, and would have kept them. 2 (2026-11-29): C chosen by the
    /// render (the Auto box, docs/deviations.md §51) and the error estimate on.
    pub const DEFAULTS: u32 = 2;

    /// The persisted settings, moved into [`limits`] and onto the current defaults where
    /// those changed since they were saved; `None` when nothing is stored or the stored value
    /// does not parse (an older format, a damaged file).
    pub fn from_storage(storage: &dyn eframe::Storage) -> Option<Self> {
        eframe::get_value::<UiSettings>(storage, Self::STORAGE_KEY)
            .map(|s| s.onto_current_defaults().within_limits())
    }

    /// Settings saved under older defaults take the newer ones where they changed.
    fn onto_current_defaults(mut self) -> Self {
        if self.defaults < 1 {
            let d = SessionConfig::default().settings;
            self.render.guided_emission = d.guided_emission;
            self.render.nee_samples = d.nee_samples;
        }
        if self.defaults < 2 {
            let d = SessionConfig::default().settings;
            self.render.auto_c = d.auto_c;
            self.render.estimate_error |= d.estimate_error;
        }
        self.defaults = Self::DEFAULTS;
        self
    }

    /// Store the settings in eframe's storage.
    pub fn save(&self, storage: &mut dyn eframe::Storage) {
        eframe::set_value(storage, Self::STORAGE_KEY, self);
    }

    /// Every numeric setting moved into its range of [`limits`] (the window's widgets show
    /// the same ranges).
    pub fn within_limits(mut self) -> Self {
        self.render = self.render.within_limits();
        self.ray_budget = limits::RAY_BUDGET.clamp(self.ray_budget);
        self.exposure = limits::EXPOSURE.clamp(self.exposure);
        let e = &mut self.environment;
        e.strength = limits::ENV_STRENGTH.clamp(e.strength);
        e.rotation_deg = limits::ENV_ROTATION.clamp(e.rotation_deg);
        if e.sun.is_some_and(|s| s.check().is_err()) {
            e.sun = None;
        }
        let pause = crate::app::error_panel::PAUSE_RANGE;
        self.pause_below = if self.pause_below.is_finite() {
            self.pause_below.clamp(*pause.start(), *pause.end())
        } else {
            0.002
        };
        self.split_at = if self.split_at.is_finite() {
            self.split_at.clamp(0.0, 1.0)
        } else {
            0.5
        };
        self
    }

    /// The threshold the worker pauses at, if the pause is on.
    pub fn pause_threshold(&self) -> Option<f64> {
        self.pause_below_on.then_some(self.pause_below)
    }

    /// The worker's configuration for these settings.
    pub fn session_config(&self) -> SessionConfig {
        SessionConfig {
            settings: self.render.clone(),
            max_stored_rays: self.ray_budget,
            environment: self.environment.clone(),
            ..SessionConfig::default()
        }
    }
}
