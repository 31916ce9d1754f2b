//! The snapshots panel: the snapshot folder and the save button. Snapshots are the window's
//! business, not the worker's, so this panel emits no worker command; it returns what it asks
//! of the window, which writes the files with [`crate::app::snapshot_writer`].

use crate::app::UiSettings;
use std::path::PathBuf;

/// What the snapshots panel asks of the window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SnapshotRequest {
    /// Open a folder dialog for the snapshot folder.
    ChooseFolder,
    /// Save a snapshot of the image on screen now.
    Save,
}

/// The snapshot folder (typed or chosen) and "Save snapshot".
#[derive(Clone, Debug, Default)]
pub struct SnapshotPanel;

impl SnapshotPanel {
    /// Draw the folder field (accessible name "Snapshot folder"), "Choose…" and
    /// "Save snapshot". Typing changes `settings.snapshot_dir`; the buttons return requests.
    pub fn ui(&mut self, ui: &mut egui::Ui, settings: &mut UiSettings) -> Option<SnapshotRequest> {
        ui.heading("Snapshots");
        let mut request = None;
        ui.horizontal(|ui| {
            let mut dir = settings.snapshot_dir.display().to_string();
            if ui
                .add(egui::TextEdit::singleline(&mut dir).desired_width(170.0))
                .accessible_name("Snapshot folder")
                .on_hover_text("Snapshot folder")
                .changed()
            {
                settings.snapshot_dir = PathBuf::from(dir);
            }
            if ui.button("Choose…").clicked() {
                request = Some(SnapshotRequest::ChooseFolder);
            }
        });
        if ui.button("Save snapshot").clicked() {
            request = Some(SnapshotRequest::Save);
        }
        request
    }
}
