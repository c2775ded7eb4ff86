//! UI tests of the ray replay and the export, driven like a user: the replay tool chosen by
//! its label, a click on the viewport, the arrow keys, Home and End; the export writing the
//! shown view and its counters, and saying clearly when it cannot.

use bvhlab_testkit as common;

use bvhlab::accel::replay::Step;
use bvhlab::app::BvhLabApp;
use bvhlab::app::export::Export;
use bvhlab::render::RayKind;
use bvhlab::render::export::CSV_HEADER;
use common::app::{launch, settle};
use eframe::egui::{self, Key};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

fn app(scene: &str) -> Harness<'static, BvhLabApp> {
    launch(
        Harness::builder().with_size(egui::vec2(1400.0, 900.0)),
        scene,
        |_| {},
    )
}

/// A click of the left button at `pos` (press and release without moving).
fn click_at(h: &mut Harness<'static, BvhLabApp>, pos: egui::Pos2) {
    h.hover_at(pos);
    h.run_steps(1);
    h.drag_at(pos);
    h.run_steps(1);
    h.drop_at(pos);
    h.run_steps(1);
    settle(h);
}

/// A point inside the viewport (between the two side panels), on the Cornell box's back
/// wall or one of its boxes.
const IN_VIEW: egui::Pos2 = egui::pos2(560.0, 480.0);

fn stop(h: &Harness<'static, BvhLabApp>) -> usize {
    h.state().replay.as_ref().expect("a replay").stop
}

#[test]
fn clicking_a_pixel_replays_its_ray_and_the_keys_step_through_it() {
    let mut h = app("cornell");
    h.get_by_label("replay a ray (P)").click();
    settle(&mut h);
    click_at(&mut h, IN_VIEW);
    let view = h.state().replay.clone().expect("the click replayed a ray");
    let replay = view.replay.clone();
    assert_eq!(replay.rays, RayKind::Primary);
    // The replay is the clicked pixel's ray: the frame's counts and hit for that pixel.
    let shown = h.state().shown.clone().expect("a frame");
    let (x, y) = replay.pixel;
    let sample = *shown.frame.sample(x, y).expect("the pixel is in the frame");
    assert_eq!(replay.counters, sample.primary);
    assert_eq!(
        replay.hit.map(|h| (h.triangle, h.t.to_bits())),
        sample
            .is_hit()
            .then_some((sample.triangle, sample.t.to_bits()))
    );
    let visits = replay.visit_count();
    assert!(visits > 2, "the ray visits several nodes");
    assert_eq!(visits as u32, sample.primary.nodes_visited);
    assert_eq!(view.stop, 0);
    assert!(h.query_by_label(&format!("visit 1 of {visits}")).is_some());
    // The visited box's slab test, from the replay's numbers: a visited box is entered.
    assert!(h.query_by_label("The slab test of this box").is_some());
    assert!(h.query_by_label_contains("enter at max(near)").is_some());

    // A stop whose node tested a child and did not take it shows that child's slab test
    // too: its intervals do not meet (or meet only beyond the best hit).
    let missed = (0..replay.stops())
        .find(|&k| {
            replay.stop_range(k).any(|i| {
                matches!(&replay.steps[i], Step::Children { children, .. }
                    if children.iter().any(|c| c.entry.is_none()))
            })
        })
        .expect("a ray into the Cornell box passes by some box");
    for _ in 0..missed {
        h.key_press(Key::ArrowRight);
    }
    h.run_steps(2);
    assert_eq!(stop(&h), missed);
    assert!(h.query_by_label_contains(", not taken").is_some());
    assert!(h.query_by_label_contains(": a miss").is_some());
    h.key_press(Key::Home);
    h.run_steps(2);

    h.key_press(Key::ArrowRight);
    h.run_steps(2);
    assert_eq!(stop(&h), 1);
    assert!(h.query_by_label(&format!("visit 2 of {visits}")).is_some());
    h.key_press(Key::End);
    h.run_steps(2);
    assert_eq!(stop(&h), visits - 1);
    // The last visit's stop shows the hit as the best so far.
    let best = h.state().replay.as_ref().unwrap().best_so_far();
    assert_eq!(best, replay.hit);
    h.key_press(Key::ArrowRight);
    h.run_steps(2);
    assert_eq!(stop(&h), visits - 1, "no step past the last visit");
    h.key_press(Key::Home);
    h.run_steps(2);
    assert_eq!(stop(&h), 0);
    h.key_press(Key::ArrowLeft);
    h.run_steps(2);
    assert_eq!(stop(&h), 0, "no step before the first visit");
    h.get_by_label("next visit").click();
    h.run_steps(2);
    assert_eq!(stop(&h), 1);
    // While the replay is open the arrows step it, not the tree walk.
    assert_eq!(h.state().walk, None);

    // With shadow rays shown, a click replays the pixel's shadow ray.
    h.key_press(Key::S);
    h.run_steps(1);
    settle(&mut h);
    click_at(&mut h, IN_VIEW);
    let shadow = h.state().replay.clone().expect("replayed").replay;
    assert_eq!(shadow.rays, RayKind::Shadow);
    let shown = h.state().shown.clone().unwrap();
    let sample = *shown.frame.sample(shadow.pixel.0, shadow.pixel.1).unwrap();
    assert_eq!(shadow.counters, sample.shadow);
    assert_eq!(shadow.hit.is_some(), !sample.lit);

    h.key_press(Key::Escape);
    h.run_steps(2);
    assert!(h.state().replay.is_none(), "Esc closes the replay");
}

#[test]
fn a_new_structure_closes_a_replay_of_the_old_one() {
    let mut h = app("cornell");
    h.key_press(Key::P);
    h.run_steps(1);
    click_at(&mut h, IN_VIEW);
    assert!(h.state().replay.is_some());
    h.get_by_label("object median").click();
    settle(&mut h);
    assert!(h.state().replay.is_none());
}

#[test]
fn export_writes_the_view_as_png_and_the_counters_as_csv() {
    let mut h = app("cornell");
    assert!(h.query_by_label("Save view as PNG…").is_some());
    assert!(h.query_by_label("Save counters as CSV…").is_some());
    let dir = common::TempDir::new("export");
    let shown = h.state().shown.clone().expect("a frame");
    let (w, hgt) = (shown.job.width, shown.job.height);

    let png = dir.join("view.png");
    h.state_mut().export(Export::ViewPng, &png).unwrap();
    let image = image::open(&png).expect("a PNG").to_rgba8();
    assert_eq!(image.dimensions(), (w, hgt));
    assert_eq!(image.as_raw(), &shown.rgba, "the view as shown");

    // With a replay open, the saved view shows it too, as the viewport does.
    h.key_press(Key::P);
    h.run_steps(1);
    click_at(&mut h, IN_VIEW);
    assert!(h.state().replay.is_some());
    let shown = h.state().shown.clone().expect("a frame");
    let with_replay = dir.join("replay.png");
    h.state_mut().export(Export::ViewPng, &with_replay).unwrap();
    let image = image::open(&with_replay).expect("a PNG").to_rgba8();
    let drawn = image
        .as_raw()
        .chunks(4)
        .zip(shown.rgba.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        drawn > 50,
        "the replay's box and ray are drawn ({drawn} pixels)"
    );

    let csv = dir.join("counters.csv");
    h.state_mut().export(Export::CountersCsv, &csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len() as u32, 1 + w * hgt);
    let (x, y) = (w / 2, hgt / 2);
    let s = shown.frame.sample(x, y).unwrap();
    let row: Vec<&str> = lines[1 + (y * w + x) as usize].split(',').collect();
    assert_eq!(
        row[0..3],
        [x.to_string(), y.to_string(), s.triangle.to_string()]
    );
    assert_eq!(row[5], s.primary.nodes_visited.to_string());
    assert_eq!(row[9], s.shadow.nodes_visited.to_string());
    h.run_steps(2);
    assert!(h.query_by_label_contains("saved").is_some());

    // A path that cannot be written is a clear error, shown in the panel; nothing breaks.
    let bad = dir.join("no-such-dir").join("view.png");
    let e = h.state_mut().export(Export::ViewPng, &bad).unwrap_err();
    assert!(
        e.contains("cannot write") && e.contains("no-such-dir"),
        "{e}"
    );
    h.run_steps(2);
    assert!(h.query_by_label_contains("cannot write").is_some());
    assert!(h.state().shown.is_some());
}

/// The hierarchy diagram under the view: shown by its toggle, and a click on a cell walks
/// the tree to that cell's node (the root's row, then the first child's at the left edge).
#[test]
fn clicking_a_cell_of_the_hierarchy_diagram_walks_the_tree_to_its_node() {
    let mut h = app("cornell");
    h.get_by_label("tree").click();
    settle(&mut h);
    let area = h.get_by_label("hierarchy diagram").rect();
    let outline = h.state().outline.clone();
    assert!(outline.nodes.len() > 1);
    let row = area.height() / (outline.max_depth() + 1) as f32;
    click_at(&mut h, egui::pos2(area.center().x, area.top() + row * 0.5));
    assert_eq!(h.state().walk, Some(0));
    click_at(
        &mut h,
        egui::pos2(area.left() + 1.0, area.top() + row * 1.5),
    );
    assert_eq!(h.state().walk, Some(outline.nodes[0].first_child));
    // Hidden again, the diagram is gone and the walk stays.
    h.get_by_label("tree").click();
    settle(&mut h);
    assert!(h.query_by_label("hierarchy diagram").is_none());
    assert_eq!(h.state().walk, Some(outline.nodes[0].first_child));
}

/// A big tree's diagram folds its deep subtrees; scrolling (here a pinch, the same zoom)
/// over it zooms in around the pointer and draws nodes that were folded, dragging pans, and
/// "whole tree" (or a double click) shows the whole tree again.
#[test]
fn zooming_the_hierarchy_diagram_unfolds_the_subtrees_under_the_pointer() {
    let mut h = launch(
        Harness::builder().with_size(egui::vec2(1400.0, 900.0)),
        "sphere:40000",
        |app| app.settings.show_tree = true,
    );
    let area = h.get_by_label("hierarchy diagram").rect();
    let whole = h.state().tree_diagram().drawn().expect("laid out").clone();
    assert_eq!(h.state().tree_diagram().window(), (0.0, 1.0));
    assert!(whole.hidden > 0, "a tree this big folds at full width");
    let at = egui::pos2(area.left() + area.width() * 0.25, area.center().y);
    h.hover_at(at);
    h.run_steps(1);
    for _ in 0..5 {
        h.event(egui::Event::Zoom(4.0));
        h.run_steps(1);
    }
    settle(&mut h);
    let (w0, w1) = h.state().tree_diagram().window();
    assert!(
        (w1 - w0 - 1.0 / 1024.0).abs() < 1e-9,
        "zoomed ×1024: {w0} {w1}"
    );
    // The point under the pointer stayed there.
    assert!((w0 + 0.25 * (w1 - w0) - 0.25).abs() < 1e-3, "{w0} {w1}");
    let zoomed = h.state().tree_diagram().drawn().expect("laid out").clone();
    assert!(zoomed.cells.iter().all(|c| c.x1 > w0 && c.x0 < w1));
    let before: std::collections::HashSet<u32> = whole.cells.iter().map(|c| c.node).collect();
    assert!(
        zoomed.cells.iter().any(|c| !before.contains(&c.node)),
        "zoomed in, nodes folded before are drawn"
    );
    // Dragged 100 points to the left, the window moves right by 100 points' worth.
    let from = egui::pos2(area.center().x, area.center().y);
    h.drag_at(from);
    h.run_steps(1);
    for k in 1..=10 {
        h.hover_at(from - egui::vec2(10.0 * k as f32, 0.0));
        h.run_steps(1);
    }
    h.drop_at(from - egui::vec2(100.0, 0.0));
    settle(&mut h);
    let (p0, _) = h.state().tree_diagram().window();
    let moved = (p0 - w0) / (w1 - w0) * f64::from(area.width());
    assert!(moved > 50.0 && moved < 110.0, "panned by {moved} points");
    assert_eq!(h.state().walk, None, "a drag is not a click");
    // "whole tree" shows it all again.
    h.get_by_label("whole tree").click();
    settle(&mut h);
    assert_eq!(h.state().tree_diagram().window(), (0.0, 1.0));
    assert_eq!(h.state().tree_diagram().drawn(), Some(&whole));
}
