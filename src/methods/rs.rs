//! rs: photon ray splatting, the paper's method. Every batch of photon rays (indirect and
//! caustic, and direct with `--direct photons`) is splatted onto every splat target as it
//! arrives (Alg. 1); the film is the radiance map over the batches so far (§4, eq. 5),
//! optionally read through the radiance cache (§8.3, the previewer's ε slider) and filtered in
//! image space (§8.2).

use crate::methods::Timings;
use crate::methods::eye_side::{LobeDraws, TargetGeometry};
use crate::methods::photon_core::{
    Classes, Combine, CoreConfig, EyePasses, PhotonCore, SampleLight, SplatStats, StoredRays,
};
use crate::methods::photon_method::{PhotonMethod, Resolved, Resolver};
use crate::pipeline::cache::{self, Cache, PixelGeometry, record_value};
use crate::pipeline::radiance_map::Interpolated;
use crate::pipeline::splat::SplatCounters;
use crate::settings::MethodKind;
use std::time::Instant;

/// Photon ray splatting.
pub type RaySplatting = PhotonMethod<RsResolver>;

/// rs's resolver: the full radiance map, optionally through the cache and the filter.
#[derive(Default)]
pub struct RsResolver {
    /// The radiance cache of the last film (with `cache_on`).
    cache: Option<Cache>,
}

impl Resolver for RsResolver {
    const KIND: MethodKind = MethodKind::Rs;
    const CONFIG: CoreConfig = CoreConfig {
        splatted: Classes {
            direct: false,
            indirect: true,
            caustic: true,
        },
        lobes: LobeDraws::PerBatch,
        eye_passes: EyePasses::Redrawn,
        targets: TargetGeometry::Freed,
        stored_rays: StoredRays::Unread,
    };

    fn film(&mut self, core: &mut PhotonCore) -> Resolved {
        let t = Instant::now();
        let b = core.pass_batches() as u32;
        self.cache = None;
        // The cache pass counts as splatting (T_S), not as resolving.
        let mut timings = Timings::default();
        let mut cached = None;
        if core.settings().cache_on {
            let t = Instant::now();
            let (cache, values) = cache_from_map(core, b);
            (self.cache, cached) = (Some(cache), Some(values));
            timings.t_splat = t.elapsed().as_secs_f64();
        }
        let mut map = core.resolve_indirect(b);
        if cached.is_some() || core.settings().filter.enabled {
            core.resolve_samples(
                &mut map,
                SampleLight {
                    values: cached,
                    batches: b,
                    splat_stats: SplatStats::FromMap,
                    combine: Combine::Replace,
                },
            );
        }
        let film = core.compose(map, b, core.direct_photons());
        timings.t_resolve = t.elapsed().as_secs_f64() - timings.t_splat;
        Resolved {
            film,
            timings,
            counters: SplatCounters::default(),
        }
    }

    fn cache(&self) -> Option<&Cache> {
        self.cache.as_ref()
    }
}

/// The cache's record values read from the full radiance map: no splatting, so ε can move
/// freely (§8.3 in the previewer). Returns the cache and the eye samples' values from it.
fn cache_from_map(core: &PhotonCore, batches: u32) -> (Cache, Interpolated) {
    let side = core.side();
    let settings = core.settings();
    let geo = PixelGeometry::new(&side.eye, settings.width, settings.height);
    let acc = &side.acc_indirect;
    let inv_b = 1.0 / batches.max(1) as f32;
    cache::build(
        &side.eye,
        &geo,
        core.camera(),
        &settings.cache,
        acc.mode,
        |samples| {
            samples
                .iter()
                .map(|&i| {
                    let slot = side.tree.target_slot[side.eye.target[i as usize] as usize] as usize;
                    record_value(acc, slot, inv_b)
                })
                .collect()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::photon_method::PhotonMethod;
    use crate::methods::{Method, Step};
    use crate::scene::{BuiltinScene, Scene};
    use crate::settings::RenderSettings;
    use std::sync::Arc;

    fn small_rs() -> PhotonMethod<RsResolver> {
        rs_of_size(16)
    }

    /// rs on the classic box at `side`² pixels, one eye sample each, batches of 2,000.
    fn rs_of_size(side: u32) -> PhotonMethod<RsResolver> {
        let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
        let settings = RenderSettings {
            width: side,
            height: side,
            spp: 1,
            photons: 2_000,
            ..RenderSettings::default()
        };
        crate::methods::testing::open(scene, settings).unwrap()
    }

    /// rs on the classic box at 24² pixels with the error estimate on and one eye pass
    /// (batches of 2,000), `paced` as in the window.
    fn estimating_rs(paced: bool) -> PhotonMethod<RsResolver> {
        let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
        let settings = RenderSettings {
            width: 24,
            height: 24,
            spp: 1,
            photons: 2_000,
            estimate_error: true,
            progressive_eye: false,
            ..RenderSettings::default()
        };
        let mut m: PhotonMethod<RsResolver> =
            crate::methods::testing::open(scene, settings).unwrap();
        if paced {
            m.pace();
        }
        m
    }

    fn traced(m: &mut PhotonMethod<RsResolver>) {
        while m.step() != Step::Traced {}
    }

    /// The relative difference of two films' images (largest over pixels and channels).
    fn largest_difference(a: &crate::film::Film, b: &crate::film::Film) -> f32 {
        a.rgb
            .iter()
            .zip(&b.rgb)
            .map(|(x, y)| ((*x - *y).abs() / (y.abs() + glam::Vec3::splat(1e-3))).max_element())
            .fold(0.0, f32::max)
    }

    /// A new count of light samples reaches the NEE drawn from the next batch on (the
    /// settings table's `Resolve`): nothing is traced again or re-splatted, the next eye
    /// pass's direct light is drawn with it, and its mean stays (NEE is unbiased at any
    /// count).
    #[test]
    fn more_light_samples_reach_the_next_draws_without_a_retrace() {
        // Larger than `small_rs`: at its 256 pixels the two means differed by 23% (0.277 →
        // 0.214, the noise of one NEE sample a pixel), here by 6% (0.279 → 0.262).
        let mut m = rs_of_size(48);
        // Its twin keeps one light sample: the same seeds, so its direct light differs from
        // `m`'s only if the new count was used.
        let mut twin = rs_of_size(48);
        for r in [&mut m, &mut twin] {
            traced(r);
            traced(r);
        }
        let before = m.film();
        let photons = m.stats().photons_traced;
        let mut s = m.settings().clone();
        s.nee_samples = 4;
        m.update(&s).unwrap();
        assert_eq!(m.settings().nee_samples, 4);
        assert_eq!(m.stats().photons_traced, photons, "no photon traced again");
        assert_eq!(m.step(), Step::Traced, "no re-splat before the next batch");
        let after = m.film();
        let mean =
            |v: &[glam::Vec3]| v.iter().map(|c| c.x + c.y + c.z).sum::<f32>() / v.len() as f32;
        assert_ne!(
            before.direct, after.direct,
            "the direct light was drawn anew"
        );
        assert_eq!(twin.step(), Step::Traced);
        assert_ne!(
            twin.film().direct,
            after.direct,
            "the next eye pass drew its direct light with 4 light samples, not 1"
        );
        let (a, b) = (mean(&before.direct), mean(&after.direct));
        eprintln!("direct light's mean {a} -> {b}");
        assert!((a - b).abs() < 0.1 * a, "direct light's mean {a} -> {b}");
    }

    /// In the window (paced, not headless) a new batch is splatted in
    /// [`crate::methods::photon_core::SPLAT_PIECES`] steps: the first ones are partial (no
    /// image is whole between them), the last completes it, and the film is the one batch a
    /// headless render splats at once. A view set between the pieces re-splats the stored
    /// batch, in pieces as well, to the same film.
    #[test]
    fn the_window_splats_a_batch_in_pieces_and_a_change_between_them_loses_nothing() {
        use crate::methods::photon_core::SPLAT_PIECES;
        let mut whole = small_rs();
        assert_eq!(whole.step(), Step::Traced);
        let reference = whole.film();

        let mut m = small_rs();
        m.pace();
        let mut partial = 0;
        loop {
            match m.step() {
                Step::Partial => {
                    partial += 1;
                    assert!(m.mid_step());
                }
                Step::Traced => break,
                Step::Resplatted => panic!("nothing to re-splat"),
                Step::Side => panic!("no side was given up"),
            }
        }
        assert_eq!(partial, SPLAT_PIECES - 1);
        assert!(!m.mid_step());
        let d = largest_difference(&m.film(), &reference);
        assert!(d < 1e-4, "pieces against a whole batch: {d}");

        let mut cut = small_rs();
        cut.pace();
        assert_eq!(cut.step(), Step::Partial);
        let camera = cut.camera().clone();
        let (w, h, spp) = (
            cut.settings().width,
            cut.settings().height,
            cut.settings().spp,
        );
        cut.set_view(camera, w, h, spp).unwrap();
        assert!(!cut.mid_step() && cut.catching_up());
        // The re-splat goes in pieces too.
        let mut pieces = 0;
        while cut.catching_up() {
            match cut.step() {
                Step::Partial => pieces += 1,
                Step::Resplatted => assert!(!cut.catching_up()),
                Step::Traced => panic!("a new batch before the re-splat ended"),
                Step::Side => panic!("no side was given up"),
            }
        }
        assert_eq!(pieces, SPLAT_PIECES - 1);
        assert_eq!(cut.passes(), 1);
        let d = largest_difference(&cut.film(), &reference);
        assert!(d < 1e-4, "a batch cut short, re-splatted: {d}");
    }

    /// In the window a re-splat puts every stored batch back into the image before any of
    /// them is splatted again at the error estimate's fine bandwidth (docs/deviations.md §51,
    /// "The fine splat deferred"): until the last fine splat the pass shows no estimate
    /// values (L(h/k) would lack batches that L(h) holds), and once they are all paid its
    /// values are those of a headless render, which splats both at once.
    #[test]
    fn the_window_defers_a_resplats_fine_splat_and_loses_nothing() {
        use crate::methods::photon_core::SPLAT_PIECES;
        let open = |paced: bool| {
            let mut m = estimating_rs(paced);
            for _ in 0..3 {
                traced(&mut m);
            }
            assert!(
                !m.film().pass_error.is_empty(),
                "new batches splat h/k at once"
            );
            let mut s = m.settings().clone();
            s.bandwidth.sensitivity_s = 0.35;
            m.update(&s).unwrap();
            assert!(m.catching_up());
            m
        };
        let mut window = open(true);
        let mut headless = open(false);
        while headless.catching_up() {
            headless.step();
        }
        let expected = headless.film().pass_error;
        assert!(!expected.is_empty());
        // The window: three batches re-splatted (in pieces), then three fine splats, of which
        // only the last shows a frame (the image does not change).
        let (mut resplatted, mut without_values, mut steps) = (0, 0, 0);
        while window.catching_up() {
            steps += 1;
            if window.step() == Step::Resplatted {
                resplatted += 1;
                if window.catching_up() {
                    without_values += 1;
                    assert!(
                        window.film().pass_error.is_empty(),
                        "an estimate half splat"
                    );
                }
            }
        }
        assert_eq!(
            resplatted, 4,
            "three batches, then the last of their fine splats"
        );
        assert_eq!(without_values, 3);
        assert!(steps >= 3 * SPLAT_PIECES + 3, "{steps} steps");
        let got = window.film().pass_error;
        assert_eq!(got.len(), expected.len());
        let scale = expected.iter().map(|e| e.bias.abs()).fold(0.0, f32::max);
        assert!(scale > 0.0, "the kernels show a bias");
        for (g, e) in got.iter().zip(&expected) {
            for (a, b) in [(g.bias, e.bias), (g.difference, e.difference)] {
                assert!((a - b).abs() <= 1e-4 * scale, "{a} against {b}");
            }
        }
    }

    /// A batch whose pieces went partly at h/k (the view came to rest, or turned interactive,
    /// between two of them) cannot be completed without splatting some rays twice: the side makes no
    /// estimate, rather than reading the missing pieces as kernel bias.
    #[test]
    fn a_batch_splatted_at_h_over_k_in_part_makes_no_estimate() {
        let mut m = estimating_rs(true);
        traced(&mut m);
        assert!(!m.film().pass_error.is_empty(), "a whole batch at h/k");
        // The first piece in an interactive view, the rest at rest.
        m.set_interactive(true);
        assert_eq!(m.step(), Step::Partial);
        m.set_interactive(false);
        traced(&mut m);
        assert!(m.film().pass_error.is_empty(), "a batch at h/k in part");
        traced(&mut m);
        assert!(
            m.film().pass_error.is_empty(),
            "the side's fine accumulators stay short of that batch"
        );
    }

    /// Paced by the clock, an eye pass that costs more than the batches splatted onto it
    /// stays (its NEE is redrawn with every batch instead, when a draw costs less than a
    /// batch); once the batches have taken as long as the pass, the next one is drawn. The
    /// costs are set here, not timed, so the test holds on any machine. Unpaced, every
    /// batch gets its own pass (these batches hold far more than 0.05 photons per sample).
    #[test]
    fn a_paced_render_draws_eye_passes_as_they_pay() {
        let mut m = small_rs();
        traced(&mut m);
        traced(&mut m);
        assert_eq!(m.core().eye_passes(), 2, "unpaced: a pass per batch");
        assert_eq!(m.core().side().nee_draws, 1);

        let mut m = small_rs();
        m.pace();
        m.core_mut().clock.pass_cost = 1e9;
        for _ in 0..4 {
            m.core_mut().clock.nee_cost = 0.0;
            traced(&mut m);
        }
        assert_eq!(m.core().eye_passes(), 1, "a dear pass is kept");
        assert_eq!(m.core().pass_batches(), 4);
        assert_eq!(
            m.core().side().nee_draws,
            4,
            "NEE redrawn with each batch after the first"
        );

        // With its cost measured: the time since a draw counts the batches after it, not
        // the draw (else every draw would pay for the next, and NEE be redrawn every batch).
        m.core_mut().clock.nee_cost = 0.0;
        let before = m.core().clock.pass_spent;
        traced(&mut m);
        let c = m.core().clock;
        assert_eq!(m.core().side().nee_draws, 5);
        assert!(c.nee_cost > 0.0, "the draw was timed");
        assert!(
            c.since_nee + c.nee_cost <= c.pass_spent - before + 1e-9,
            "since the draw {} + the draw {} within the step {}",
            c.since_nee,
            c.nee_cost,
            c.pass_spent - before
        );

        m.core_mut().clock.nee_cost = 1e9;
        traced(&mut m);
        assert_eq!(m.core().side().nee_draws, 5, "a dear NEE draw waits");

        m.core_mut().clock.pass_cost = 0.0;
        traced(&mut m);
        assert_eq!(
            m.core().eye_passes(),
            2,
            "a pass that has paid for itself is redrawn"
        );
        assert_eq!(m.core().pass_batches(), 1);
    }
}
