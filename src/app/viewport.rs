//! The viewport: the displayed image as a texture, the orbit camera the mouse drives (each move
//! emits an interactive [`Command::SetCamera`], and a final one once the camera rests), the
//! pixel probe under the pointer and the false-colour legend.

use crate::app::widgets::Commands;
use crate::film::display::{DisplayImage, ViewMode};
use crate::scene::Camera;
use crate::session::{Command, Frame};
use egui::{Color32, TextureHandle, TextureOptions, Vec2};
use glam::Vec3;
use std::time::{Duration, Instant};

/// The camera the mouse controls: orbit around `target`.
#[derive(Clone, Debug)]
struct Orbit {
    target: Vec3,
    distance: f32,
    yaw: f32,
    pitch: f32,
    yfov: f32,
}

impl Orbit {
    fn from_camera(c: &Camera, scene_center: Vec3) -> Self {
        let f = c.forward.normalize();
        let distance = (scene_center - c.position).dot(f).max(1e-3);
        Self {
            target: c.position + f * distance,
            distance,
            yaw: f.x.atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin(),
            yfov: c.yfov,
        }
    }

    fn forward(&self) -> Vec3 {
        Vec3::new(
            self.yaw.sin() * self.pitch.cos(),
            self.pitch.sin(),
            -self.yaw.cos() * self.pitch.cos(),
        )
    }

    fn camera(&self) -> Camera {
        let f = self.forward();
        Camera::look_at(
            "orbit",
            self.target - f * self.distance,
            self.target,
            self.yfov,
        )
    }
}

/// The image area of the window.
#[derive(Default)]
pub(crate) struct Viewport {
    texture: Option<TextureHandle>,
    /// Centre of the scene's bounding box: the orbit's pivot depth.
    center: Vec3,
    orbit: Option<Orbit>,
    /// The camera is being moved (interactive frames); when it settles a final view is sent.
    moving_since: Option<Instant>,
    /// The split view's divider is being dragged (the drag moves it, not the camera).
    dragging_divider: bool,
}

/// How near the split view's divider (screen points) a drag takes hold of it.
const DIVIDER_GRIP: f32 = 8.0;

impl Viewport {
    /// A new scene: orbit around `center`, starting at `camera`.
    pub(crate) fn set_scene(&mut self, center: Vec3, camera: Option<&Camera>) {
        self.center = center;
        self.orbit = camera.map(|c| Orbit::from_camera(c, center));
        self.moving_since = None;
    }

    /// Put the orbit at `camera` (a camera was chosen in the camera panel).
    pub(crate) fn reset_orbit(&mut self, camera: &Camera) {
        self.orbit = Some(Orbit::from_camera(camera, self.center));
        self.moving_since = None;
    }

    /// Show `img`.
    pub(crate) fn set_image(&mut self, ctx: &egui::Context, img: &DisplayImage) {
        let color = egui::ColorImage::from_rgba_unmultiplied(
            [img.width as usize, img.height as usize],
            &img.rgba,
        );
        match &mut self.texture {
            Some(t) => t.set(color, TextureOptions::LINEAR),
            None => self.texture = Some(ctx.load_texture("render", color, TextureOptions::LINEAR)),
        }
    }

    /// Draw the image (scaled to fit), the pixel probe and the legend; mouse input moves the
    /// orbit and emits `SetCamera`. With `split` (the divider's place as a fraction of the
    /// width), the image is the split view's: the divider is drawn, and a drag that starts on
    /// it moves it instead of the camera.
    pub(crate) fn ui(
        &mut self,
        ui: &mut egui::Ui,
        frame: Option<&Frame>,
        shown: Option<&DisplayImage>,
        view_mode: ViewMode,
        split: Option<&mut f32>,
        out: &mut Commands,
    ) {
        let Some(tex) = &self.texture else {
            ui.centered_and_justified(|ui| ui.spinner());
            return;
        };
        let legend = shown.and_then(|s| s.legend.as_ref());
        let legend_h = if legend.is_some() { 28.0 } else { 0.0 };
        let avail = ui.available_size() - Vec2::new(0.0, legend_h);
        let size = tex.size_vec2();
        let scale = (avail.x / size.x).min(avail.y / size.y).max(0.05);
        let response =
            ui.add(egui::Image::new((tex.id(), size * scale)).sense(egui::Sense::click_and_drag()));
        // Where the reference begins, for the probe (the divider may move below).
        let reference_from = split.as_deref().copied();
        match split {
            Some(at) => {
                self.divider(ui, &response, at, view_mode);
                if !self.dragging_divider {
                    self.camera_input(ui, &response, out);
                }
            }
            None => {
                self.dragging_divider = false;
                self.camera_input(ui, &response, out);
            }
        }
        if let (Some(pos), Some(f)) = (response.hover_pos(), frame) {
            // Right of the split view's divider the pixel is the reference's.
            let reference = reference_from
                .filter(|&at| pos.x >= response.rect.min.x + at * response.rect.width())
                .and(f.reference.as_ref());
            match reference {
                Some(r) => probe_reference(response, pos, r),
                None => probe(response, pos, f),
            }
        }
        if let Some(legend) = legend {
            ui.horizontal(|ui| {
                ui.label(format!("{:.4} {}", legend.min, legend.unit));
                let (rect, _) =
                    ui.allocate_exact_size(Vec2::new(200.0, 14.0), egui::Sense::hover());
                let n = 50;
                for k in 0..n {
                    let c = legend.scale.colour(k as f32 / (n - 1) as f32);
                    let x0 = rect.min.x + rect.width() * k as f32 / n as f32;
                    let x1 = rect.min.x + rect.width() * (k + 1) as f32 / n as f32;
                    ui.painter().rect_filled(
                        egui::Rect::from_min_max(
                            egui::pos2(x0, rect.min.y),
                            egui::pos2(x1, rect.max.y),
                        ),
                        0.0,
                        Color32::from_rgb(c[0], c[1], c[2]),
                    );
                }
                ui.label(format!("{:.4} {}", legend.max, legend.unit));
                ui.label(format!(
                    "({}, {})",
                    super::display::view_mode_label(view_mode),
                    legend.scale.note()
                ));
            });
        }
    }

    /// The split view's divider: drawn at `at`, with the two sides named; a drag that starts
    /// within [`DIVIDER_GRIP`] of it moves it.
    fn divider(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        at: &mut f32,
        view_mode: ViewMode,
    ) {
        let rect = response.rect;
        let x = rect.min.x + *at * rect.width();
        let near = |p: egui::Pos2| (p.x - x).abs() <= DIVIDER_GRIP;
        if response.drag_started() {
            // Where the button went down: egui starts a drag only after some movement.
            let origin = ui.input(|i| i.pointer.press_origin());
            self.dragging_divider = origin.is_some_and(near);
        }
        if self.dragging_divider {
            if let Some(p) = response.interact_pointer_pos() {
                *at = ((p.x - rect.min.x) / rect.width().max(1.0)).clamp(0.0, 1.0);
            }
            if !response.dragged() {
                self.dragging_divider = false;
            }
        }
        if self.dragging_divider || response.hover_pos().is_some_and(near) {
            ui.ctx().set_cursor_icon(egui::CursorIcon::ResizeHorizontal);
        }
        let x = rect.min.x + *at * rect.width();
        let painter = ui.painter_at(rect);
        painter.line_segment(
            [egui::pos2(x, rect.min.y), egui::pos2(x, rect.max.y)],
            egui::Stroke::new(2.0, Color32::WHITE),
        );
        let label = |pos: egui::Pos2, align: egui::Align2, text: &str| {
            painter.text(
                pos,
                align,
                text,
                egui::FontId::proportional(13.0),
                Color32::WHITE,
            );
        };
        // Beside the estimated error the right side is the image's error against the
        // reference (window.rs), in the same colours.
        let (left, right) = if view_mode == ViewMode::EstimatedError {
            ("estimated error", "error against the reference")
        } else {
            ("image", "reference")
        };
        label(
            egui::pos2(x - 6.0, rect.min.y + 4.0),
            egui::Align2::RIGHT_TOP,
            left,
        );
        label(
            egui::pos2(x + 6.0, rect.min.y + 4.0),
            egui::Align2::LEFT_TOP,
            right,
        );
    }

    fn camera_input(&mut self, ui: &egui::Ui, response: &egui::Response, out: &mut Commands) {
        let Some(orbit) = self.orbit.as_mut() else {
            return;
        };
        let mut moved = false;
        if response.dragged() {
            let d = response.drag_delta();
            let pan =
                ui.input(|i| i.modifiers.shift) || response.dragged_by(egui::PointerButton::Middle);
            if pan {
                let f = orbit.forward();
                let right = f.cross(Vec3::Y).normalize_or(Vec3::X);
                let up = right.cross(f);
                let k = orbit.distance * 2.0 * (0.5 * orbit.yfov).tan()
                    / response.rect.height().max(1.0);
                orbit.target += (-d.x * right + d.y * up) * k;
            } else {
                orbit.yaw += d.x * 0.008;
                orbit.pitch = (orbit.pitch - d.y * 0.008).clamp(-1.5, 1.5);
            }
            moved = d != Vec2::ZERO;
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                orbit.distance = (orbit.distance * (-scroll * 0.002).exp()).max(1e-3);
                moved = true;
            }
        }
        let interactive = if moved {
            self.moving_since = Some(Instant::now());
            Some(true)
        } else if let Some(t) = self.moving_since
            && !response.dragged()
            && t.elapsed() > Duration::from_millis(150)
        {
            // The camera came to rest: render the full-resolution view.
            self.moving_since = None;
            Some(false)
        } else {
            None
        };
        if let Some(interactive) = interactive {
            out.push(Command::SetCamera {
                camera: orbit.camera(),
                interactive,
            });
        }
        if self.moving_since.is_some() {
            ui.ctx().request_repaint_after(Duration::from_millis(50));
        }
    }
}

/// The pixel under the pointer, or none outside a `width` × `height` image in `rect`.
fn pixel_at(rect: egui::Rect, pos: egui::Pos2, width: u32, height: u32) -> Option<(u32, u32)> {
    let px = ((pos.x - rect.min.x) / rect.width() * width as f32) as u32;
    let py = ((pos.y - rect.min.y) / rect.height() * height as f32) as u32;
    (px < width && py < height).then_some((px, py))
}

/// The split view's reference at the pixel under the pointer: its radiance and, once it has
/// two paths, its own relative error there.
fn probe_reference(response: egui::Response, pos: egui::Pos2, r: &crate::film::Film) {
    let Some((px, py)) = pixel_at(response.rect, pos, r.width, r.height) else {
        return;
    };
    let i = (py * r.width + px) as usize;
    response.on_hover_ui_at_pointer(|ui| {
        ui.label(format!("pixel ({px}, {py}) of the path-traced reference"));
        ui.label(format!("radiance {}", fmt3(r.rgb[i])));
        if let Some(e) = r.estimated_error.get(i) {
            ui.label(format!("its own relative error ≈ {:.1}%", 100.0 * e));
        }
    });
}

/// The film's values at the pixel under the pointer, in a tooltip.
fn probe(response: egui::Response, pos: egui::Pos2, f: &Frame) {
    let Some((px, py)) = pixel_at(response.rect, pos, f.film.width, f.film.height) else {
        return;
    };
    let i = (py * f.film.width + px) as usize;
    let film = &f.film;
    response.on_hover_ui_at_pointer(|ui| {
        ui.label(format!("pixel ({px}, {py})"));
        ui.label(format!("radiance {}", fmt3(film.rgb[i])));
        ui.label(format!("direct {}", fmt3(film.direct[i])));
        ui.label(format!("indirect {}", fmt3(film.indirect[i])));
        let info = &film.info[i];
        ui.label(format!("bandwidth {:.4} m", info.mean_bandwidth));
        ui.label(format!("kernel weight {:.3}", info.kernel_weight));
        if let Some(e) = film.estimated_error.get(i) {
            ui.label(format!("estimated relative error ≈ {:.1}%", 100.0 * e));
        }
        ui.label(format!("splats per batch {:.0}", info.splats));
        ui.label(format!(
            "harmonic mean distance {:.3} m",
            info.harmonic_mean_distance
        ));
        if let Some(text) = glossy_source_text(film.glossy_source[i]) {
            ui.label(text);
        }
    });
}

/// Where a pixel's glossy part came from, for the probe: the radiance map, traced
/// reflections, or both with their shares of the pixel's eye-sample weight; `None` where the
/// pixel sees nothing glossy.
pub fn glossy_source_text(source: [f32; 2]) -> Option<String> {
    let [map, traced] = source;
    match (map > 0.0, traced > 0.0) {
        (false, false) => None,
        (true, false) => Some("glossy: from the radiance map".into()),
        (false, true) => Some("glossy: traced reflections".into()),
        (true, true) => Some(format!(
            "glossy: radiance map {:.0}%, traced reflections {:.0}%",
            100.0 * map,
            100.0 * traced
        )),
    }
}

fn fmt3(c: Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", c.x, c.y, c.z)
}
