//! `tonemap`: a linear EXR to an 8-bit image (PNG or JPEG, from the output's extension) with
//! the window's tone curves and the same exposure meaning as `render`.

use super::args::ToneArgs;
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
pub fn run(args: TonemapArgs) -> Result<(), String> {
    if output::Format::of(&args.output)? == output::Format::Exr {
        return Err(format!(
            "{}: tonemap writes 8-bit images (.png or .jpg)",
            args.output.display()
        ));
    }
    output::check(&[(args.output.as_path(), true)], &[args.input.as_path()])?;
    let (w, h, rgb) = raysplat::film::read_exr(&args.input)?;
    let mut film = Film::new(w, h);
    film.rgb = rgb;
    let stops = args.tone.exposure.stops(&film);
    output::write_image(Path::new(&args.output), &film, stops, args.tone.tonemap)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}
