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

/// A resting view's eye side that the window's worker gives up for a newer view
/// (`Method::set_stop`, docs/benchmarks.md "The previewer") leaves the method mid-step, with
/// no film taken, until a step draws it; given up again while the flag stays raised, drawn
/// once it is lowered, and then the render is the one a method never stopped makes, pixel
/// for pixel. A dragged (interactive) view's side is never given up.
#[test]
fn an_eye_side_given_up_for_a_new_view_is_drawn_by_the_next_step() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let scene = Arc::new(Scene::builtin(BuiltinScene::WindowRoom));
    let settings = RenderSettings {
        width: 32,
        height: 24,
        spp: 1,
        photons: 4_000,
        method: MethodKind::Rs,
        ..RenderSettings::default()
    };
    let mut plain = methods::build(scene.clone(), settings.clone()).unwrap();
    let mut stopped = methods::build(scene.clone(), settings).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    stopped.set_stop(stop.clone());
    for m in [&mut plain, &mut stopped] {
        m.step();
        m.step();
    }
    let mut camera = plain.camera().clone();
    camera.position += camera.right() * 0.1;
    stop.store(true, Ordering::Release);
    plain.set_view(camera.clone(), 32, 24, 1).unwrap();
    stopped.set_view(camera.clone(), 32, 24, 1).unwrap();
    assert!(!plain.mid_step());
    assert!(stopped.mid_step(), "the side was not given up");
    assert_eq!(stopped.step(), methods::Step::Side);
    assert!(stopped.mid_step(), "drawn while the flag was raised");
    stop.store(false, Ordering::Release);
    // The step that draws the side does nothing else.
    assert_eq!(stopped.step(), methods::Step::Side);
    assert!(!stopped.mid_step());
    for _ in 0..4 {
        plain.step();
        stopped.step();
    }
    assert!(!stopped.mid_step());
    let (a, b) = (plain.film(), stopped.film());
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(plain.passes(), stopped.passes());

    // An interactive view's side is drawn whatever the flag says.
    stop.store(true, Ordering::Release);
    stopped.set_interactive(true);
    camera.position += camera.right() * 0.1;
    stopped.set_view(camera, 16, 12, 1).unwrap();
    assert!(!stopped.mid_step());
}
