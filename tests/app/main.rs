//! UI tests of the explorer app with egui_kittest: the real app, its real worker thread,
//! driven through its labelled widgets and pointer events.

use bvhlab::accel::bvh::{BuildParams, Strategy, build};
use bvhlab_testkit as common;

use bvhlab::app::BvhLabApp;
use bvhlab::render::{RenderSettings, render};
use common::app::{launch, settle};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

fn app(scene: &str) -> Harness<'static, BvhLabApp> {
    launch(
        Harness::builder().with_size(egui::vec2(1400.0, 900.0)),
        scene,
        |_| {},
    )
}

/// `app` in a taller window: the longer parameter lists' last controls in sight (a click
/// does not scroll the controls to them).
fn tall_app(scene: &str) -> Harness<'static, BvhLabApp> {
    launch(
        Harness::builder().with_size(egui::vec2(1400.0, 1100.0)),
        scene,
        |_| {},
    )
}

/// Drags the whole object under the middle of the viewport (the back wall or a box of the
/// Cornell box) up and to the right.
fn drag_an_object(h: &mut Harness<'static, BvhLabApp>) {
    h.get_by_label("move triangles (M)").click();
    // The checkbox lies below the window's fold under the longer parameter lists; set as
    // the click would.
    h.state_mut().settings.move_whole_object = true;
    settle(h);
    let centre = egui::pos2(700.0, 430.0);
    h.hover_at(centre);
    h.run_steps(1);
    h.drag_at(centre);
    h.run_steps(1);
    for k in 1..=8 {
        h.hover_at(centre + egui::vec2(6.0 * k as f32, -3.0 * k as f32));
        h.run_steps(1);
    }
    h.drop_at(centre + egui::vec2(48.0, -24.0));
    settle(h);
}

/// The settings `shown` was traced with, over `scene`, counting.
fn settings_of(shown: &bvhlab::app::worker::Shown, scene: &bvhlab::scene::Scene) -> RenderSettings {
    RenderSettings {
        width: shown.job.width,
        height: shown.job.height,
        camera: shown.job.camera,
        light: scene.light(),
        mode: shown.job.mode,
        heat_max: None,
        shadows: true,
        counters: true,
    }
}

/// The frame shown equals one traced through a fresh BVH2 build of the moved scene.
fn assert_frame_equals_a_fresh_build(h: &mut Harness<'static, BvhLabApp>) {
    h.state_mut().request_snapshot();
    settle(h);
    let app = h.state();
    let moved = app.snapshot.clone().expect("snapshot");
    let shown = app.shown.clone().unwrap();
    let (fresh, _) = build(&moved.triangles, &BuildParams::default()).unwrap();
    let settings = settings_of(&shown, &moved);
    let expected = render(&fresh, &moved, &settings);
    let mut differing = 0;
    for (a, b) in shown.frame.samples.iter().zip(&expected.samples) {
        if a.triangle != b.triangle || a.t.to_bits() != b.t.to_bits() {
            differing += 1;
        }
    }
    assert_eq!(
        differing, 0,
        "hits through the refitted tree equal a fresh build's"
    );
}

/// A file dropped onto the window, as the windowing layer hands it to egui.
#[derive(Debug)]
struct DroppedPath(std::path::PathBuf);

impl egui::DroppedFile for DroppedPath {
    fn path(&self) -> &std::path::Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

/// Chooses `title` in the structure selector.
fn choose_structure(h: &mut Harness<'static, BvhLabApp>, title: &str) {
    h.get_by_role_and_label(egui::accesskit::Role::ComboBox, "structure")
        .click();
    h.run_steps(2);
    h.get_by_label(title).click();
    settle(h);
}

/// The app on a small island (three objects) under the two levels, settled.
fn small_island() -> Harness<'static, BvhLabApp> {
    let mut h = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .with_max_steps(16)
        .build_eframe(|cc| {
            BvhLabApp::new(
                cc,
                bvhlab::app::Launch {
                    scene: Some("island:1".into()),
                    accel: Some(bvhlab::accel::AccelKind::TwoLevel),
                    fresh: true,
                    ..Default::default()
                },
            )
        });
    settle(&mut h);
    h
}

mod controls;
mod files;
mod moves;
mod panels;
mod structures;
