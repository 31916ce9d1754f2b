//! The error panel (issue 32): the error the render estimates from its own eye passes
//! (docs/deviations.md §51), a pause at a threshold of it, and the split view with the
//! path-traced reference of the same view, with their measured relMSE beside the estimate.

use crate::app::UiSettings;
use crate::app::widgets::Commands;
use crate::session::{Command, Frame};
use crate::settings::MethodKind;
use egui::Color32;

/// Smallest and largest pause threshold (relMSE) the panel offers.
pub const PAUSE_RANGE: std::ops::RangeInclusive<f64> = 1e-5..=1.0;

/// Estimate, pause threshold, split view.
#[derive(Clone, Debug, Default)]
pub struct ErrorPanel;

impl ErrorPanel {
    /// Draw the widgets (accessible names "Estimate the error", "Pause below", "Pause
    /// threshold", "Split view with the reference", "Divider"); `frame` is the newest frame.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        frame: Option<&Frame>,
        out: &mut Commands,
    ) {
        ui.heading("Error");
        let rs = settings.render.method == MethodKind::Rs;
        // Automatic C needs the estimate: the box stays ticked while it is on.
        let auto = settings.render.auto_c;
        out.on_change(
            &mut settings.render.estimate_error,
            |on| {
                ui.add_enabled(rs && !auto, egui::Checkbox::new(on, "Estimate the error"))
                    .on_hover_text(
                        "Estimate the image's relMSE from its own eye passes: variance from their \
                         spread, kernel bias from a second splat at a quarter of the bandwidth (a fifth \
                         to a third more splat time; docs/deviations.md §51). Automatic C needs it.",
                    );
            },
            |&on| Command::SetErrorEstimate(on),
        );
        let estimate = frame.and_then(|f| f.film.estimate.as_ref());
        match estimate {
            Some(e) => {
                // The path tracer's passes are not eye passes.
                let passes = if rs { "eye passes" } else { "passes" };
                ui.label(format!(
                    "estimated relMSE {:.5} (bias² {:.5}, variance {:.5}) from {} {passes}",
                    e.rel_mse, e.bias2, e.variance, e.passes
                ))
                .on_hover_text(
                    "Error that does not change with the bandwidth (glossy reflections of \
                     splatted light, caustics) is not in it: on the scenes measured headless \
                     the truth was 1.1 to 2.2 times the estimate (docs/deviations.md §51), \
                     and more on glossy scenes after few eye passes. The split view's \
                     reference shows the truth beside it.",
                );
            }
            None if settings.render.estimate_error => {
                ui.label("estimate: after two eye passes…");
            }
            None => {}
        }
        // The pause: its threshold is kept while the box is off.
        let before = (settings.pause_below_on, settings.pause_below);
        ui.horizontal(|ui| {
            ui.add_enabled(
                rs,
                egui::Checkbox::new(&mut settings.pause_below_on, "Pause below"),
            )
            .on_hover_text("Pause once the estimated relMSE falls below the threshold");
            ui.add_enabled(
                rs,
                egui::DragValue::new(&mut settings.pause_below)
                    .range(PAUSE_RANGE)
                    .speed(0.00005)
                    .max_decimals(5),
            )
            .on_hover_text("Pause threshold (estimated relMSE)");
        });
        if (settings.pause_below_on, settings.pause_below) != before {
            if settings.pause_below_on && !settings.render.estimate_error {
                settings.render.estimate_error = true;
                out.push(Command::SetErrorEstimate(true));
            }
            out.push(Command::SetPauseBelow(settings.pause_threshold()));
        }
        // One line whatever the state, so that the panels below do not jump.
        match frame.and_then(|f| f.stats.paused_below) {
            Some(t) => {
                ui.colored_label(
                    Color32::from_rgb(120, 200, 120),
                    format!("paused: estimate below {t}"),
                );
            }
            None if settings.pause_below_on => {
                ui.label(format!(
                    "pauses once the estimate is below {}",
                    settings.pause_below
                ));
            }
            None => {
                ui.label("refines until paused");
            }
        }
        ui.separator();
        out.on_change(
            &mut settings.split,
            |on| {
                ui.checkbox(on, "Split view with the reference")
                    .on_hover_text(
                        "The path tracer refines the same view beside the photon batches (each \
                     gets half the time); drag the divider in the image, or set it below",
                    );
            },
            |&on| Command::SetSplit(on),
        );
        if settings.split {
            ui.add(egui::Slider::new(&mut settings.split_at, 0.0..=1.0).text("Divider"));
            if let Some(f) = frame {
                let s = &f.stats;
                match s.reference_rel_mse {
                    Some(r) => {
                        ui.label(format!(
                            "relMSE against the reference: {r:.5} ({} paths per pixel)",
                            s.reference_spp
                        ));
                        // relMSE(image, reference) ≈ the image's error + the reference's own
                        // variance (the two are independent).
                        if let Some(noise) = s.reference_noise {
                            ui.label(format!(
                                "of which the reference's own noise ≈ {noise:.5}: the image's \
                                 error ≈ {:.5}",
                                (r - noise).max(0.0)
                            ))
                            .on_hover_text(
                                "The reference's variance from its paths' spread; what is left \
                                 is the image's error to compare with the estimate above",
                            );
                        }
                    }
                    None if s.paused => {
                        ui.label("reference: starts when the render runs (paused)");
                    }
                    None => {
                        ui.label("reference: starting after the first batches…");
                    }
                }
            }
        }
    }
}
