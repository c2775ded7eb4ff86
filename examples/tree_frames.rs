//! The hierarchy diagram's frame time, as the app makes it: a scene's BVH2 opened with the
//! diagram shown (1280 × 720), then frames of hovering, zooming and panning, each timed
//! from the app's update through the tessellation of what it drew (the GPU's share is left
//! out: here it is software Vulkan, on a lecture machine a GPU).
//!
//! ```sh
//! cargo build --release --example tree_frames
//! target/release/examples/tree_frames ../shared/scenes/conference.obj
//! ```
use bvhlab::app::BvhLabApp;
use bvhlab_testkit as common;
use common::app::{launch, settle};
use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::time::Instant;

fn stats(name: &str, mut times: Vec<f64>) {
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = times.len();
    println!(
        "{name}: median {:.2} ms, p90 {:.2} ms, max {:.2} ms ({n} frames)",
        times[n / 2],
        times[n * 9 / 10],
        times[n - 1]
    );
}

/// One frame, timed in ms: the app's update and the tessellation of what it drew.
fn frame(h: &mut Harness<'static, BvhLabApp>) -> f64 {
    let t = Instant::now();
    h.step();
    let shapes = h.output().shapes.clone();
    let ppp = h.output().pixels_per_point;
    let _ = h.ctx.tessellate(shapes, ppp);
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let Some(scene) = std::env::args().nth(1) else {
        eprintln!("usage: tree_frames <scene>");
        std::process::exit(2);
    };
    let mut h: Harness<'static, BvhLabApp> = launch(
        Harness::builder().with_size(egui::vec2(1280.0, 720.0)),
        &scene,
        |_| {},
    );
    settle(&mut h);
    h.state_mut().settings.show_tree = true;
    let t = Instant::now();
    h.step();
    println!(
        "opening frame (sizes and layout made): {:.2} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    settle(&mut h);
    println!("outline nodes: {}", h.state().outline.nodes.len());
    let area = h.get_by_label("hierarchy diagram").rect();
    let y = area.top() + area.height() * 0.6;
    let mut hover = Vec::new();
    for i in 0..120 {
        let x = area.left() + 10.0 + (i as f32 * 7.0) % (area.width() - 20.0);
        h.event(egui::Event::PointerMoved(egui::pos2(x, y)));
        hover.push(frame(&mut h));
    }
    stats("hover", hover);
    let mut zoom = Vec::new();
    h.event(egui::Event::PointerMoved(egui::pos2(
        area.center().x + 37.0,
        y,
    )));
    h.step();
    for _ in 0..40 {
        h.event(egui::Event::Zoom(1.25));
        zoom.push(frame(&mut h));
    }
    stats("zoom in, ×1.25 a frame to ×7500", zoom);
    let mut pan = Vec::new();
    let mut x = area.center().x;
    h.event(egui::Event::PointerButton {
        pos: egui::pos2(x, y),
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: Default::default(),
    });
    h.step();
    for _ in 0..60 {
        x -= 9.0;
        if x < area.left() + 20.0 {
            x = area.right() - 20.0;
        }
        h.event(egui::Event::PointerMoved(egui::pos2(x, y)));
        pan.push(frame(&mut h));
    }
    stats("pan (drag) while zoomed", pan);
}
