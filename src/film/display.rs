//! What the previewer shows: a view mode of the film, tone-mapped (final, direct, indirect) or
//! in false colour (bandwidth as in Fig. 5, kernel density, harmonic mean distance), as RGBA8.

use super::error::error_colour;
use super::{Film, SplatInfo, false_colour, linear_to_srgb};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Which image of the film the previewer shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ViewMode {
    /// The final image: direct plus indirect light, tone-mapped.
    Final,
    /// Direct light and emission only.
    DirectOnly,
    /// Splatted indirect light only.
    IndirectOnly,
    /// Mean splat bandwidth per pixel, red = smallest to blue = largest (Fig. 5).
    Bandwidth,
    /// Kernel-weight sum per pixel.
    KernelDensity,
    /// Harmonic mean distance of incident photon rays.
    HarmonicDistance,
    /// The built-in path tracer's image of the same view, refining progressively.
    Reference,
    /// The image with the radiance cache's records drawn as circles of their radii (Fig. 8b).
    CacheRecords,
    /// The error the render estimates from its own passes (docs/deviations.md §51), per pixel
    /// as a relative RMS error in Fig. 10's colours; black until two passes give a spread.
    EstimatedError,
}

impl ViewMode {
    /// Every mode, in menu order.
    pub const ALL: [ViewMode; 9] = [
        ViewMode::Final,
        ViewMode::DirectOnly,
        ViewMode::IndirectOnly,
        ViewMode::Bandwidth,
        ViewMode::KernelDensity,
        ViewMode::HarmonicDistance,
        ViewMode::Reference,
        ViewMode::CacheRecords,
        ViewMode::EstimatedError,
    ];

    /// The splat statistic a false-colour mode shows, with its unit.
    fn scalar(self) -> Option<(Statistic, &'static str)> {
        match self {
            ViewMode::Bandwidth => Some((|i| i.mean_bandwidth, "m")),
            ViewMode::KernelDensity => Some((|i| i.kernel_weight, "1/m²")),
            ViewMode::HarmonicDistance => Some((|i| i.harmonic_mean_distance, "m")),
            _ => None,
        }
    }
}

/// One of a pixel's splat statistics.
type Statistic = fn(&SplatInfo) -> f32;

/// How linear radiance becomes display values (after the exposure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ToneMap {
    /// Exposure, clamp, sRGB.
    Clamp,
    /// x / (1 + x) per channel.
    Reinhard,
    /// The ACES filmic fit of Narkowicz (2015).
    Aces,
}

impl ToneMap {
    /// Every tone curve, in menu order.
    pub const ALL: [ToneMap; 3] = [ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces];

    #[inline]
    fn apply(self, x: f32) -> f32 {
        match self {
            ToneMap::Clamp => x,
            ToneMap::Reinhard => x / (1.0 + x),
            ToneMap::Aces => {
                let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
                (x * (a * x + b)) / (x * (c * x + d) + e)
            }
        }
    }
}

/// The numeric range a false-colour image maps onto its colour scale.
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    /// Value at the scale's start.
    pub min: f32,
    /// Value at its end.
    pub max: f32,
    /// Unit of the values ("m", "1/m²").
    pub unit: &'static str,
    /// The colours between.
    pub scale: Scale,
}

/// A legend's colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Red (min) to blue (max), [`false_colour`].
    FalseColour,
    /// Fig. 10's error colours, blue (≤ min) through green to red (≥ max), [`error_colour`].
    Fig10,
}

impl Scale {
    /// The colour at `t` ∈ [0, 1] along the legend.
    pub fn colour(self, t: f32) -> [u8; 3] {
        match self {
            Scale::FalseColour => false_colour(t),
            Scale::Fig10 => error_colour(FIG10_LOW + t * (FIG10_HIGH - FIG10_LOW)),
        }
    }

    /// How to read the colours.
    pub fn note(self) -> &'static str {
        match self {
            Scale::FalseColour => "red = smallest",
            Scale::Fig10 => "Fig. 10's colours: blue below, red above",
        }
    }
}

/// The relative errors where Fig. 10's scale leaves blue and reaches red ([`error_colour`]).
const FIG10_LOW: f32 = 0.05;
const FIG10_HIGH: f32 = 0.30;

/// An image ready for the screen or a PNG.
#[derive(Clone, Debug)]
pub struct DisplayImage {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// RGBA8, row-major, top row first.
    pub rgba: Vec<u8>,
    /// The false-colour range, for false-colour modes.
    pub legend: Option<Legend>,
}

impl DisplayImage {
    /// Draw each record (pixel x, y, radius in pixels) as a dot and a circle of its radius,
    /// coloured by the pass that made it, coarse (blue) to fine (red) (Fig. 8b).
    pub fn draw_records(&mut self, records: &[[f32; 4]], passes: f32) {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut put = |x: i64, y: i64, c: [u8; 3]| {
            if x >= 0 && y >= 0 && x < w && y < h {
                let i = 4 * (y * w + x) as usize;
                self.rgba[i..i + 3].copy_from_slice(&c);
            }
        };
        for &[x, y, r, pass] in records {
            let c = false_colour(1.0 - pass / passes.max(1.0));
            let steps = (r * 6.3).ceil().max(8.0) as usize;
            for k in 0..steps {
                let a = k as f32 / steps as f32 * std::f32::consts::TAU;
                put(
                    (x + r * a.cos()).round() as i64,
                    (y + r * a.sin()).round() as i64,
                    c,
                );
            }
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)] {
                put(x as i64 + dx, y as i64 + dy, [255, 255, 255]);
            }
        }
    }

    /// An opaque image of 8-bit RGB pixels (an error map), no legend.
    pub fn from_rgb(width: u32, height: u32, rgb: &[u8]) -> Self {
        Self {
            width,
            height,
            rgba: rgb
                .chunks_exact(3)
                .flat_map(|p| [p[0], p[1], p[2], 255])
                .collect(),
            legend: None,
        }
    }

    /// The split view: the columns from `at` (a fraction of the width) rightwards taken from
    /// `right`, an image of the same size (nothing when the sizes differ).
    pub fn split_with(&mut self, right: &DisplayImage, at: f32) {
        if (right.width, right.height) != (self.width, self.height) {
            return;
        }
        let w = self.width as usize;
        let x0 = ((at.clamp(0.0, 1.0) * w as f32).round() as usize).min(w);
        for (row, src) in self
            .rgba
            .chunks_exact_mut(4 * w)
            .zip(right.rgba.chunks_exact(4 * w))
        {
            row[4 * x0..].copy_from_slice(&src[4 * x0..]);
        }
    }

    /// The image as RGB8 (alpha dropped), for PNG files.
    pub fn rgb(&self) -> Vec<u8> {
        self.rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect()
    }
}

/// Render `film` in `mode`. False-colour modes map the 0.5th–99.5th percentile of the pixels
/// that received splats; pixels without splats are black.
pub fn display(film: &Film, mode: ViewMode, exposure_stops: f32, tone: ToneMap) -> DisplayImage {
    let n = (film.width * film.height) as usize;
    let mut rgba = Vec::with_capacity(4 * n);
    let mut legend = None;
    if let Some((get, unit)) = mode.scalar() {
        let values = || film.info.iter().map(get);
        let mut valid: Vec<f32> = values().filter(|v| v.is_finite() && *v > 0.0).collect();
        let (lo, hi) = if valid.is_empty() {
            (0.0, 1.0)
        } else {
            valid.sort_unstable_by(f32::total_cmp);
            let at = |q: f64| valid[((valid.len() - 1) as f64 * q).round() as usize];
            (at(0.005), at(0.995))
        };
        let span = (hi - lo).max(f32::MIN_POSITIVE);
        for v in values() {
            let c = if v.is_finite() && v > 0.0 {
                false_colour((v - lo) / span)
            } else {
                [0, 0, 0]
            };
            rgba.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
        legend = Some(Legend {
            min: lo,
            max: hi,
            unit,
            scale: Scale::FalseColour,
        });
    } else if mode == ViewMode::EstimatedError {
        // Black until the estimate exists (fewer than two passes, or the estimate is off).
        let map = &film.estimated_error;
        for i in 0..n {
            let c = map.get(i).map_or([0, 0, 0], |&e| error_colour(e));
            rgba.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
        legend = Some(Legend {
            min: FIG10_LOW,
            max: FIG10_HIGH,
            unit: "relative error",
            scale: Scale::Fig10,
        });
    } else {
        let src: &[Vec3] = match mode {
            ViewMode::DirectOnly => &film.direct,
            ViewMode::IndirectOnly => &film.indirect,
            _ => &film.rgb,
        };
        let k = 2f32.powf(exposure_stops);
        for c in src {
            let c = if c.is_finite() { *c * k } else { Vec3::ZERO };
            let q = |x: f32| (linear_to_srgb(tone.apply(x.max(0.0))) * 255.0 + 0.5) as u8;
            rgba.extend_from_slice(&[q(c.x), q(c.y), q(c.z), 255]);
        }
    }
    DisplayImage {
        width: film.width,
        height: film.height,
        rgba,
        legend,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bandwidth_view_runs_red_to_blue() {
        let mut film = Film::new(3, 1);
        for (i, h) in film.info.iter_mut().zip([0.01, 0.0, 0.05]) {
            i.mean_bandwidth = h;
        }
        let d = display(&film, ViewMode::Bandwidth, 0.0, ToneMap::Clamp);
        assert_eq!(&d.rgba[0..4], &[255, 0, 0, 255]); // smallest: red
        assert_eq!(&d.rgba[4..8], &[0, 0, 0, 255]); // no splats: black
        assert_eq!(&d.rgba[8..12], &[0, 0, 255, 255]); // largest: blue
        let l = d.legend.unwrap();
        assert_eq!((l.min, l.max, l.unit), (0.01, 0.05, "m"));
    }

    /// The split takes the right image's columns from the divider on, and nothing else.
    #[test]
    fn split_takes_the_right_columns() {
        let img = |v: u8| DisplayImage {
            width: 4,
            height: 2,
            rgba: vec![v; 32],
            legend: None,
        };
        let mut left = img(10);
        left.split_with(&img(200), 0.5);
        for row in left.rgba.chunks(16) {
            assert_eq!(&row[..8], &[10; 8]);
            assert_eq!(&row[8..], &[200; 8]);
        }
        let mut same = img(10);
        same.split_with(&img(200), 1.0);
        assert_eq!(same.rgba, vec![10; 32]);
    }

    /// The estimated-error view shows each pixel's estimate in Fig. 10's colours, black where
    /// there is none yet, with a legend over Fig. 10's range.
    #[test]
    fn estimated_error_view_uses_fig_10_colours() {
        let mut film = Film::new(3, 1);
        let d = display(&film, ViewMode::EstimatedError, 0.0, ToneMap::Clamp);
        assert!(
            d.rgba.chunks(4).all(|p| p == [0, 0, 0, 255]),
            "no estimate yet"
        );
        film.estimated_error = vec![0.01, 0.15, 0.5];
        let d = display(&film, ViewMode::EstimatedError, 0.0, ToneMap::Clamp);
        assert_eq!(&d.rgba[0..4], &[0, 0, 255, 255]);
        assert_eq!(&d.rgba[4..8], &[0, 255, 0, 255]);
        assert_eq!(&d.rgba[8..12], &[255, 0, 0, 255]);
        let l = d.legend.unwrap();
        assert_eq!(l.scale.colour(0.0), [0, 0, 255]);
        assert_eq!(l.scale.colour(1.0), [255, 0, 0]);
    }

    #[test]
    fn tone_maps_are_monotone_and_bounded() {
        for t in ToneMap::ALL {
            let mut prev = -1.0;
            for i in 0..1000 {
                let y = t.apply(i as f32 * 0.02);
                assert!(y >= prev, "{t:?}");
                prev = y;
            }
        }
        assert!(ToneMap::Reinhard.apply(1e6) <= 1.0);
    }
}
