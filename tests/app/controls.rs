//! The build controls and the layout: strategy, buckets, treelets, the overlap penalty,
//! out-of-range values, the walls' angle, the top bar and the in-view controls.

use super::*;

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

/// Under BVH8, ticking "wide nodes straight from the splits" greys out the pre-split
/// slider (that build splits no reference, and would refuse a budget); unticked, or for
/// the BVH2, the slider is live again.
#[test]
fn wide_nodes_straight_from_the_splits_grey_out_the_presplit_slider() {
    let mut h = tall_app("soup:3000");
    use egui_kittest::kittest::NodeT;
    let presplit = |h: &Harness<'static, BvhLabApp>| {
        h.get_by_role_and_label(egui::accesskit::Role::Slider, "pre-split budget × N")
            .accesskit_node()
            .is_disabled()
    };
    assert!(!presplit(&h), "the BVH2 takes a pre-split budget");
    choose_structure(&mut h, bvhlab::accel::AccelKind::Bvh8.title());
    assert!(!presplit(&h));
    h.get_by_label("wide nodes straight from the splits (no BVH2)")
        .click();
    settle(&mut h);
    assert!(h.state().settings.structure.bvh.direct_wide);
    assert!(presplit(&h), "greyed out under a direct wide build");
    h.get_by_label("wide nodes straight from the splits (no BVH2)")
        .click();
    settle(&mut h);
    assert!(!presplit(&h), "live again");
    h.get_by_label("wide nodes straight from the splits (no BVH2)")
        .click();
    settle(&mut h);
    choose_structure(&mut h, bvhlab::accel::AccelKind::Bvh.title());
    assert!(!presplit(&h), "the BVH2 ignores the wide trees' setting");
}

/// Under the octree, whose report weighs its cells with the k-d tree's constants, those
/// two sliders are drawn too, and moving one rebuilds the report with it.
#[test]
fn the_octree_panel_moves_the_constants_its_sah_cost_is_weighed_with() {
    let mut h = tall_app("soup:3000");
    choose_structure(&mut h, bvhlab::accel::AccelKind::Octree.title());
    let detail = |h: &Harness<'static, BvhLabApp>, name: &str| {
        let report = h.state().report.clone().expect("built");
        report.detail(name).expect(name).to_string()
    };
    let constants = "C_trav / C_isect (the k-d tree's)";
    assert_eq!(detail(&h, constants), "1 / 2");
    let before = detail(&h, "SAH cost");
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "C_trav")
        .set_value_accesskit(3.0);
    settle(&mut h);
    assert_eq!(h.state().settings.structure.kdtree.c_trav, 3.0);
    assert_eq!(detail(&h, constants), "3 / 2", "the report follows");
    assert_ne!(detail(&h, "SAH cost"), before);
}
