//! The start view of a scene opened from a file: an interior (sponza, sibenik, the
//! conference room) starts from inside, where the outside view shows only its hull; other
//! meshes, and every built-in scene, keep their views.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildParams, build};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::app::BvhLabApp;
use bvhlab::app::start_view::{interior_view, probe};
use bvhlab::geometry::Watertight;
use bvhlab::scene::{Scene, builtin, load_obj};
use common::app::launch;
use eframe::egui;
use egui_kittest::Harness;

/// Share of a 64 × 36 view's rays that hit, and their median distance.
fn seen(scene: &Scene, camera: &bvhlab::scene::Camera) -> (f32, f32) {
    let (tree, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
    let rays = camera.rays(64, 36);
    let mut ts = Vec::new();
    for y in 0..36 {
        for x in 0..64 {
            if let Some(h) =
                tree.closest_hit::<Watertight, _>(&rays.pixel_center(x, y), &mut NoStats)
            {
                ts.push(h.t);
            }
        }
    }
    ts.sort_by(f32::total_cmp);
    (
        ts.len() as f32 / (64.0 * 36.0),
        ts.get(ts.len() / 2).copied().unwrap_or(0.0),
    )
}

#[test]
fn an_interior_starts_from_inside_and_a_model_from_outside() {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("BVHLAB_SCENES not set: skipping the shared scenes");
        return;
    };
    for file in [
        "sponza.obj",
        "sibenik.obj",
        "conference.obj",
        "bunny.obj",
        "teapot.obj",
    ] {
        let scene = load_obj(&dir.join(file)).unwrap();
        eprintln!("{file}: {:?}", probe(&scene));
    }
    for file in ["sponza.obj", "sibenik.obj", "conference.obj"] {
        let scene = load_obj(&dir.join(file)).unwrap();
        let p = probe(&scene).unwrap();
        let camera = interior_view(&scene).unwrap_or_else(|| panic!("{file}: {p:?}"));
        let b = scene.bounds();
        assert!(
            b.contains_point(camera.eye),
            "{file}: the eye is inside the box"
        );
        // The view shows the interior: nearly every ray hits, well inside the box.
        let (hit, median) = seen(&scene, &camera);
        eprintln!(
            "{file}: inside {hit} hit, median t {median} of diagonal {}",
            b.diagonal()
        );
        assert!(hit > 0.9, "{file}: {hit}");
        assert!(median < 0.5 * b.diagonal(), "{file}: {median}");
    }
    for file in ["bunny.obj", "teapot.obj"] {
        let scene = load_obj(&dir.join(file)).unwrap();
        assert_eq!(interior_view(&scene), None, "{file}");
    }
}

#[test]
fn models_and_built_in_scenes_keep_the_framing_view() {
    for name in [
        "cornell",
        "sphere:2000",
        "soup:2000",
        "walls",
        "teapot-in-stadium",
    ] {
        let scene = Scene::load(name).unwrap();
        eprintln!("{name}: {:?}", probe(&scene));
        if !["cornell"].contains(&name) {
            assert_eq!(interior_view(&scene), None, "{name}");
        }
    }
    assert!(builtin::NAMES.contains(&"cornell"));
}

#[test]
fn the_app_opens_an_interior_inside_and_a_built_in_scene_as_before() {
    let h = launch(
        Harness::builder().with_size(egui::vec2(1000.0, 700.0)),
        "cornell",
        |_| {},
    );
    let here = h.state().preset_here("x").camera.unwrap().camera();
    let own = Scene::load("cornell").unwrap().camera();
    assert!((here.eye - own.eye).length() < 1e-4, "{here:?} {own:?}");
    let Some(dir) = common::shared_scenes() else {
        return;
    };
    let path = dir.join("sponza.obj");
    let mut h: Harness<'static, BvhLabApp> = launch(
        Harness::builder().with_size(egui::vec2(1000.0, 700.0)),
        path.to_str().unwrap(),
        |_| {},
    );
    common::app::settle(&mut h);
    let here = h.state().preset_here("x").camera.unwrap().camera();
    let inside = interior_view(&load_obj(&path).unwrap()).unwrap();
    assert!(
        (here.eye - inside.eye).length() < 1e-3,
        "{here:?} {inside:?}"
    );
}
