//! The camera panel: pick one of the scene's cameras, or reset the view to the chosen one.
//! Either emits [`Command::SetCamera`] with a final (non-interactive) view; the mouse's orbit
//! around the chosen camera lives in the viewport.

use crate::app::widgets::Commands;
use crate::scene::Camera;
use crate::session::Command;

/// The scene's cameras and the chosen one.
#[derive(Clone, Debug, Default)]
pub struct CameraPanel {
    /// The scene's cameras, as the worker reported them when the scene loaded.
    pub cameras: Vec<Camera>,
    /// Index of the chosen camera in `cameras`.
    pub selected: usize,
}

impl CameraPanel {
    /// A panel for these cameras, the first chosen.
    pub fn new(cameras: Vec<Camera>) -> Self {
        Self {
            cameras,
            selected: 0,
        }
    }

    /// Draw the camera list (accessible name "Camera") and the "Reset" button. A new choice
    /// or a reset emits `SetCamera` and returns the camera, for the window to put its orbit
    /// there.
    pub fn ui(&mut self, ui: &mut egui::Ui, out: &mut Commands) -> Option<Camera> {
        ui.heading("Camera");
        ui.label("Drag: orbit · Shift-drag or middle: pan · Wheel: zoom");
        let mut chosen = None;
        ui.horizontal(|ui| {
            let mut sel = self.selected;
            let name = |i: usize| self.cameras.get(i).map(|c| c.name.clone());
            egui::ComboBox::from_id_salt("camera")
                .selected_text(name(sel).unwrap_or_default())
                .show_ui(ui, |ui| {
                    for (i, c) in self.cameras.iter().enumerate() {
                        ui.selectable_value(&mut sel, i, &c.name);
                    }
                })
                .response
                .accessible_name("Camera");
            if sel != self.selected {
                chosen = self.select(sel, out);
            }
            if ui.button("Reset").clicked() {
                chosen = self.select(self.selected, out);
            }
        });
        chosen
    }

    /// Choose camera `i` and emit its final view; `None` (and nothing emitted) when there is
    /// no such camera.
    pub fn select(&mut self, i: usize, out: &mut Commands) -> Option<Camera> {
        let camera = self.cameras.get(i)?.clone();
        self.selected = i;
        out.push(Command::SetCamera {
            camera: camera.clone(),
            interactive: false,
        });
        Some(camera)
    }
}
