//! `scenes`: the project's generated scenes written out as .glb files.

use clap::Args;
use raysplat::scene::BuiltinScene;
use std::path::PathBuf;

#[derive(Args)]
pub struct ScenesArgs {
    #[arg(long, default_value = "assets")]
    out: PathBuf,
}

/// Writes every built-in scene into `--out`, one line per file.
pub fn run(args: ScenesArgs) -> Result<(), super::error::CliError> {
    use super::error::CliError;
    let out = &args.out;
    std::fs::create_dir_all(out)
        .map_err(|e| CliError::Output(format!("cannot create {}: {e}", out.display())))?;
    for s in BuiltinScene::ALL {
        let path = out.join(s.file_name());
        raysplat::film::write_atomic(&path, &s.to_glb()).map_err(CliError::Output)?;
        println!("wrote {} ({})", path.display(), s.title());
    }
    Ok(())
}
