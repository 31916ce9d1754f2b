//! Images: the film (linear RGB plus AOVs), tone mapping, false colour, and EXR/PNG writing.
//! Every file is written to a temporary name in the same folder and renamed into place, so a
//! failed or interrupted write never leaves a partial file under the final name.
//!
//! What the previewer shows (view modes and tone curves, as RGBA8) is in [`display`], error
//! measures against a reference in [`error`].

pub mod display;
pub mod error;
pub mod estimate;

use glam::Vec3;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Per-pixel splat statistics (§3: kernel-weight sum and harmonic mean distance; plus the
/// mean bandwidth for the false-colour view of Fig. 5).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplatInfo {
    /// Kernel-weight sum per batch, weighted by the pixel's eye-sample weights.
    pub kernel_weight: f32,
    /// Kernel-weighted mean bandwidth (m); 0 where nothing splatted.
    pub mean_bandwidth: f32,
    /// Weighted harmonic mean distance to the photon-ray origins (m); 0 where nothing splatted.
    pub harmonic_mean_distance: f32,
    /// Accepted splats per batch, weighted by the pixel's eye-sample weights.
    pub splats: f32,
}

/// A rendered image with the buffers the view modes show.
#[derive(Clone, Debug)]
pub struct Film {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Final linear RGB radiance.
    pub rgb: Vec<Vec3>,
    /// Direct light (NEE or splatted direct photons) plus emission.
    pub direct: Vec<Vec3>,
    /// Splatted indirect light (indirect-diffuse and caustic photons).
    pub indirect: Vec<Vec3>,
    /// Splat statistics per pixel: mean bandwidth (m), kernel weight, harmonic mean distance
    /// of incident photon rays (m) and splats per batch; zero where nothing splatted.
    pub info: Vec<SplatInfo>,
    /// Where the pixel's glossy reflection comes from (docs/deviations.md §38): the share of its
    /// eye-sample weight on glossy samples whose lobe went through the radiance map (`[0]`) and on
    /// those whose lobe the eye path traced (`[1]`); both 0 where nothing glossy is seen.
    pub glossy_source: Vec<[f32; 2]>,
    /// Per pixel, this eye pass's estimate of the splat kernels' bias and its splatted light
    /// (luminance both; [`estimate`]); empty unless the error is estimated.
    pub pass_error: Vec<estimate::PassError>,
    /// The image's estimated error ([`estimate`]), once two eye passes give a spread.
    pub estimate: Option<estimate::ErrorEstimate>,
    /// Per pixel, the estimated relative RMS error √(bias² + variance)/r against the estimated
    /// reference r behind [`Film::estimate`] (the window's error view); empty without an
    /// estimate.
    pub estimated_error: Vec<f32>,
    /// Contributions dropped on the way to this film because they were NaN or infinite
    /// (photon rays, light samples, eye-sample resolves, pixels), like Mitsuba's
    /// `warn_invalid`: counted, never written.
    pub invalid_contributions: u64,
}

impl Film {
    /// Bytes per pixel of a film: rgb, direct and indirect, the splat statistics and the
    /// glossy source.
    pub const BYTES_PER_PIXEL: usize = 3 * 12 + std::mem::size_of::<SplatInfo>() + 8;

    /// A black film of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self::around(
            width,
            height,
            vec![Vec3::ZERO; n],
            vec![SplatInfo::default(); n],
        )
    }

    /// A film whose indirect light and splat statistics are `indirect` and `info` (a radiance
    /// map's, moved in rather than copied: docs/benchmarks.md, "Memory"), black otherwise.
    pub fn around(width: u32, height: u32, indirect: Vec<Vec3>, info: Vec<SplatInfo>) -> Self {
        let n = (width * height) as usize;
        assert!(
            indirect.len() == n && info.len() == n,
            "a film's buffers have its size"
        );
        Self {
            width,
            height,
            rgb: vec![Vec3::ZERO; n],
            direct: vec![Vec3::ZERO; n],
            indirect,
            info,
            glossy_source: vec![[0.0; 2]; n],
            pass_error: Vec::new(),
            estimate: None,
            estimated_error: Vec::new(),
            invalid_contributions: 0,
        }
    }

    /// Pixels whose value is NaN or infinite.
    pub fn invalid_pixels(&self) -> usize {
        self.rgb.iter().filter(|c| !c.is_finite()).count()
    }

    /// Mean of the RGB image.
    pub fn mean(&self) -> Vec3 {
        self.rgb.iter().copied().sum::<Vec3>() / self.rgb.len().max(1) as f32
    }

    /// Write the final image as linear 32-bit float OpenEXR ([`write_exr`]).
    pub fn write_exr(&self, path: &Path) -> Result<(), String> {
        write_exr(path, self.width, self.height, &self.rgb)
    }
}

/// sRGB transfer function of a linear value in [0, 1].
#[inline]
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Fig. 5's colour scale: red (t = 0, smallest) through yellow, green, cyan to blue (t = 1).
pub fn false_colour(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    let h = (1.0 - t) * 0.0 + t * (2.0 / 3.0); // hue from 0 (red) to 2/3 (blue)
    let (r, g, b) = hsv_to_rgb(h, 1.0, 1.0);
    [
        (r * 255.0 + 0.5) as u8,
        (g * 255.0 + 0.5) as u8,
        (b * 255.0 + 0.5) as u8,
    ]
}

fn hsv_to_rgb(h: f32, s: f32, v: f32) -> (f32, f32, f32) {
    let h6 = (h * 6.0).rem_euclid(6.0);
    let c = v * s;
    let x = c * (1.0 - ((h6 % 2.0) - 1.0).abs());
    let (r, g, b) = match h6 as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    (r + m, g + m, b + m)
}

/// A temporary path next to `path` (same folder, so the final rename is atomic).
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    // Unique per process and per call, so that concurrent writers never share a temporary.
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    path.with_file_name(format!(".{name}.tmp{}-{k}", std::process::id()))
}

/// Write `bytes` to `path` atomically (temporary file, sync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let tmp = temp_path(path);
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(format!("cannot write {}: {e}", path.display()));
    }
    Ok(())
}

/// Linear RGB (32-bit float) OpenEXR.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<(), String> {
    use exr::prelude::*;
    let (w, h) = (width as usize, height as usize);
    let image = Image::from_channels(
        (w, h),
        SpecificChannels::rgb(|p: Vec2<usize>| {
            let c = rgb[p.y() * w + p.x()];
            (c.x, c.y, c.z)
        }),
    );
    let mut buf = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut buf)
        .map_err(|e| format!("cannot encode EXR for {}: {e}", path.display()))?;
    write_atomic(path, buf.get_ref())
}

/// 8-bit sRGB PNG from interleaved RGB bytes.
pub fn write_png(path: &Path, width: u32, height: u32, rgb8: &[u8]) -> Result<(), String> {
    let mut buf = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut buf,
        rgb8,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("cannot encode PNG for {}: {e}", path.display()))?;
    write_atomic(path, buf.get_ref())
}

/// Read a linear RGB EXR (first layer's R, G, B channels).
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res: Vec2<usize>, _| (res, vec![Vec3::ZERO; res.width() * res.height()]),
        |(res, px): &mut (Vec2<usize>, Vec<Vec3>),
         pos: Vec2<usize>,
         (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * res.width() + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let (res, px) = image.layer_data.channel_data.pixels;
    Ok((res.width() as u32, res.height() as u32, px))
}

/// Relative mean squared error, mean((x − ref)² / (ref² + 0.01)) over pixels and channels
/// (the definition `compare` reports).
pub fn rel_mse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    assert_eq!(image.len(), reference.len());
    let mut sum = 0.0f64;
    for (x, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            sum += (x - r) * (x - r) / (r * r + 0.01);
        }
    }
    sum / (3 * image.len().max(1)) as f64
}
