//! The radiance cache (§8.3) and image filter (§8.2) panel. The cache's switch, ε and minimum
//! records emit [`Command::SetCache`] (the worker re-runs the cache over the current radiance
//! map: no re-trace, no re-splat); the filter's switch and strength emit
//! [`Command::SetFilter`] (applied when the next frame is resolved).

use crate::app::UiSettings;
use crate::app::widgets::{Commands, param_slider};
use crate::pipeline::cache::CacheParams;
use crate::pipeline::filter::FilterParams;
use crate::session::{Command, SessionStats};
use crate::settings::limits;

/// The radiance cache's switch, ε and records per pixel; the image filter's switch and
/// strength.
#[derive(Clone, Debug, Default)]
pub struct CacheFilterPanel;

impl CacheFilterPanel {
    /// Draw both sections. Accessible names: "Resolve through the radiance cache", "ε",
    /// "Min. records per pixel", "Filter the indirect light", "strength". `stats` are the
    /// newest frame's counters (the number of cache records is shown).
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        settings: &mut UiSettings,
        stats: Option<&SessionStats>,
        out: &mut Commands,
    ) {
        let r = &mut settings.render;
        ui.heading("Radiance cache (§8.3)");
        let mut cache = (r.cache_on, r.cache);
        out.on_change(
            &mut cache,
            |(on, params)| {
                ui.checkbox(on, "Resolve through the radiance cache")
                    .on_hover_text(
                        "Interpolate the indirect light from sparse cache records in image \
                         space. Moving ε re-runs the cache over the current radiance map (no \
                         re-trace, no re-splat).",
                    );
                ui.add_enabled_ui(*on, |ui| {
                    param_slider(
                        ui,
                        &mut params.error,
                        limits::CACHE_ERROR.range(),
                        "ε",
                        "cache error: records are valid up to ε × their harmonic mean \
                         distance; smaller ε, more records, more detail",
                        CacheParams::default().error,
                    );
                    ui.horizontal(|ui| {
                        let label = ui.label("Min. records per pixel");
                        ui.add(
                            egui::DragValue::new(&mut params.min_records)
                                .range(limits::MIN_RECORDS.range()),
                        )
                        .labelled_by(label.id);
                    });
                });
            },
            |&(on, params)| Command::SetCache { on, params },
        );
        (r.cache_on, r.cache) = cache;
        if let Some(n) = stats.and_then(|s| s.method.cache_records)
            && n > 0
        {
            ui.label(format!("{n} cache records"));
        }

        ui.heading("Image filter (§8.2)");
        out.on_change(
            &mut r.filter,
            |f| {
                ui.checkbox(&mut f.enabled, "Filter the indirect light")
                    .on_hover_text(
                        "Box-filter the incident light within continuous surfaces (depth, \
                         normal and material discontinuities stop it); the box grows where \
                         fewer splats landed.",
                    );
                ui.add_enabled_ui(f.enabled, |ui| {
                    param_slider(
                        ui,
                        &mut f.strength,
                        limits::FILTER_STRENGTH.range(),
                        "strength",
                        "scales every pixel's filter box",
                        FilterParams::default().strength,
                    );
                });
            },
            |&f| Command::SetFilter(f),
        );
    }
}
