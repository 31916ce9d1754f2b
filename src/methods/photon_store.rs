//! The stored photon rays: the pilot (§6), every traced batch with the class sizes M its
//! bandwidth is computed for (eq. 8), and a ray budget beyond which the oldest batches are
//! dropped. Photon rays are view-independent and bandwidth is a pure function of stored ray
//! data, so the store is what lets a new view or new C/S/R re-splat without re-tracing.

use crate::pipeline::photon::{
    Bandwidth, BandwidthParams, ClampCounts, ClassBudgets, EmissionGuide, HitDensity,
    LightPassPlan, LightPassSettings, PhotonBatch, PhotonClass, PhotonRay, Pilot, light_pass,
    pilot,
};
use crate::scene::Scene;
use crate::settings::RenderSettings;

/// One stored light pass with the class sizes M its bandwidth was computed for.
pub struct StoredBatch {
    /// The photon rays.
    pub rays: Vec<PhotonRay>,
    /// Each ray's φ, its floor from the photons stored up to its batch
    /// ([`HitDensity::phi`]; docs/deviations.md §63): 4 bytes beside a ray's 64, since a
    /// [`PhotonRay`] has no room left.
    pub phis: Vec<f32>,
    /// Stored rays per class over every batch up to and including this one (eq. 8's M).
    pub m: [u64; 3],
    /// Its rays at the bandwidth bounds under the parameters they were last counted for.
    clamps: Option<(BandwidthParams, [ClampCounts; 3])>,
}

/// The pilot and the stored batches.
pub struct PhotonStore {
    pilot: Pilot,
    batches: Vec<StoredBatch>,
    /// Stored rays per class over all traced batches (each batch's M, eq. 8).
    m_total: [u64; 3],
    /// Stored rays per class of the first batch that stored any; 0 until then. With the
    /// photons that batch asked for (`photons_first`) and the photons a batch asks for now
    /// (`batch_photons`) it gives the progressive schedule's M₁ ([`PhotonStore::anchor`]).
    m_first: [u64; 3],
    /// Photons per batch (settings' M) asked for by the batch that set `m_first`, per class.
    photons_first: [u64; 3],
    /// Photons per batch (settings' M) asked for now ([`PhotonStore::set_batch_photons`]).
    batch_photons: u64,
    /// Bandwidths follow the progressive schedule (deviations §43), else eq. 8 alone.
    progressive_bandwidth: bool,
    /// Photons traced (depends on thread count: the last wave may trace beyond the budget).
    pub photons_traced: u64,
    /// Photon paths and rays dropped for NaN or infinite values, over all batches.
    pub invalid_photon_rays: u64,
    /// Photons whose rays were kept; the next batch's photon indices start here.
    photons_used: u64,
    /// Photons the newest batch drew from the lights (the largest class's count).
    last_batch_photons: u64,
    /// Keep at most this many photon rays; older batches are dropped ([`PhotonStore::fold`]).
    pub max_stored_rays: usize,
    /// [`PhotonStore::fold`] keeps the newest batch whatever the budget (false only for a
    /// method whose film never reads stored rays, in a render that never re-splats).
    pub keep_newest: bool,
    /// Rays dropped by [`PhotonStore::fold`] while `keep_newest` was false: a headless rs
    /// render frees every batch once it is splatted, and its stats still count them.
    pub released: usize,
    /// Photons where the camera looks (docs/deviations.md §44): the light passes emit as it
    /// says; `None`, in proportion to power.
    guide: Option<EmissionGuide>,
    /// Where every batch's rays landed, for the floor from the photons stored
    /// (docs/deviations.md §63); made with the first light pass.
    density: Option<HitDensity>,
    /// Count where the rays land and give each its φ (a method that splats them; photon
    /// mapping gathers and needs neither).
    floors: bool,
}

impl PhotonStore {
    /// An empty store with the pilot of `scene` (§6).
    pub fn new(scene: &Scene, seed: u64) -> Self {
        Self {
            pilot: pilot(scene, seed),
            batches: Vec::new(),
            m_total: [0; 3],
            m_first: [0; 3],
            photons_first: [0; 3],
            batch_photons: 0,
            progressive_bandwidth: true,
            photons_traced: 0,
            invalid_photon_rays: 0,
            photons_used: 0,
            last_batch_photons: 0,
            max_stored_rays: usize::MAX,
            keep_newest: true,
            released: 0,
            guide: None,
            density: None,
            floors: true,
        }
    }

    /// Count where the rays land and give each ray its φ (true, the default), or neither
    /// (a method that never splats: its batches' `phis` stay empty). Set before the first
    /// batch.
    pub fn set_floors(&mut self, on: bool) {
        self.floors = on;
    }

    /// The count of where the rays landed, made for a first light pass of `budgets` when
    /// there is none (its cubes follow that batch's typical bandwidth); `None` when the store
    /// keeps no floors ([`PhotonStore::set_floors`]).
    pub fn density_for(&mut self, budgets: &ClassBudgets) -> Option<&mut HitDensity> {
        if !self.floors {
            return None;
        }
        let pilot = &self.pilot;
        Some(
            self.density
                .get_or_insert_with(|| HitDensity::for_pilot(pilot, budgets.total())),
        )
    }

    /// Emit the next light passes' photons where the camera looks, learning from each batch
    /// ([`PhotonStore::learn`]), or in proportion to power (`on` false). Turning it on
    /// starts a guide that has learned nothing.
    pub fn set_guided(&mut self, scene: &Scene, on: bool) {
        match (on, self.guide.is_some()) {
            (true, false) => self.guide = Some(EmissionGuide::new(&scene.lights)),
            (false, true) => self.guide = None,
            _ => {}
        }
    }

    /// The emission guide, when photons are guided.
    pub fn guide(&self) -> Option<&EmissionGuide> {
        self.guide.as_ref()
    }

    /// Cells of the emission guide (0 without one): the length of the `reach` counts that
    /// [`PhotonStore::learn`] takes.
    pub fn guide_cells(&self) -> usize {
        self.guide.as_ref().map_or(0, |g| g.cells())
    }

    /// Teach the guide what the newest batch's rays reached: `reach[c]` rays of photons from
    /// cell c splatted onto at least one eye sample.
    pub fn learn(&mut self, reach: &[u32]) {
        let photons = self.batches.last().map_or(0, |_| self.last_batch_photons);
        if let Some(g) = self.guide.as_mut() {
            g.learn(reach, photons);
        }
    }

    /// Lend the emission guide out for a streamed light pass (the store changes meanwhile);
    /// [`PhotonStore::put_guide`] gives it back.
    pub fn take_guide(&mut self) -> Option<EmissionGuide> {
        self.guide.take()
    }

    /// Give back the guide [`PhotonStore::take_guide`] lent.
    pub fn put_guide(&mut self, guide: Option<EmissionGuide>) {
        self.guide = guide;
    }

    /// Forget what the guide learned (a new view).
    pub fn reset_guide(&mut self) {
        if let Some(g) = self.guide.as_mut() {
            g.reset();
        }
    }

    /// The pilot's statistics.
    pub fn pilot(&self) -> &Pilot {
        &self.pilot
    }

    /// The stored batches, oldest first.
    pub fn batches(&self) -> &[StoredBatch] {
        &self.batches
    }

    /// Trace one light pass of `settings.photons` stored rays (split by the fractions; direct
    /// photons only when `with_direct`) and store it; returns its index.
    pub fn trace(&mut self, scene: &Scene, settings: &RenderSettings, with_direct: bool) -> usize {
        let lps = LightPassSettings {
            guide: self.guide.as_ref(),
            ..self.light_pass_settings(settings, with_direct)
        };
        let batch = light_pass(scene, &lps);
        // The count's cubes follow the first light pass's budgets (or a streamed pass makes
        // it for its plan); `add` counts the batch.
        self.density_for(&lps.budgets);
        self.add(batch, settings.photons)
    }

    /// The next light pass's settings: its class budgets, and photon indices after those of
    /// the batches so far; without the emission guide, which the caller lends
    /// ([`PhotonStore::take_guide`]).
    pub fn light_pass_settings(
        &self,
        settings: &RenderSettings,
        with_direct: bool,
    ) -> LightPassSettings<'static> {
        LightPassSettings {
            budgets: ClassBudgets::from_fractions(
                settings.photons,
                settings.fractions,
                with_direct,
            ),
            max_emitted_factor: settings.max_emitted_factor,
            seed: settings.seed,
            first_photon: self.photons_used,
            units: self.pilot.units(),
            guide: None,
        }
    }

    /// Count a light pass of `photons` (settings' M) planned from
    /// [`PhotonStore::light_pass_settings`] whose rays will be streamed, not stored
    /// ([`PhotonStore::frees_every_batch`]): its M joins the total and its rays count as
    /// released; it is stored as a batch without rays until the next [`PhotonStore::fold`].
    /// Its landings were counted by the plan ([`PhotonStore::density_for`]). Returns its
    /// index.
    pub fn add_streamed(&mut self, plan: &LightPassPlan, photons: u64) -> usize {
        self.released += plan.batch.stored.iter().sum::<u64>() as usize;
        self.add(
            PhotonBatch {
                rays: Vec::new(),
                ..plan.batch.clone()
            },
            photons,
        )
    }

    /// Store `batch`, traced for `photons` (settings' M).
    fn add(&mut self, batch: PhotonBatch, photons: u64) -> usize {
        self.photons_traced += batch.traced;
        self.invalid_photon_rays += batch.invalid;
        self.last_batch_photons = batch.emitted.iter().copied().max().unwrap_or(0);
        self.photons_used += self.last_batch_photons;
        for c in 0..3 {
            self.m_total[c] += batch.stored[c];
            if self.m_first[c] == 0 {
                self.m_first[c] = self.m_total[c];
                self.photons_first[c] = photons;
            }
        }
        let mut phis = Vec::new();
        if let Some(d) = self.density.as_mut() {
            d.add_batch(&batch.rays, batch.stored, &mut phis);
        }
        self.batches.push(StoredBatch {
            rays: batch.rays,
            phis,
            m: self.m_total,
            clamps: None,
        });
        self.batches.len() - 1
    }

    /// No batch is kept once splatted (a headless rs render: [`PhotonStore::keep_newest`] off
    /// and no ray budget), so a batch's rays can be splatted as they are traced and never held.
    pub fn frees_every_batch(&self) -> bool {
        !self.keep_newest && self.max_stored_rays == 0
    }

    /// Drop the oldest batches beyond the ray budget (keeping the newest unless
    /// `keep_newest` is off); returns how
    /// many were dropped. Their light stays wherever it was splatted until the next re-splat.
    pub fn fold(&mut self) -> usize {
        let mut stored = self.rays();
        let mut drop = 0;
        let keep = usize::from(self.keep_newest);
        // A store that frees every batch drops them all, streamed ones (no rays) included.
        let free_all = self.frees_every_batch();
        while self.batches.len() - drop > keep && (free_all || stored > self.max_stored_rays) {
            stored -= self.batches[drop].rays.len();
            if !self.keep_newest {
                self.released += self.batches[drop].rays.len();
            }
            drop += 1;
        }
        self.batches.drain(..drop);
        drop
    }

    /// Stored photon rays over all batches.
    pub fn rays(&self) -> usize {
        self.batches.iter().map(|b| b.rays.len()).sum()
    }

    /// Photon rays per class over all traced batches.
    pub fn rays_per_class(&self) -> [u64; 3] {
        self.m_total
    }

    /// Bytes of the stored rays with their φ.
    pub fn memory_bytes(&self) -> usize {
        let phis: usize = self.batches.iter().map(|b| b.phis.len()).sum();
        self.rays() * std::mem::size_of::<PhotonRay>() + phis * std::mem::size_of::<f32>()
    }

    /// The floor's φ of each ray of `rays` (a streamed wave of the newest batch) into `out`,
    /// from the landings counted so far ([`HitDensity::phi`]).
    pub fn phis(&self, rays: &[PhotonRay], out: &mut Vec<f32>) {
        match &self.density {
            Some(d) => d.phis(rays, out),
            None => out.clear(),
        }
    }

    /// Bytes of the count of where the rays landed (kept for the view's life, also by a
    /// headless render that frees its rays).
    pub fn density_bytes(&self) -> usize {
        self.density.as_ref().map_or(0, |d| d.bytes())
    }

    /// Bytes of the emission guide (docs/deviations.md §44): kept for the view's life, also
    /// by a headless render that frees its rays.
    pub fn guide_bytes(&self) -> usize {
        self.guide.as_ref().map_or(0, |g| g.bytes())
    }

    /// The bandwidth per class that a batch with class sizes `m` (over every batch up to it)
    /// is splatted with: eq. 8, shrunk by the progressive schedule beyond the first batch
    /// unless it is off ([`PhotonStore::set_progressive_bandwidth`]).
    pub fn bandwidths(&self, params: &BandwidthParams, m: [u64; 3]) -> [Bandwidth; 3] {
        let mean_r = self.pilot.mean_r(params.sensitivity_s);
        let anchor = self.anchor();
        PhotonClass::ALL.map(|c| {
            let c = c as usize;
            Bandwidth::progressive(params, &self.pilot, m[c], anchor[c], mean_r)
        })
    }

    /// The progressive schedule's M₁ per class (0: eq. 8 alone): the M the class's first
    /// batch stored, scaled to the photons a batch asks for now, so that M/M₁ counts batches
    /// of the current size whatever the first one's (the previewer's coarse first image
    /// traces half a batch; a slider can change the size later).
    fn anchor(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            if !self.progressive_bandwidth || self.photons_first[c] == 0 {
                return 0.0;
            }
            self.m_first[c] as f64 * self.batch_photons as f64 / self.photons_first[c] as f64
        })
    }

    /// Follow the progressive bandwidth schedule (true, the default) or eq. 8 alone; returns
    /// whether any stored batch's bandwidth changed (they then want a re-splat).
    pub fn set_progressive_bandwidth(&mut self, on: bool) -> bool {
        self.changing_anchor(|s| s.progressive_bandwidth = on)
    }

    /// The photons (settings' M) each batch asks for from now on; returns whether any stored
    /// batch's bandwidth changed with the schedule's M₁ (they then want a re-splat).
    pub fn set_batch_photons(&mut self, photons: u64) -> bool {
        self.changing_anchor(|s| s.batch_photons = photons)
    }

    /// Apply `change`; forget the clamp counts and report true when it moved the bandwidth
    /// of any stored batch.
    fn changing_anchor(&mut self, change: impl FnOnce(&mut Self)) -> bool {
        let before = self.anchor();
        change(self);
        let after = self.anchor();
        let changed = self.batches.iter().any(|b| {
            (0..3).any(|c| {
                Bandwidth::shrink(b.m[c], before[c]) != Bandwidth::shrink(b.m[c], after[c])
            })
        });
        if changed {
            for b in &mut self.batches {
                b.clamps = None;
            }
        }
        changed
    }

    /// Photon mapping's largest gather radius: rs's h_max (eq. 8's upper bound from μC and R)
    /// for the largest class stored, so both methods share one bound that follows the
    /// lighting's scale, never the bounding box.
    pub fn largest_h_max(&self, params: &BandwidthParams) -> f32 {
        // Eq. 8 alone: photon mapping's K-NN bound does not follow rs's schedule.
        let mean_r = self.pilot.mean_r(params.sensitivity_s);
        let bw = PhotonClass::ALL
            .map(|c| Bandwidth::new(params, &self.pilot, self.m_total[c as usize], mean_r));
        PhotonClass::ALL
            .iter()
            .filter(|&&c| self.m_total[c as usize] > 0)
            .map(|&c| bw[c as usize].h_max)
            .fold(0.0f32, f32::max)
            .max(bw[PhotonClass::Indirect as usize].h_max)
    }

    /// Rays of each class (direct, indirect, caustic) whose cones sit at h_min or h_max under
    /// `params`, over the stored batches (each with its own M). Each batch is counted once
    /// per parameter set, so the previewer can ask every frame.
    pub fn clamps(&mut self, params: &BandwidthParams) -> [ClampCounts; 3] {
        let mut out = [ClampCounts::default(); 3];
        for i in 0..self.batches.len() {
            let counts = match self.batches[i].clamps {
                Some((p, c)) if p == *params => c,
                _ => {
                    let b = &self.batches[i];
                    let bw = self.bandwidths(params, b.m);
                    let c = ClampCounts::count(&b.rays, &b.phis, &bw);
                    self.batches[i].clamps = Some((*params, c));
                    c
                }
            };
            for c in 0..3 {
                out[c] += counts[c];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every stored ray carries its φ (docs/deviations.md §63), finite, positive where rays
    /// land; a store that keeps no floors (photon mapping) neither counts nor stores any.
    #[test]
    fn a_stored_batch_carries_a_phi_per_ray() {
        let scene = Scene::default_scene();
        let s = RenderSettings {
            photons: 4_000,
            ..RenderSettings::default()
        };
        let mut store = PhotonStore::new(&scene, 1);
        store.trace(&scene, &s, false);
        store.trace(&scene, &s, false);
        for b in store.batches() {
            assert_eq!(b.phis.len(), b.rays.len());
            assert!(b.phis.iter().all(|p| p.is_finite() && *p >= 0.0));
            let mut landing = b.rays.iter().zip(&b.phis).filter(|(r, _)| r.lands());
            assert!(landing.clone().count() > 0);
            assert!(landing.all(|(_, &p)| p > 0.0));
        }
        assert!(store.density_bytes() > 0);
        let mut pm = PhotonStore::new(&scene, 1);
        pm.set_floors(false);
        pm.trace(&scene, &s, false);
        assert!(pm.batches()[0].phis.is_empty());
        assert_eq!(pm.density_bytes(), 0);
    }

    /// The schedule's M₁ counts batches of the size asked for now: a first batch of half the
    /// size (the previewer's coarse first image) gives the same M₁ as a full one, within the
    /// few rays a photon's path stores beyond its class's budget.
    #[test]
    fn the_schedule_counts_batches_of_the_current_size() {
        let scene = Scene::default_scene();
        let full = RenderSettings {
            photons: 4_000,
            ..RenderSettings::default()
        };
        let half = RenderSettings {
            photons: 2_000,
            ..full.clone()
        };
        let mut a = PhotonStore::new(&scene, 1);
        a.set_batch_photons(half.photons);
        a.trace(&scene, &half, false);
        // Only the first batch is stored, at or below either M₁: nothing to re-splat.
        assert!(!a.set_batch_photons(full.photons));
        let mut b = PhotonStore::new(&scene, 1);
        b.set_batch_photons(full.photons);
        b.trace(&scene, &full, false);
        for c in 1..3 {
            let (ma, mb) = (a.anchor()[c], b.anchor()[c]);
            assert!(
                mb > 0.0 && (ma / mb - 1.0).abs() < 0.01,
                "class {c}: {ma} vs {mb}"
            );
        }
        // With a second batch beyond M₁, a new batch size moves its bandwidth.
        b.trace(&scene, &full, false);
        let before = b.bandwidths(&BandwidthParams::default(), b.batches()[1].m);
        assert!(b.set_batch_photons(2 * full.photons));
        let after = b.bandwidths(&BandwidthParams::default(), b.batches()[1].m);
        assert!(after[1].h_max > before[1].h_max);
        // Without the schedule, M₁ plays no part.
        assert!(b.set_progressive_bandwidth(false));
        assert_eq!(b.anchor(), [0.0; 3]);
    }
}
