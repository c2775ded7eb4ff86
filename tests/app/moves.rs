//! Levels and drags: stepping the levels, a dragged triangle refitted to what a fresh build
//! hits, the level boxes moved and put back, wide trees refitted in place.

use super::*;

#[test]
fn stepping_levels_changes_the_overlay() {
    let mut h = app("cornell");
    let plain = h.state().shown.clone().expect("frame").rgba.clone();
    h.get_by_label("show the boxes or cells of one level")
        .click();
    settle(&mut h);
    let level0 = h.state().shown.clone().expect("frame").rgba.clone();
    assert_ne!(plain, level0, "the root box is drawn");
    h.get_by_label("next >").click();
    settle(&mut h);
    assert_eq!(h.state().settings.level, 1);
    let level1 = h.state().shown.clone().expect("frame").rgba.clone();
    assert_ne!(level0, level1, "level 1 shows other boxes");
    // The frame was recoloured, not traced again: the samples are the same.
    h.get_by_label("< previous").click();
    settle(&mut h);
    assert_eq!(h.state().shown.clone().unwrap().rgba, level0);
}

#[test]
fn dragging_a_triangle_refits_and_hits_equal_a_fresh_build() {
    let mut h = app("cornell");
    let sah_before = h.state().sah_history.clone();
    drag_an_object(&mut h);
    let app = h.state();
    assert!(app.selection.is_some(), "the drag picked a triangle");
    assert!(
        app.sah_history.len() > sah_before.len(),
        "each move refitted"
    );
    assert_ne!(
        app.sah_history.last(),
        sah_before.last(),
        "the SAH cost changed"
    );
    assert_frame_equals_a_fresh_build(&mut h);
    let moved = h.state().snapshot.clone().expect("snapshot");
    assert_eq!(
        moved.triangles.len(),
        bvhlab::scene::Scene::load("cornell")
            .unwrap()
            .triangles
            .len()
    );
}

/// Every node of `outline` is exactly the box of the triangles under it: a leaf's is the
/// union of its triangles' boxes, an inner node's the union of its children's.
fn assert_boxes_are_tight(outline: &bvhlab::accel::Outline, scene: &bvhlab::scene::Scene) {
    for (i, n) in outline.nodes.iter().enumerate().rev() {
        let tight = if n.is_leaf() {
            outline
                .leaf_refs(i)
                .iter()
                .fold(bvhlab::geometry::Aabb::EMPTY, |b, &t| {
                    b.union(scene.triangles[t as usize].bounds())
                })
        } else {
            n.children().fold(bvhlab::geometry::Aabb::EMPTY, |b, c| {
                b.union(outline.nodes[c].bounds)
            })
        };
        assert_eq!(n.bounds, tight, "node {i} is the box of what it holds");
    }
}

#[test]
fn a_refit_moves_the_level_boxes_and_ctrl_z_puts_them_back() {
    let mut h = app("cornell");
    h.get_by_label("show the boxes or cells of one level")
        .click();
    settle(&mut h);
    let built = h.state().outline.clone();
    let history = h.state().sah_history.clone();
    let before = h.state().shown.clone().expect("frame").rgba.clone();
    h.state_mut().request_snapshot();
    settle(&mut h);
    let scene_before = h.state().snapshot.clone().expect("snapshot");
    drag_an_object(&mut h);
    let after = h.state().outline.clone();
    assert_eq!(
        after.nodes.len(),
        built.nodes.len(),
        "a refit keeps the tree's shape"
    );
    let stretched = (after.nodes.iter().zip(&built.nodes)).filter(|(a, b)| a.bounds != b.bounds);
    assert!(stretched.count() > 0, "the drawn boxes follow the move");
    h.state_mut().request_snapshot();
    settle(&mut h);
    let moved = h.state().snapshot.clone().expect("snapshot");
    assert_boxes_are_tight(&after, &moved);
    let shown = h.state().shown.clone().expect("frame").rgba.clone();
    assert_ne!(
        shown, before,
        "the level's boxes are drawn where they are now"
    );
    assert!(h.state().sah_history.len() > history.len());

    // Ctrl+Z with the viewport focused, as a user presses it.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    settle(&mut h);
    let undone = h.state().outline.clone();
    // Undo ends where the drag started, bit for bit (not −delta's rounding): the boxes
    // and the scene are the ones before it.
    for (u, b) in undone.nodes.iter().zip(&built.nodes) {
        assert_eq!(u.bounds, b.bounds, "undo puts the boxes back");
    }
    h.state_mut().request_snapshot();
    settle(&mut h);
    let restored = h.state().snapshot.clone().expect("snapshot");
    assert_eq!(
        restored.triangles, scene_before.triangles,
        "undo puts the scene back"
    );
    assert_eq!(
        h.state().sah_history,
        history,
        "and takes its points off the chart"
    );
}

#[test]
fn dragging_under_a_wide_bvh_refits_it_in_place() {
    for kind in [
        bvhlab::accel::AccelKind::Bvh4,
        bvhlab::accel::AccelKind::Bvh8,
    ] {
        let mut h = app("cornell");
        choose_structure(&mut h, kind.title());
        assert_eq!(h.state().report.clone().unwrap().structure, kind.label());
        drag_an_object(&mut h);
        let app = h.state();
        assert!(app.selection.is_some(), "the drag picked a triangle");
        assert!(app.last_refit.is_some(), "{}: refitted", kind.label());
        assert!(app.last_rebuild.is_none(), "{}: not rebuilt", kind.label());
        assert!(app.sah_history.len() >= 2, "the SAH cost before and after");
        assert_frame_equals_a_fresh_build(&mut h);
    }
}
