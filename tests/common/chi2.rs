//! A generic chi-square goodness-of-fit test for direction samplers, after pbrt-v3/v4's and
//! Mitsuba 3's BSDF tests: directions are binned in (θ, φ) about +Z, the expected count of
//! every bin is the sampler's claimed pdf integrated over the bin, bins expecting fewer than
//! [`MIN_EXPECTED`] samples are pooled, and the statistic's p-value is compared with the
//! significance level after Šidák's correction for the number of tests run.
#![allow(dead_code)]

use glam::Vec3;
use raysplat::sampling::Rng;
use std::f64::consts::PI;

/// Bins expecting fewer samples are pooled (the usual rule of thumb for the χ² approximation).
pub const MIN_EXPECTED: f64 = 5.0;

#[derive(Clone, Copy, Debug)]
pub struct Chi2 {
    pub theta_bins: usize,
    pub phi_bins: usize,
    pub samples: usize,
    /// Significance of the whole suite, 0.01 as in pbrt and Mitsuba.
    pub significance: f64,
    /// Tests in the suite (Šidák correction).
    pub tests: usize,
    /// Midpoint sub-cells per bin side when integrating the pdf.
    pub refine: usize,
}

impl Default for Chi2 {
    fn default() -> Self {
        Self {
            theta_bins: 10,
            phi_bins: 20,
            samples: 200_000,
            significance: 0.01,
            tests: 1,
            refine: 16,
        }
    }
}

/// The outcome: the statistic, its degrees of freedom and the p-value.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Result {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Samples returned as None (absorbed) and their expected count.
    pub absorbed: (f64, f64),
}

fn bin_of(d: Vec3, c: &Chi2) -> usize {
    let theta = (d.z as f64).clamp(-1.0, 1.0).acos();
    let mut phi = (d.y as f64).atan2(d.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let i = ((theta / PI * c.theta_bins as f64) as usize).min(c.theta_bins - 1);
    let j = ((phi / (2.0 * PI) * c.phi_bins as f64) as usize).min(c.phi_bins - 1);
    i * c.phi_bins + j
}

/// Run the test: `sample` draws one direction (None when the sampler absorbs), `pdf` is the
/// solid-angle density it claims for a direction. Missing probability mass (∫pdf < 1) is the
/// expected share of absorbed samples and enters the statistic as one more bin.
/// Returns Err with a description when the sampler fails.
pub fn chi2_test(
    c: &Chi2,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Result<Chi2Result, String> {
    let nb = c.theta_bins * c.phi_bins;
    let mut observed = vec![0.0f64; nb];
    let mut absorbed = 0.0;
    let mut rng = Rng::new(seed, 0xc41);
    for _ in 0..c.samples {
        match sample(&mut rng) {
            Some(d) if d.is_finite() => observed[bin_of(d.normalize(), c)] += 1.0,
            Some(d) => return Err(format!("sampler returned a non-finite direction {d}")),
            None => absorbed += 1.0,
        }
    }
    // Expected counts: ∫ pdf over each bin, midpoint rule in (θ, φ) with sin θ.
    let mut expected = vec![0.0f64; nb];
    let (dt, dp) = (PI / c.theta_bins as f64, 2.0 * PI / c.phi_bins as f64);
    let r = c.refine;
    for i in 0..c.theta_bins {
        for j in 0..c.phi_bins {
            let mut sum = 0.0;
            for a in 0..r {
                let t = (i as f64 + (a as f64 + 0.5) / r as f64) * dt;
                for b in 0..r {
                    let p = (j as f64 + (b as f64 + 0.5) / r as f64) * dp;
                    let d = Vec3::new(
                        (t.sin() * p.cos()) as f32,
                        (t.sin() * p.sin()) as f32,
                        t.cos() as f32,
                    );
                    sum += pdf(d) * t.sin();
                }
            }
            expected[i * c.phi_bins + j] = sum * dt * dp / (r * r) as f64 * c.samples as f64;
        }
    }
    let total: f64 = expected.iter().sum();
    let absorbed_expected = (c.samples as f64 - total).max(0.0);
    let mut cells: Vec<(f64, f64)> = observed.into_iter().zip(expected).collect();
    // The quadrature is good to about 1e-4 of the total (measured on sharp-edged lights), so a
    // sampler that never absorbs is only held to a deficit above 0.1%.
    if absorbed > 0.0 || absorbed_expected > 1e-3 * c.samples as f64 {
        cells.push((absorbed, absorbed_expected));
    }
    // A sample where the pdf claims (almost) nothing is a hard failure.
    for (k, &(o, e)) in cells.iter().enumerate() {
        if e < 1e-6 * c.samples as f64 && o > 0.0 && o > 10.0 * e + 5.0 {
            return Err(format!(
                "bin {k}: {o} samples where the pdf expects {e:.3e}"
            ));
        }
    }
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, e) in cells {
        if e < MIN_EXPECTED {
            pool_o += o;
            pool_e += e;
            continue;
        }
        stat += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(MIN_EXPECTED);
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = puruspe::gammq(dof as f64 / 2.0, stat / 2.0);
    let result = Chi2Result {
        statistic: stat,
        dof,
        p_value,
        absorbed: (absorbed, absorbed_expected),
    };
    let alpha = 1.0 - (1.0 - c.significance).powf(1.0 / c.tests as f64);
    if p_value < alpha {
        Err(format!(
            "rejected: χ² = {stat:.1} with {dof} dof, p = {p_value:.3e} < {alpha:.3e}; \
             absorbed {absorbed} vs {absorbed_expected:.1} expected"
        ))
    } else {
        Ok(result)
    }
}
