//! `tonemap`: a linear EXR to an 8-bit image (PNG or JPEG, from the output's extension) with
//! the window's tone curves and the same exposure meaning as `render`.

use super::args::ToneArgs;
use super::error::CliError;
use super::output;
use clap::Args;
use raysplat::film::Film;
use std::path::{Path, PathBuf};

/// `tonemap INPUT OUTPUT [--exposure STOPS|auto] [--tonemap clamp|reinhard|aces]`.
#[derive(Args)]
pub struct TonemapArgs {
    /// A linear EXR.
    input: PathBuf,
    /// The image to write: .png or .jpg (never the input).
    output: PathBuf,
    #[command(flatten)]
    tone: ToneArgs,
}

/// Reads `input`, tone-maps it and writes `output`.
pub fn run(args: TonemapArgs) -> Result<(), CliError> {
    if output::Format::of(&args.output).map_err(CliError::Output)? == output::Format::Exr {
        return Err(CliError::Output(format!(
            "{}: tonemap writes 8-bit images (.png or .jpg)",
            args.output.display()
        )));
    }
    output::check(&[(args.output.as_path(), true)], &[args.input.as_path()])
        .map_err(CliError::Output)?;
    let (w, h, rgb) = raysplat::film::read_exr(&args.input).map_err(CliError::Input)?;
    let mut film = Film::new(w, h);
    film.rgb = rgb;
    let stops = args.tone.exposure.stops(&film);
    output::write_image(Path::new(&args.output), &film, stops, args.tone.tonemap)
        .map_err(CliError::Output)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}
