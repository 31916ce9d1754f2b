//! For tests only: drives and reads of a method that no renderer needs (the worker, the
//! headless loop and the window go through [`Method`] alone). Kept public so the integration
//! tests in `tests/` can reach them; nothing in the crate calls them.

use crate::methods::photon_method::{PhotonMethod, Resolver};
use crate::methods::{Method, MethodError, Step};
use crate::pipeline::eye::EyeSamples;
use crate::pipeline::photon::BandwidthParams;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::Vec3;
use std::sync::Arc;

/// A photon method of the resolver's kind from the settings' named camera (the scene's
/// first), typed so that the reads below reach its core.
pub fn open<R: Resolver + Default>(
    scene: Arc<Scene>,
    settings: RenderSettings,
) -> Result<PhotonMethod<R>, MethodError> {
    let camera = crate::methods::camera_for(&scene, &settings)?;
    PhotonMethod::new(scene, settings, camera)
}

/// Step until a new batch (or pass) is traced: a pending re-splat finishes first, and a new
/// eye pass is drawn when one is due, as in the window and a headless render.
pub fn run_batch(m: &mut dyn Method) {
    while m.step() != Step::Traced {}
}

/// Re-splat every stored batch with `params`, all at once, even when they are the current
/// ones (`Method::update` re-splats only on a change).
pub fn resplat<R: Resolver>(m: &mut PhotonMethod<R>, params: BandwidthParams) {
    m.core_mut().begin_resplat(params);
    while m.catching_up() {
        m.step();
    }
}

/// The eye samples of the current eye pass.
pub fn eye_samples<R: Resolver>(m: &PhotonMethod<R>) -> &EyeSamples {
    &m.core().side().eye
}

/// The positions of the current view's splat targets, from the splat tree (rs frees the
/// targets' own copy once the tree is built).
pub fn target_positions<R: Resolver>(m: &PhotonMethod<R>) -> Vec<Vec3> {
    let tree = &m.core().side().tree;
    tree.target_slot.iter().map(|&s| tree.position(s)).collect()
}

/// Batch-averaged splatted irradiance E (eq. 5) at every splat target of the current eye
/// pass, from the indirect and caustic photons (`direct` = false) or from the direct photons.
pub fn target_irradiance<R: Resolver>(m: &PhotonMethod<R>, direct: bool) -> Vec<Vec3> {
    let core = m.core();
    core.side().target_irradiance(direct, core.pass_batches())
}
