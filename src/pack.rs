//! Compact storage for the per-eye-sample arrays (docs/benchmarks.md, "Memory"):
//! unit vectors in 32 bits (octahedral, 16 bits per coordinate) and RGB in three f16.

use glam::{Vec3, Vec3A};
use half::f16;

/// A unit vector in 32 bits: the octahedral map (Meyer et al. 2010, "On floating-point
/// normal vectors"), 16 bits per coordinate. The decoded vector is within 10⁻⁴ rad of the
/// encoded one. The splat tree's cull nodes store their reference normal in it too.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Oct(u32);

impl Oct {
    /// `v` (any length but zero; finite: a NaN decodes to −Z) to 32 bits.
    #[inline]
    pub fn new(v: Vec3) -> Self {
        let n = v / (v.x.abs() + v.y.abs() + v.z.abs());
        let (mut x, mut y) = (n.x, n.y);
        if n.z < 0.0 {
            let (ox, oy) = (x, y);
            x = (1.0 - oy.abs()) * ox.signum();
            y = (1.0 - ox.abs()) * oy.signum();
        }
        // Rounded by adding ½ before the truncating cast: the argument is never negative, and
        // `round` is a libm call on baseline x86-64 (1% of an rc render's time). It differs
        // from `round` by one code for 0.5 − 2⁻²⁵ only (the addition rounds up to 1).
        let q = |c: f32| (((c.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0 + 0.5) as u32) & 0xffff;
        Self(q(x) | (q(y) << 16))
    }

    /// The unit vector.
    #[inline(always)]
    pub fn get(self) -> Vec3 {
        Vec3::from(self.get_a())
    }

    /// The unit vector, SIMD-aligned.
    #[inline(always)]
    pub fn get_a(self) -> Vec3A {
        let x = (self.0 & 0xffff) as f32 / 65535.0 * 2.0 - 1.0;
        let y = (self.0 >> 16) as f32 / 65535.0 * 2.0 - 1.0;
        let z = 1.0 - x.abs() - y.abs();
        let t = (-z).max(0.0);
        let x = x + if x >= 0.0 { -t } else { t };
        let y = y + if y >= 0.0 { -t } else { t };
        Vec3A::new(x, y, z).normalize()
    }

    /// The 32 bits.
    #[inline]
    pub fn bits(self) -> u32 {
        self.0
    }

    /// From 32 bits written by [`Oct::bits`].
    #[inline]
    pub fn from_bits(bits: u32) -> Self {
        Self(bits)
    }
}

/// A unit vector or the zero vector in 32 bits: [`Oct`] with code 0 kept for zero (the
/// octahedron's corner codes all decode to −Z; −Z is written with the other one). A photon
/// ray's origin normal is zero at a point light, its end normal zero when it escapes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OctOrZero(u32);

impl OctOrZero {
    /// The zero vector.
    pub const ZERO: Self = Self(0);

    /// `v` to 32 bits: zero (or not finite) to [`OctOrZero::ZERO`], any other length as its
    /// direction.
    #[inline]
    pub fn new(v: Vec3) -> Self {
        if v == Vec3::ZERO || !v.is_finite() {
            return Self::ZERO;
        }
        match Oct::new(v).bits() {
            0 => Self(u32::MAX),
            b => Self(b),
        }
    }

    /// True for the zero vector.
    #[inline]
    pub fn is_zero(self) -> bool {
        self.0 == 0
    }

    /// The unit vector, or zero.
    #[inline]
    pub fn get(self) -> Vec3 {
        if self.is_zero() {
            Vec3::ZERO
        } else {
            Oct::from_bits(self.0).get()
        }
    }
}

/// RGB in three f16 (6 bytes): relative precision 2⁻¹¹, values above f16's largest finite
/// number (65,504) clamped to it, NaN kept.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb16([f16; 3]);

impl Rgb16 {
    /// `c` in half precision.
    #[inline]
    pub fn new(c: Vec3) -> Self {
        // Not `min`, which would turn NaN into the maximum: NaN stays NaN, so the film's
        // last guard still finds it.
        let max = f16::MAX.to_f32();
        let h = |x: f32| f16::from_f32(if x > max { max } else { x });
        Self([h(c.x), h(c.y), h(c.z)])
    }

    /// The colour.
    #[inline]
    pub fn get(self) -> Vec3 {
        Vec3::new(self.0[0].to_f32(), self.0[1].to_f32(), self.0[2].to_f32())
    }
}

/// A non-negative error bound in one f16 (2 bytes), never below the value given: rounded up
/// to the next f16 (relative 2⁻¹⁰ at most; bounds below f16's smallest subnormal, 6·10⁻⁸,
/// become it), and clamped to f16's largest finite number (65,504). A NaN or negative bound
/// is 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bound16(f16);

impl Bound16 {
    /// `x` rounded up to half precision.
    #[inline]
    pub fn new(x: f32) -> Self {
        let x = if x > 0.0 { x } else { 0.0 };
        let h = f16::from_f32(x.min(f16::MAX.to_f32()));
        if h.to_f32() < x && h < f16::MAX {
            // The next f16 up (bit patterns of positive f16 ascend with their values).
            Self(f16::from_bits(h.to_bits() + 1))
        } else {
            Self(h)
        }
    }

    /// The bound.
    #[inline]
    pub fn get(self) -> f32 {
        self.0.to_f32()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, uniform_sphere};

    #[test]
    fn bounds_round_up_within_one_f16_step() {
        let mut rng = Rng::new(9, 2);
        for _ in 0..100_000 {
            // Magnitudes from 10⁻¹⁰ to 10⁴.
            let x = 10f32.powf(rng.next_f32() * 14.0 - 10.0);
            let b = Bound16::new(x).get();
            assert!(b >= x, "{b} < {x}");
            assert!(b <= x * (1.0 + 1.0 / 1024.0) + 6e-8, "{b} far above {x}");
        }
        assert_eq!(Bound16::new(0.0).get(), 0.0);
        assert_eq!(Bound16::new(f32::NAN).get(), 0.0);
        assert_eq!(Bound16::new(-1.0).get(), 0.0);
        assert_eq!(Bound16::new(1e9).get(), 65504.0);
    }

    #[test]
    fn unit_vectors_survive_within_1e_4_rad() {
        let mut rng = Rng::new(5, 1);
        let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let mut worst = 0.0f32;
        for v in (0..100_000)
            .map(|_| uniform_sphere(rng.next_2d()))
            .chain(axes)
        {
            let back = Oct::new(v).get();
            assert!((back.length() - 1.0).abs() < 1e-6);
            worst = worst.max((back - v).length());
        }
        assert!(worst < 1e-4, "{worst}");
        assert!((Oct::new(Vec3::Z * 3.0).get() - Vec3::Z).length() < 1e-4);
    }

    #[test]
    fn zero_stays_zero_and_minus_z_survives() {
        assert!(OctOrZero::new(Vec3::ZERO).is_zero());
        assert_eq!(OctOrZero::new(Vec3::ZERO).get(), Vec3::ZERO);
        assert!(OctOrZero::new(Vec3::NAN).is_zero());
        // −Z with negative zeros is the one vector whose plain code is 0.
        for v in [Vec3::new(-0.0, -0.0, -1.0), Vec3::NEG_Z, Vec3::Y * 2.0] {
            let c = OctOrZero::new(v);
            assert!(!c.is_zero());
            assert!(
                (c.get() - v.normalize()).length() < 1e-4,
                "{v} -> {}",
                c.get()
            );
        }
    }

    #[test]
    fn colours_keep_eleven_bits() {
        for c in [
            Vec3::new(0.25, 1.0 / 3.0, 0.7),
            Vec3::splat(1e-3),
            Vec3::new(0.0, 4.0, 900.0),
        ] {
            let back = Rgb16::new(c).get();
            assert!(((back - c).abs().cmple(c * 4.9e-4)).all(), "{c} -> {back}");
        }
        assert_eq!(Rgb16::new(Vec3::splat(1e9)).get(), Vec3::splat(65504.0));
        assert!(Rgb16::new(Vec3::new(f32::NAN, 0.5, 0.5)).get().x.is_nan());
    }
}
