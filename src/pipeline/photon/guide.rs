//! Photons where the camera looks (docs/deviations.md §44): an emission guide learns from the
//! batches so far which parts of each light send photons whose rays splat onto eye samples,
//! and emits in proportion, with the weights that keep the estimate unbiased.
//!
//! **Cells.** A photon leaving light i is a function of its primary sample: the position
//! sample `u_pos` (a point on an emitting triangle, or on the disc of light from afar), the
//! direction sample `u_dir` (a direction of the hemisphere, the environment map's or the
//! sun's disc) and a side ([`crate::scene::Lights::emit`]). Each light's square of `u_pos` and
//! square of `u_dir` are cut into a grid of cells ([`cells_of`]): the environment's
//! position disc and directions both, the sun's and a directional light's disc, a
//! punctual light's directions, an area light's position coarsely and its directions as
//! finely as the scene's own lights' shared budget allows ([`LOCAL_CELL_BUDGET`]).
//!
//! **Learning.** After each batch the splat pass says, per stored ray, whether it splatted
//! onto at least one eye sample ([`crate::pipeline::splat::prepare_and_splat`]); a cell's
//! rate is the reaching rays per photon drawn from it, summed over the batches
//! ([`EmissionGuide::learn`]), with a prior of [`PRIOR_PHOTONS`] photons at its light's mean
//! rate, so that a cell seen a few times does not decide alone.
//!
//! **Sampling.** Light i is chosen with P(i) = (1 − α)·p_sel(i) + α·p_sel(i)·rate_i / Σ_j
//! p_sel(j)·rate_j, and its cell c with P(c | i) = (1 − α)/n_i + α·rate_c / Σ rate, α =
//! [`GUIDE_MIX`] (a defensive mixture, Hesterberg 1995: every cell keeps at least (1 − α)²
//! of its uniform probability, so no photon weighs more than 4 times its unguided power and
//! no part of a light is ever left out). The sample is uniform within the cell, so the
//! photon's density in primary sample space is P(i)·P(c | i)·n_i instead of p_sel(i): its
//! power is divided by it and its eq. 7 density multiplied by it ([`crate::scene::Lights::emit`]).
//! Each batch is unbiased given the guide it was drawn with (the guide is fixed while a batch
//! is traced), so the progressive average is too.

use crate::sampling::{Distribution1D, Rng};
use crate::scene::{EmittedPhoton, Light, Lights};
use glam::Vec2;

pub use super::NO_CELL;

/// α, the share of photons emitted in proportion to the learned rates (the rest in
/// proportion to power, as without the guide).
pub const GUIDE_MIX: f32 = 0.5;
/// The prior of a cell's rate: this many photons at its light's mean rate.
pub const PRIOR_PHOTONS: f64 = 4.0;
/// Area lights each get a grid of cells while there are at most this many; beyond, one cell
/// each (the guide then chooses among the triangles only).
pub const AREA_LIGHTS_WITH_GRID: usize = 4096;
/// Cells per side of an area light's position square.
pub const AREA_POSITION_GRID: u32 = 2;
/// Cells shared by the scene's own lights (area and punctual): each gets an equal part, as a
/// direction grid as fine as that allows within [`AREA_DIRECTION_GRID`] or
/// [`PUNCTUAL_DIRECTION_GRID`] (a soft bound: the coarsest grids of very many lights exceed
/// it; a light of many triangles has a grid per triangle, each learning from its own
/// photons). A lamp that lights a room through its window sends a few tenths of a percent of
/// its photons through it (`builtin:room`'s lamp, 14 m out: 0.4% of its cosine-weighted
/// directions); only a grid of about that cell size can find the window, and a coarse one
/// starves the lamp instead (docs/deviations.md §44). 2¹⁶ cells hold 768 kB.
pub const LOCAL_CELL_BUDGET: usize = 1 << 16;
/// The coarsest and finest direction grid sides of an area light (its cosine-weighted
/// hemisphere).
pub const AREA_DIRECTION_GRID: (u32, u32) = (2, 16);
/// The coarsest and finest direction grid sides of a point or spot light (its sphere or cone).
pub const PUNCTUAL_DIRECTION_GRID: (u32, u32) = (8, 32);

/// The cells of one light: (position grid side, direction grid side). `local_lights` counts
/// the scene's area and punctual lights, `area_lights` the area ones.
pub fn cells_of(light: &Light, local_lights: usize, area_lights: usize) -> (u32, u32) {
    let share = LOCAL_CELL_BUDGET / local_lights.max(1);
    let side = |cells: usize, (lo, hi): (u32, u32)| ((cells as f64).sqrt() as u32).clamp(lo, hi);
    match light {
        // The disc of light from afar is where the guide finds a window: 32 × 32.
        Light::Environment { .. } => (32, 4),
        Light::Sun(_) | Light::Directional { .. } => (32, 1),
        Light::Point { .. } | Light::Spot { .. } => (1, side(share, PUNCTUAL_DIRECTION_GRID)),
        Light::Area { .. } if area_lights <= AREA_LIGHTS_WITH_GRID => {
            let position = AREA_POSITION_GRID;
            let per_direction = share / (position * position) as usize;
            (position, side(per_direction, AREA_DIRECTION_GRID))
        }
        Light::Area { .. } => (1, 1),
    }
}

/// One light's cells: the first global cell and the grids' sides.
#[derive(Clone, Copy, Debug)]
struct LightCells {
    first: u32,
    pos: u16,
    dir: u16,
}

impl LightCells {
    fn count(&self) -> usize {
        (self.pos as usize).pow(2) * (self.dir as usize).pow(2)
    }
}

/// The emission guide of one scene and view (module docs).
#[derive(Clone, Debug)]
pub struct EmissionGuide {
    lights: Vec<LightCells>,
    /// Each light's selection probability by power (p_sel).
    p_sel: Vec<f32>,
    /// Guided light selection; `None` until something was learned.
    select: Option<Distribution1D>,
    /// Per light, its cells' guided distribution (`None`: uniform over its cells).
    within: Vec<Option<Distribution1D>>,
    /// Reaching rays per cell, summed over the batches learned from.
    reached: Vec<f32>,
    /// Photons drawn per cell (expected: photons × its probability), summed likewise.
    drawn: Vec<f32>,
    /// Batches after which something had reached an eye sample ([`EmissionGuide::batches`]).
    batches: u32,
}

impl EmissionGuide {
    /// A guide for `lights` that has learned nothing: it emits as the lights do (by power),
    /// the same photons from the same random numbers, and only names their cells.
    pub fn new(lights: &Lights) -> Self {
        let count = |local: fn(&Light) -> bool| lights.lights.iter().filter(|l| local(l)).count();
        let area = count(|l| matches!(l, Light::Area { .. }));
        let local = count(|l| {
            matches!(
                l,
                Light::Area { .. } | Light::Point { .. } | Light::Spot { .. }
            )
        });
        let mut first = 0u32;
        let cells = lights
            .lights
            .iter()
            .map(|l| {
                let (pos, dir) = cells_of(l, local, area);
                let c = LightCells {
                    first,
                    pos: pos as u16,
                    dir: dir as u16,
                };
                first = first.saturating_add(c.count() as u32);
                c
            })
            .collect::<Vec<_>>();
        // Beyond 2^24 cells (millions of emitting triangles) the guide gives up: no cells.
        let usable = (first as u64) < NO_CELL as u64;
        let n = if usable { first as usize } else { 0 };
        Self {
            p_sel: (0..lights.lights.len())
                .map(|i| lights.selection_pmf(i))
                .collect(),
            lights: if usable { cells } else { Vec::new() },
            select: None,
            within: vec![None; if usable { lights.lights.len() } else { 0 }],
            reached: vec![0.0; n],
            drawn: vec![0.0; n],
            batches: 0,
        }
    }

    /// Cells over every light.
    pub fn cells(&self) -> usize {
        self.reached.len()
    }

    /// Batches after which the guide emitted by what reached the eye samples (0: photons
    /// still leave the lights by power, nothing having reached one).
    pub fn batches(&self) -> u32 {
        self.batches
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.reached.len() * 8
            + self.lights.len() * std::mem::size_of::<LightCells>()
            + self.p_sel.len() * 4
            + self
                .within
                .iter()
                .flatten()
                .map(|d| d.len() * 4)
                .sum::<usize>()
    }

    /// Forget what was learned (a new view): photons leave the lights by power again.
    pub fn reset(&mut self) {
        self.emit_by_power();
        self.reached.iter_mut().for_each(|r| *r = 0.0);
        self.drawn.iter_mut().for_each(|d| *d = 0.0);
        self.batches = 0;
    }

    /// Drop the guided distributions: the next photons leave the lights by power.
    fn emit_by_power(&mut self) {
        self.select = None;
        self.within.iter_mut().for_each(|w| *w = None);
    }

    /// The probability that a photon comes from cell `c` of light `i` (cell `local`).
    fn probability(&self, i: usize, local: usize) -> f64 {
        let p_light = match &self.select {
            Some(d) => d.pmf(i),
            None => self.p_sel[i],
        } as f64;
        let n = self.lights[i].count();
        let p_cell = match &self.within[i] {
            Some(d) => d.pmf(local) as f64,
            None => 1.0 / n as f64,
        };
        p_light * p_cell
    }

    /// Draw a photon (the lights' own sampling, [`Lights::sample_emission`], while nothing
    /// is learned: the same random numbers give the same photon) and its global cell.
    pub fn sample(&self, lights: &Lights, rng: &mut Rng) -> Option<(EmittedPhoton, u32)> {
        if self.lights.is_empty() {
            return lights.sample_emission(rng).map(|e| (e, NO_CELL));
        }
        let u_light = rng.next_f32();
        let mut u_pos = rng.next_2d();
        let mut u_dir = rng.next_2d();
        let u_side = rng.next_f32();
        let Some(select) = &self.select else {
            let (i, p_sel) = lights.select(u_light)?;
            let cell = self.cell_of(i, u_pos, u_dir);
            return lights
                .emit(i, p_sel, u_pos, u_dir, u_side)
                .map(|e| (e, cell));
        };
        let (i, p_light) = select.sample(u_light);
        let lc = self.lights[i];
        let n = lc.count();
        let (local, p_cell) = match &self.within[i] {
            Some(d) => d.sample(rng.next_f32()),
            None => {
                let c = ((rng.next_f32() * n as f32) as usize).min(n - 1);
                (c, 1.0 / n as f32)
            }
        };
        // The cell's square of u_pos and of u_dir; the sample uniform within each.
        let (pos, dir) = (lc.pos as usize, lc.dir as usize);
        let (pc, dc) = (local / (dir * dir), local % (dir * dir));
        let within = |u: Vec2, c: usize, side: usize| {
            let (x, y) = ((c % side) as f32, (c / side) as f32);
            let s = side as f32;
            Vec2::new(
                ((x + u.x) / s).min(1.0 - f32::EPSILON / 2.0),
                ((y + u.y) / s).min(1.0 - f32::EPSILON / 2.0),
            )
        };
        u_pos = within(u_pos, pc, pos);
        u_dir = within(u_dir, dc, dir);
        let density = p_light * p_cell * n as f32;
        lights
            .emit(i, density, u_pos, u_dir, u_side)
            .map(|e| (e, lc.first + local as u32))
    }

    /// The global cell of light `i`'s primary sample (`u_pos`, `u_dir`).
    fn cell_of(&self, i: usize, u_pos: Vec2, u_dir: Vec2) -> u32 {
        let lc = self.lights[i];
        let at = |u: Vec2, side: u16| {
            let s = side as f32;
            let x = ((u.x * s) as usize).min(side as usize - 1);
            let y = ((u.y * s) as usize).min(side as usize - 1);
            y * side as usize + x
        };
        let d = (lc.dir as usize).pow(2);
        lc.first + (at(u_pos, lc.pos) * d + at(u_dir, lc.dir)) as u32
    }

    /// Learn from one batch: `reached[c]` rays of photons from cell c splatted onto at least
    /// one eye sample, of `photons` photons drawn with the current guide. Then the guided
    /// distributions for the next batch (module docs).
    pub fn learn(&mut self, reached: &[u32], photons: u64) {
        if self.lights.is_empty() || reached.len() != self.reached.len() || photons == 0 {
            return;
        }
        for i in 0..self.lights.len() {
            let lc = self.lights[i];
            for local in 0..lc.count() {
                let c = lc.first as usize + local;
                let drawn = photons as f64 * self.probability(i, local);
                self.drawn[c] += drawn as f32;
                self.reached[c] += reached[c] as f32;
            }
        }
        let (total_reached, total_drawn) = (
            self.reached.iter().map(|&r| r as f64).sum::<f64>(),
            self.drawn.iter().map(|&d| d as f64).sum::<f64>(),
        );
        if total_reached <= 0.0 || total_drawn <= 0.0 {
            // Nothing reached the eye samples yet: keep emitting by power.
            self.emit_by_power();
            return;
        }
        self.batches += 1;
        let mean = total_reached / total_drawn;
        let alpha = GUIDE_MIX as f64;
        let mut light_rates = Vec::with_capacity(self.lights.len());
        let mut weights = Vec::new();
        for (i, lc) in self.lights.iter().enumerate() {
            let cells = lc.first as usize..lc.first as usize + lc.count();
            let r: f64 = self.reached[cells.clone()].iter().map(|&v| v as f64).sum();
            let d: f64 = self.drawn[cells.clone()].iter().map(|&v| v as f64).sum();
            let rate_i = (r + PRIOR_PHOTONS * mean) / (d + PRIOR_PHOTONS);
            light_rates.push(rate_i);
            self.within[i] = if lc.count() > 1 {
                weights.clear();
                weights.extend(cells.map(|c| {
                    (self.reached[c] as f64 + PRIOR_PHOTONS * rate_i)
                        / (self.drawn[c] as f64 + PRIOR_PHOTONS)
                }));
                let sum: f64 = weights.iter().sum();
                let n = weights.len() as f64;
                weights
                    .iter_mut()
                    .for_each(|w| *w = (1.0 - alpha) / n + alpha * *w / sum);
                Distribution1D::new(&weights)
            } else {
                None
            };
        }
        let norm: f64 = (0..self.lights.len())
            .map(|i| self.p_sel[i] as f64 * light_rates[i])
            .sum();
        let light_weights: Vec<f64> = (0..self.lights.len())
            .map(|i| {
                let p = self.p_sel[i] as f64;
                (1.0 - alpha) * p + alpha * p * light_rates[i] / norm
            })
            .collect();
        self.select = Distribution1D::new(&light_weights);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BuiltinScene, EnvironmentKind, EnvironmentSettings, Scene, Sun};

    /// The guided photons' mean power is the lights' total power, whatever was learned:
    /// a guide taught that one corner of the environment's disc is all that matters still
    /// gives the total within the noise (the weights make up for the density).
    #[test]
    fn guided_emission_keeps_the_total_power() {
        let mut scene = Scene::builtin(BuiltinScene::Outdoor);
        scene
            .set_environment(&EnvironmentSettings {
                kind: EnvironmentKind::Sky,
                sun: Some(Sun {
                    elevation_deg: 40.0,
                    azimuth_deg: 30.0,
                    strength: 10.0,
                }),
                ..Default::default()
            })
            .expect("a sky and a sun");
        let lights = &scene.lights;
        let mut guide = EmissionGuide::new(lights);
        assert!(guide.cells() > 0);
        // Teach it that only the first 40 cells of each light reach anything.
        let mut reached = vec![0u32; guide.cells()];
        for lc in &guide.lights {
            for c in 0..lc.count().min(40) {
                reached[lc.first as usize + c] = 50;
            }
        }
        guide.learn(&reached, 100_000);
        assert!(guide.select.is_some());
        let n = 400_000u64;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        let mut in_taught = 0u64;
        for k in 0..n {
            let mut rng = Rng::new(7, k);
            let Some((e, cell)) = guide.sample(lights, &mut rng) else {
                continue;
            };
            let p = crate::sampling::luminance(e.power) as f64;
            sum += p;
            sum2 += p * p;
            let i = guide.lights.partition_point(|l| l.first <= cell) - 1;
            in_taught += ((cell - guide.lights[i].first) < 40) as u64;
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        let total = crate::sampling::luminance(lights.total_power) as f64;
        assert!(
            (mean - total).abs() < 4.0 * sigma + 1e-4 * total,
            "mean power {mean} vs total {total} (σ {sigma})"
        );
        // And it does guide: far more photons from the taught cells than their share.
        assert!(
            in_taught as f64 > 0.3 * n as f64,
            "{in_taught} of {n} photons from the taught cells"
        );
    }

    /// The scene's own lights share [`LOCAL_CELL_BUDGET`]: the direction grid's side is the
    /// square root of a light's share within its bounds, and the cell count fits the ray tag.
    #[test]
    fn the_scenes_own_lights_share_the_cell_budget() {
        let point = Light::Point {
            position: glam::Vec3::ZERO,
            intensity: glam::Vec3::ONE,
        };
        // One light: the finest grid; 64: √1024 = 32; 65: √1008 → 31; 4,096: √16 → the
        // coarsest, 8.
        for (local, side) in [
            (1, 32),
            (64, 32),
            (65, 31),
            (256, 16),
            (4096, 8),
            (1 << 20, 8),
        ] {
            assert_eq!(cells_of(&point, local, 0), (1, side), "{local} lights");
        }
        // CORNELL BOX I's two light triangles: 2 × 2 positions × 16 × 16 directions each.
        let scene = Scene::builtin(BuiltinScene::CornellBox1);
        let guide = EmissionGuide::new(&scene.lights);
        assert_eq!(guide.cells(), 2 * 4 * 256);
        // The room: its lamp's two triangles likewise, and the sky's 32² × 4².
        let mut room = Scene::builtin(BuiltinScene::WindowRoom);
        room.set_environment(&EnvironmentSettings {
            kind: EnvironmentKind::Uniform,
            ..Default::default()
        })
        .expect("a uniform sky");
        let guide = EmissionGuide::new(&room.lights);
        assert_eq!(guide.cells(), 2 * 4 * 256 + 32 * 32 * 16);
        assert!((guide.cells() as u64) < NO_CELL as u64);
    }

    /// Before learning, the guide emits the lights' own photons from the same numbers.
    #[test]
    fn an_untaught_guide_emits_as_the_lights_do() {
        let scene = Scene::builtin(BuiltinScene::CornellBox1);
        let guide = EmissionGuide::new(&scene.lights);
        for k in 0..1000 {
            let a = scene.lights.sample_emission(&mut Rng::new(3, k));
            let b = guide.sample(&scene.lights, &mut Rng::new(3, k));
            match (a, b) {
                (Some(a), Some((b, cell))) => {
                    assert_eq!(a.origin, b.origin);
                    assert_eq!(a.direction, b.direction);
                    assert_eq!(a.power, b.power);
                    assert!((cell as usize) < guide.cells());
                }
                (None, None) => {}
                _ => panic!("photon {k}: one sampler emitted and the other did not"),
            }
        }
    }
}
