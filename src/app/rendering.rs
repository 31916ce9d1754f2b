//! The rendering panel: photons per batch, samples per pixel, resolution, direct light and its
//! light samples, the glossy radiance map, visibility in the splat footprint, photons where the
//! camera looks, the ray store's budget, pause, restart and the path-traced reference.
//! Each widget emits its own worker command when it changes.

use crate::app::UiSettings;
use crate::app::display::set_view_mode;
use crate::app::widgets::Commands;
use crate::choice::Choice;
use crate::film::display::ViewMode;
use crate::pipeline::directional::DirectionalMode;
use crate::session::Command;
use crate::settings::{DirectMode, limits};

/// What the worker renders and how it runs.
#[derive(Clone, Debug, Default)]
pub struct RenderingPanel;

impl RenderingPanel {
    /// Draw the widgets. Accessible names: "Photons per batch", "Samples per pixel", "Width",
    /// "Height", "NEE", "photons", "Light samples", "Glossy radiance map", "Visibility in the
    /// splat footprint", "Photons where the camera looks", "Ray store budget",
    /// "Pause (Space)" or "Resume (Space)", "Restart", "Path-trace this view". `paused` is
    /// the worker's state as last reported; the pause button flips it.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        paused: &mut bool,
        out: &mut Commands,
    ) {
        ui.heading("Rendering");
        let r = &mut settings.render;
        out.on_change(
            &mut r.photons,
            |m| {
                ui.horizontal(|ui| {
                    let label = ui.label("Photons per batch");
                    ui.add(
                        egui::DragValue::new(m)
                            .range(limits::PHOTONS.range())
                            .speed(1000),
                    )
                    .labelled_by(label.id);
                });
            },
            |&m| Command::SetPhotonsPerBatch(m),
        );
        out.on_change(
            &mut r.spp,
            |spp| {
                ui.add(egui::Slider::new(spp, limits::SPP.range()).text("Samples per pixel"));
            },
            |&spp| Command::SetSamplesPerPixel(spp),
        );
        let mut size = (r.width, r.height);
        out.on_change(
            &mut size,
            |(w, h)| {
                ui.horizontal(|ui| {
                    ui.label("Resolution");
                    let range = limits::RESOLUTION.range();
                    // Typed sizes apply on Enter or when the field is left, not at every
                    // keystroke (a width typed as 2, 20, 200 restarted the view at each).
                    ui.add(
                        egui::DragValue::new(w)
                            .range(range.clone())
                            .update_while_editing(false),
                    )
                    .accessible_name("Width");
                    ui.label("×");
                    ui.add(
                        egui::DragValue::new(h)
                            .range(range)
                            .update_while_editing(false),
                    )
                    .accessible_name("Height");
                });
            },
            |&(width, height)| Command::SetResolution { width, height },
        );
        (r.width, r.height) = size;
        out.on_change(
            &mut r.direct,
            |d| {
                ui.horizontal(|ui| {
                    ui.label("Direct light");
                    ui.radio_value(d, DirectMode::Nee, "NEE");
                    ui.radio_value(d, DirectMode::Photons, "photons");
                });
            },
            |&d| Command::SetDirect(d),
        );
        out.on_change(
            &mut r.nee_samples,
            |n| {
                ui.add(
                    egui::Slider::new(n, limits::WINDOW_NEE_SAMPLES.range())
                        .logarithmic(true)
                        .text("Light samples"),
                )
                .on_hover_text(
                    "Light samples (NEE, with a BSDF sample under MIS) per eye sample and \
                     draw; with direct light by photons, only the traced glossy lobes draw \
                     them. The direct light is drawn again with each photon batch while \
                     that costs less than the batch. 4 by default: a room lit through its \
                     window sees most of its noise here (docs/deviations.md §50). A change \
                     reaches the direct light drawn from the next batch on (no re-trace, no \
                     re-splat).",
                );
            },
            |&n| Command::SetNeeSamples(n),
        );
        out.on_change(
            &mut r.radiance_map,
            |map| {
                // The short name on the button keeps it and its label on one line in the
                // side panel; the menu gives the long ones.
                egui::ComboBox::from_label("Glossy radiance map")
                    .selected_text(match *map {
                        DirectionalMode::Diffuse => "diffuse",
                        DirectionalMode::Sh => "SH, 16 coeff.",
                        DirectionalMode::Histogram => "20 strata",
                    })
                    .show_ui(ui, |ui| {
                        for &m in DirectionalMode::ALL {
                            ui.selectable_value(map, m, directional_label(m));
                        }
                    })
                    .response
                    .on_hover_text(
                        "How glossy surfaces store the direction of incident light (§8.1): \
                         irradiance only (matte), 16 spherical-harmonic coefficients or 20 \
                         strata per colour channel. Switching re-splats the stored photon rays.",
                    );
            },
            |&m| Command::SetRadianceMap(m),
        );
        out.on_change(
            &mut r.splat_visibility,
            |on| {
                ui.checkbox(on, "Visibility in the splat footprint")
                    .on_hover_text(
                        "Keep each splat kernel to the part of its footprint the eye sample \
                         sees, renormalised over it: light outside a room stays off the inside \
                         of its walls and corners keep their light (docs/deviations.md §40). \
                         On by default; off is the paper's splatting, about twice as fast to \
                         splat. \
                         Switching restarts tracing.",
                    );
            },
            |&on| Command::SetSplatVisibility(on),
        );
        out.on_change(
            &mut r.guided_emission,
            |on| {
                ui.checkbox(on, "Photons where the camera looks")
                    .on_hover_text(
                        "Learn from the batches so far which parts of each light (triangles \
                         and directions, the sky's disc and directions, the sun) send photons \
                         that reach the eye samples, and emit there more often, each photon \
                         weighted so that the image stays unbiased (docs/deviations.md §44). \
                         On by default: with 4 light samples, a room lit through its window \
                         had 0.46-0.55x the error at 10 s, other scenes level or better. Off, \
                         photons leave the lights in proportion to power, as the paper's do. \
                         Auto C was measured with emission by power. Moving the camera \
                         starts the learning again. Switching restarts tracing.",
                    );
            },
            |&on| Command::SetGuidedEmission(on),
        );
        out.on_change(
            &mut settings.ray_budget,
            |budget| {
                ui.horizontal(|ui| {
                    let label = ui.label("Ray store budget");
                    ui.add(
                        egui::DragValue::new(budget)
                            .range(limits::RAY_BUDGET.range())
                            .speed(50_000)
                            .custom_formatter(|n, _| format!("{:.2}", n / 1e6))
                            .custom_parser(|s| {
                                s.trim().parse::<f64>().ok().map(|m| (m * 1e6).round())
                            })
                            .suffix(" M rays"),
                    )
                    .labelled_by(label.id)
                    .on_hover_text("Photon rays kept for re-splatting; older batches are folded");
                });
            },
            |&budget| Command::SetRayBudget(budget),
        );
        ui.horizontal(|ui| {
            let label = if *paused {
                "Resume (Space)"
            } else {
                "Pause (Space)"
            };
            if ui.button(label).clicked() {
                toggle_pause(paused, out);
            }
            if ui
                .button("Restart")
                .on_hover_text("Drop all photons and trace again")
                .clicked()
            {
                out.push(Command::Restart);
            }
        });
        let mut reference = settings.view_mode == ViewMode::Reference;
        if ui
            .checkbox(&mut reference, "Path-trace this view")
            .on_hover_text(
                "The reference view mode: the worker path-traces the current view progressively \
                 instead of tracing photon batches.",
            )
            .changed()
        {
            let mode = if reference {
                ViewMode::Reference
            } else {
                ViewMode::Final
            };
            set_view_mode(settings, mode, out);
        }
    }
}

/// Flip `paused` and emit `Pause` or `Resume` to match (the pause button, the Space key).
pub fn toggle_pause(paused: &mut bool, out: &mut Commands) {
    *paused = !*paused;
    out.push(if *paused {
        Command::Pause
    } else {
        Command::Resume
    });
}

/// The window's name for a directional mode (§8.1).
pub fn directional_label(m: DirectionalMode) -> &'static str {
    match m {
        DirectionalMode::Diffuse => "diffuse (irradiance only)",
        DirectionalMode::Sh => "spherical harmonics (16 per channel)",
        DirectionalMode::Histogram => "histogram (20 strata)",
    }
}
