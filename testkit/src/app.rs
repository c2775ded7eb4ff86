//! The real explorer app in an egui_kittest harness, for the UI and snapshot tests: its real
//! worker thread, settled on the full-resolution frame before a test looks at it.

use bvhlab::app::{BvhLabApp, Launch};
use egui_kittest::{Harness, HarnessBuilder};

/// The app on `scene` (fresh settings), with `setup` applied to its state, settled.
pub fn launch(
    builder: HarnessBuilder<BvhLabApp>,
    scene: &str,
    setup: impl FnOnce(&mut BvhLabApp),
) -> Harness<'static, BvhLabApp> {
    let scene = scene.to_string();
    let mut harness = builder.with_max_steps(16).build_eframe(move |cc| {
        BvhLabApp::new(
            cc,
            Launch {
                scene: Some(scene),
                // The BVH2, the teaching tree, whatever layout a fresh start would trace.
                accel: Some(bvhlab::accel::AccelKind::Bvh),
                fresh: true,
                ..Default::default()
            },
        )
    });
    setup(harness.state_mut());
    settle(&mut harness);
    harness
}

/// The app opened as `launch` says (a preset, a screenshot plan) in a `width` × `height`
/// window, not yet settled.
pub fn open(width: f32, height: f32, launch: Launch) -> Harness<'static, BvhLabApp> {
    Harness::builder()
        .with_size([width, height])
        .with_max_steps(16)
        .build_eframe(move |cc| BvhLabApp::new(cc, launch))
}

/// Runs frames and waits for the worker until the full-resolution frame is shown and stays
/// so over two more frames (a panel that grows once the report is filled in resizes the
/// viewport, which asks for another frame).
pub fn settle(h: &mut Harness<'static, BvhLabApp>) {
    for _ in 0..40 {
        h.run_steps(2);
        let ctx = h.ctx.clone();
        h.state_mut().wait_for_worker(&ctx);
        h.run_steps(1);
        if h.state().settled() {
            h.run_steps(2);
            if h.state().settled() {
                return;
            }
        }
        // Let a preview's settling time pass.
        std::thread::sleep(std::time::Duration::from_millis(60));
    }
    panic!("the app did not settle");
}
