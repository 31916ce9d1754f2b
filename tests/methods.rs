//! The `Method` interface, the same for every method: a view outside the limits table is
//! refused by `set_view` (before anything is allocated) and the method goes on rendering its
//! old view.

use raysplat::choice::Choice;
use raysplat::methods;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::settings::{MethodKind, RenderSettings};
use std::sync::Arc;

#[test]
fn every_method_refuses_a_view_outside_the_limits_and_keeps_its_own() {
    let scene = Arc::new(Scene::builtin(BuiltinScene::CornellClassic));
    for &kind in MethodKind::ALL {
        let settings = RenderSettings {
            width: 16,
            height: 16,
            spp: 1,
            photons: 2_000,
            fg_rays: 2,
            method: kind,
            ..RenderSettings::default()
        };
        let mut m = methods::build(scene.clone(), settings).unwrap();
        let camera = m.camera().clone();
        let e = m.set_view(camera, 5_000, 16, 1).unwrap_err();
        // Refused as a setting out of its range, naming it; the method keeps its view.
        assert!(
            matches!(e, methods::MethodError::Settings(_)) && e.to_string().contains("width"),
            "{}: {e}",
            kind.name()
        );
        m.step();
        let film = m.film();
        assert_eq!((film.width, film.height), (16, 16), "{}", kind.name());
        assert_eq!(film.invalid_pixels(), 0, "{}", kind.name());
    }
}
