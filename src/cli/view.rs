//! `view` (the default command): the interactive previewer window.

use clap::Args;
use std::path::PathBuf;

#[derive(Args, Default)]
pub struct ViewArgs {
    /// A .gltf/.glb file; without it, the embedded CORNELL BOX I.
    scene: Option<PathBuf>,
}

/// Opens the previewer window on `args`' scene and returns when it closes.
pub fn run(args: ViewArgs) -> Result<(), String> {
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("raysplat")
            .with_inner_size([1280.0, 860.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    let app_options = raysplat::app::AppOptions {
        scene: args.scene,
        settings: None,
    };
    eframe::run_native(
        "raysplat",
        options,
        Box::new(move |cc| Ok(Box::new(raysplat::app::App::new(cc, app_options)))),
    )
    .map_err(|e| {
        format!("cannot open the previewer window ({e}); without a display, use `raysplat render`")
    })
}
