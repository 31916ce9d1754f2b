//! Final gathering (§8.4): N gather rays per eye sample, cosine-distributed; photon density is
//! estimated where they land instead of at the eye samples. Ray splatting stores the gather hits
//! as eye samples and splats the same photon rays onto them, a band of image rows at a time to
//! bound memory (the paper's tiles); photon mapping queries its maps there.
//!
//! Paths are split without overlap: emission seen directly; direct light by NEE at the eye
//! sample; caustics (L S+ D E) by splatting caustic photons (rs-fg) or the caustic map (pm-fg)
//! at the eye sample; everything else through a gather ray that lands on a non-specular surface
//! (gather rays that meet emitters or specular surfaces add nothing: the terms above hold them).

use crate::film::Film;
use crate::methods::{Method, MethodError, MethodStats, Step, Timings};
use crate::scene::{Camera, Scene};
use crate::settings::{MethodKind, RenderSettings};
use glam::Vec3;
use std::sync::Arc;

mod pass;

use pass::Pass;

/// How final gathering bounds its work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FgSettings {
    /// Gather rays per eye sample.
    pub rays: u32,
    /// At most this many gather hits are splatted or gathered at once (a band of rows).
    pub max_band_samples: usize,
}

impl Default for FgSettings {
    fn default() -> Self {
        Self {
            rays: 64,
            // About a second of gathering per band on two cores: small enough that a time
            // budget or Ctrl-C is honoured within a step, large enough to amortise the tree.
            max_band_samples: 1 << 17,
        }
    }
}

/// Final gathering as a progressive method: every step is one independent pass (fresh
/// photons and gather rays, seed advanced per pass) and the film is their mean.
pub struct FinalGathering {
    scene: Arc<Scene>,
    settings: RenderSettings,
    camera: Camera,
    sum: Vec<Vec3>,
    /// Completed passes.
    passes: u64,
    /// The pass under way.
    current: Option<Pass>,
    photons: u64,
    timings: Timings,
}

impl FinalGathering {
    /// Final gathering over splatted rays (`settings.method` = rs-fg) or photon maps (pm-fg).
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        camera: Camera,
    ) -> Result<Self, MethodError> {
        if !matches!(settings.method, MethodKind::RsFg | MethodKind::PmFg) {
            return Err(MethodError::NotFinalGathering(settings.method));
        }
        let n = (settings.width * settings.height) as usize;
        Ok(Self {
            scene,
            settings,
            camera,
            sum: vec![Vec3::ZERO; n],
            passes: 0,
            current: None,
            photons: 0,
            timings: Timings::default(),
        })
    }
}

impl Method for FinalGathering {
    fn kind(&self) -> MethodKind {
        self.settings.method
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Start a pass (eye side, direct light, photons, caustics), or gather one band of rows
    /// of the pass under way; a finished pass joins the mean.
    fn step(&mut self) -> Step {
        match self.current.as_mut() {
            None => {
                let s = RenderSettings {
                    seed: self.settings.seed.wrapping_add(self.passes * 0x9e37),
                    ..self.settings.clone()
                };
                let fg = FgSettings {
                    rays: s.fg_rays.max(1),
                    ..FgSettings::default()
                };
                let splatting = self.settings.method == MethodKind::RsFg;
                let pass = Pass::start(
                    &self.scene,
                    &self.camera,
                    splatting,
                    s,
                    fg,
                    &mut self.timings,
                );
                self.photons += pass.photons;
                self.current = Some(pass);
            }
            Some(pass) => pass.gather_band(&self.scene, &mut self.timings),
        }
        if self.current.as_ref().is_some_and(Pass::done) {
            let pass = self.current.take().expect("a pass under way");
            for (a, x) in self.sum.iter_mut().zip(&pass.image) {
                *a += *x;
            }
            self.passes += 1;
        }
        Step::Traced
    }

    /// Gathering depends on the view: a new one starts from no passes.
    fn set_view(
        &mut self,
        camera: Camera,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), MethodError> {
        let settings = crate::methods::checked_view(&self.settings, width, height, spp)?;
        self.settings = settings;
        self.camera = camera;
        self.sum = vec![Vec3::ZERO; (width * height) as usize];
        self.passes = 0;
        self.current = None;
        Ok(())
    }

    fn update(&mut self, settings: &RenderSettings) -> Result<(), MethodError> {
        self.settings.photons = settings.photons;
        self.settings.bandwidth = settings.bandwidth;
        // Each gathering pass draws its own direct light: the next one with the new count.
        self.settings.nee_samples = settings.nee_samples;
        Ok(())
    }

    /// The mean of the completed passes; before the first completes, the pass under way
    /// (rows not gathered yet hold direct light and caustics only).
    fn film(&mut self) -> Film {
        let mut film = Film::new(self.settings.width, self.settings.height);
        match (&self.current, self.passes) {
            (Some(pass), 0) => film.rgb.copy_from_slice(&pass.image),
            _ => {
                let inv = 1.0 / self.passes.max(1) as f32;
                for (o, a) in film.rgb.iter_mut().zip(&self.sum) {
                    *o = *a * inv;
                }
            }
        }
        film
    }

    fn passes(&self) -> u64 {
        self.passes
    }

    fn timings(&self) -> Timings {
        self.timings
    }

    fn stats(&mut self) -> MethodStats {
        MethodStats {
            photons_traced: self.photons,
            passes: self.passes,
            ..MethodStats::default()
        }
    }
}
