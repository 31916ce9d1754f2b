//! The previewer window (egui/eframe): shows the worker's frames and sends it commands. It only
//! draws and sends messages; all rendering happens on the [`crate::session`] worker.
//!
//! One file per panel, each a struct whose `ui` draws its widgets and emits worker
//! [`Command`](crate::session::Command)s into [`Commands`] (so a panel runs without a worker):
//!
//! | file | panel | emits |
//! |---|---|---|
//! | [`bandwidth`] | C, S, R of eq. 8; automatic C | `SetBandwidth`, `SetAutoC` |
//! | [`cache_filter`] | radiance cache ε, records per pixel; image filter | `SetCache`, `SetFilter` |
//! | [`rendering`] | photons per batch, spp, resolution, direct light, glossy radiance map, ray budget, pause, restart, reference | one command per widget |
//! | [`environment`] | none, uniform, sky or a map file; strength, rotation, sun | `SetEnvironment` (a map file once the window's dialog has chosen one) |
//! | [`camera`] | the scene's cameras | `SetCamera` |
//! | [`display`] | view mode, exposure, tone mapping | `SetReference`, `SetCache`, `SetErrorEstimate` (three view modes) |
//! | [`error_panel`] | the estimated error, pause below a threshold, split view with the reference | `SetErrorEstimate`, `SetPauseBelow`, `SetSplit` |
//! | [`snapshots`] | snapshot folder, save | nothing (asks the window) |
//! | [`stats`] | the frame's counters, messages | nothing |
//!
//! [`widgets`] holds [`Commands::on_change`], the one helper that turns a changed widget into
//! a command; `window.rs` holds [`App`] (session, frames, panels, menu, shortcuts), `viewport.rs`
//! the image, the orbit camera and mouse input; [`snapshot_writer`] writes snapshot files and
//! [`UiSettings`] (`ui_settings.rs`) is what the window persists.

pub mod bandwidth;
pub mod cache_filter;
pub mod camera;
pub mod display;
pub mod environment;
pub mod error_panel;
pub mod rendering;
pub mod snapshot_writer;
pub mod snapshots;
pub mod stats;
mod ui_settings;
mod viewport;
pub mod widgets;
mod window;

pub use ui_settings::UiSettings;
pub use widgets::Commands;
pub use window::{App, AppOptions, LoadedScene};
