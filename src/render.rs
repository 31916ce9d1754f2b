//! The renderer: pipeline state and the progressive batch step shared by the headless
//! `render` command and the previewer's worker.
//!
//! It owns the eye samples (in splat-tree order), the splat tree, explicit direct light,
//! the stored photon batches and the splat accumulators. Photon rays are view-independent
//! and bandwidth is a pure function of stored ray data, so [`Renderer::resplat`] recomputes
//! the image for new C/S/R without re-tracing.

use crate::direct::direct_light;
use crate::eye::{EyePass, EyeSamples, EyeSettings, SplatTargets, eye_pass};
use crate::film::Film;
use crate::photon::{
    Bandwidth, BandwidthParams, ClassBudgets, LightPassSettings, PhotonBatch, PhotonClass,
    PhotonRay, Pilot, light_pass, pilot,
};
use crate::radiance_map::{Accumulators, Channel, RadianceMap};
use crate::scene::{Camera, Scene};
use crate::splat::{SplatCounters, prepare, splat};
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
}

pub struct Renderer {
    pub scene: Arc<Scene>,
    pub settings: RenderSettings,
    pub camera: Camera,
    eye: EyeSamples,
    targets: SplatTargets,
    tree: SplatTree,
    /// Per pixel: emission seen directly or through specular chains.
    emitted: Vec<Vec3>,
    /// Per pixel: NEE direct light (eye weights applied).
    direct: Vec<Vec3>,
    pilot: Pilot,
    /// Accumulators for indirect and caustic photons, and for direct photons when splatted.
    acc_indirect: Accumulators,
    acc_direct: Accumulators,
    batches: Vec<StoredBatch>,
    /// Stored rays per class so far (each batch's M, eq. 8).
    m_total: [u64; 3],
    /// Photons traced (depends on thread count: the last wave may trace beyond the budget).
    pub photons_traced: u64,
    /// Photons whose rays were kept; the next batch's photon indices start here.
    photons_used: u64,
    pub counters: SplatCounters,
    pub timings: Timings,
}

impl Renderer {
    /// Eye pass, splat tree, direct light and pilot for `scene` as seen by the settings' camera.
    pub fn new(scene: Arc<Scene>, settings: RenderSettings) -> Result<Self, String> {
        if settings.width == 0 || settings.height == 0 || settings.spp == 0 {
            return Err("width, height and samples per pixel must be positive".into());
        }
        let camera = scene
            .camera(settings.camera.as_deref())
            .cloned()
            .ok_or_else(|| {
                format!(
                    "no camera named {:?}; the scene has: {}",
                    settings.camera.as_deref().unwrap_or(""),
                    scene
                        .cameras
                        .iter()
                        .map(|c| c.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        let mut timings = Timings::default();

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
        } = eye_pass(&scene, &camera, &eye_settings);
        let tree = SplatTree::build(&targets.position, &targets.normal, scene.diagonal());
        timings.t_eye = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let mut direct = vec![Vec3::ZERO; (settings.width * settings.height) as usize];
        if settings.direct == DirectMode::Nee {
            let per_sample = direct_light(&scene, &eye, settings.nee_samples, settings.seed);
            for (i, l) in per_sample.iter().enumerate() {
                direct[eye.pixel[i] as usize] += eye.weight[i] * *l;
            }
        }
        timings.t_direct = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let pilot = pilot(&scene, settings.seed);
        timings.t_light = t.elapsed().as_secs_f64();

        let slots = tree.slots();
        let acc_direct = if settings.direct == DirectMode::Photons {
            Accumulators::new(slots)
        } else {
            Accumulators::default()
        };
        Ok(Self {
            scene,
            camera,
            eye,
            targets,
            tree,
            emitted,
            direct,
            pilot,
            acc_indirect: Accumulators::new(slots),
            acc_direct,
            batches: Vec::new(),
            m_total: [0; 3],
            photons_traced: 0,
            photons_used: 0,
            counters: SplatCounters::default(),
            timings,
            settings,
        })
    }

    pub fn eye_samples(&self) -> &EyeSamples {
        &self.eye
    }

    pub fn targets(&self) -> &SplatTargets {
        &self.targets
    }

    /// Batch-averaged splatted irradiance E (eq. 5) at every splat target, from the indirect
    /// and caustic photons (`direct` = false) or from the direct photons (`direct` = true).
    pub fn target_irradiance(&self, direct: bool) -> Vec<Vec3> {
        let acc = if direct {
            &self.acc_direct
        } else {
            &self.acc_indirect
        };
        let b = self.batches.len().max(1) as f32;
        self.tree
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

    pub fn tree(&self) -> &SplatTree {
        &self.tree
    }

    pub fn pilot(&self) -> &Pilot {
        &self.pilot
    }

    pub fn batch_count(&self) -> usize {
        self.batches.len()
    }

    /// Stored photon rays over all batches.
    pub fn photon_rays(&self) -> usize {
        self.batches.iter().map(|b| b.rays.len()).sum()
    }

    /// Stored photon rays per class.
    pub fn photon_rays_per_class(&self) -> [u64; 3] {
        self.m_total
    }

    pub fn photon_memory_bytes(&self) -> usize {
        self.photon_rays() * std::mem::size_of::<PhotonRay>()
    }

    fn splat_direct(&self) -> bool {
        self.settings.direct == DirectMode::Photons
    }

    fn bandwidths(&self, m: [u64; 3]) -> [Bandwidth; 3] {
        let mean_r = self.pilot.mean_r(self.settings.bandwidth.sensitivity_s);
        PhotonClass::ALL
            .map(|c| Bandwidth::new(&self.settings.bandwidth, &self.pilot, m[c as usize], mean_r))
    }

    /// Bytes held by eye samples, splat tree and accumulators.
    pub fn splat_memory_bytes(&self) -> usize {
        self.eye.memory_bytes()
            + self.tree.memory_bytes()
            + self.acc_indirect.memory_bytes()
            + self.acc_direct.memory_bytes()
    }

    /// Trace one light pass of M photons, splat it with the bandwidth for the total M so far.
    pub fn run_batch(&mut self) {
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
            },
        );
        self.photons_traced += batch.traced;
        self.photons_used += batch.emitted.iter().copied().max().unwrap_or(0);
        for c in 0..3 {
            self.m_total[c] += batch.stored[c];
        }
        self.timings.t_light += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let m = self.m_total;
        self.splat_rays(&batch.rays, m);
        self.batches.push(StoredBatch {
            rays: batch.rays,
            m,
        });
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    fn splat_rays(&mut self, rays: &[PhotonRay], m: [u64; 3]) {
        let bw = self.bandwidths(m);
        let indirect = prepare(rays, &bw, [false, true, true]);
        self.counters += splat(&self.tree, &indirect, &mut self.acc_indirect);
        if self.splat_direct() {
            let direct = prepare(rays, &bw, [true, false, false]);
            self.counters += splat(&self.tree, &direct, &mut self.acc_direct);
        }
    }

    /// Re-splat every stored batch with new bandwidth parameters (no re-tracing).
    pub fn resplat(&mut self, params: BandwidthParams) {
        let t = Instant::now();
        self.settings.bandwidth = params;
        self.acc_indirect.clear();
        self.acc_direct.clear();
        let batches = std::mem::take(&mut self.batches);
        for b in &batches {
            self.splat_rays(&b.rays, b.m);
        }
        self.batches = batches;
        self.timings.t_splat += t.elapsed().as_secs_f64();
    }

    /// Compose the film: emission + direct + splatted light, with AOVs.
    pub fn film(&mut self) -> Film {
        let t = Instant::now();
        let (w, h) = (self.settings.width, self.settings.height);
        let b = self.batches.len() as u32;
        let mut map = RadianceMap::new(w, h);
        map.resolve_from(&self.eye, &self.tree.target_slot, &self.acc_indirect, b);
        let mut film = Film::new(w, h);
        let mut direct = self.direct.clone();
        if self.splat_direct() {
            let mut dmap = RadianceMap::new(w, h);
            dmap.resolve_from(&self.eye, &self.tree.target_slot, &self.acc_direct, b);
            for (d, s) in direct.iter_mut().zip(&dmap.diffuse) {
                *d += *s;
            }
        }
        for (i, (d, e)) in direct.iter().zip(&self.emitted).enumerate() {
            let d = *d + *e;
            let ind = map.diffuse[i];
            let info = &map.info[i];
            film.direct[i] = d;
            film.indirect[i] = ind;
            film.rgb[i] = d + ind;
            film.bandwidth[i] = info.mean_bandwidth;
            film.kernel_weight[i] = info.kernel_weight;
            film.harmonic_distance[i] = info.harmonic_mean_distance;
        }
        self.timings.t_resolve += t.elapsed().as_secs_f64();
        film
    }
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
