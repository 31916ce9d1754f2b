//! `tonemap`: a linear EXR to an sRGB PNG.

use clap::Args;
use raysplat::film::Film;
use raysplat::film::display::{ToneMap, ViewMode, display};
use std::path::PathBuf;

#[derive(Args)]
pub struct TonemapArgs {
    input: PathBuf,
    output: PathBuf,
    #[arg(long, default_value_t = 0.0)]
    exposure: f32,
    /// Clamp instead of the ACES filmic curve.
    #[arg(long)]
    clamp: bool,
}

/// Reads `input`, tone-maps it at `exposure` stops (ACES filmic, or a clamp) and writes `output`.
pub fn run(args: TonemapArgs) -> Result<(), String> {
    let (w, h, rgb) = raysplat::film::read_exr(&args.input)?;
    let mut film = Film::new(w, h);
    film.rgb = rgb;
    let tone = if args.clamp {
        ToneMap::Clamp
    } else {
        ToneMap::Aces
    };
    let img = display(&film, ViewMode::Final, args.exposure, tone);
    raysplat::film::write_png(&args.output, w, h, &img.rgb())?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}
