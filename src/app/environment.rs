//! The environment panel: which environment lights the scene (automatic, none, uniform, the
//! analytic sky or a map file), its strength and rotation, and an optional sun. Every change
//! sends the whole environment to the worker, which re-traces under it.

use crate::app::UiSettings;
use crate::app::widgets::Commands;
use crate::scene::environment::{ANGLE_RANGE, ELEVATION_RANGE, describe};
use crate::scene::{EnvironmentKind, EnvironmentSettings, Sun};
use crate::session::Command;
use crate::settings::limits;

/// What the panel asks of the window besides worker commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvironmentRequest {
    /// Open a file dialog for an `.hdr`/`.exr` map.
    ChooseMap,
}

/// The environment panel; `lit_by` is the environment the worker last reported (resolved).
#[derive(Clone, Debug, Default)]
pub struct EnvironmentPanel {
    /// The environment lighting the scene now, as the worker reported it.
    pub lit_by: Option<EnvironmentSettings>,
}

impl EnvironmentPanel {
    /// Draw the widgets. Accessible names: "Environment" (a combo box: "Automatic", "None",
    /// "Uniform", "Sky", "Map file…"), "Strength", "Rotation", "Sun", "Sun elevation",
    /// "Sun azimuth", "Sun strength". A change emits [`Command::SetEnvironment`]; picking
    /// "Map file…" returns [`EnvironmentRequest::ChooseMap`] instead (the window opens a
    /// dialog and sends the command once a file is chosen).
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        out: &mut Commands,
    ) -> Option<EnvironmentRequest> {
        ui.heading("Environment");
        if let Some(env) = &self.lit_by {
            ui.label(format!("Lit by: {}", describe(env)));
        }
        let mut request = None;
        out.on_change(
            &mut settings.environment,
            |env| {
                let current = match &env.kind {
                    EnvironmentKind::Auto => "Automatic",
                    EnvironmentKind::None => "None",
                    EnvironmentKind::Uniform => "Uniform",
                    EnvironmentKind::Sky => "Sky",
                    EnvironmentKind::File(_) => "Map file…",
                };
                egui::ComboBox::from_label("Environment")
                    .selected_text(current)
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut env.kind, EnvironmentKind::Auto, "Automatic")
                            .on_hover_text(
                                "none when the file has lights, uniform when it has none",
                            );
                        ui.selectable_value(&mut env.kind, EnvironmentKind::None, "None");
                        ui.selectable_value(&mut env.kind, EnvironmentKind::Uniform, "Uniform");
                        ui.selectable_value(&mut env.kind, EnvironmentKind::Sky, "Sky")
                            .on_hover_text("the CIE standard clear sky");
                        if ui
                            .selectable_label(
                                matches!(env.kind, EnvironmentKind::File(_)),
                                "Map file…",
                            )
                            .clicked()
                        {
                            request = Some(EnvironmentRequest::ChooseMap);
                        }
                    });
                if let EnvironmentKind::File(p) = &env.kind {
                    ui.label(format!("Map: {}", p.display()));
                }
                ui.add(
                    egui::Slider::new(&mut env.strength, limits::ENV_STRENGTH.min..=100.0)
                        .logarithmic(true)
                        .text("Strength"),
                );
                ui.add(egui::Slider::new(&mut env.rotation_deg, -180.0..=180.0).text("Rotation"));
                let mut on = env.sun.is_some();
                ui.checkbox(&mut on, "Sun");
                match (on, &mut env.sun) {
                    (true, None) => {
                        env.sun = Some(Sun {
                            elevation_deg: 45.0,
                            azimuth_deg: 30.0,
                            strength: Sun::DEFAULT_STRENGTH,
                        })
                    }
                    (false, Some(_)) => env.sun = None,
                    (true, Some(sun)) => {
                        ui.add(
                            egui::Slider::new(&mut sun.elevation_deg, ELEVATION_RANGE)
                                .text("Sun elevation"),
                        );
                        ui.add(
                            egui::Slider::new(
                                &mut sun.azimuth_deg,
                                *ANGLE_RANGE.start() / 2.0..=*ANGLE_RANGE.end() / 2.0,
                            )
                            .text("Sun azimuth"),
                        );
                        ui.add(
                            egui::Slider::new(&mut sun.strength, 0.0..=1000.0)
                                .logarithmic(true)
                                .text("Sun strength"),
                        );
                    }
                    (false, None) => {}
                }
            },
            |env| Command::SetEnvironment(env.clone()),
        );
        request
    }
}
