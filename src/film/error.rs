//! Error metrics against a reference image (RMSE, relative errors, mean bias) and Fig. 10's
//! relative-error maps.

use crate::sampling::luminance;
use glam::Vec3;

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

/// Root mean squared error over pixels and channels.
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
