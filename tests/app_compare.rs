//! UI tests of the comparison of two configurations, driven like a user: pin the current
//! configuration as A (button or key A), change the builder, choose the view A | B or
//! B − A, and read the summary; A follows the scene through moves and loads.

use bvhlab_testkit as common;

use bvhlab::app::BvhLabApp;
use bvhlab::render::Mode;
use bvhlab::render::colormap::to_rgba8;
use bvhlab::render::compare::{CompareView, diverging};
use bvhlab::render::per_triangle::shared_shown;
use common::app::{launch, settle};
use eframe::egui::{self, Key};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::sync::Arc;

fn app(scene: &str) -> Harness<'static, BvhLabApp> {
    // Tall enough that the Compare section sits in sight below View (a click does not
    // scroll the controls to it).
    launch(
        Harness::builder().with_size(egui::vec2(1400.0, 1100.0)),
        scene,
        |_| {},
    )
}

/// The one summary of the heatmap's counter, as the stats panel shows it.
fn summary(h: &Harness<'static, BvhLabApp>) -> bvhlab::render::compare::CompareSummary {
    let compared = h.state().compared.clone().expect("a comparison");
    assert_eq!(compared.error, None);
    assert_eq!(compared.summaries.len(), 1);
    compared.summaries[0]
}

/// Whether every pixel of the shown image is the difference map's grey of zero.
fn all_zero(h: &Harness<'static, BvhLabApp>) -> bool {
    let grey = to_rgba8(diverging(0.0));
    let shown = h.state().shown.clone().expect("a frame");
    shown.rgba.chunks_exact(4).all(|p| p == grey)
}

fn nodes_difference(h: &mut Harness<'static, BvhLabApp>) {
    h.get_by_role_and_label(egui::accesskit::Role::Button, "nodes visited")
        .click();
    settle(h);
    h.get_by_label("Pin as A").click();
    settle(h);
    h.get_by_role_and_label(egui::accesskit::Role::Button, "B − A")
        .click();
    settle(h);
}

#[test]
fn pin_change_the_builder_and_see_the_difference() {
    let mut h = app("soup:3000");
    assert!(h.state().pinned.is_none());
    nodes_difference(&mut h);
    assert!(h.state().pinned.is_some());
    assert_eq!(h.state().settings.compare_view, CompareView::Difference);
    // A and B are the same configuration: no pixel differs.
    let same = summary(&h);
    assert_eq!(same.total_a, same.total_b);
    assert_eq!((same.cheaper, same.dearer), (0, 0));
    assert!(all_zero(&h));
    assert!(h.query_by_label("A against B").is_some());
    // B: another builder.
    h.get_by_label("object median").click();
    settle(&mut h);
    let changed = summary(&h);
    assert_eq!(changed.total_a, same.total_a, "A stays as pinned");
    assert_ne!(changed.total_b, changed.total_a);
    assert!(changed.cheaper + changed.dearer > 0);
    assert_eq!(
        changed.cheaper + changed.equal + changed.dearer,
        changed.pixels
    );
    assert!(!all_zero(&h));
    let text = format!("{:+}", changed.total_difference());
    assert!(
        h.get_all_by_label_contains(&text).count() >= 1,
        "the panel shows B − A = {text}"
    );
    assert!(
        h.get_all_by_label_contains("pixels cheaper under B")
            .count()
            >= 1
    );
    // Pinning B as A: they agree again.
    h.get_by_label("Pin B as A").click();
    settle(&mut h);
    assert!(all_zero(&h));
    // Key A unpins: one configuration, one image.
    h.key_press(Key::A);
    settle(&mut h);
    assert!(h.state().pinned.is_none());
    assert!(h.state().shown.as_ref().unwrap().compared.is_none());
    assert!(h.query_by_label("A against B").is_none());
}

#[test]
fn the_split_shows_a_left_of_the_divider_and_b_right() {
    let mut h = app("soup:3000");
    h.get_by_role_and_label(egui::accesskit::Role::Button, "nodes visited")
        .click();
    settle(&mut h);
    h.key_press(Key::A);
    settle(&mut h);
    assert!(h.state().pinned.is_some());
    assert_eq!(h.state().settings.compare_view, CompareView::Split);
    let before = h.state().shown.clone().unwrap();
    h.get_by_label("object median").click();
    settle(&mut h);
    let after = h.state().shown.clone().unwrap();
    let (w, hgt) = (after.job.width as usize, after.job.height as usize);
    assert_eq!(
        (w, hgt),
        (before.job.width as usize, before.job.height as usize)
    );
    let px = |rgba: &[u8], x: usize, y: usize| rgba[(y * w + x) * 4..(y * w + x) * 4 + 4].to_vec();
    // A white divider down the middle.
    assert!((hgt / 4..hgt).all(|y| px(&after.rgba, w / 2, y) == [255, 255, 255, 255]));
    // B changed the right half only, but for the letters' corners the left half is A's
    // under a scale shared by both halves.
    let rows = hgt / 3..hgt;
    let changed = |x0: usize, x1: usize| {
        rows.clone()
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| px(&before.rgba, x, y) != px(&after.rgba, x, y))
            .count()
    };
    assert!(changed(w / 2 + 2, w) > 0, "B's half changed");
    let scale_changed = before.heat_max != after.heat_max;
    assert!(
        scale_changed || changed(0, w / 2 - 2) == 0,
        "A's half stayed"
    );
    // Key C cycles the views: A | B → B − A → B only.
    h.key_press(Key::C);
    settle(&mut h);
    assert_eq!(h.state().settings.compare_view, CompareView::Difference);
    h.key_press(Key::C);
    settle(&mut h);
    assert_eq!(h.state().settings.compare_view, CompareView::BOnly);
    // B only still compares in the panel.
    assert!(summary(&h).total_b != summary(&h).total_a);
}

#[test]
fn a_follows_the_scene_through_moves_undo_and_loads() {
    let mut h = app("soup:3000");
    nodes_difference(&mut h);
    assert!(all_zero(&h));
    let before = summary(&h);
    // Move a third of the triangles: A is built afresh over the moved scene, while B's BVH
    // is refitted, so B − A is what the refit costs.
    let moved: Arc<Vec<u32>> = Arc::new((0..1000).collect());
    h.state_mut()
        .move_triangles(moved, glam::Vec3::new(0.0, 0.6, 0.0));
    h.state_mut().end_gesture();
    settle(&mut h);
    let refitted = summary(&h);
    assert_ne!(refitted.total_a, before.total_a, "A saw the move");
    assert!(refitted.total_b > refitted.total_a, "the refit costs");
    // Rebuilt, B is A again over the moved scene.
    h.state_mut().rebuild();
    settle(&mut h);
    let rebuilt = summary(&h);
    assert_eq!(rebuilt.total_a, refitted.total_a);
    assert_eq!(rebuilt.total_b, rebuilt.total_a);
    assert!(all_zero(&h));
    h.state_mut().undo();
    h.state_mut().rebuild();
    settle(&mut h);
    let undone = summary(&h);
    assert_eq!(undone.total_a, undone.total_b);
    assert!(all_zero(&h));
    // Another scene: A stays pinned and is built over it.
    h.state_mut().load("cornell".into());
    settle(&mut h);
    assert!(h.state().pinned.is_some());
    let cornell = summary(&h);
    assert_eq!(cornell.total_a, cornell.total_b);
    assert_ne!(cornell.total_a, before.total_a);
    assert!(all_zero(&h));
}

#[test]
fn the_difference_of_a_shaded_view_says_it_needs_a_heatmap() {
    let mut h = app("soup:3000");
    h.get_by_label("Pin as A").click();
    settle(&mut h);
    h.state_mut().settings.compare_view = CompareView::Difference;
    settle(&mut h);
    assert!(
        h.query_by_label("B − A needs a heatmap mode: showing B.")
            .is_some()
    );
    // The summary compares the lecture's two counters meanwhile.
    let compared = h.state().compared.clone().unwrap();
    assert_eq!(compared.summaries.len(), 2);
}

#[test]
fn the_frame_carries_a_s_work_per_pixel() {
    let mut h = app("soup:3000");
    nodes_difference(&mut h);
    h.get_by_label("object median").click();
    settle(&mut h);
    let s = summary(&h);
    let shown = h.state().shown.clone().unwrap();
    // A's own frame of the view (the pixel tooltip reads it): its counts are the summary's A.
    let a = shown.pinned_frame.as_ref().expect("A's frame");
    let total = |f: &bvhlab::render::Frame| {
        f.samples
            .iter()
            .map(|p| u64::from(p.primary.nodes_visited))
            .sum::<u64>()
    };
    assert_eq!(total(a), s.total_a);
    assert_eq!(total(&shown.frame), s.total_b);
}

#[test]
fn a_s_triangles_are_coloured_by_a_s_tree_on_the_scale_b_shares() {
    let mut h = app("soup:3000");
    h.get_by_role_and_label(egui::accesskit::Role::Button, "SAH cost per triangle")
        .click();
    settle(&mut h);
    h.key_press(Key::A);
    settle(&mut h);
    h.get_by_label("object median").click();
    settle(&mut h);
    let shown = h.state().shown.clone().unwrap();
    assert_eq!(shown.job.mode, Mode::TriangleCost);
    // A's frame has its own tree's costs (the median tree costs more than binned SAH's).
    let a = shown.pinned_frame.as_ref().expect("A's frame");
    let a_values = a.triangle_values(Mode::TriangleCost).expect("A's costs");
    let b_values = shown.frame.triangle_values(Mode::TriangleCost).unwrap();
    assert!(a_values.total < b_values.total, "A is binned SAH, B median");
    // A's half is coloured, not left grey: every hit left of the divider is painted on the
    // scale both halves share, from the cheapest triangle either shows to the dearest.
    let shared = shared_shown(&[a, &shown.frame], Mode::TriangleCost).unwrap();
    assert_eq!(shared.0, a_values.shown.0.min(b_values.shown.0));
    assert_eq!(shared.1, a_values.shown.1.max(b_values.shown.1));
    let (w, hgt) = (shown.job.width as usize, shown.job.height as usize);
    let grey = to_rgba8(glam::Vec3::splat(0.5));
    let left_hits = (0..hgt)
        .flat_map(|y| (0..w / 2 - 2).map(move |x| (x, y)))
        .filter(|&(x, y)| a.samples[y * w + x].is_hit())
        .map(|(x, y)| &shown.rgba[(y * w + x) * 4..(y * w + x) * 4 + 4])
        .collect::<Vec<_>>();
    assert!(left_hits.len() > 100);
    assert!(left_hits.iter().all(|p| *p != grey), "A's hits are grey");
    // The same in the measured tests per triangle.
    h.get_by_role_and_label(egui::accesskit::Role::Button, "tests per triangle")
        .click();
    settle(&mut h);
    let shown = h.state().shown.clone().unwrap();
    let a = shown.pinned_frame.as_ref().expect("A's frame");
    assert!(a.triangle_values(shown.job.mode).is_some(), "A's tests");
}
