//! The renderer: pipeline state and the progressive batch step shared by the headless
//! `render` command and the previewer's worker.
//!
//! It owns the eye side (eye samples, splat targets, splat tree, explicit direct light), the
//! stored photon batches and the splat accumulators. Photon rays are view-independent and
//! bandwidth is a pure function of stored ray data, so new C/S/R ([`Renderer::begin_resplat`])
//! and a new view ([`Renderer::set_view`]) re-splat stored rays without re-tracing. Re-splatting
//! is progressive: [`Renderer::step`] splats one stored batch (newest first) per call, and the
//! film averages over the batches splatted so far.

use crate::baseline::Method;
use crate::baseline::photon_map::{PmStats, build_maps, estimate_targets};
use crate::cache::{self, Cache, CacheParams, PixelGeometry, RecordValue};
use crate::direct::direct_light;
use crate::eye::{EyePass, EyeSamples, EyeSettings, SplatTargets, eye_pass};
use crate::film::Film;
use crate::filter::FilterParams;
use crate::photon::{
    Bandwidth, BandwidthParams, ClampCounts, ClassBudgets, LightPassSettings, PhotonBatch,
    PhotonClass, PhotonRay, Pilot, light_pass, pilot,
};
use crate::radiance_map::{Accumulators, Channel, DirectionalMode, RadianceMap};
use crate::scene::{Camera, Scene};
use crate::splat::{SplatBatch, SplatCounters, prepare, splat};
use crate::splat_tree::SplatTree;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// How direct light reaches eye samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DirectMode {
    /// Explicit light sampling with shadow rays at eye samples.
    Nee,
    /// Direct photons splatted in cones from the lights (the paper's way).
    Photons,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// M: stored photon rays per batch, split by `fractions` (Table 2).
    pub photons: u64,
    /// Fractions of M for direct, indirect-diffuse and caustic photons (Table 2).
    pub fractions: [f32; 3],
    pub bandwidth: BandwidthParams,
    pub seed: u64,
    pub direct: DirectMode,
    pub max_specular_depth: u32,
    /// Light samples per eye sample for NEE.
    pub nee_samples: u32,
    /// Give up filling a photon class after this many emitted photons per stored-photon budget.
    pub max_emitted_factor: u64,
    pub camera: Option<String>,
    /// Eye samples of a pixel on the same surface share one splat target (docs/deviations.md).
    pub merge_targets: bool,
    /// Photon ray splatting or photon mapping (the path tracer is `baseline::pt`).
    pub method: Method,
    /// K of the global photon map (`--method pm`).
    pub pm_k: usize,
    /// K of the caustic photon map (`--method pm`).
    pub pm_caustic_k: usize,
    /// Gather rays per eye sample for the final-gathering methods (§8.4).
    pub fg_rays: u32,
    /// Directional storage at glossy samples (§8.1).
    #[serde(default)]
    pub radiance_map: DirectionalMode,
    /// Radiance cache parameters (§8.3): used by `--method rc`, and by rs when `cache_on`.
    #[serde(default)]
    pub cache: CacheParams,
    /// rs: resolve the full radiance map through the cache (the previewer's ε slider).
    #[serde(default)]
    pub cache_on: bool,
    /// Image-space filter of the indirect light (§8.2).
    #[serde(default)]
    pub filter: FilterParams,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 500,
            height: 500,
            spp: 4,
            photons: 200_000,
            fractions: [0.3, 0.6, 0.1],
            bandwidth: BandwidthParams::default(),
            seed: 1,
            direct: DirectMode::Nee,
            max_specular_depth: 8,
            nee_samples: 1,
            max_emitted_factor: 4,
            camera: None,
            merge_targets: true,
            method: Method::Rs,
            pm_k: 400,
            pm_caustic_k: 250,
            fg_rays: 64,
            radiance_map: DirectionalMode::Sh,
            cache: CacheParams::default(),
            cache_on: false,
            filter: FilterParams::default(),
        }
    }
}

/// Seconds spent per phase (Table 2: T_E, T_L, T_S).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// T_E: eye pass and splat-tree build.
    pub t_eye: f64,
    /// Explicit direct light (NEE) at eye samples.
    pub t_direct: f64,
    /// T_L: pilot and light pass.
    pub t_light: f64,
    /// T_S: bandwidth and splatting.
    pub t_splat: f64,
    /// Folding accumulators into the film.
    pub t_resolve: f64,
}

impl Timings {
    pub fn total(&self) -> f64 {
        self.t_eye + self.t_direct + self.t_light + self.t_splat + self.t_resolve
    }
}

/// One stored light pass with the class sizes M its bandwidth was computed for.
struct StoredBatch {
    rays: Vec<PhotonRay>,
    m: [u64; 3],
    /// Its rays at the bandwidth bounds under the parameters they were last counted for.
    clamps: Option<(BandwidthParams, [ClampCounts; 3])>,
}

/// What [`Renderer::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Re-splatted one stored batch with the current parameters or view.
    Resplatted,
    /// Traced and splatted a new batch.
    Traced,
}

/// The eye side of a render: everything that depends on the camera and resolution.
struct EyeSide {
    eye: EyeSamples,
    targets: SplatTargets,
    tree: SplatTree,
    /// Per pixel: emission seen directly or through specular chains.
    emitted: Vec<Vec3>,
    /// Per pixel: NEE direct light (eye weights applied).
    direct: Vec<Vec3>,
    /// Eye samples whose NEE estimate was NaN or infinite (dropped).
    invalid_direct: u64,
    /// Accumulators for indirect and caustic photons, and for direct photons when splatted.
    acc_indirect: Accumulators,
    acc_direct: Accumulators,
}

pub struct Renderer {
    pub scene: Arc<Scene>,
    pub settings: RenderSettings,
    pub camera: Camera,
    side: EyeSide,
    pilot: Pilot,
    batches: Vec<StoredBatch>,
    /// Stored batches (indices into `batches`) still to be re-splatted, next last.
    resplat_queue: Vec<usize>,
    /// Batches whose light the accumulators hold.
    splatted: usize,
    /// Batches dropped from the store (over budget) whose light the accumulators still hold.
    folded: usize,
    /// Stored rays per class over all traced batches (each batch's M, eq. 8).
    m_total: [u64; 3],
    /// Photons traced (depends on thread count: the last wave may trace beyond the budget).
    pub photons_traced: u64,
    /// Photon paths and rays dropped for NaN or infinite values, over all batches.
    pub invalid_photon_rays: u64,
    /// Photons whose rays were kept; the next batch's photon indices start here.
    photons_used: u64,
    /// Keep at most this many photon rays; older batches are folded (see `fold_over_budget`).
    pub max_stored_rays: usize,
    pub counters: SplatCounters,
    pub timings: Timings,
    /// Photon mapping: the estimate must be recomputed before the next film.
    pm_dirty: bool,
    /// Gather statistics of the last photon-mapping estimate.
    pub pm_stats: Option<PmStats>,
    /// The radiance cache of the last film (rc, or rs with `cache_on`).
    pub cache: Option<Cache>,
}

impl Renderer {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by the settings' camera.
    pub fn new(scene: Arc<Scene>, settings: RenderSettings) -> Result<Self, String> {
        let camera = scene.camera_or_error(settings.camera.as_deref())?;
        Self::with_camera(scene, settings, camera)
    }

    /// As [`Renderer::new`] with an explicit camera.
    pub fn with_camera(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
    ) -> Result<Self, String> {
        let mut timings = Timings::default();
        let side = eye_side(&scene, &camera, &settings, &mut timings)?;
        let t = Instant::now();
        let pilot = pilot(&scene, settings.seed);
        timings.t_light = t.elapsed().as_secs_f64();
        Ok(Self {
            scene,
            camera,
            side,
            pilot,
            batches: Vec::new(),
            resplat_queue: Vec::new(),
            splatted: 0,
            folded: 0,
            m_total: [0; 3],
            photons_traced: 0,
            invalid_photon_rays: 0,
            photons_used: 0,
            max_stored_rays: usize::MAX,
            counters: SplatCounters::default(),
            timings,
            settings,
            pm_dirty: false,
            pm_stats: None,
            cache: None,
        })
    }

    pub fn eye_samples(&self) -> &EyeSamples {
        &self.side.eye
    }

    pub fn targets(&self) -> &SplatTargets {
        &self.side.targets
    }

    pub fn tree(&self) -> &SplatTree {
        &self.side.tree
    }

    pub fn pilot(&self) -> &Pilot {
        &self.pilot
    }

    /// Batches whose light the image holds (stored and splatted, plus folded).
    pub fn batch_count(&self) -> usize {
        self.splatted + self.folded
    }

    /// Batches whose rays are stored.
    pub fn stored_batches(&self) -> usize {
        self.batches.len()
    }

    /// Batches dropped from the ray store whose light the image still holds.
    pub fn folded_batches(&self) -> usize {
        self.folded
    }

    /// True while stored batches wait to be re-splatted after a parameter or view change.
    pub fn resplat_pending(&self) -> bool {
        !self.resplat_queue.is_empty()
    }

    /// Stored photon rays over all batches.
    pub fn photon_rays(&self) -> usize {
        self.batches.iter().map(|b| b.rays.len()).sum()
    }

    /// Photon rays per class over all traced batches.
    pub fn photon_rays_per_class(&self) -> [u64; 3] {
        self.m_total
    }

    pub fn photon_memory_bytes(&self) -> usize {
        self.photon_rays() * std::mem::size_of::<PhotonRay>()
    }

    /// Bytes of directional radiance-map records (§8.1) and the glossy splat targets owning them.
    pub fn directional_memory(&self) -> (usize, usize) {
        let side = &self.side;
        (
            side.acc_indirect.directional_bytes() + side.acc_direct.directional_bytes(),
            side.targets.glossy.iter().filter(|&&g| g).count(),
        )
    }

    /// Bytes held by eye samples, splat tree and accumulators.
    pub fn splat_memory_bytes(&self) -> usize {
        self.side.eye.memory_bytes()
            + self.side.tree.memory_bytes()
            + self.side.acc_indirect.memory_bytes()
            + self.side.acc_direct.memory_bytes()
    }

    /// Batch-averaged splatted irradiance E (eq. 5) at every splat target, from the indirect
    /// and caustic photons (`direct` = false) or from the direct photons (`direct` = true).
    pub fn target_irradiance(&self, direct: bool) -> Vec<Vec3> {
        let acc = if direct {
            &self.side.acc_direct
        } else {
            &self.side.acc_indirect
        };
        let b = self.batch_count().max(1) as f32;
        self.side
            .tree
            .target_slot
            .iter()
            .map(|&slot| {
                let slot = slot as usize;
                if acc.is_empty() {
                    return Vec3::ZERO;
                }
                Vec3::new(
                    acc.get(Channel::R, slot),
                    acc.get(Channel::G, slot),
                    acc.get(Channel::B, slot),
                ) / b
            })
            .collect()
    }

    fn splat_direct(&self) -> bool {
        self.settings.direct == DirectMode::Photons
    }

    fn bandwidths(&self, m: [u64; 3]) -> [Bandwidth; 3] {
        let mean_r = self.pilot.mean_r(self.settings.bandwidth.sensitivity_s);
        PhotonClass::ALL
            .map(|c| Bandwidth::new(&self.settings.bandwidth, &self.pilot, m[c as usize], mean_r))
    }

    /// Photon mapping's largest gather radius: rs's h_max (eq. 8's upper bound from μC and R)
    /// for the largest class stored, so both methods share one bound that follows the lighting's
    /// scale, never the bounding box.
    fn pm_max_radius(&self) -> f32 {
        let bw = self.bandwidths(self.m_total);
        PhotonClass::ALL
            .iter()
            .filter(|&&c| self.m_total[c as usize] > 0)
            .map(|&c| bw[c as usize].h_max)
            .fold(0.0f32, f32::max)
            .max(bw[PhotonClass::Indirect as usize].h_max)
    }

    /// Rays of each class (direct, indirect, caustic) whose cones sit at h_min or h_max under
    /// the current parameters, over the stored batches (each with its own M). Each batch is
    /// counted once per parameter set, so the previewer can ask every frame.
    pub fn bandwidth_clamps(&mut self) -> [ClampCounts; 3] {
        let params = self.settings.bandwidth;
        let mut out = [ClampCounts::default(); 3];
        for i in 0..self.batches.len() {
            let counts = match self.batches[i].clamps {
                Some((p, c)) if p == params => c,
                _ => {
                    let b = &self.batches[i];
                    let bw = self.bandwidths(b.m);
                    let c =
                        PhotonClass::ALL.map(|c| ClampCounts::count(&b.rays, &bw[c as usize], c));
                    self.batches[i].clamps = Some((params, c));
                    c
                }
            };
            for c in 0..3 {
                out[c] += counts[c];
            }
        }
        out
    }

    /// Do one unit of work: re-splat the next stored batch if a re-splat is pending, otherwise
    /// trace and splat a new batch.
    pub fn step(&mut self) -> Step {
        if let Some(b) = self.resplat_queue.pop() {
            let t = Instant::now();
            let batch = std::mem::take(&mut self.batches[b].rays);
            let m = self.batches[b].m;
            self.splat_rays(&batch, m);
            self.batches[b].rays = batch;
            self.splatted += 1;
            self.timings.t_splat += t.elapsed().as_secs_f64();
            Step::Resplatted
        } else {
            self.run_batch();
            Step::Traced
        }
    }

    /// Trace one light pass of M photons, splat it with the bandwidth for the total M so far.
    /// Finishes a pending re-splat first.
    pub fn run_batch(&mut self) {
        while self.resplat_pending() {
            self.step();
        }
        let t = Instant::now();
        let budgets = ClassBudgets::from_fractions(
            self.settings.photons,
            self.settings.fractions,
            self.splat_direct(),
        );
        let batch: PhotonBatch = light_pass(
            &self.scene,
            &LightPassSettings {
                budgets,
                max_emitted_factor: self.settings.max_emitted_factor,
                seed: self.settings.seed,
                first_photon: self.photons_used,
                units: self.pilot.units(),
            },
        );
        self.photons_traced += batch.traced;
        self.invalid_photon_rays += batch.invalid;
        self.photons_used += batch.emitted.iter().copied().max().unwrap_or(0);
        for c in 0..3 {
            self.m_total[c] += batch.stored[c];
        }
        self.timings.t_light += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let m = self.m_total;
        self.splat_rays(&batch.rays, m);
        self.splatted += 1;
        self.batches.push(StoredBatch {
            rays: batch.rays,
            m,
            clamps: None,
        });
        self.fold_over_budget();
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// Drop the oldest stored batches beyond the ray budget; their light stays in the
    /// accumulators (folded) until the next re-splat, which can only use stored rays.
    fn fold_over_budget(&mut self) {
        let mut stored = self.photon_rays();
        let mut drop = 0;
        while self.batches.len() - drop > 1 && stored > self.max_stored_rays {
            stored -= self.batches[drop].rays.len();
            drop += 1;
        }
        if drop > 0 {
            self.batches.drain(..drop);
            self.folded += drop;
            self.splatted -= drop;
        }
    }

    fn splat_rays(&mut self, rays: &[PhotonRay], m: [u64; 3]) {
        if self.settings.method == Method::Pm {
            // Photon mapping gathers from all stored photons when the film is made.
            self.pm_dirty = true;
            return;
        }
        let bw = self.bandwidths(m);
        let mode = self.settings.radiance_map;
        // Radiance caching splats indirect-diffuse light onto its records when the film is
        // made; caustics, sharp by nature, are splatted onto every target as in rs.
        let classes = if self.settings.method == Method::Rc {
            [false, false, true]
        } else {
            [false, true, true]
        };
        let indirect = prepare(rays, &bw, classes, mode);
        self.counters += splat(&self.side.tree, &indirect, &mut self.side.acc_indirect);
        if self.splat_direct() {
            let direct = prepare(rays, &bw, [true, false, false], mode);
            self.counters += splat(&self.side.tree, &direct, &mut self.side.acc_direct);
        }
    }

    /// Start re-splatting every stored batch with new bandwidth parameters (no re-tracing).
    /// Folded batches cannot be re-splatted: their light leaves the image.
    pub fn begin_resplat(&mut self, params: BandwidthParams) {
        self.settings.bandwidth = params;
        self.side.acc_indirect.clear();
        self.side.acc_direct.clear();
        self.splatted = 0;
        self.folded = 0;
        // Newest first: it has the smallest bandwidth, so the first frame is the sharpest.
        self.resplat_queue = (0..self.batches.len()).collect();
    }

    /// Re-splat every stored batch with new bandwidth parameters, all at once.
    pub fn resplat(&mut self, params: BandwidthParams) {
        self.begin_resplat(params);
        while self.resplat_pending() {
            self.step();
        }
    }

    /// A new camera, resolution or sample count: new eye pass and splat tree, then a
    /// progressive re-splat of the stored rays (photon rays do not depend on the view).
    pub fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), String> {
        let mut settings = self.settings.clone();
        settings.width = width;
        settings.height = height;
        settings.spp = spp;
        self.side = eye_side(&self.scene, &camera, &settings, &mut self.timings)?;
        self.settings = settings;
        self.camera = camera;
        self.begin_resplat(self.settings.bandwidth);
        Ok(())
    }

    /// The cache's record values read from the full radiance map (rs with `cache_on`): no
    /// splatting, so ε can move freely (§8.3 in the previewer).
    fn build_cache_from_map(&self, batches: u32) -> Cache {
        let side = &self.side;
        let (w, h) = (self.settings.width, self.settings.height);
        let geo = PixelGeometry::new(&side.eye, w, h);
        let acc = &side.acc_indirect;
        let inv_b = 1.0 / batches.max(1) as f32;
        cache::build(
            &side.eye,
            &geo,
            &self.camera,
            &self.settings.cache,
            |samples| {
                samples
                    .iter()
                    .map(|&i| {
                        let slot =
                            side.tree.target_slot[side.eye.target[i as usize] as usize] as usize;
                        record_value(acc, slot, inv_b)
                    })
                    .collect()
            },
        )
    }

    /// `--method rc`: every pass splats the stored photon rays onto its new records only.
    fn build_cache_by_splatting(&mut self) -> Cache {
        let (w, h) = (self.settings.width, self.settings.height);
        let geo = PixelGeometry::new(&self.side.eye, w, h);
        let mode = self.settings.radiance_map;
        // Rays are prepared once for every pass.
        let batches: Vec<SplatBatch> = self
            .batches
            .iter()
            .map(|b| prepare(&b.rays, &self.bandwidths(b.m), [false, true, false], mode))
            .collect();
        let inv_b = 1.0 / batches.len().max(1) as f32;
        let side = &self.side;
        let mut counters = SplatCounters::default();
        let cache = cache::build(
            &side.eye,
            &geo,
            &self.camera,
            &self.settings.cache,
            |samples| {
                if samples.is_empty() {
                    return Vec::new();
                }
                let targets: Vec<usize> = samples
                    .iter()
                    .map(|&i| side.eye.target[i as usize] as usize)
                    .collect();
                let pos: Vec<Vec3> = targets.iter().map(|&t| side.targets.position[t]).collect();
                let nrm: Vec<Vec3> = targets.iter().map(|&t| side.targets.normal[t]).collect();
                let glossy: Vec<bool> = targets.iter().map(|&t| side.targets.glossy[t]).collect();
                let tree = SplatTree::build(&pos, &nrm);
                let mut acc = Accumulators::for_tree(&tree, &glossy, mode);
                for batch in &batches {
                    counters += splat(&tree, batch, &mut acc);
                }
                (0..samples.len())
                    .map(|k| record_value(&acc, tree.target_slot[k] as usize, inv_b))
                    .collect()
            },
        );
        self.counters += counters;
        cache
    }

    /// Photon mapping: build the maps from every stored batch and estimate at every target.
    fn photon_map_estimate(&mut self) {
        let t = Instant::now();
        let batches: Vec<&[PhotonRay]> = self.batches.iter().map(|b| &b.rays[..]).collect();
        let (global, caustic) = build_maps(&batches, self.splat_direct());
        let r_max = self.pm_max_radius();
        let side = &mut self.side;
        self.pm_stats = Some(estimate_targets(
            &global,
            &caustic,
            &side.targets.position,
            &side.targets.normal,
            &side.tree.target_slot,
            (self.settings.pm_k, self.settings.pm_caustic_k),
            r_max,
            &mut side.acc_indirect,
        ));
        self.pm_dirty = false;
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// Compose the film: emission + direct + splatted (or gathered) light, with AOVs.
    pub fn film(&mut self) -> Film {
        let pm = self.settings.method == Method::Pm;
        if pm && self.pm_dirty {
            self.photon_map_estimate();
        }
        let t = Instant::now();
        let (w, h) = (self.settings.width, self.settings.height);
        // Photon mapping holds its estimate already averaged over the batches.
        let b = if pm { 1 } else { self.batch_count() as u32 };
        let rc = self.settings.method == Method::Rc;
        let cached = rc || (self.settings.cache_on && !pm);
        self.cache = None;
        // The cache pass counts as splatting (T_S), not as resolving.
        let mut cache_time = 0.0;
        if cached {
            let t = Instant::now();
            self.cache = Some(if rc {
                self.build_cache_by_splatting()
            } else {
                self.build_cache_from_map(b)
            });
            cache_time = t.elapsed().as_secs_f64();
            self.timings.t_splat += cache_time;
        }
        let side = &self.side;
        let scene = &self.scene;
        let mut map = RadianceMap::new(w, h);
        // rs: everything splatted; rc: the caustics (its indirect-diffuse light is cached).
        map.resolve_from(
            scene,
            &side.eye,
            &side.tree.target_slot,
            &side.acc_indirect,
            b,
        );
        let caustics = rc.then(|| map.radiance.clone());
        let filter = self.settings.filter;
        if self.cache.is_some() || filter.enabled {
            let geo = PixelGeometry::new(&side.eye, w, h);
            let mode = side.acc_indirect.mode;
            let mut values = match &self.cache {
                Some(c) => cache::interpolate(c, &side.eye, &geo, mode),
                None => sample_values(&side.eye, &side.tree.target_slot, &side.acc_indirect, b),
            };
            if filter.enabled {
                // Splat statistics exist only where every sample was splatted (not after rc).
                let splats: Vec<f32> = if rc {
                    vec![0.0; map.info.len()]
                } else {
                    map.info.iter().map(|i| i.splats).collect()
                };
                filter_values(
                    &side.eye,
                    &geo,
                    &self.camera,
                    &splats,
                    b,
                    filter,
                    &mut values,
                );
            }
            map.resolve_interpolated(scene, &side.eye, &values, mode);
            if let Some(c) = caustics {
                for (m, c) in map.radiance.iter_mut().zip(c) {
                    *m += c;
                }
            }
        }
        let mut film = Film::new(w, h);
        let mut direct = side.direct.clone();
        if self.settings.direct == DirectMode::Photons && !pm {
            let mut dmap = RadianceMap::new(w, h);
            dmap.resolve_from(
                scene,
                &side.eye,
                &side.tree.target_slot,
                &side.acc_direct,
                b,
            );
            film.invalid_contributions += dmap.invalid;
            for (d, s) in direct.iter_mut().zip(&dmap.radiance) {
                *d += *s;
            }
        }
        film.invalid_contributions += map.invalid + side.invalid_direct + self.invalid_photon_rays;
        for (i, (d, e)) in direct.iter().zip(&side.emitted).enumerate() {
            let (mut d, mut ind) = (*d + *e, map.radiance[i]);
            // The last guard: nothing non-finite reaches the film.
            if !(d + ind).is_finite() {
                film.invalid_contributions += 1;
                (d, ind) = (Vec3::ZERO, Vec3::ZERO);
            }
            let info = &map.info[i];
            film.direct[i] = d;
            film.indirect[i] = ind;
            film.rgb[i] = d + ind;
            film.bandwidth[i] = info.mean_bandwidth;
            film.kernel_weight[i] = info.kernel_weight;
            film.harmonic_distance[i] = info.harmonic_mean_distance;
            film.splats[i] = info.splats;
        }
        self.timings.t_resolve += t.elapsed().as_secs_f64() - cache_time;
        film
    }
}

/// Batch-averaged irradiance and directional floats of every eye sample's splat target, in the
/// shape the cache's interpolation gives (for filtering without a cache).
fn sample_values(
    eye: &EyeSamples,
    target_slot: &[u32],
    acc: &Accumulators,
    batches: u32,
) -> cache::Interpolated {
    let floats = acc.mode.record_floats();
    let inv_b = 1.0 / batches.max(1) as f32;
    let mut out = cache::Interpolated::zeroed(eye, floats);
    for i in 0..eye.len() {
        let slot = target_slot[eye.target[i] as usize] as usize;
        out.irradiance[i] = Vec3::new(
            acc.get(Channel::R, slot),
            acc.get(Channel::G, slot),
            acc.get(Channel::B, slot),
        ) * inv_b;
        if let (Some(r), Some(dst)) = (acc.record(slot), out.dir_mut(i)) {
            for (o, v) in dst.iter_mut().zip(r) {
                *o = v * inv_b;
            }
        }
    }
    out
}

/// The image-space filter (§8.2) over per-sample incident light: each pixel's first eye sample
/// stands for the pixel in the discontinuity buffer; every channel (irradiance RGB, then each
/// directional float) is filtered within continuous regions; samples of a pixel that lie on
/// its first sample's surface take the filtered values, others keep theirs.
#[allow(clippy::too_many_arguments)]
fn filter_values(
    eye: &EyeSamples,
    geo: &PixelGeometry,
    camera: &Camera,
    splats: &[f32],
    batches: u32,
    params: FilterParams,
    values: &mut cache::Interpolated,
) {
    use crate::filter::{Discontinuity, filter_channel, radii, segment};
    let n = geo.first.len();
    let (w, h) = (geo.width as usize, geo.height as usize);
    let rep = |p: usize| (geo.first[p] != u32::MAX).then(|| geo.first[p] as usize);
    let d = Discontinuity {
        width: geo.width,
        height: geo.height,
        position: (0..n)
            .map(|p| rep(p).map_or(Vec3::ZERO, |i| eye.position[i]))
            .collect(),
        normal: (0..n)
            .map(|p| rep(p).map_or(Vec3::ZERO, |i| eye.normal[i]))
            .collect(),
        material: (0..n)
            .map(|p| rep(p).map_or(u32::MAX, |i| eye.material[i]))
            .collect(),
        depth: (0..n)
            .map(|p| rep(p).map_or(0.0, |i| (eye.position[i] - camera.position).length()))
            .collect(),
    };
    let (labels, regions) = segment(&d);
    let radius = radii(splats, batches, params.strength);
    let floats = values.floats;
    let mut channel = vec![0.0f32; n];
    // Samples that follow their pixel's filtered value: on its first primary sample's surface
    // (pixels seen only through specular chains have none and are not filtered).
    let follows: Vec<bool> = (0..eye.len())
        .map(|i| {
            let Some(f) = rep(eye.pixel[i] as usize) else {
                return false;
            };
            eye.target[i] == eye.target[f]
                || (eye.primary[i]
                    && eye.material[i] == eye.material[f]
                    && eye.normal[i].dot(eye.normal[f]) > 0.966)
        })
        .collect();
    for c in 0..3 + floats {
        let get = |i: usize| {
            if c < 3 {
                values.irradiance[i][c]
            } else {
                values.dir(i).map_or(0.0, |d| d[c - 3])
            }
        };
        for (p, v) in channel.iter_mut().enumerate() {
            *v = rep(p).map_or(0.0, get);
        }
        filter_channel(&labels, regions, w, h, &radius, &mut channel);
        for i in 0..eye.len() {
            if !follows[i] {
                continue;
            }
            let v = channel[eye.pixel[i] as usize];
            if c < 3 {
                values.irradiance[i][c] = v;
            } else if let Some(d) = values.dir_mut(i) {
                d[c - 3] = v;
            }
        }
    }
}

/// A cache record's value from the sums at `slot` (§8.3): batch-averaged irradiance, the
/// harmonic mean distance (SplatInfo) and the directional record.
fn record_value(acc: &Accumulators, slot: usize, inv_b: f32) -> RecordValue {
    let wsum = acc.get(Channel::Weight, slot);
    let inv_d = acc.get(Channel::WeightedInvDist, slot);
    RecordValue {
        irradiance: Vec3::new(
            acc.get(Channel::R, slot),
            acc.get(Channel::G, slot),
            acc.get(Channel::B, slot),
        ) * inv_b,
        // Where no photon ray reached the record, its radius falls back to the clamp.
        harmonic_distance: if inv_d > 0.0 { wsum / inv_d } else { 0.0 },
        directional: acc
            .record(slot)
            .map(|r| r.iter().map(|v| v * inv_b).collect())
            .unwrap_or_default(),
    }
}

/// Eye pass, splat tree and explicit direct light for one view.
fn eye_side(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    timings: &mut Timings,
) -> Result<EyeSide, String> {
    if settings.width == 0 || settings.height == 0 || settings.spp == 0 {
        return Err("width, height and samples per pixel must be positive".into());
    }
    let t = Instant::now();
    let eye_settings = EyeSettings {
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        max_specular_depth: settings.max_specular_depth,
        seed: settings.seed,
        merge_targets: settings.merge_targets,
    };
    let EyePass {
        samples: eye,
        targets,
        emitted,
    } = eye_pass(scene, camera, &eye_settings);
    let tree = SplatTree::build(&targets.position, &targets.normal);
    timings.t_eye += t.elapsed().as_secs_f64();

    let t = Instant::now();
    let mut direct = vec![Vec3::ZERO; (settings.width * settings.height) as usize];
    let mut invalid_direct = 0;
    if settings.direct == DirectMode::Nee {
        let (per_sample, invalid) = direct_light(scene, &eye, settings.nee_samples, settings.seed);
        invalid_direct = invalid;
        for (i, l) in per_sample.iter().enumerate() {
            direct[eye.pixel[i] as usize] += eye.weight[i] * *l;
        }
    }
    timings.t_direct += t.elapsed().as_secs_f64();

    let mode = settings.radiance_map;
    let acc_direct = if settings.direct == DirectMode::Photons {
        Accumulators::for_tree(&tree, &targets.glossy, mode)
    } else {
        Accumulators::default()
    };
    let acc_indirect = Accumulators::for_tree(&tree, &targets.glossy, mode);
    Ok(EyeSide {
        eye,
        targets,
        tree,
        emitted,
        direct,
        invalid_direct,
        acc_indirect,
        acc_direct,
    })
}

/// Peak resident memory of this process in MB (Linux VmHWM; 0 where unavailable).
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(0.0)
}
