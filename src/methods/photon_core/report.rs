//! What the photon core holds and has counted: its memory by part and the counters every
//! photon-based method shares.

use super::PhotonCore;
use crate::film::Film;
use crate::methods::{MemoryBreakdown, MethodStats};
use glam::Vec3;

impl PhotonCore {
    /// Free the splat tree's search structure before a finished render's last resolve (it
    /// takes no more steps); the stats keep reporting the memory held until then.
    pub(crate) fn release_search(&mut self) {
        if self.held.is_none() {
            self.held = Some((self.memory(), self.side.tree.nodes.len()));
        }
        self.side.tree.release_search();
    }

    /// Where this render's memory is: what it held before
    /// [`PhotonCore::release_search`], if that was called.
    pub fn memory(&self) -> MemoryBreakdown {
        if let Some((m, _)) = self.held {
            return m;
        }
        let side = &self.side;
        let (directional, _) = side.directional_memory();
        let pixels = (self.settings.width * self.settings.height) as usize;
        let vec3 = std::mem::size_of::<Vec3>();
        MemoryBreakdown {
            eye_samples: side.eye.memory_bytes(),
            splat_targets: side.targets.memory_bytes(),
            splat_tree: side.tree.memory_bytes() + self.domains.memory_bytes(),
            accumulators: side.acc_indirect.memory_bytes()
                + side.acc_direct.memory_bytes()
                + side.acc_fine.memory_bytes()
                - directional,
            directional_records: directional,
            photon_rays: self.store.memory_bytes(),
            emission_guide: self.store.guide_bytes(),
            photon_density: self.store.density_bytes(),
            pixel_sums: (side.emitted.len() + side.nee.len()) * vec3
                + self.lobes.memory_bytes()
                + self.earlier.memory_bytes(),
            film: pixels * Film::BYTES_PER_PIXEL,
            scene: self.scene.memory_bytes() - self.scene.texture_bytes(),
            textures: self.scene.texture_bytes(),
        }
    }

    /// The counters every photon-based method shares.
    pub fn stats(&mut self) -> MethodStats {
        let (directional_bytes, glossy_targets) = self.side.directional_memory();
        let (glossy_map_samples, glossy_traced_samples) = self.side.eye.glossy_counts();
        let mut clamps = self.store.clamps(&self.settings.bandwidth);
        // A headless render's batches were streamed and are not in the store.
        for (c, s) in clamps.iter_mut().zip(self.streamed_clamps) {
            *c += s;
        }
        MethodStats {
            photons_traced: self.store.photons_traced,
            photon_rays: self.store.rays() + self.store.released,
            photon_rays_per_class: self.store.rays_per_class(),
            photon_ray_bytes: self.store.memory_bytes(),
            passes: self.batch_count() as u64,
            folded_batches: self.folded_total,
            eye_passes: self.eye_passes(),
            memory: self.memory(),
            stored_batches: self.store.batches().len(),
            splat_bytes: self.side.memory_bytes(),
            directional_bytes,
            glossy_targets,
            glossy_map_samples,
            glossy_traced_samples,
            eye_samples: self.side.eye.len(),
            splat_targets: self.side.tree.samples,
            splat_tree_nodes: self
                .held
                .map_or(self.side.tree.nodes.len(), |(_, nodes)| nodes),
            tested_pairs: self.counters.tested,
            accepted_pairs: self.counters.accepted,
            domain_tests: self.counters.domain_tests,
            occluded_pairs: self.counters.occluded,
            domains_reused: self.domains.reused,
            domains_probed: self.domains.probed,
            splat_rays: self.counters.rays,
            rays_reaching: self.counters.rays_reaching,
            guide_batches: self.store.guide().map(|g| g.batches()),
            pilot_mean_length: Some(self.store.pilot().mean_length),
            bandwidth_clamps: Some(clamps),
            ..MethodStats::default()
        }
    }
}
