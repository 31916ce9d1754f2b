//! Rendering any method with the same settings (same eye samples and photons for rs and pm),
//! error metrics against a reference, and Fig. 10's relative-error maps.

use super::Method;
use super::final_gather::{FgSettings, render_fg};
use super::pt::{PathTracer, PtSettings};
use crate::film::Film;
use crate::render::{RenderSettings, Renderer, Timings};
use crate::sampling::luminance;
use crate::scene::Scene;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// How long to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// One batch of M photons (rs, pm) or this many paths per pixel (pt).
    Fixed { pt_spp: u32 },
    /// Batches (rs, pm) or samples per pixel (pt) until the time is spent (at least one).
    Seconds(f64),
}

/// A finished render and what it cost.
pub struct Rendered {
    pub film: Film,
    pub timings: Timings,
    /// Photons traced (0 for pt).
    pub photons: u64,
    /// Batches (rs, pm) or samples per pixel (pt).
    pub passes: u64,
    pub invalid: u64,
}

/// Render `scene` with `method`. rs and pm share the eye pass and the light pass for a given
/// seed, so they see the same eye samples and photons.
pub fn render_method(
    scene: &Arc<Scene>,
    method: Method,
    settings: &RenderSettings,
    budget: Budget,
) -> Result<Rendered, String> {
    let start = Instant::now();
    let spent = |start: &Instant, b: f64| start.elapsed().as_secs_f64() >= b;
    match method {
        Method::Rs | Method::Rc | Method::Pm => {
            let mut r = Renderer::new(
                scene.clone(),
                RenderSettings {
                    method,
                    ..settings.clone()
                },
            )?;
            loop {
                r.run_batch();
                match budget {
                    Budget::Seconds(b) if !spent(&start, b) => continue,
                    _ => break,
                }
            }
            let film = r.film();
            Ok(Rendered {
                invalid: film.invalid_pixels() as u64,
                film,
                timings: r.timings,
                photons: r.photons_traced,
                passes: r.batch_count() as u64,
            })
        }
        Method::RsFg | Method::PmFg => {
            let fg = FgSettings {
                rays: settings.fg_rays.max(1),
                ..FgSettings::default()
            };
            let mut out = render_fg(scene, method, settings, fg)?;
            // With a time budget, average independent passes (fresh photons and gather rays).
            if let Budget::Seconds(b) = budget {
                let mut sum = out.film.rgb.clone();
                let mut passes = 1u64;
                while !spent(&start, b) {
                    let s = RenderSettings {
                        seed: settings.seed.wrapping_add(passes * 0x9e37),
                        ..settings.clone()
                    };
                    let more = render_fg(scene, method, &s, fg)?;
                    for (a, x) in sum.iter_mut().zip(&more.film.rgb) {
                        *a += *x;
                    }
                    out.timings.t_eye += more.timings.t_eye;
                    out.timings.t_direct += more.timings.t_direct;
                    out.timings.t_light += more.timings.t_light;
                    out.timings.t_splat += more.timings.t_splat;
                    out.photons += more.photons;
                    passes += 1;
                }
                for (o, a) in out.film.rgb.iter_mut().zip(&sum) {
                    *o = *a / passes as f32;
                }
                out.passes = passes;
            }
            Ok(out)
        }
        Method::Pt => {
            let camera = scene.camera_or_error(settings.camera.as_deref())?;
            let mut pt = PathTracer::new(
                scene.clone(),
                camera,
                PtSettings::matching(
                    settings.width,
                    settings.height,
                    settings.seed,
                    settings.fractions,
                ),
            );
            match budget {
                Budget::Fixed { pt_spp } => pt.add_samples(pt_spp.max(1)),
                Budget::Seconds(b) => loop {
                    pt.add_samples(1);
                    if spent(&start, b) {
                        break;
                    }
                },
            }
            let timings = Timings {
                t_splat: start.elapsed().as_secs_f64(),
                ..Timings::default()
            };
            Ok(Rendered {
                film: pt.film(),
                timings,
                photons: 0,
                passes: pt.samples_per_pixel() as u64,
                invalid: pt.invalid,
            })
        }
    }
}

/// Root mean squared error over pixels and channels.
/// Mean luminance of `image` over that of `reference`, minus 1.
pub fn mean_bias(image: &[Vec3], reference: &[Vec3]) -> f64 {
    let lum = |v: &[Vec3]| {
        v.iter()
            .map(|c| crate::sampling::luminance(*c) as f64)
            .sum::<f64>()
    };
    let r = lum(reference);
    if r > 0.0 { lum(image) / r - 1.0 } else { 0.0 }
}

pub fn rmse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    let sum: f64 = image
        .iter()
        .zip(reference)
        .map(|(x, r)| (*x - *r).as_dvec3().length_squared())
        .sum();
    (sum / (3 * image.len().max(1)) as f64).sqrt()
}

/// Per-pixel relative error of luminance, |x − r| / r (0 where both are black).
pub fn relative_errors(image: &[Vec3], reference: &[Vec3]) -> Vec<f32> {
    image
        .iter()
        .zip(reference)
        .map(|(x, r)| {
            let (lx, lr) = (luminance(*x), luminance(*r));
            if lr.abs() < 1e-6 {
                if lx.abs() < 1e-6 { 0.0 } else { 1.0 }
            } else {
                (lx - lr).abs() / lr.abs()
            }
        })
        .collect()
}

/// Fig. 10's colour scale: blue below 5% error, green at 15%, red at 30% and above.
pub fn error_colour(e: f32) -> [u8; 3] {
    let lerp = |a: [f32; 3], b: [f32; 3], t: f32| -> [u8; 3] {
        let t = t.clamp(0.0, 1.0);
        [0, 1, 2].map(|i| (a[i] + (b[i] - a[i]) * t).round() as u8)
    };
    const BLUE: [f32; 3] = [0.0, 0.0, 255.0];
    const GREEN: [f32; 3] = [0.0, 255.0, 0.0];
    const RED: [f32; 3] = [255.0, 0.0, 0.0];
    if e.is_nan() || e >= 0.30 {
        [255, 0, 0]
    } else if e <= 0.05 {
        [0, 0, 255]
    } else if e <= 0.15 {
        lerp(BLUE, GREEN, (e - 0.05) / 0.10)
    } else {
        lerp(GREEN, RED, (e - 0.15) / 0.15)
    }
}

/// The relative-error map as 8-bit RGB.
pub fn error_map(image: &[Vec3], reference: &[Vec3]) -> Vec<u8> {
    relative_errors(image, reference)
        .into_iter()
        .flat_map(error_colour)
        .collect()
}

/// One row of `compare`'s table (Table 2's phases plus errors).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareRow {
    pub t_eye: f64,
    pub t_light: f64,
    pub t_splat: f64,
    pub t_total: f64,
    pub rmse: f64,
    pub relmse: f64,
    /// Image mean over reference mean, minus 1 (luminance): the method's overall bias.
    #[serde(default)]
    pub mean_bias: f64,
    pub photons: u64,
    pub passes: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_colours_follow_fig_10() {
        assert_eq!(error_colour(0.0), [0, 0, 255]);
        assert_eq!(error_colour(0.049), [0, 0, 255]);
        assert_eq!(error_colour(0.15), [0, 255, 0]);
        assert_eq!(error_colour(0.10), [0, 128, 128]);
        assert_eq!(error_colour(0.30), [255, 0, 0]);
        assert_eq!(error_colour(5.0), [255, 0, 0]);
        assert_eq!(error_colour(f32::NAN), [255, 0, 0]);
    }

    #[test]
    fn error_map_of_known_images() {
        let r = vec![Vec3::ONE; 4];
        let x = vec![
            Vec3::ONE,
            Vec3::splat(1.1),
            Vec3::splat(0.85),
            Vec3::splat(2.0),
        ];
        let m = error_map(&x, &r);
        // ±1 for the rounding of errors like 1.1/1 − 1 = 0.10000002.
        let near = |a: &[u8], b: [u8; 3]| a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= 1);
        assert!(near(&m[0..3], [0, 0, 255]), "{:?}", &m[0..3]);
        assert!(near(&m[3..6], [0, 128, 128]), "{:?}", &m[3..6]);
        assert!(near(&m[6..9], [0, 255, 0]), "{:?}", &m[6..9]);
        assert!(near(&m[9..12], [255, 0, 0]), "{:?}", &m[9..12]);
        assert!((rmse(&x, &r) - ((0.01 + 0.0225 + 1.0) / 4.0f64).sqrt()).abs() < 1e-6);
    }
}
