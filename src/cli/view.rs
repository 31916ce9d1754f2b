//! `view` (the default command, also `raysplat SCENE`): the interactive previewer window.

use super::load_scene;
use clap::Args;
use raysplat::app::LoadedScene;
use std::path::PathBuf;
use std::sync::Arc;

/// `view [SCENE]`.
#[derive(Args, Default)]
pub struct ViewArgs {
    /// A .gltf/.glb file, or builtin:cornell1 | builtin:cornell2 | builtin:classic |
    /// builtin:glossy | builtin:glossy-sharp | builtin:outdoor | builtin:room | builtin:features.
    /// Without it, the embedded CORNELL BOX I.
    pub scene: Option<String>,
    #[command(flatten)]
    pub environment: super::args::EnvArgs,
}

/// Loads the scene (a failure is reported here, on stderr, and no window opens), then opens
/// the previewer window on it and returns when the window closes.
pub fn run(args: ViewArgs) -> Result<(), super::error::CliError> {
    let scene = load_scene(args.scene.as_deref(), &args.environment)?;
    let path = args
        .scene
        .as_deref()
        .filter(|s| !s.starts_with("builtin:"))
        .map(PathBuf::from);
    let options = eframe::NativeOptions {
        renderer: eframe::Renderer::Wgpu,
        viewport: egui::ViewportBuilder::default()
            .with_title("raysplat")
            .with_inner_size([1280.0, 860.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    let app_options = raysplat::app::AppOptions {
        loaded: Some(LoadedScene {
            scene: Arc::new(scene),
            path,
        }),
        ..Default::default()
    };
    eframe::run_native(
        "raysplat",
        options,
        Box::new(move |cc| Ok(Box::new(raysplat::app::App::new(cc, app_options)))),
    )
    .map_err(|e| {
        super::error::CliError::Failed(format!(
            "cannot open the previewer window ({e}); without a display, use `raysplat render`"
        ))
    })
}
