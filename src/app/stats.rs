//! The status bar: the newest frame's counters ([`StatsPanel`]) and the window's messages
//! ([`Messages`]: scene loads, warnings, errors, saved snapshots). Neither emits commands.

use crate::session::Frame;
use egui::{Color32, RichText};
use std::time::Instant;

/// The newest frame's counters: photons, stored rays, batches, speed, memory, resolution.
/// The bar keeps the tallest height it has had at the window's width ([`StatsPanel::min_height`]):
/// counters that grow a digit wrap the line, and a bar that followed them would move the
/// image up and down as they do.
#[derive(Clone, Debug, Default)]
pub struct StatsPanel {
    /// The tallest the status bar has been at `width`.
    tallest: f32,
    /// The window width `tallest` was measured at.
    width: f32,
}

impl StatsPanel {
    /// The least height of the status bar at a window `width` points wide: the tallest it
    /// has been at that width (a new width starts afresh).
    pub fn min_height(&mut self, width: f32) -> f32 {
        if (width - self.width).abs() > 0.5 {
            (self.width, self.tallest) = (width, 0.0);
        }
        self.tallest
    }

    /// Note the status bar's height this frame.
    pub fn note_height(&mut self, height: f32) {
        if height.is_finite() {
            self.tallest = self.tallest.max(height);
        }
    }

    /// Draw the counters of `frame`, or a waiting note before the first one.
    pub fn ui(&mut self, ui: &mut egui::Ui, frame: Option<&Frame>) {
        let Some(f) = frame else {
            ui.label("waiting for the first image…");
            return;
        };
        let s = &f.stats;
        let m = &s.method;
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("photons traced {}", m.photons_traced));
            ui.separator();
            ui.label(format!(
                "photon rays {} ({:.1} MB)",
                m.photon_rays,
                m.photon_ray_bytes as f64 / 1e6
            ));
            ui.separator();
            ui.label(format!(
                "batches {} ({} stored)",
                m.passes, m.stored_batches
            ));
            ui.separator();
            ui.label(format!("{:.0} photons/s", s.photons_per_second));
            ui.separator();
            // A batch's whole step: its NEE redraws, tracing and splatting (a new user read
            // "splat" and found seconds of light samples in it).
            ui.label(format!("{:.0} ms/batch", s.last_splat_ms))
                .on_hover_text(
                    "The last batch's step: the direct light's redraw, the photons' tracing \
                     and their splat",
                );
            ui.separator();
            ui.label(format!(
                "at h_min {:.1}% / h_max {:.1}% / floor {:.1}%",
                100.0 * s.indirect_at_h_min,
                100.0 * s.indirect_at_h_max,
                100.0 * s.indirect_at_floor
            ))
            .on_hover_text(
                "indirect photon rays whose bandwidth sits at eq. 8's bounds, and those widened \
                 to the floor from the photons stored (K in the bandwidth panel)",
            );
            ui.separator();
            ui.label(format!(
                "eye samples {} ({} splat targets, {:.1} MB with tree and accumulators), \
                 eye pass {}",
                m.eye_samples,
                m.splat_targets,
                m.splat_bytes as f64 / 1e6,
                m.eye_passes
            ))
            .on_hover_text(
                "the eye samples are drawn anew every few batches, and the image averages over \
                 every eye pass (docs/deviations.md §41)",
            );
            let mem = &m.memory;
            if mem.total() > 0 {
                ui.separator();
                let mb = |b: usize| b as f64 / 1e6;
                ui.label(format!("memory {:.0} MB", mb(mem.total())))
                    .on_hover_text(format!(
                        "eye samples {:.1} MB, splat targets {:.1}, splat tree {:.1}, \
                         accumulators {:.1}, directional records {:.1}, stored photon rays \
                         {:.1}, emission guide {:.1}, photon landings {:.1}, per-pixel sums {:.1}, \
                         film {:.1}, scene \
                         and BVH {:.1}, textures {:.1} (steady state; a batch in flight adds \
                         its own)",
                        mb(mem.eye_samples),
                        mb(mem.splat_targets),
                        mb(mem.splat_tree),
                        mb(mem.accumulators),
                        mb(mem.directional_records),
                        mb(mem.photon_rays),
                        mb(mem.emission_guide),
                        mb(mem.photon_density),
                        mb(mem.pixel_sums),
                        mb(mem.film),
                        mb(mem.scene),
                        mb(mem.textures)
                    ));
            }
            if m.glossy_targets > 0 {
                ui.separator();
                ui.label(format!(
                    "glossy targets {} ({:.1} MB directional, {:.0} B each)",
                    m.glossy_targets,
                    m.directional_bytes as f64 / 1e6,
                    m.directional_bytes as f64 / m.glossy_targets as f64
                ));
            }
            if m.glossy_map_samples + m.glossy_traced_samples > 0 {
                ui.separator();
                ui.label(format!(
                    "glossy eye samples: {} radiance map, {} traced",
                    m.glossy_map_samples, m.glossy_traced_samples
                ))
                .on_hover_text(
                    "lobes sharper than the directional mode resolves are traced by the eye path",
                );
            }
            if m.splat_rays > 0 {
                ui.separator();
                let guide = match m.guide_batches {
                    Some(0) => " (emission guide: nothing reached yet)".to_string(),
                    Some(b) => format!(" (emission guided by {b} batches)"),
                    None => String::new(),
                };
                ui.label(format!(
                    "photon rays reaching an eye sample: {:.1}% of {}{guide}",
                    100.0 * m.rays_reaching as f64 / m.splat_rays as f64,
                    m.splat_rays
                ))
                .on_hover_text(
                    "photon rays (of new batches and re-splats) that splat onto at least one \
                     eye sample; with \
                     'Photons where the camera looks' the lights emit more where they did \
                     (docs/deviations.md §44)",
                );
            }
            if m.domain_tests > 0 {
                ui.separator();
                ui.label(format!(
                    "visibility: {} pairs tested, {:.1}% outside their domain",
                    m.domain_tests,
                    100.0 * m.occluded_pairs as f64 / m.domain_tests as f64
                ))
                .on_hover_text(
                    "splatted pairs tested against the visible kernel domain of their target: \
                     light beyond a wall splats nothing there (docs/deviations.md §40)",
                );
                // Once a pass has taken kept domains (pm and rc draw one eye pass).
                let probed = m.domains_reused + m.domains_probed;
                if m.domains_reused > 0 {
                    ui.label(format!(
                        "domains: {:.0}% of the pixels' targets took an earlier pass's probes",
                        100.0 * m.domains_reused as f64 / probed as f64
                    ))
                    .on_hover_text(
                        "a pixel's target on the same plane near where an earlier eye pass \
                         probed its visible domain takes those cells, shrunk by the distance, \
                         instead of casting 16 probes (docs/deviations.md §40)",
                    );
                }
            }
            ui.separator();
            ui.label(format!("{}×{}", f.film.width, f.film.height));
            ui.separator();
            ui.label(format!("elapsed {:.1} s", s.elapsed_s));
            if f.film.invalid_contributions > 0 {
                ui.separator();
                ui.label(
                    RichText::new(format!(
                        "{} NaN/Inf contributions dropped",
                        f.film.invalid_contributions
                    ))
                    .color(Color32::from_rgb(230, 160, 60)),
                )
                .on_hover_text(
                    "Photon rays, light samples or pixels whose value was not finite were \
                     left out of the image (the scene may hold extreme values).",
                );
            }
            if s.paused {
                ui.separator();
                ui.label(RichText::new("paused").strong());
            }
            if s.resplat_pending {
                ui.separator();
                ui.label("re-splatting…");
            }
            if s.reference_spp > 0 {
                ui.separator();
                ui.label(format!("reference {} paths/pixel", s.reference_spp));
            }
        });
    }
}

/// One line of the message list.
#[derive(Clone, Debug)]
struct Message {
    text: String,
    error: bool,
    at: Instant,
}

/// The newest few messages, newest shown first; errors in red.
#[derive(Clone, Debug, Default)]
pub struct Messages(Vec<Message>);

impl Messages {
    /// How many messages are kept.
    pub const MAX: usize = 6;

    /// Add a note.
    pub fn info(&mut self, text: String) {
        self.push(text, false);
    }

    /// Add an error or a warning (shown in red).
    pub fn error(&mut self, text: String) {
        self.push(text, true);
    }

    fn push(&mut self, text: String, error: bool) {
        self.0.push(Message {
            text,
            error,
            at: Instant::now(),
        });
        if self.0.len() > Self::MAX {
            self.0.remove(0);
        }
    }

    /// The texts, oldest first.
    pub fn texts(&self) -> Vec<String> {
        self.0.iter().map(|m| m.text.clone()).collect()
    }

    /// Draw the messages, newest first, each with its age.
    pub fn ui(&self, ui: &mut egui::Ui) {
        for m in self.0.iter().rev() {
            let age = m.at.elapsed().as_secs();
            let text = format!("{} ({age} s ago)", m.text);
            if m.error {
                ui.colored_label(Color32::from_rgb(240, 110, 100), text);
            } else {
                ui.label(text);
            }
        }
    }
}
