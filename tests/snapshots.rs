//! Snapshot tests of the explorer app's main views: the whole window (panels, viewport,
//! status bar) rendered by wgpu on the CPU (Mesa's lavapipe) and compared with the reference
//! PNGs in tests/snapshots/. Refresh them with `UPDATE_SNAPSHOTS=1`.

use bvhlab::app::settings::ViewMode;
use bvhlab::app::{BvhLabApp, Launch};
use eframe::egui;
use egui_kittest::kittest::Queryable;
use egui_kittest::wgpu::WgpuTestRenderer;
use egui_kittest::{Harness, SnapshotOptions};

/// Set to 1 (as CI does) to make a machine without a wgpu adapter fail instead of skip.
const REQUIRE: &str = "BVHLAB_REQUIRE_SNAPSHOTS";

/// Small enough to keep the reference PNGs modest, large enough for all three columns.
const WINDOW: egui::Vec2 = egui::vec2(1000.0, 700.0);

/// Per-pixel tolerance and the number of pixels allowed over it. See the README's testing
/// section: lavapipe on another CPU may round a few edge pixels differently, while any real
/// change (another mode, scene, level or a moved widget) changes thousands of pixels.
fn options() -> SnapshotOptions {
    SnapshotOptions::new().threshold(1.0).max_failed_pixels(50)
}

/// The CPU renderer, or `None` to skip when this machine has no wgpu adapter. Kittest panics
/// when it finds none, so its own constructor is the check: it cannot disagree with the harness.
fn renderer() -> Option<WgpuTestRenderer> {
    let err = match std::panic::catch_unwind(WgpuTestRenderer::new) {
        Ok(renderer) => return Some(renderer),
        Err(e) => e,
    };
    let why = err
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| err.downcast_ref::<&str>().copied())
        .unwrap_or("unknown error");
    let required = std::env::var(REQUIRE).is_ok_and(|v| v == "1");
    assert!(
        !required,
        "{REQUIRE}=1 but wgpu found no adapter ({why}); install mesa-vulkan-drivers"
    );
    eprintln!(
        "snapshot test skipped: wgpu found no adapter ({why}). Install mesa-vulkan-drivers \
         to run it; set {REQUIRE}=1 to make this a failure."
    );
    None
}

/// The real app on `scene`, with `setup` applied to its settings, settled on its full frame.
fn app(scene: &str, setup: impl FnOnce(&mut BvhLabApp)) -> Option<Harness<'static, BvhLabApp>> {
    let renderer = renderer()?;
    let scene = scene.to_string();
    let mut harness = Harness::builder()
        .with_size(WINDOW)
        .with_max_steps(16)
        .renderer(renderer)
        .build_eframe(move |cc| {
            BvhLabApp::new(
                cc,
                Launch {
                    scene: Some(scene),
                    fresh: true,
                    screenshot: None,
                },
            )
        });
    setup(harness.state_mut());
    settle(&mut harness);
    Some(harness)
}

/// Runs frames and waits for the worker until the full-resolution frame is shown
/// (as in tests/app.rs).
fn settle(h: &mut Harness<'static, BvhLabApp>) {
    for _ in 0..40 {
        h.run_steps(2);
        let ctx = h.ctx.clone();
        h.state_mut().wait_for_worker(&ctx);
        h.run_steps(1);
        if h.state().settled() {
            // Two more frames so grids sized from the new frame's numbers are laid out.
            h.run_steps(2);
            assert!(
                h.state().settled(),
                "the extra frames asked for a new render"
            );
            return;
        }
        // Let a preview's settling time pass.
        std::thread::sleep(std::time::Duration::from_millis(60));
    }
    panic!("the app did not settle");
}

/// Masks the texts that change from run to run (build and trace times, Mrays/s), then
/// compares the window with tests/snapshots/`name`.png.
fn check(mut h: Harness<'static, BvhLabApp>, name: &str) {
    let timings: Vec<egui::Rect> = h
        .get_all_by(|n| {
            n.label()
                .is_some_and(|l| l.ends_with(" ms") || l.contains(" ms ") || l.contains("Mrays/s"))
        })
        .map(|n| n.rect())
        .collect();
    assert!(
        timings.len() >= 3,
        "expected the build time, the status bar and the last frame"
    );
    for rect in timings {
        h.mask(rect);
    }
    h.snapshot_options(name, &options());
}

#[test]
fn cornell_box_shaded() {
    let Some(h) = app("cornell", |_| {}) else {
        return;
    };
    check(h, "cornell_shaded");
}

#[test]
fn teapot_in_stadium_nodes_visited() {
    let Some(h) = app("teapot-in-stadium", |a| a.settings.mode = ViewMode::Nodes) else {
        return;
    };
    check(h, "teapot_in_stadium_nodes");
}

#[test]
fn teapot_in_stadium_level_three_overlay() {
    let Some(h) = app("teapot-in-stadium", |a| {
        a.settings.show_levels = true;
        a.settings.level = 3;
    }) else {
        return;
    };
    check(h, "teapot_in_stadium_level3");
}
