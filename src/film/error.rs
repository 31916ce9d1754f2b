//! Error metrics against a reference image (RMSE, relative errors, mean bias, bright dots)
//! and Fig. 10's relative-error maps.

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

/// Isolated bright dots (issue 30's speckle count): pixels of `image` whose luminance is more
/// than 3× the median of their 5×5 neighbourhood (themselves included) where the same pixel of
/// `reference` is not, so that a sparkle the reference has too (a highlight, a lamp) is not
/// counted. Pixels within 2 of the border are not tested. Both images are `width` × `height`.
pub fn bright_dots(image: &[Vec3], reference: &[Vec3], width: u32, height: u32) -> usize {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(image.len(), w * h);
    assert_eq!(reference.len(), w * h);
    let lum = |v: &[Vec3]| v.iter().map(|c| luminance(*c)).collect::<Vec<f32>>();
    let (a, r) = (lum(image), lum(reference));
    let dot = |l: &[f32], x: usize, y: usize, window: &mut [f32; 25]| {
        let mut k = 0;
        for yy in y - 2..=y + 2 {
            for xx in x - 2..=x + 2 {
                window[k] = l[yy * w + xx];
                k += 1;
            }
        }
        let (_, median, _) = window.select_nth_unstable_by(12, f32::total_cmp);
        l[y * w + x] > 3.0 * median.max(0.0)
    };
    let mut window = [0.0f32; 25];
    let mut count = 0;
    for y in 2..h.saturating_sub(2) {
        for x in 2..w.saturating_sub(2) {
            if dot(&a, x, y, &mut window) && !dot(&r, x, y, &mut window) {
                count += 1;
            }
        }
    }
    count
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
    fn bright_dots_count_isolated_sparkles_the_reference_lacks() {
        let (w, h) = (12u32, 10u32);
        let flat = vec![Vec3::splat(0.5); (w * h) as usize];
        let mut img = flat.clone();
        img[(4 * w + 5) as usize] = Vec3::splat(2.0); // 4× its neighbourhood: a dot
        img[(6 * w + 8) as usize] = Vec3::splat(1.4); // 2.8×: not one
        img[(w + 5) as usize] = Vec3::splat(9.0); // within 2 of the border: not tested
        assert_eq!(bright_dots(&img, &flat, w, h), 1);
        // The reference has it too: a highlight, not a speckle.
        assert_eq!(bright_dots(&img, &img, w, h), 0);
        assert_eq!(bright_dots(&flat, &flat, w, h), 0);
    }

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
