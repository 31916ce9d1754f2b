//! Unit tests of the eye pass: splat targets.

use super::chain::RawSample;
use super::*;

/// A glossy sample on a plane facing +z at the origin, its lobe traced or not.
fn raw(lobe_traced: bool) -> RawSample {
    RawSample {
        sample: EyeSample {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            geo_normal: Vec3::Z,
            offset: 0.0,
            wo: Vec3::Z,
            material: 0,
            pixel: 0,
            weight: Vec3::ONE,
            albedo: Vec3::splat(0.5),
            specular: Vec3::splat(0.3),
            alpha: 0.3,
            f90: 1.0,
            primary: true,
            lobe_traced,
        },
        path_length: 1.0,
        target: 0,
    }
}

/// Samples on one spot of one material merge, but not a traced lobe's with an untraced
/// one's (a max-depth sample the eye path did not continue): the target's directional
/// record must serve all its samples or none.
#[test]
fn merged_samples_are_glossy_in_the_map_alike() {
    let mut px = vec![raw(false), raw(true), raw(false), raw(true)];
    let mut targets = SplatTargets::default();
    assign_targets(&mut px, &mut targets, true, 0.01);
    assert_eq!(targets.len(), 2);
    assert_eq!(px[0].target, px[2].target);
    assert_eq!(px[1].target, px[3].target);
    assert_ne!(px[0].target, px[1].target);
    assert!(targets.glossy[px[0].target as usize]);
    assert!(!targets.glossy[px[1].target as usize]);
}
