//! The display panel: view mode, exposure and tone mapping. These change only how the window
//! shows the film, except two view modes that need the worker: the reference mode makes it
//! path-trace the view ([`Command::SetReference`]) and the cache-records mode turns the
//! radiance cache on when it is off ([`Command::SetCache`]); [`set_view_mode`] emits both.

use crate::app::UiSettings;
use crate::app::widgets::Commands;
use crate::film::display::{ToneMap, ViewMode};
use crate::session::Command;
use crate::settings::limits;

/// View mode, exposure and tone mapping.
#[derive(Clone, Debug, Default)]
pub struct DisplayPanel;

impl DisplayPanel {
    /// Draw the widgets (accessible names "View", "Exposure (stops)", "Tone mapping"); a new
    /// view mode goes through [`set_view_mode`].
    pub fn ui(&mut self, ui: &mut egui::Ui, settings: &mut UiSettings, out: &mut Commands) {
        ui.heading("Display");
        let mut mode = settings.view_mode;
        egui::ComboBox::from_label("View")
            .selected_text(view_mode_label(mode))
            .show_ui(ui, |ui| {
                for m in ViewMode::ALL {
                    ui.selectable_value(&mut mode, m, view_mode_label(m));
                }
            });
        set_view_mode(settings, mode, out);
        ui.add(
            egui::Slider::new(&mut settings.exposure, limits::EXPOSURE.range())
                .text("Exposure (stops)"),
        );
        egui::ComboBox::from_label("Tone mapping")
            .selected_text(tone_map_label(settings.tone_map))
            .show_ui(ui, |ui| {
                for t in ToneMap::ALL {
                    ui.selectable_value(&mut settings.tone_map, t, tone_map_label(t));
                }
            });
    }
}

/// Show `mode`: entering or leaving the reference mode emits `SetReference`, entering the
/// cache-records mode with the cache off turns it on (`SetCache`), and entering the
/// estimated-error mode with the estimate off turns that on (`SetErrorEstimate`). Nothing when
/// `mode` is already shown.
pub fn set_view_mode(settings: &mut UiSettings, mode: ViewMode, out: &mut Commands) {
    let old = settings.view_mode;
    if mode == old {
        return;
    }
    settings.view_mode = mode;
    let reference = mode == ViewMode::Reference;
    if reference != (old == ViewMode::Reference) {
        out.push(Command::SetReference(reference));
    }
    if mode == ViewMode::EstimatedError && !settings.render.estimate_error {
        settings.render.estimate_error = true;
        out.push(Command::SetErrorEstimate(true));
    }
    if mode == ViewMode::CacheRecords && !settings.render.cache_on {
        settings.render.cache_on = true;
        out.push(Command::SetCache {
            on: true,
            params: settings.render.cache,
        });
    }
}

/// The mode's name in the window's menu.
pub fn view_mode_label(m: ViewMode) -> &'static str {
    match m {
        ViewMode::Final => "Final",
        ViewMode::DirectOnly => "Direct only",
        ViewMode::IndirectOnly => "Indirect only",
        ViewMode::Bandwidth => "Bandwidth (false colour)",
        ViewMode::KernelDensity => "Kernel-weight density",
        ViewMode::HarmonicDistance => "Harmonic mean distance",
        ViewMode::Reference => "Reference (path traced)",
        ViewMode::CacheRecords => "Cache records (radii)",
        ViewMode::EstimatedError => "Estimated error (per pixel)",
    }
}

/// The curve's name in the window's menu.
pub fn tone_map_label(m: ToneMap) -> &'static str {
    match m {
        ToneMap::Clamp => "Clamp",
        ToneMap::Reinhard => "Reinhard",
        ToneMap::Aces => "ACES filmic",
    }
}
