//! What a command writes: the image format follows the file's extension (linear EXR, or PNG
//! and JPEG tone-mapped with the window's curves), every output is checked before any work
//! starts (a known format, a folder that exists or can be made and is writable, no two outputs
//! on one file, never an input), and every file is written atomically.

use raysplat::film::Film;
use raysplat::film::display::{ToneMap, ViewMode, display};
use raysplat::sampling::luminance;
use raysplat::settings::limits;
use std::path::{Path, PathBuf};

/// An image file format, from a path's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR, linear radiance.
    Exr,
    /// 8-bit sRGB PNG, tone-mapped.
    Png,
    /// 8-bit sRGB JPEG, tone-mapped.
    Jpeg,
}

impl Format {
    /// The format `path`'s extension names, or an error listing the ones written.
    pub fn of(path: &Path) -> Result<Format, String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("exr") => Ok(Format::Exr),
            Some("png") => Ok(Format::Png),
            Some("jpg" | "jpeg") => Ok(Format::Jpeg),
            _ => Err(format!(
                "{}: unknown image format (use .exr for linear radiance, .png or .jpg for a \
                 tone-mapped image)",
                path.display()
            )),
        }
    }
}

/// Exposure in stops, or chosen from the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    /// This many stops.
    Stops(f32),
    /// The stops that bring the image's log-average luminance to middle grey (0.18).
    Auto,
}

impl Exposure {
    /// The stops for `film`.
    pub fn stops(self, film: &Film) -> f32 {
        match self {
            Exposure::Stops(s) => s,
            Exposure::Auto => auto_exposure(&film.rgb),
        }
    }
}

/// clap's parser for `--exposure`: `auto`, or stops within the limits table's range.
pub fn parse_exposure(s: &str) -> Result<Exposure, String> {
    if s.trim().eq_ignore_ascii_case("auto") {
        return Ok(Exposure::Auto);
    }
    let e = limits::EXPOSURE;
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is neither `auto` nor a number of stops"))?;
    if e.contains(v) {
        Ok(Exposure::Stops(v))
    } else {
        Err(format!("must be `auto` or in {}..={}", e.min, e.max))
    }
}

/// clap's parser for `--tonemap`.
pub fn parse_tonemap(s: &str) -> Result<ToneMap, String> {
    match s.trim() {
        "clamp" => Ok(ToneMap::Clamp),
        "reinhard" => Ok(ToneMap::Reinhard),
        "aces" => Ok(ToneMap::Aces),
        _ => Err("must be clamp, reinhard or aces".into()),
    }
}

/// Stops that map the log-average luminance of the finite, non-black pixels to 0.18
/// (Reinhard et al. 2002's key value); 0 for a black image.
pub fn auto_exposure(rgb: &[glam::Vec3]) -> f32 {
    let (mut sum, mut n) = (0.0f64, 0u64);
    for c in rgb {
        let l = luminance(*c);
        if l.is_finite() && l > 1e-6 {
            sum += (l as f64).ln();
            n += 1;
        }
    }
    if n == 0 {
        return 0.0;
    }
    let log_avg = (sum / n as f64).exp();
    let e = limits::EXPOSURE;
    ((0.18 / log_avg).log2() as f32).clamp(e.min, e.max)
}

/// Check outputs before any work: each has a known format (when `images`), a folder that
/// exists (made if missing) and takes a file, none is written twice, none is an input.
pub fn check(outputs: &[(&Path, bool)], inputs: &[&Path]) -> Result<(), String> {
    for (i, &(path, image)) in outputs.iter().enumerate() {
        for &input in inputs {
            if same_file(path, input) {
                return Err(format!(
                    "{} is an input; refusing to overwrite it",
                    path.display()
                ));
            }
        }
        for &(other, _) in &outputs[..i] {
            if same_file(path, other) {
                return Err(format!("{} is named for two outputs", path.display()));
            }
        }
        if image {
            Format::of(path)?;
        }
        if path.is_dir() {
            return Err(format!("{} is a folder, not a file", path.display()));
        }
        check_folder(path)?;
    }
    Ok(())
}

/// True when `a` and `b` name the same file (the same canonical path when both exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => absolute(a) == absolute(b),
    }
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// Make `path`'s folder if it is missing, and check that a file can be created in it.
pub fn check_folder(path: &Path) -> Result<(), String> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir)
        .map_err(|e| format!("cannot create the folder {}: {e}", dir.display()))?;
    let probe = dir.join(format!(".raysplat-write-test-{}", std::process::id()));
    std::fs::File::create(&probe)
        .and_then(|_| std::fs::remove_file(&probe))
        .map_err(|e| format!("cannot write into {}: {e}", dir.display()))
}

/// Write `film` to `path` in the format its extension names: EXR as linear radiance, PNG and
/// JPEG tone-mapped with `tone` at `stops` (the window's curves).
pub fn write_image(path: &Path, film: &Film, stops: f32, tone: ToneMap) -> Result<(), String> {
    match Format::of(path)? {
        Format::Exr => film.write_exr(path),
        f => {
            let rgb = display(film, ViewMode::Final, stops, tone).rgb();
            write_rgb8(path, f, film.width, film.height, &rgb)
        }
    }
}

/// Write 8-bit RGB to `path` as PNG or JPEG, atomically.
pub fn write_rgb8(
    path: &Path,
    format: Format,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<(), String> {
    match format {
        Format::Png => raysplat::film::write_png(path, width, height, rgb),
        Format::Jpeg => {
            let img = image::RgbImage::from_raw(width, height, rgb.to_vec())
                .ok_or("the image has the wrong size")?;
            let mut buf = std::io::Cursor::new(Vec::new());
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 90)
                .encode_image(&img)
                .map_err(|e| format!("cannot encode JPEG for {}: {e}", path.display()))?;
            raysplat::film::write_atomic(path, buf.get_ref())
        }
        Format::Exr => Err(format!("{}: 8-bit data cannot be an EXR", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn formats_follow_the_extension() {
        assert_eq!(Format::of(Path::new("a.EXR")), Ok(Format::Exr));
        assert_eq!(Format::of(Path::new("a.png")), Ok(Format::Png));
        assert_eq!(Format::of(Path::new("a.jpeg")), Ok(Format::Jpeg));
        assert!(Format::of(Path::new("a.tif")).is_err());
        assert!(Format::of(Path::new("a")).is_err());
    }

    #[test]
    fn exposure_parses_auto_negatives_and_refuses_nan() {
        assert_eq!(parse_exposure("auto"), Ok(Exposure::Auto));
        assert_eq!(parse_exposure("-2"), Ok(Exposure::Stops(-2.0)));
        assert!(parse_exposure("NaN").is_err());
        assert!(parse_exposure("40").is_err());
    }

    #[test]
    fn auto_exposure_brings_the_log_average_to_middle_grey() {
        let img = vec![Vec3::splat(0.72); 16];
        assert!((auto_exposure(&img) - (-2.0)).abs() < 1e-4);
        assert_eq!(auto_exposure(&[Vec3::ZERO; 4]), 0.0);
    }
}
