//! The kd-tree traversal (Alg. 1 with cull nodes, leaf and chunk spheres) finds exactly the
//! eye samples a brute-force conical test finds, on random data, and the directional records
//! of glossy targets (SH mode, §8.1) hold exactly the brute-force projections.

use glam::{Vec3, Vec3A};
use proptest::prelude::*;
use raysplat::pipeline::directional::DirectionalMode;
use raysplat::pipeline::directional::SH_COEFFS;
use raysplat::pipeline::radiance_map::{Accumulators, Channel};
use raysplat::pipeline::splat::{RayDirection, SplatBatch, SplatRay, splat, test_sample};
use raysplat::pipeline::splat_tree::{Cone, SplatTree};
use raysplat::sampling::{Rng, uniform_sphere};

/// Random splat targets: a mix of planes (coherent normals, so cull nodes appear), a sphere
/// and a cloud with random normals, with duplicated points for degenerate leaves.
fn targets(seed: u64, n: usize) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut rng = Rng::new(seed, 1);
    let (mut p, mut nrm) = (Vec::new(), Vec::new());
    for i in 0..n {
        let u = rng.next_2d();
        match i % 4 {
            0 => {
                p.push(Vec3::new(u.x * 2.0 - 1.0, 0.0, u.y * 2.0 - 1.0));
                nrm.push(Vec3::Y);
            }
            1 => {
                p.push(Vec3::new(-1.0, u.x * 2.0, u.y * 2.0 - 1.0));
                nrm.push(Vec3::X);
            }
            2 => {
                let d = uniform_sphere(u);
                p.push(Vec3::new(0.3, 0.5, 0.2) + d * 0.3);
                nrm.push(d);
            }
            _ => {
                let q = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                // Every 16th cloud point repeats the previous one exactly.
                let q = if i % 64 == 3 && !p.is_empty() {
                    p[p.len() - 1]
                } else {
                    q
                };
                p.push(q);
                nrm.push(uniform_sphere(rng.next_2d()));
            }
        }
    }
    (p, nrm)
}

fn rays(seed: u64, n: usize, radius: f32, grow: f32) -> Vec<SplatRay> {
    let mut rng = Rng::new(seed, 2);
    (0..n)
        .map(|i| {
            let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0 - 1.5;
            let dir = uniform_sphere(rng.next_2d());
            let length = 0.1 + 2.0 * rng.next_f32();
            let h0 = if i % 5 == 0 {
                0.0
            } else {
                radius * rng.next_f32()
            };
            let dh = grow * rng.next_f32();
            let cone = Cone {
                origin: origin.into(),
                dir: dir.into(),
                length,
                h0,
                dh,
                h_end: h0 + dh * length,
            };
            let (bounds_min, bounds_max) = cone.bounds();
            let origin_normal = if i % 3 == 0 { Vec3A::ZERO } else { dir.into() };
            SplatRay {
                cone,
                power: Vec3::new(1.0, 2.0, 3.0),
                origin_normal,
                end_normal: if i % 4 == 0 {
                    Vec3A::ZERO
                } else {
                    (-dir).into()
                },
                end_gain: 1.0 + rng.next_f32(),
                end_plane: if i % 4 == 0 { 0.0 } else { -length },
                beyond: if i % 5 == 0 { 0.0 } else { 1.0 },
                bounds_min,
                bounds_max,
            }
        })
        .collect()
}

fn check(seed: u64, n_targets: usize, n_rays: usize, radius: f32, grow: f32) {
    let (p, nrm) = targets(seed, n_targets);
    let tree = SplatTree::build(&p, &nrm);
    let rays = rays(seed, n_rays, radius, grow);
    // Every third target glossy, so that subtrees own differing numbers of records.
    let glossy: Vec<bool> = (0..p.len()).map(|t| t % 3 == 1).collect();
    let mut acc = Accumulators::for_tree(&tree, &glossy, DirectionalMode::Sh);
    let batch = SplatBatch {
        directions: rays
            .iter()
            .map(|r| RayDirection::new(r.cone.dir.into(), DirectionalMode::Sh))
            .collect(),
        rays: rays.clone(),
    };
    splat(&tree, &batch, &mut acc, None);
    for (t, (&pos, &n)) in p.iter().zip(&nrm).enumerate() {
        let slot = tree.target_slot[t] as usize;
        let (mut count, mut weight) = (0u32, 0.0f64);
        let mut sh = [0.0f64; 3 * SH_COEFFS];
        for (ray, dir) in rays.iter().zip(&batch.directions) {
            let r = test_sample(ray, pos, n);
            if r.feasible {
                count += 1;
                weight += r.weight as f64;
                let pw = ray.power * r.weight;
                for (c, pc) in [pw.x, pw.y, pw.z].into_iter().enumerate() {
                    for k in 0..SH_COEFFS {
                        sh[c * SH_COEFFS + k] += (pc * dir.basis[k]) as f64;
                    }
                }
            }
        }
        match acc.record(slot) {
            Some(rec) => {
                assert!(glossy[t], "target {t} is not glossy but has a record");
                for (k, (&got, &want)) in rec.iter().zip(&sh).enumerate() {
                    assert!(
                        (got as f64 - want).abs() <= 1e-3 * (1.0 + weight * 6.0),
                        "target {t} coefficient {k}: {got} vs {want}"
                    );
                }
            }
            None => assert!(!glossy[t], "glossy target {t} has no record"),
        }
        let got = acc.get(Channel::Count, slot);
        assert_eq!(
            got as u32, count,
            "target {t} at {pos}: tree found {got} rays, brute force {count}"
        );
        let w = acc.get(Channel::Weight, slot) as f64;
        assert!(
            (w - weight).abs() <= 1e-4 * weight.max(1.0),
            "target {t}: weight {w} vs {weight}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn traversal_matches_brute_force(
        seed in 0u64..1_000_000,
        n_targets in 1usize..6000,
        radius in 0.001f32..0.4,
        grow in 0.0f32..0.3,
    ) {
        check(seed, n_targets, 300, radius, grow);
    }
}

#[test]
fn traversal_matches_brute_force_on_a_large_tree() {
    // Enough targets for many subtrees and deep trees.
    check(42, 60_000, 200, 0.1, 0.05);
}
