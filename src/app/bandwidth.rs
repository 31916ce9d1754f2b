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
    /// Draw the sliders (accessible names "C", "S", "R") and the "Auto" box beside C; a moved
    /// slider emits `SetBandwidth` with all three values, the box `SetAutoC` (turned off, the
    /// worker keeps the chosen C). `stats` are the newest frame's counters.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        stats: Option<&SessionStats>,
        out: &mut Commands,
    ) {
        let defaults = BandwidthParams::default();
        ui.heading("Bandwidth (eq. 8)");
        let auto_before = settings.render.auto_c;
        let mut auto = auto_before;
        out.on_change(
            &mut settings.render.bandwidth,
            |b| {
                // C, or the C the render chooses (the slider then follows it, disabled).
                ui.horizontal(|ui| {
                    ui.add_enabled(
                        !auto,
                        egui::Slider::new(&mut b.smoothness_c, limits::SMOOTHNESS_C.range())
                            .text("C"),
                    )
                    .on_hover_text("smoothness");
                    if ui
                        .add_enabled(!auto, egui::Button::new("reset").small())
                        .on_hover_text(format!("reset C to {}", defaults.smoothness_c))
                        .clicked()
                    {
                        b.smoothness_c = defaults.smoothness_c;
                    }
                    ui.checkbox(&mut auto, "Auto").on_hover_text(
                        "Choose C between eye passes to minimise the error the render estimates \
                         from its own passes (docs/deviations.md §51); the slider shows the \
                         chosen value, and keeps it when Auto is turned off. It is the C every \
                         batch so far would best share, which rises slowly as batches come in: \
                         the progressive schedule shrinks the bandwidth faster than the error's \
                         optimum. Turning it on re-splats the stored batches (the estimate needs \
                         a second splat)",
                    );
                });
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
                param_slider(
                    ui,
                    &mut b.floor_neighbours,
                    limits::FLOOR_NEIGHBOURS.range(),
                    "K",
                    "floor from the photons stored: no kernel narrower than C times the radius \
                     holding K photon rays where it lands (0: off)",
                    defaults.floor_neighbours,
                );
            },
            |&b| Command::SetBandwidth(b),
        );
        if auto != auto_before {
            settings.render.auto_c = auto;
            // Off, the worker keeps the C the render chose last (the window's slider follows
            // it from the frames rendered under Auto).
            out.push(Command::SetAutoC(auto));
            if auto {
                // The estimate it chooses from.
                settings.render.estimate_error = true;
            }
        }
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
