//! What the panels share: [`Commands`], the one place where a changed widget becomes a worker
//! command ([`Commands::on_change`]), and [`param_slider`].

use crate::session::Command;
use std::ops::RangeInclusive;

/// The worker commands the panels emitted during one frame, in order. The window sends them to
/// the worker after drawing; a test reads them instead.
#[derive(Debug, Default)]
pub struct Commands(Vec<Command>);

impl Commands {
    /// No commands yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Emit `command` (a button was clicked).
    pub fn push(&mut self, command: Command) {
        self.0.push(command);
    }

    /// Draw widgets over a copy of `value` with `draw`; when the copy changed, store it in
    /// `value` and emit `command(value)`. Returns whether it changed.
    ///
    /// ```ignore
    /// out.on_change(&mut settings.render.spp, |spp| {
    ///     ui.add(egui::Slider::new(spp, limits::SPP.range()));
    /// }, |&spp| Command::SetSamplesPerPixel(spp));
    /// ```
    pub fn on_change<T: Clone + PartialEq>(
        &mut self,
        value: &mut T,
        draw: impl FnOnce(&mut T),
        command: impl FnOnce(&T) -> Command,
    ) -> bool {
        let mut edited = value.clone();
        draw(&mut edited);
        if edited == *value {
            return false;
        }
        *value = edited;
        self.0.push(command(value));
        true
    }

    /// The commands emitted so far.
    pub fn as_slice(&self) -> &[Command] {
        &self.0
    }

    /// True when nothing was emitted.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Take the commands out, leaving none.
    pub fn take(&mut self) -> Vec<Command> {
        std::mem::take(&mut self.0)
    }
}

/// A labelled slider (its accessible name is `name`) with numeric entry and a button that
/// resets it to `default`.
pub fn param_slider(
    ui: &mut egui::Ui,
    value: &mut f32,
    range: RangeInclusive<f32>,
    name: &str,
    hint: &str,
    default: f32,
) {
    ui.horizontal(|ui| {
        ui.add(egui::Slider::new(value, range).text(name))
            .on_hover_text(hint);
        if ui
            .small_button("reset")
            .on_hover_text(format!("reset {name} to {default}"))
            .clicked()
        {
            *value = default;
        }
    });
}
