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

#[test]
fn switching_the_strategy_changes_the_build_report() {
    let mut h = app("soup:3000");
    let before = h.state().bvh_report.clone().expect("built");
    assert_eq!(before.params.strategy, Strategy::SahBinned);
    h.get_by_label("object median").click();
    settle(&mut h);
    let after = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(after.params.strategy, Strategy::ObjectMedian);
    assert_ne!(after.tree.sah_cost, before.tree.sah_cost);
    // The report panel says so too (the radio button is the other match).
    assert!(h.get_all_by_label_contains("object median").count() >= 2);
}

#[test]
fn moving_the_bucket_slider_rebuilds_with_that_bucket_count() {
    let mut h = app("soup:3000");
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "buckets B")
        .set_value_accesskit(4.0);
    settle(&mut h);
    let r = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(r.params.buckets, 4);
    let expected = build(
        &bvhlab::scene::Scene::load("soup:3000").unwrap().triangles,
        &BuildParams {
            buckets: 4,
            ..Default::default()
        },
    )
    .unwrap()
    .1;
    assert_eq!(r.tree.sah_cost, expected.tree.sah_cost);
}

#[test]
fn choosing_lbvh_with_treelets_rebuilds_with_its_rounds() {
    let mut h = app("soup:3000");
    h.get_by_label("LBVH + treelets").click();
    settle(&mut h);
    let r = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(r.params.strategy, Strategy::LbvhTreelet);
    assert_eq!(r.phases.sah_after_round.len(), 3);
    // The stats panel lists the SAH cost of each round, and charts them.
    assert!(
        h.get_all_by_label_contains("SAH cost after round 3")
            .count()
            >= 1
    );
    assert!(h.query_by_label("SAH cost per treelet round").is_some());
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "treelet rounds")
        .set_value_accesskit(1.0);
    settle(&mut h);
    let r = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(r.params.treelet_rounds, 1);
    assert_eq!(r.phases.sah_after_round.len(), 1);
    let expected = build(
        &bvhlab::scene::Scene::load("soup:3000").unwrap().triangles,
        &BuildParams {
            strategy: Strategy::LbvhTreelet,
            treelet_rounds: 1,
            ..Default::default()
        },
    )
    .unwrap()
    .1;
    assert_eq!(r.tree.sah_cost, expected.tree.sah_cost);
}

#[test]
fn the_overlap_penalty_slider_rebuilds_the_sbvh_with_it() {
    let mut h = app("walls-rotated:60");
    h.get_by_label("SBVH (spatial splits)").click();
    settle(&mut h);
    let plain = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(plain.params.strategy, Strategy::Sbvh);
    assert_eq!(plain.params.overlap_penalty, 0.0);
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "overlap penalty κ")
        .set_value_accesskit(1.0);
    settle(&mut h);
    let r = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(r.params.overlap_penalty, 1.0);
    let expected = build(
        &bvhlab::scene::Scene::load("walls-rotated:60")
            .unwrap()
            .triangles,
        &BuildParams {
            strategy: Strategy::Sbvh,
            overlap_penalty: 1.0,
            ..Default::default()
        },
    )
    .unwrap()
    .1;
    assert_eq!(r.tree.sah_cost, expected.tree.sah_cost);
    assert_ne!(r.tree.sah_cost, plain.tree.sah_cost);
}

#[test]
fn the_sbvh_report_counts_its_duplicated_references() {
    let mut h = app("walls-rotated:60");
    h.get_by_label("SBVH (spatial splits)").click();
    settle(&mut h);
    let r = h.state().bvh_report.clone().expect("rebuilt");
    assert_eq!(r.params.strategy, Strategy::Sbvh);
    let duplicated = r.duplicated_references();
    assert!(duplicated > 0, "the turned walls' references are split");
    // The stats panel gives the count (and its share of the triangles) beside its label.
    assert!(h.query_by_label("duplicated references").is_some());
    assert!(
        h.get_all_by_label_contains(&format!("{duplicated} (+"))
            .count()
            >= 1,
        "{duplicated} shown"
    );
}

#[test]
fn out_of_range_build_parameters_are_brought_into_range_and_built() {
    let mut h = app("soup:3000");
    h.get_by_label("LBVH + treelets").click();
    settle(&mut h);
    // Values no slider can set (a settings file from elsewhere might hold them): each
    // parameter's slider brings its value into range, and the tree is built with those.
    {
        let s = &mut h.state_mut().settings.structure.bvh;
        s.treelet_size = 10;
        s.treelet_rounds = 1000;
        s.split_alpha = f32::NAN;
        s.split_budget = -1.0;
        s.presplit = f32::INFINITY;
    }
    settle(&mut h);
    let app = h.state();
    assert_eq!(app.build_error, None);
    let r = app.bvh_report.clone().expect("built");
    assert_eq!(r.params.strategy, Strategy::LbvhTreelet);
    assert!(r.params.validate().is_ok(), "{:?}", r.params);
    assert_eq!(r.params.treelet_size, 9);
    assert_eq!(r.phases.sah_after_round.len(), 16, "at most 16 rounds");
    assert!(app.shown.is_some());
}

#[test]
fn the_walls_angle_slider_loads_the_walls_turned_that_far() {
    let mut h = app("walls-rotated:20");
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "walls turned")
        .set_value_accesskit(10.0);
    settle(&mut h);
    let app = h.state();
    assert_eq!(app.load_error, None);
    let scene = app.scene.clone().expect("a scene");
    let expected = bvhlab::scene::Scene::load("walls-rotated@10:20").unwrap();
    assert_eq!(scene.name, expected.name);
    assert_eq!(scene.triangles, expected.triangles, "the walls turned 10°");
    // And the structure was rebuilt over them.
    let r = app.bvh_report.clone().expect("built");
    assert_eq!(r.triangles, expected.triangles.len());
}

#[test]
fn the_walls_slider_sits_over_the_view_and_the_top_bar_keeps_one_row_at_1280() {
    let mut h = launch(
        Harness::builder().with_size(egui::vec2(1280.0, 720.0)),
        "walls-rotated:20",
        |_| {},
    );
    settle(&mut h);
    let slider = h
        .get_by_role_and_label(egui::accesskit::Role::Slider, "walls turned")
        .rect();
    let (first, last) = (
        h.get_by_label("Open…").rect(),
        h.get_by_label("Help (F1)").rect(),
    );
    assert!((first.center().y - last.center().y).abs() < 1.0, "one row");
    assert!(
        slider.top() > last.bottom(),
        "under the top bar, over the view"
    );
}

/// In the presentation layout the controls over the view grow with the window, as the
/// caption does: the walls slider and the crack choices are larger there than in the
/// normal layout, and at 1280 the crack choices still keep one row each.
#[test]
fn the_in_view_controls_grow_in_the_presentation_layout() {
    use egui::accesskit::Role;
    let mut h = launch(
        Harness::builder().with_size(egui::vec2(1280.0, 720.0)),
        "walls-rotated:20",
        |_| {},
    );
    settle(&mut h);
    let slider = |h: &Harness<'static, BvhLabApp>| {
        h.get_by_role_and_label(Role::Slider, "walls turned").rect()
    };
    let normal = slider(&h);
    let button = h.get_by_label("Present (Tab)").rect();
    h.state_mut().settings.presentation = true;
    settle(&mut h);
    let presented = slider(&h);
    assert!(
        presented.height() > 1.4 * normal.height(),
        "{normal:?} → {presented:?}"
    );
    // The presentation bar's buttons grow with its caption.
    let exit = h.get_by_label("exit presentation").rect();
    assert!(
        exit.height() > 1.2 * button.height(),
        "{button:?} → {exit:?}"
    );
    let step = h
        .state()
        .lecture
        .sequence
        .presets
        .iter()
        .position(|p| p.settings.show_cracks)
        .expect("a step shows the cracks");
    assert!(h.state_mut().go_to_preset(step));
    h.state_mut().settings.presentation = false;
    settle(&mut h);
    // The View section has the same choices further left: the one over the view is the
    // rightmost.
    let over_view = |h: &Harness<'static, BvhLabApp>, label: &str| {
        h.get_all_by_label(label)
            .map(|n| n.rect())
            .max_by(|a, b| a.left().total_cmp(&b.left()))
            .unwrap_or_else(|| panic!("{label}"))
    };
    let normal = over_view(&h, "10^6");
    h.state_mut().settings.presentation = true;
    settle(&mut h);
    let presented = over_view(&h, "10^6");
    assert!(
        presented.height() > 1.4 * normal.height(),
        "{normal:?} → {presented:?}"
    );
    let same_row = |a: egui::Rect, b: egui::Rect| (a.center().y - b.center().y).abs() < 1.0;
    assert!(
        same_row(over_view(&h, "scene moved to"), presented),
        "one row"
    );
    assert!(
        same_row(over_view(&h, "test"), over_view(&h, "f64 reference")),
        "one row"
    );
}

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

#[test]
fn loading_a_bad_obj_shows_the_error_and_keeps_the_scene() {
    let mut h = app("cornell");
    let path = std::env::temp_dir().join(format!("bvhlab-bad-{}.obj", std::process::id()));
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n").unwrap();
    h.state_mut().load(path.display().to_string());
    settle(&mut h);
    let app = h.state();
    let error = app.load_error.clone().expect("an error is shown");
    assert!(error.contains(":3"), "names the line: {error}");
    assert_eq!(app.scene.as_ref().unwrap().name, "cornell");
    assert!(h.query_by_label_contains("Load failed").is_some());
    std::fs::remove_file(&path).ok();
}

/// What the loader skipped is said in the window too, not only on the command line, until
/// dismissed.
#[test]
fn an_obj_loaded_with_warnings_says_so_in_the_window() {
    let mut h = app("cornell");
    let path = std::env::temp_dir().join(format!("bvhlab-warn-{}.obj", std::process::id()));
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n").unwrap();
    h.state_mut().load(path.display().to_string());
    settle(&mut h);
    let scene = h.state().scene.clone().expect("loaded");
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(h.query_by_label("Loaded with warnings:").is_some());
    assert!(h.query_by_label(&scene.warnings[0]).is_some());
    h.get_by_label("Dismiss").click();
    settle(&mut h);
    assert!(h.query_by_label("Loaded with warnings:").is_none());
    std::fs::remove_file(&path).ok();
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

#[test]
fn dropping_an_obj_on_the_window_loads_it_and_remembers_it() {
    let mut h = app("cornell");
    let path = std::env::temp_dir().join(format!("bvhlab-drop-{}.obj", std::process::id()));
    std::fs::write(
        &path,
        "o quad\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    h.input_mut()
        .dropped_files
        .push(std::sync::Arc::new(DroppedPath(path.clone())));
    h.run_steps(1);
    settle(&mut h);
    let app = h.state();
    assert_eq!(app.load_error, None);
    let scene = app.scene.as_ref().expect("a scene");
    assert_eq!(
        scene.triangles.len(),
        2,
        "the dropped quad replaced the Cornell box"
    );
    let spec = path.display().to_string();
    assert_eq!(
        app.settings.recent.first(),
        Some(&spec),
        "listed under recent files"
    );
    assert!(
        app.shown
            .as_ref()
            .is_some_and(|s| s.frame.summary.primary_hits > 0)
    );
    std::fs::remove_file(&path).ok();
}

/// Chooses `title` in the structure selector.
fn choose_structure(h: &mut Harness<'static, BvhLabApp>, title: &str) {
    h.get_by_role_and_label(egui::accesskit::Role::ComboBox, "structure")
        .click();
    h.run_steps(2);
    h.get_by_label(title).click();
    settle(h);
}

#[test]
fn the_structure_selector_rebuilds_keeps_the_camera_and_each_structure_draws_its_levels() {
    // Tall enough that the two levels' longer parameter list leaves the levels checkbox in
    // sight (a click does not scroll the controls to it).
    let mut h = launch(
        Harness::builder().with_size(egui::vec2(1400.0, 1100.0)),
        "soup:300",
        |_| {},
    );
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

/// A full shaded frame comes before its counts: until the counted pass arrives, the stats
/// panel says "counting…" and the pixel report waits; then it shows the counted means.
#[test]
fn the_stats_panel_says_counting_until_the_counted_pass_arrives() {
    use bvhlab::app::worker::{Reply, Shown};
    use bvhlab::render::trace;
    use std::sync::Arc;
    let mut h = app("cornell");
    assert!(h.query_by_label("per ray: mean / max").is_some());
    assert!(h.query_by_label("counting…").is_none());
    let (shown, scene) = {
        let app = h.state();
        (app.shown.clone().unwrap(), app.scene.clone().unwrap())
    };
    assert!(
        shown.frame.summary.counted(),
        "a settled full frame is counted"
    );
    // The same view traced as the worker shows it first: without counting.
    let (bvh, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
    let settings = RenderSettings {
        counters: false,
        ..settings_of(&shown, &scene)
    };
    let uncounted = Arc::new(trace(&bvh, &scene, &settings));
    let first = Shown {
        frame: uncounted,
        ..(*shown).clone()
    };
    let ctx = h.ctx.clone();
    h.state_mut()
        .handle_replies(&ctx, vec![Reply::Frame(Arc::new(first))]);
    h.run_steps(2);
    assert!(h.query_by_label("counting…").is_some());
    assert!(h.query_by_label("per ray: mean / max").is_none());
    h.state_mut().handle_replies(
        &ctx,
        vec![Reply::Counted {
            job: shown.job.clone(),
            frame: shown.frame.clone(),
        }],
    );
    h.run_steps(2);
    assert!(h.query_by_label("counting…").is_none());
    assert!(h.query_by_label("per ray: mean / max").is_some());
    let now = h.state().shown.clone().unwrap();
    assert!(
        Arc::ptr_eq(&now.frame, &shown.frame),
        "the counted frame is shown"
    );
    assert_eq!(now.rgba, shown.rgba, "the image does not change");
}

/// An island under the two levels: the status bar counts the placed triangles (the scene
/// stores none of them) and the build panel says how the scene is instanced, with the
/// memory a flattened copy would take, as `bvhlab stats` does.
#[test]
fn an_instanced_scene_shows_its_placed_triangles_and_flattened_size() {
    let h = small_island();
    let scene = h.state().scene.clone().expect("the island loaded");
    assert!(
        scene.triangles.is_empty(),
        "the island stores no placed triangle"
    );
    let placed = scene.placed_triangles();
    assert!(placed > 0);
    h.get_by_label_contains(&format!(": {placed} triangles, 3 objects"));
    let rows = scene.instancing_rows();
    assert_eq!(
        rows.len(),
        4,
        "instances, unique and instanced triangles, flattened copy"
    );
    for (k, v) in rows {
        h.get_by_label(&format!("scene {k}"));
        assert!(h.query_all_by_label(&v).next().is_some(), "{k}: {v} shown");
    }
    assert!(h.query_all_by_label(&placed.to_string()).next().is_some());
}

/// A .glb dropped on the window loads as the scene, its mesh placed by two nodes, and a
/// dropped broken .gltf shows its error naming the node, keeping the scene.
#[test]
fn dropping_a_gltf_on_the_window_loads_its_instances() {
    use common::gltf::{GltfBuilder, UNSIGNED_SHORT, temp_dir, write_json};
    let mut h = app("cornell");
    let mut b = GltfBuilder::default();
    let p = b.positions(&[
        glam::Vec3::new(-1.0, -1.0, 0.0),
        glam::Vec3::new(1.0, -1.0, 0.0),
        glam::Vec3::new(1.0, 1.0, 0.0),
        glam::Vec3::new(-1.0, 1.0, 0.0),
    ]);
    let i = b.indices(&[0, 1, 2, 0, 2, 3], UNSIGNED_SHORT);
    let mesh = b.mesh(&[(p, Some(i))]);
    let left =
        b.node(serde_json::json!({"mesh": mesh, "name": "left", "translation": [-2.0, 0.0, 0.0]}));
    let right =
        b.node(serde_json::json!({"mesh": mesh, "name": "right", "scale": [1.0, 2.0, 1.0]}));
    b.roots.extend([left, right]);
    let dir = temp_dir("app-drop");
    let glb = b.write_glb(&dir, "quads");
    let drop = |h: &mut Harness<'static, BvhLabApp>, path: &std::path::Path| {
        h.input_mut()
            .dropped_files
            .push(std::sync::Arc::new(DroppedPath(path.to_path_buf())));
        h.run_steps(1);
        settle(h);
    };
    drop(&mut h, &glb);
    let app = h.state();
    assert_eq!(app.load_error, None);
    let scene = app.scene.clone().expect("a scene");
    assert_eq!(
        scene.placed_triangles(),
        4,
        "two quads replaced the Cornell box"
    );
    assert_eq!((scene.instances.len(), scene.meshes.len()), (2, 1));
    assert!(
        app.shown
            .as_ref()
            .is_some_and(|s| s.frame.summary.primary_hits > 0)
    );
    // The right quad's node made singular: an error naming the file and node.
    let mut doc = b.document(Some(format!(
        "data:application/octet-stream;base64,{}",
        common::gltf::base64(&b.bin)
    )));
    doc["nodes"][right]["scale"] = serde_json::json!([1.0, 0.0, 1.0]);
    let bad = write_json(&dir, "singular", &doc);
    drop(&mut h, &bad);
    let app = h.state();
    let error = app.load_error.clone().expect("an error is shown");
    assert!(
        error.contains("singular.gltf") && error.contains("'right'") && error.contains("singular"),
        "{error}"
    );
    assert_eq!(
        app.scene.as_ref().unwrap().placed_triangles(),
        4,
        "the quads stay"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A first scene that cannot be loaded leaves the window without a scene: it says so and
/// offers the built-in scenes, and one click loads one.
#[test]
fn a_failed_first_load_offers_the_built_in_scenes() {
    let missing = std::env::temp_dir().join(format!("bvhlab-missing-{}.obj", std::process::id()));
    let mut h = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .with_max_steps(16)
        .build_eframe(move |cc| {
            BvhLabApp::new(
                cc,
                bvhlab::app::Launch {
                    scene: Some(missing.display().to_string()),
                    fresh: true,
                    ..Default::default()
                },
            )
        });
    for _ in 0..20 {
        h.run_steps(2);
        let ctx = h.ctx.clone();
        h.state_mut().wait_for_worker(&ctx);
        if h.state().load_error.is_some() {
            break;
        }
    }
    h.run_steps(2);
    assert!(h.state().scene.is_none());
    assert!(h.query_by_label_contains("No scene is loaded").is_some());
    assert!(h.query_by_label_contains("The previous scene").is_none());
    h.get_by_label("walls").click();
    settle(&mut h);
    assert_eq!(h.state().scene.as_ref().unwrap().name, "walls");
    assert!(h.state().load_error.is_none());
}

/// The view's share of the window: at least 55 % with the panels at 1280×720, at least
/// 90 % in the presentation layout, which Tab and F11 toggle; the layout is a setting.
#[test]
fn the_view_keeps_its_share_and_tab_presents_it() {
    let mut h = launch(
        Harness::builder().with_size(egui::vec2(1280.0, 720.0)),
        "cornell",
        |_| {},
    );
    let share = |h: &Harness<'static, BvhLabApp>| {
        let [w, v] = h.state().viewport_px;
        (w * v) as f32 / (1280.0 * 720.0)
    };
    assert!(share(&h) >= 0.55, "normal layout: {}", share(&h));
    assert!(!h.state().settings.presentation);
    h.key_press(egui::Key::Tab);
    settle(&mut h);
    assert!(h.state().settings.presentation);
    assert!(share(&h) >= 0.9, "presentation layout: {}", share(&h));
    h.key_press(egui::Key::F11);
    settle(&mut h);
    assert!(!h.state().settings.presentation, "F11 goes back");
    h.get_by_label("Present (Tab)").click();
    settle(&mut h);
    assert!(h.state().settings.presentation, "and so does the button");
    h.get_by_label("exit presentation").click();
    settle(&mut h);
    assert!(!h.state().settings.presentation);
    assert!(share(&h) >= 0.55);
}

/// A widget with egui's focus (Tab moves it, as a click may) must not switch the
/// shortcuts off: only a text field being typed into takes the keys.
#[test]
fn shortcuts_answer_while_a_widget_has_the_focus() {
    let mut h = app("cornell");
    // Tab: into the presentation layout, and egui moves its focus onto a widget.
    h.key_press(egui::Key::Tab);
    settle(&mut h);
    assert!(h.state().settings.presentation);
    h.key_press_modifiers(egui::Modifiers::SHIFT, egui::Key::Num4);
    settle(&mut h);
    assert_eq!(h.state().settings.mode, bvhlab::render::ViewMode::Nodes);
    let levels = h.state().settings.show_levels;
    h.key_press(egui::Key::L);
    settle(&mut h);
    assert_ne!(
        h.state().settings.show_levels,
        levels,
        "L toggles the levels"
    );
    h.key_press(egui::Key::W);
    settle(&mut h);
    assert_eq!(h.state().walk, Some(0), "W opens the tree walk");
    h.key_press(egui::Key::M);
    settle(&mut h);
    assert_eq!(h.state().tool, bvhlab::app::Tool::Move);
    h.key_press(egui::Key::F11);
    settle(&mut h);
    assert!(!h.state().settings.presentation, "F11 goes back");
}

/// Open… and Save… where no desktop portal answers (no D-Bus session, as here and in a
/// kiosk): the in-app file browser opens with the title of what it is for, and Cancel
/// closes it.
#[test]
fn open_and_save_without_a_desktop_portal_open_the_in_app_browser() {
    use bvhlab::app::export::Export;
    use bvhlab::app::file_browser::{Purpose, Start};
    let mut h = app("cornell");
    for (button, purpose, title) in [
        ("Open…", Purpose::OpenScene, "Open a scene"),
        (
            "Save view as PNG…",
            Purpose::Export(Export::ViewPng),
            "Save the view as a PNG",
        ),
    ] {
        if std::env::var_os("DBUS_SESSION_BUS_ADDRESS").is_none() {
            match purpose {
                Purpose::Export(what) => {
                    // Below the fold of the statistics: asked for as its button does.
                    let ctx = h.ctx.clone();
                    h.state_mut().save_dialog(what, &ctx);
                }
                _ => h.get_by_label(button).click(),
            }
        } else {
            // A session bus here: the portal may answer; open the browser as its fallback
            // would.
            h.state_mut().files.open_browser(purpose, &Start::default());
        }
        h.run_steps(3);
        assert!(
            h.state().files.browsing(),
            "{button}: the in-app browser is open"
        );
        assert!(h.query_by_label_contains(title).is_some(), "{button}");
        h.get_by_label("Cancel").click();
        h.run_steps(3);
        assert!(!h.state().files.browsing(), "{button}: Cancel closes it");
    }
    assert!(h.state().load_error.is_none());
    assert!(h.state().export_status.is_none());
}

/// A screenshot told to open the tree walk at a node the tree does not have, or to show a
/// replay visit the ray does not make, ends with an error naming it instead of a shot of
/// something else.
#[test]
fn a_screenshot_of_a_node_or_visit_that_does_not_exist_fails() {
    use bvhlab::app::Launch;
    use bvhlab::app::screenshot::{ReplayShot, ScreenshotPlan, Shot};
    let out = std::env::temp_dir().join(format!("bvhlab-never-{}.png", std::process::id()));
    let mut walk = ScreenshotPlan::new(out.clone(), Shot::Levels, 800, 500);
    walk.walk = Some(99_999_999);
    let mut replay = ScreenshotPlan::new(out.clone(), Shot::Shaded, 800, 500);
    replay.replay = Some(ReplayShot {
        at: [0.5, 0.5],
        visit: 100_000,
    });
    for (plan, expected) in [
        (walk, "there is no node 99999999 to walk from"),
        (replay, "there is no visit 100000"),
    ] {
        let result = plan.result.clone();
        let launch = Launch {
            scene: Some("cornell".into()),
            accel: Some(bvhlab::accel::AccelKind::Bvh),
            fresh: true,
            screenshot: Some(plan),
            ..Default::default()
        };
        let mut h = common::app::open(800.0, 500.0, launch);
        for _ in 0..200 {
            if result.lock().unwrap().is_some() {
                break;
            }
            h.run_steps(1);
            let ctx = h.ctx.clone();
            h.state_mut().wait_for_worker(&ctx);
        }
        let outcome = result.lock().unwrap().clone().expect("the run ended");
        let err = outcome.expect_err("no shot");
        assert!(err.contains(expected), "{err}");
        assert!(!out.exists());
    }
}
