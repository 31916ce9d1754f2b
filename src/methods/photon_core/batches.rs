//! Tracing and splatting batches: a new batch (stored, or streamed a wave at a time when no
//! batch is kept), a stored batch splatted again, and the traced glossy lobes' share of each.

use super::PhotonCore;
use crate::methods::Step;
use crate::methods::eye_side::{EyeSide, LobeDraws, splat_at_fine_bandwidth};
use crate::pipeline::directional::DirectionalMode;
use crate::pipeline::photon::{
    Bandwidth, ClampCounts, LightPassSettings, PhotonRay, plan_light_pass,
};
use crate::pipeline::splat::{SplatCounters, prepare_and_splat};
use crate::scene::Scene;
use crate::settings::DirectMode;
use std::time::Instant;

/// A paced render (the window) splats a new batch in at least this many pieces, one per step,
/// so that a command (a camera move, a slider) waits for a piece rather than a whole batch
/// (docs/benchmarks.md, "The previewer": a camera move while tracing).
pub const SPLAT_PIECES: usize = 8;

/// A piece takes about this long: a batch whose last splat took longer than
/// [`SPLAT_PIECES`] of them is cut into more pieces, up to [`MAX_SPLAT_PIECES`]. A move waits
/// for half a piece on average: 8 pieces of CORNELL BOX I at 500×500 took 75–125 ms each
/// early in a render, more with the error estimate's second splat and in scenes of wide
/// kernels (docs/deviations.md §62).
pub const PIECE_SECONDS: f64 = 0.04;

/// The most pieces a batch's splat is cut into.
pub const MAX_SPLAT_PIECES: usize = 64;

/// The pieces of a batch whose last splat took `last_splat` seconds: about [`PIECE_SECONDS`]
/// each, between [`SPLAT_PIECES`] and [`MAX_SPLAT_PIECES`].
fn pieces_for(last_splat: f64) -> usize {
    let by_time = (last_splat / PIECE_SECONDS).ceil();
    if by_time.is_nan() {
        return SPLAT_PIECES;
    }
    (by_time.min(MAX_SPLAT_PIECES as f64) as usize).max(SPLAT_PIECES)
}

/// A stored batch being splatted, new or re-splatted: whole in one piece, or in the window a
/// piece at a time ([`SPLAT_PIECES`]).
pub(crate) struct PartialSplat {
    /// The batch (an index into the store, which folds nothing until it is done).
    batch: usize,
    /// Just traced (else re-splatted after a change).
    new: bool,
    /// Its rays splatted so far.
    next: usize,
    /// Rays per piece.
    piece: usize,
    /// Seconds its pieces took so far.
    spent: f64,
    bw: [Bandwidth; 3],
    /// What its photons reached, for the emission guide (empty without one).
    reach: Vec<u32>,
    /// Pieces splatted at the error estimate's fine bandwidth as they went, and pieces
    /// that were not ([`PhotonCore::fine_now`]; the view can turn interactive or come to
    /// rest between two pieces).
    fine_pieces: usize,
    fine_missed: usize,
}

impl PartialSplat {
    /// Just traced (else a stored batch re-splatted after a change).
    pub(super) fn is_new(&self) -> bool {
        self.new
    }
}

impl PhotonCore {
    /// Trace one light pass of M photons, splat it with the bandwidth for the total M so
    /// far ([`PhotonCore::step`] calls it when no re-splat is pending). A paced render that
    /// is not headless (the window) splats the batch's first piece only and returns
    /// [`Step::Partial`]; the next steps splat the rest ([`PhotonCore::splat_piece`]).
    /// Elsewhere the batch goes whole, as one piece.
    pub(super) fn run_batch(&mut self) -> Step {
        debug_assert!(
            !self.side.tree.is_released(),
            "a render takes no step after its final film"
        );
        debug_assert!(!self.resplat_pending(), "re-splats come first");
        if self.store.frees_every_batch() {
            self.stream_batch();
        } else {
            let t = Instant::now();
            let b = self
                .store
                .trace(&self.scene, &self.settings, self.splat_direct());
            self.timings.t_light += t.elapsed().as_secs_f64();
            let p = self.begin_pieces(b, true, self.pieces());
            return self.splat_piece(p);
        }
        self.fold_store();
        Step::Traced
    }

    /// The pieces a batch's splat is cut into: in a paced render that is not headless (the
    /// window) [`SPLAT_PIECES`], or more where the last batch's splat would make them longer
    /// than [`PIECE_SECONDS`]; else one.
    pub(super) fn pieces(&self) -> usize {
        if self.paced && !self.whole_batches {
            pieces_for(self.last_splat)
        } else {
            1
        }
    }

    /// Start splatting stored batch `b` (`new`: just traced) in `pieces` pieces.
    pub(super) fn begin_pieces(&mut self, b: usize, new: bool, pieces: usize) -> PartialSplat {
        let m = self.store.batches()[b].m;
        let bw = self.bandwidths(m);
        self.note_bandwidth(&bw, m);
        let cells = if new { self.store.guide_cells() } else { 0 };
        let rays = self.store.batches()[b].rays.len();
        PartialSplat {
            batch: b,
            new,
            next: 0,
            piece: rays.div_ceil(pieces.max(1)).max(1),
            spent: 0.0,
            bw,
            reach: vec![0u32; cells],
            fine_pieces: 0,
            fine_missed: 0,
        }
    }

    /// Splat the next piece of `p`: [`Step::Partial`] until it is whole (`p` then waits in
    /// [`PhotonCore::splatting`]), then counted and its lobes drawn ([`Step::Resplatted`] for
    /// a stored batch; a new one also teaches the guide and folds the store, [`Step::Traced`]).
    pub(super) fn splat_piece(&mut self, mut p: PartialSplat) -> Step {
        let t = Instant::now();
        let fine_now = self.fine_now(p.new);
        let batch = &self.store.batches()[p.batch];
        let rays = &batch.rays;
        let end = (p.next + p.piece).min(rays.len());
        self.counters += splat_rays(
            &self.scene,
            &mut self.side,
            &rays[p.next..end],
            batch.phis.get(p.next..end).unwrap_or(&[]),
            &p.bw,
            self.config.splatted.mask(),
            self.settings.direct == DirectMode::Photons,
            self.settings.radiance_map,
            Some(&mut p.reach[..]).filter(|r| !r.is_empty()),
            fine_now,
        );
        p.next = end;
        if fine_now {
            p.fine_pieces += 1;
        } else {
            p.fine_missed += 1;
        }
        self.generation += 1;
        let whole = end >= rays.len();
        let spent = t.elapsed().as_secs_f64();
        self.timings.t_splat += spent;
        p.spent += spent;
        if !whole {
            self.splatting = Some(p);
            return Step::Partial;
        }
        // A batch cut into pieces at the view's full size sizes the next batches' pieces (a
        // dragged view re-splats whole, at its own size).
        if p.piece < rays.len() {
            self.last_splat = p.spent;
        }
        // A batch none of whose pieces went at h/k is owed at rest (skipped in an interactive
        // view); one that went partly cannot be completed without splatting some rays twice,
        // so the side makes no estimate.
        if p.fine_missed > 0 && !self.side.acc_fine.is_empty() {
            if p.fine_pieces > 0 || self.interactive {
                self.fine_skipped = true;
            } else {
                self.fine_owed.push((p.batch, p.bw));
            }
        }
        self.splatted += 1;
        self.draw_lobes(p.batch);
        if !p.new {
            return Step::Resplatted;
        }
        self.store.learn(&p.reach);
        self.fold_store();
        Step::Traced
    }

    /// Whether a batch's pieces (`new`: just traced) are splatted at the error estimate's
    /// fine bandwidth as they go. In the window a re-splatted batch's fine splat waits until
    /// every stored batch is back in the image ([`PhotonCore::splat_fine`]), so that the
    /// first frame after a change does not wait for it, and an interactive view (a dragged
    /// camera, the coarse first image: both replaced by a view at rest) makes none
    /// (docs/deviations.md §51, "The fine splat deferred"). Headless renders splat it at once.
    fn fine_now(&self, new: bool) -> bool {
        let window = self.paced && !self.whole_batches;
        let defer = self.interactive || !new;
        !window || !defer
    }

    /// The error estimate's splat at h/k of stored batch `b`, re-splatted earlier at `bw`
    /// (a debt of [`PhotonCore::fine_now`]).
    pub(super) fn splat_fine(&mut self, b: usize, bw: &[Bandwidth; 3]) {
        let t = Instant::now();
        if !self.side.acc_fine.is_empty() {
            let batch = &self.store.batches()[b];
            splat_at_fine_bandwidth(
                &self.side.tree,
                &batch.rays,
                &batch.phis,
                bw,
                self.config.splatted.mask(),
                self.settings.direct == DirectMode::Photons,
                &self.scene,
                &mut self.side.acc_fine,
            );
        }
        self.generation += 1;
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// Fold the oldest batches beyond the ray budget (after a batch is whole).
    fn fold_store(&mut self) {
        let t = Instant::now();
        self.folded_total += self.store.fold();
        // The dropped batches are the oldest; those of earlier eye passes were not splatted
        // onto this one, whose batches are the newest `splatted` of the store.
        let stored = self.store.batches().len();
        if self.splatted > stored {
            self.folded += self.splatted - stored;
            self.splatted = stored;
        }
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// [`PhotonCore::run_batch`] when no batch is kept once splatted (a headless rs render):
    /// the light pass is counted first, then traced again a wave at a time, and each wave is
    /// splatted (onto the eye side and the traced lobes) and dropped, so the batch's rays are
    /// never held whole (docs/benchmarks.md, "Memory"). The same rays, in the same order, with
    /// the same bandwidths as a stored batch; the second trace costs one more T_L.
    fn stream_batch(&mut self) {
        let t = Instant::now();
        let guide = self.store.take_guide();
        let lps = LightPassSettings {
            guide: guide.as_ref(),
            ..self
                .store
                .light_pass_settings(&self.settings, self.splat_direct())
        };
        let density = self.store.density_for(&lps.budgets);
        let plan = plan_light_pass(&self.scene, &lps, density);
        let b = self.store.add_streamed(&plan, self.settings.photons);
        self.timings.t_light += t.elapsed().as_secs_f64();
        let m = self.store.batches()[b].m;
        let bw = self.bandwidths(m);
        self.note_bandwidth(&bw, m);
        let classes = self.config.splatted.mask();
        let mut lobes = if self.config.lobes == LobeDraws::PerBatch {
            self.lobes.begin_batch(
                &self.scene,
                &self.camera,
                &self.settings,
                &self.side,
                classes,
                true,
                &mut self.timings,
            )
        } else {
            None
        };

        let t = Instant::now();
        let mut t_splat = 0.0;
        let (scene, side, counters) = (&self.scene, &mut self.side, &mut self.counters);
        let direct = self.settings.direct;
        let mode = self.settings.radiance_map;
        let mut reach = vec![0u32; guide.as_ref().map_or(0, |g| g.cells())];
        let store = &self.store;
        let mut phis = Vec::new();
        let clamps = &mut self.streamed_clamps;
        plan.stream(scene, &lps, |rays| {
            let t = Instant::now();
            let photons = direct == DirectMode::Photons;
            let r = Some(&mut reach[..]).filter(|r| !r.is_empty());
            store.phis(rays, &mut phis);
            for (c, wave) in clamps.iter_mut().zip(ClampCounts::count(rays, &phis, &bw)) {
                *c += wave;
            }
            *counters += splat_rays(
                scene, side, rays, &phis, &bw, classes, photons, mode, r, true,
            );
            if let Some(l) = lobes.as_mut() {
                l.gather(scene, rays, &phis, &bw);
            }
            t_splat += t.elapsed().as_secs_f64();
        });
        self.timings.t_light += t.elapsed().as_secs_f64() - t_splat;
        let t = Instant::now();
        if let Some(l) = lobes {
            self.lobes.finish_batch(l);
        }
        self.store.put_guide(guide);
        self.store.learn(&reach);
        self.timings.t_splat += t_splat + t.elapsed().as_secs_f64();
        self.splatted += 1;
        self.generation += 1;
    }

    /// With [`LobeDraws::PerBatch`], new directions for the traced glossy lobes, and stored
    /// batch `b` gathered where they land (timed into T_E, T_D and T_S by the lobes
    /// themselves).
    pub(super) fn draw_lobes(&mut self, b: usize) {
        if self.config.lobes != LobeDraws::PerBatch {
            return;
        }
        let batch = &self.store.batches()[b];
        let bw = self.bandwidths(batch.m);
        self.lobes.add_batch(
            &self.scene,
            &self.camera,
            &self.settings,
            &self.side,
            &batch.rays,
            &batch.phis,
            &bw,
            self.config.splatted.mask(),
            !self.interactive,
            &mut self.timings,
        );
    }
}

/// Splat `rays` of the `classes` (direct, indirect, caustic), with the floors of their φ
/// `phis` (empty: none), onto the eye side's targets
/// (direct photons, when `direct_photons`, into their own accumulators); with `reach`, count
/// per emission cell the rays that reached a target (the emission guide's feedback); with
/// `fine`, at the error estimate's fine bandwidth too (when the side estimates).
#[allow(clippy::too_many_arguments)]
fn splat_rays(
    scene: &Scene,
    side: &mut EyeSide,
    rays: &[PhotonRay],
    phis: &[f32],
    bw: &[Bandwidth; 3],
    classes: [bool; 3],
    direct_photons: bool,
    mode: DirectionalMode,
    mut reach: Option<&mut [u32]>,
    fine: bool,
) -> SplatCounters {
    let mut counters = SplatCounters::default();
    if classes == [false; 3] {
        return counters;
    }
    counters += prepare_and_splat(
        &side.tree,
        rays,
        phis,
        bw,
        classes,
        mode,
        scene,
        &mut side.acc_indirect,
        Some(scene),
        reach.as_deref_mut(),
    );
    if direct_photons {
        counters += prepare_and_splat(
            &side.tree,
            rays,
            phis,
            bw,
            [true, false, false],
            mode,
            scene,
            &mut side.acc_direct,
            Some(scene),
            reach,
        );
    }
    if fine && !side.acc_fine.is_empty() {
        let acc = &mut side.acc_fine;
        splat_at_fine_bandwidth(
            &side.tree,
            rays,
            phis,
            bw,
            classes,
            direct_photons,
            scene,
            acc,
        );
    }
    counters
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch's pieces follow the last splat's time, within [8, 64].
    #[test]
    fn a_batch_is_cut_into_pieces_of_about_forty_milliseconds() {
        assert_eq!(pieces_for(0.0), SPLAT_PIECES);
        assert_eq!(pieces_for(0.2), SPLAT_PIECES);
        assert_eq!(pieces_for(0.8), 20);
        assert_eq!(pieces_for(0.81), 21);
        assert_eq!(pieces_for(100.0), MAX_SPLAT_PIECES);
        assert_eq!(pieces_for(f64::NAN), SPLAT_PIECES);
    }
}
