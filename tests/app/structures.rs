//! The structure selector and the two levels: each structure draws its levels, a grid over
//! its cap is refused, instances dragged, the island's top level rebuilt, a selected
//! instance's BLAS below its leaf.

use super::*;

#[test]
fn the_structure_selector_rebuilds_keeps_the_camera_and_each_structure_draws_its_levels() {
    // Tall enough that the two levels' longer parameter list leaves the levels checkbox in
    // sight (a click does not scroll the controls to it).
    let mut h = tall_app("soup:300");
    let camera = h.state().shown.clone().unwrap().job.camera;
    let expected_scene = bvhlab::scene::Scene::load("soup:300").unwrap();
    for kind in bvhlab::accel::AccelKind::ALL {
        choose_structure(&mut h, kind.title());
        let app = h.state();
        let report = app.report.clone().expect("built");
        assert_eq!(
            report.structure,
            kind.label(),
            "report of the chosen structure"
        );
        assert_eq!(
            app.bvh_report.is_some(),
            kind == bvhlab::accel::AccelKind::Bvh
        );
        let shown = app.shown.clone().unwrap();
        assert_eq!(shown.job.camera, camera, "switching keeps the camera");
        // The explorer draws the new structure's own outline.
        let params = bvhlab::accel::StructureParams::of_kind(kind);
        let built = bvhlab::accel::structure::build(
            &expected_scene.triangles,
            &params,
            &Default::default(),
        )
        .unwrap();
        assert_eq!(
            app.outline.nodes.len(),
            built.structure.outline().nodes.len()
        );
    }
    // The last structure's levels draw something.
    let plain = h.state().shown.clone().unwrap().rgba.clone();
    h.get_by_label("show the boxes or cells of one level")
        .click();
    settle(&mut h);
    assert_ne!(plain, h.state().shown.clone().unwrap().rgba);
}

#[test]
fn a_grid_over_its_cell_cap_is_an_error_and_the_previous_grid_stays() {
    // 2^20 triangles at λ = 64 ask for 2^26 + cells: over the cap.
    let mut h = app("soup:1100000");
    choose_structure(&mut h, bvhlab::accel::AccelKind::Grid.title());
    let before = h.state().report.clone().expect("the grid built");
    let outline = h.state().outline.clone();
    h.state_mut().settings.structure.grid.lambda = 64.0;
    settle(&mut h);
    let app = h.state();
    let error = app.build_error.clone().expect("a clear error");
    assert!(error.contains("cells"), "{error}");
    assert_eq!(
        app.report.as_ref(),
        Some(&before),
        "the previous grid's report stays"
    );
    assert!(
        std::sync::Arc::ptr_eq(&app.outline, &outline),
        "and its outline"
    );
    assert!(app.shown.is_some());
}

#[test]
fn dragging_an_object_under_the_two_levels_moves_its_instance() {
    let mut h = app("cornell");
    choose_structure(&mut h, bvhlab::accel::AccelKind::TwoLevel.title());
    assert_eq!(h.state().report.clone().unwrap().structure, "two-level");
    drag_an_object(&mut h);
    let app = h.state();
    let (refit, flat) = app.last_instance_move.expect("the instance moved");
    assert!(refit > std::time::Duration::ZERO);
    assert!(
        flat.is_some(),
        "the cornell box flattens: its BVH refit is timed"
    );
    assert!(app.last_rebuild.is_none(), "nothing was rebuilt");
    // The grabbed object's instance and its transform, now a translation, are shown.
    let object = app.selected_object.expect("an object was grabbed");
    let moved_by = app.moved_transforms[&object].translation;
    assert!(moved_by.length() > 0.0, "the instance moved: {moved_by}");
    assert!(app.moved_transforms[&object].matrix3 == glam::Mat3A::IDENTITY);
    h.get_by_label_contains("as an instance of its own triangles, object to world");
    // The moved instance is traced through its inverse transform: the same triangles as a
    // fresh BVH2 over the moved triangles, t within the rounding of the translation.
    h.state_mut().request_snapshot();
    settle(&mut h);
    let app = h.state();
    let moved = app.snapshot.clone().expect("snapshot");
    assert_ne!(
        moved.triangles,
        bvhlab::scene::Scene::load("cornell").unwrap().triangles,
        "the object moved"
    );
    let shown = app.shown.clone().unwrap();
    let (fresh, _) = build(&moved.triangles, &BuildParams::default()).unwrap();
    let settings = settings_of(&shown, &moved);
    let expected = render(&fresh, &moved, &settings);
    let (mut other_triangle, mut worst) = (0, 0.0f32);
    for (a, b) in shown.frame.samples.iter().zip(&expected.samples) {
        if a.triangle != b.triangle {
            other_triangle += 1;
        } else if a.is_hit() {
            worst = worst.max((a.t - b.t).abs() / b.t.max(1.0));
        }
    }
    // Rays through an edge may name the neighbour within that rounding.
    assert!(
        other_triangle <= expected.samples.len() / 1000,
        "{other_triangle} pixels hit another triangle"
    );
    assert!(worst < 1e-4, "t differs by {worst} relative");
}

/// On an island (a scene of instances), a moved object's instance is refitted into the top
/// level, and Rebuild (B) then builds the top level alone over the instances where they
/// are: the BLASes kept, the frame the same as a whole build of the moved scene gives.
#[test]
fn rebuilding_an_island_after_a_move_rebuilds_its_top_level_only() {
    use bvhlab::accel::structure::{self, StructureParams};
    let mut h = small_island();
    let built = h.state().report.clone().unwrap();
    assert_ne!(built.detail("BLAS builds").unwrap().to_string(), "kept");
    // The first object moved twice, as a drag moves it.
    for _ in 0..2 {
        h.state_mut()
            .move_object(0, glam::Vec3::new(3.0, 0.5, -2.0));
        settle(&mut h);
    }
    h.state_mut().end_gesture();
    settle(&mut h);
    assert!(h.state().last_instance_move.is_some(), "an instance moved");
    h.state_mut().rebuild();
    settle(&mut h);
    h.state_mut().request_snapshot();
    settle(&mut h);
    let app = h.state();
    let report = app.report.clone().unwrap();
    assert_eq!(report.detail("BLAS builds").unwrap().to_string(), "kept");
    assert_eq!(
        report.nodes - report.detail("TLAS nodes").unwrap().as_count().unwrap() as usize,
        built.nodes - built.detail("TLAS nodes").unwrap().as_count().unwrap() as usize,
        "the BLASes' nodes are the build's"
    );
    let moved = app.snapshot.clone().expect("snapshot");
    let shown = app.shown.clone().unwrap();
    let params = StructureParams::of_kind(bvhlab::accel::AccelKind::TwoLevel);
    let fresh = structure::build_scene(&moved, &params, &Default::default()).unwrap();
    let settings = settings_of(&shown, &moved);
    let expected = render(&fresh.structure, &moved, &settings);
    let differing = |samples: &[bvhlab::render::Sample]| {
        (shown.frame.samples.iter().zip(samples))
            .filter(|(a, b)| a.triangle != b.triangle || a.t.to_bits() != b.t.to_bits())
            .count()
    };
    assert_eq!(
        differing(&expected.samples),
        0,
        "the rebuilt top level traces a whole build's hits"
    );
    // The move shows: the island where it was gives another picture.
    let unmoved = bvhlab::scene::Scene::load("island:1").unwrap();
    let before = structure::build_scene(&unmoved, &params, &Default::default()).unwrap();
    let before = render(&before.structure, &unmoved, &settings);
    assert!(
        differing(&before.samples) > 1000,
        "the object moved in view"
    );
}

fn outline_children(outline: &bvhlab::accel::Outline, node: usize) -> usize {
    outline.nodes[node].children().len()
}

/// The path of top-level outline nodes from the root down to `node`.
fn path_to(outline: &bvhlab::accel::Outline, node: usize) -> Vec<usize> {
    let mut path = vec![node];
    while let Some(&p) = path.last().map(|&n| &outline.nodes[n].parent)
        && p != u32::MAX
    {
        path.push(p as usize);
    }
    path.reverse();
    path
}

#[test]
fn under_the_two_levels_a_selected_instances_blas_continues_the_levels_and_the_walk() {
    use bvhlab::app::levels::WalkNode;
    let mut h = app("cornell");
    choose_structure(&mut h, bvhlab::accel::AccelKind::TwoLevel.title());
    let top = h.state().outline.max_depth();
    assert_eq!(h.state().levels().max_depth(), top);
    assert!(h.state().instance_outline.is_none());
    h.get_by_label_contains("select an instance to see its BLAS levels");
    h.get_by_label("a BLAS's SAH cost and EPO");
    // Choose instance 0 in the panel (its "select" button lies below the fold under the
    // longer control lists: pressed as the click would).
    assert!(h.query_by_label("select").is_some());
    h.state_mut().select_instance(Some(0));
    settle(&mut h);
    let o = h
        .state()
        .instance_outline
        .clone()
        .expect("instance 0 selected");
    assert_eq!(o.instance, 0);
    let blas_levels = o.blas.max_depth() + 1;
    assert!(blas_levels >= 2, "a BLAS of more than its root");
    assert_eq!(h.state().levels().max_depth(), top + blas_levels);
    h.get_by_label_contains("instance 0 of mesh 0");
    // Its BLAS weighed as a tree of its own, in its mesh's space: the SAH cost at once, the
    // EPO at the worker's next quiet moment.
    h.get_by_label("instance 0's BLAS, in its mesh's space: SAH cost");
    let sah = o.blas.sah_cost(1.0, 1.0);
    h.get_by_label(&format!("{sah:.2}"));
    let scene = bvhlab::scene::Scene::load("cornell").unwrap();
    let mesh = scene.instancing().meshes[o.mesh];
    let epo = bvhlab::accel::epo::epo(&o.blas, mesh, 1.0, 1.0);
    let shown = format!("{epo:.2} ({:.0} % of its SAH cost)", 100.0 * epo / sah);
    for _ in 0..50 {
        if h.query_by_label(&shown).is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
        settle(&mut h);
    }
    h.get_by_label(&shown);
    // Both levels' own EPO beside their SAH cost, clipped exactly on a scene this small.
    let params = bvhlab::accel::StructureParams::of_kind(bvhlab::accel::AccelKind::TwoLevel);
    let built = bvhlab::accel::structure::build_scene(&scene, &params, &Default::default())
        .unwrap()
        .structure;
    let (both_sah, ..) = built.sah_cost(&params).unwrap();
    let both = built.epo(&params, &scene).unwrap();
    let shown = format!(
        "{} ({:.0} % of the SAH cost)",
        both.label(2),
        100.0 * both.value / both_sah
    );
    h.get_by_label(&shown);
    h.get_by_label_contains("translation (0.000, 0.000, 0.000)");
    h.get_by_label_contains("rotation 0.0°");
    h.get_by_label_contains("[   1.000    0.000    0.000 |     0.000]");
    // The level slider reaches the BLAS's levels: its boxes are drawn.
    h.state_mut().settings.show_levels = true;
    h.state_mut().settings.level = top;
    settle(&mut h);
    let tlas_level = h.state().shown.clone().unwrap().rgba.clone();
    h.state_mut().settings.level = top + 1;
    settle(&mut h);
    assert_eq!(h.state().settings.level, top + 1, "not clamped to the TLAS");
    assert_ne!(h.state().shown.clone().unwrap().rgba, tlas_level);
    h.get_by_label_contains("BLAS of instance 0, its level 0");

    // The walk from the TLAS root down to the instance's leaf, into its BLAS and back.
    // The walk's buttons lie below the fold: their keys (W, arrows) do the same.
    h.key_press(egui::Key::W);
    settle(&mut h);
    assert_eq!(h.state().walk, Some(0));
    // The TLAS root holds every instance: the scene's triangles, counted by instance.
    let info = h.state().shown.clone().unwrap().walk.clone().unwrap();
    assert_eq!(info.triangles, 36);
    assert_eq!(info.children.len(), outline_children(&h.state().outline, 0));
    // The instance hangs below each leaf holding one of its references (the whole BLAS, or
    // with re-braiding a subtree of it): the walk goes down to the first such leaf.
    let entry = *o.entries.first().expect("the instance is in a leaf");
    let leaf = entry.tlas_leaf as usize;
    let below = entry.blas_node as usize;
    let outline = h.state().outline.clone();
    for pair in path_to(&outline, leaf).windows(2) {
        let levels = h.state().levels();
        let children = levels.children(WalkNode::Top(pair[0]));
        assert!(children.contains(&WalkNode::Top(pair[1])));
        h.state_mut().walk = Some(pair[1] as u32);
    }
    settle(&mut h);
    let info = h.state().shown.clone().unwrap().walk.clone().unwrap();
    assert_eq!((info.instance, info.in_blas), (Some(0), false));
    let under = o.triangles_under(below).len();
    assert_eq!(info.triangles, under);
    let whole = below == 0;
    assert_eq!(info.whole_instance, whole);
    h.get_by_label_contains(if whole {
        "TLAS leaf: instance 0"
    } else {
        "TLAS leaf: a subtree of instance 0"
    });
    h.key_press(egui::Key::ArrowLeft);
    settle(&mut h);
    let node = h.state().levels().id(WalkNode::Bottom(below));
    assert_eq!(h.state().walk, Some(node));
    let info = h.state().shown.clone().unwrap().walk.clone().unwrap();
    assert_eq!(
        (info.node, info.in_blas, info.instance),
        (node, true, Some(0))
    );
    assert_eq!(info.depth, top + 1 + o.blas.nodes[below].depth);
    assert_eq!(info.triangles, under);
    let expected: Vec<usize> = o.blas.nodes[below]
        .children()
        .map(|c| h.state().levels().id(WalkNode::Bottom(c)) as usize)
        .collect();
    assert_eq!(info.children, expected);
    h.get_by_label(&format!("{node} (BLAS of instance 0)"));
    h.key_press(egui::Key::ArrowUp);
    settle(&mut h);
    assert_eq!(h.state().walk, Some(leaf as u32));

    // Stepping into another instance's leaf selects it and enters its BLAS.
    let other = h
        .state()
        .leaf_instances
        .iter()
        .position(|&i| i != u32::MAX && i != 0)
        .expect("another leaf");
    let other_instance = h.state().leaf_instances[other] as usize;
    h.state_mut().walk = Some(other as u32);
    h.key_press(egui::Key::ArrowRight);
    settle(&mut h);
    let o2 = h.state().instance_outline.clone().unwrap();
    assert_eq!(o2.instance, other_instance);
    let entered = o2
        .entry_below(other as u32)
        .expect("the leaf holds the instance");
    assert_eq!(
        h.state().walk,
        Some(h.state().levels().id(WalkNode::Bottom(entered as usize)))
    );

    // Clicking an object with the move tool selects its instance; after a drag the panel
    // shows the moved transform.
    h.state_mut().walk = None;
    drag_an_object(&mut h);
    let object = h.state().selected_object.expect("an object was grabbed");
    let o3 = h.state().instance_outline.clone().unwrap();
    assert_eq!(o3.instance, object, "cornell's objects are its instances");
    let moved = h.state().moved_transforms[&object];
    assert_eq!(o3.transform, moved);
    assert!(moved.translation.length() > 0.0);
    let t = moved.translation;
    h.get_by_label_contains(&format!("translation ({:.3}, {:.3}, {:.3})", t.x, t.y, t.z));
    // The placed BLAS root box moved with it: it holds the moved triangles.
    h.state_mut().request_snapshot();
    settle(&mut h);
    let scene = h.state().snapshot.clone().unwrap();
    for t in &scene.triangles[scene.objects[object].range()] {
        for v in t.v {
            assert!(o3.placed_box_contains(0, v, 1e-4));
        }
    }
    // "none" clears the selection: the levels end with the TLAS again.
    assert!(h.query_by_label("none").is_some());
    h.state_mut().select_instance(None);
    settle(&mut h);
    assert!(h.state().instance_outline.is_none());
    assert_eq!(h.state().levels().max_depth(), top);
    assert!(h.state().settings.level <= top);
}
