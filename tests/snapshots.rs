//! Snapshot tests of the explorer app's main views: the whole window (panels, viewport,
//! status bar) rendered by wgpu on the CPU (Mesa's lavapipe) and compared with the reference
//! PNGs in tests/snapshots/. Refresh them with `UPDATE_SNAPSHOTS=1`.

use bvhlab::render::ViewMode;
use bvhlab_testkit as common;

use bvhlab::app::BvhLabApp;
use common::app::launch;
use eframe::egui;
use egui_kittest::kittest::Queryable;
use egui_kittest::wgpu::WgpuTestRenderer;
use egui_kittest::{Harness, SnapshotOptions};

/// Set to 1 (as CI does) to make a machine without a wgpu adapter fail instead of skip.
const REQUIRE: &str = "BVHLAB_REQUIRE_SNAPSHOTS";

/// Small enough to keep the reference PNGs modest, large enough for all three columns.
const WINDOW: egui::Vec2 = egui::vec2(1000.0, 700.0);

/// Kittest's default per-pixel tolerance (YIQ distance 0.6) and 20 pixels allowed over it.
/// Measured: Mesa's GL path instead of Vulkan differs in at most 15 pixels, all under 0.4;
/// the smallest real change tried (the heatmap scale's top at 110 instead of 109) fails 845.
fn options() -> SnapshotOptions {
    SnapshotOptions::new().threshold(0.6).max_failed_pixels(20)
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

/// The real app on `scene`, with `setup` applied to its settings, settled on its full frame;
/// `None` to skip on a machine without a wgpu adapter.
fn app(scene: &str, setup: impl FnOnce(&mut BvhLabApp)) -> Option<Harness<'static, BvhLabApp>> {
    let builder = Harness::builder().with_size(WINDOW).renderer(renderer()?);
    Some(launch(builder, scene, setup))
}

/// Masks the texts that change from run to run (build and trace times, Mrays/s), then
/// compares the window with tests/snapshots/`name`.png.
fn check(mut h: Harness<'static, BvhLabApp>, name: &str) {
    // egui puts a label's text in its accesskit value.
    let timings: Vec<egui::Rect> = h
        .query_all_by(|n| {
            n.value()
                .is_some_and(|v| v.ends_with(" ms") || v.contains(" ms ") || v.contains("Mrays/s"))
        })
        .map(|n| n.rect())
        .collect();
    assert!(!timings.is_empty(), "the status bar shows the trace time");
    for rect in timings {
        // Up to the window's right edge: a longer number must not change the masked area.
        h.mask(egui::Rect::from_min_max(
            rect.min,
            egui::pos2(WINDOW.x, rect.max.y),
        ));
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
