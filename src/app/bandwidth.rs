//! The bandwidth panel: eq. 8's C, S and R. Moving a slider emits [`Command::SetBandwidth`];
//! the worker re-splats the stored photon rays with the new bandwidths (no re-trace).

use crate::app::UiSettings;
use crate::app::widgets::{Commands, param_slider};
use crate::pipeline::photon::BandwidthParams;
use crate::session::{Command, SessionStats};
use crate::settings::limits;
use egui::Color32;

/// C (smoothness), S (sensitivity) and R (bandwidth range) of eq. 8, and a warning when the
/// ray store is full (older photons are folded into the image and cannot be re-splatted).
#[derive(Clone, Debug, Default)]
pub struct BandwidthPanel;

impl BandwidthPanel {
    /// Draw the sliders (accessible names "C", "S", "R"); a moved slider emits
    /// `SetBandwidth` with all three values. `stats` are the newest frame's counters.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        stats: Option<&SessionStats>,
        out: &mut Commands,
    ) {
        let defaults = BandwidthParams::default();
        ui.heading("Bandwidth (eq. 8)");
        out.on_change(
            &mut settings.render.bandwidth,
            |b| {
                param_slider(
                    ui,
                    &mut b.smoothness_c,
                    limits::SMOOTHNESS_C.range(),
                    "C",
                    "smoothness",
                    defaults.smoothness_c,
                );
                param_slider(
                    ui,
                    &mut b.sensitivity_s,
                    limits::SENSITIVITY_S.range(),
                    "S",
                    "sensitivity",
                    defaults.sensitivity_s,
                );
                param_slider(
                    ui,
                    &mut b.max_bandwidth_r,
                    limits::MAX_BANDWIDTH_R.range(),
                    "R",
                    "bandwidth range: h within [R·h̄, h̄/R]",
                    defaults.max_bandwidth_r,
                );
            },
            |&b| Command::SetBandwidth(b),
        );
        if let Some(s) = stats
            && s.method.folded_batches > 0
        {
            ui.colored_label(
                Color32::from_rgb(230, 170, 60),
                format!(
                    "Ray store full: {} older batches are folded into the image. Slider and camera \
                     changes re-splat the stored {} rays only: the folded light leaves the image and \
                     new batches replace it.",
                    s.method.folded_batches, s.method.photon_rays
                ),
            );
        }
    }
}
