//! The panels and the view: counting until the counted pass arrives, an instanced scene's
//! sizes, the view's share and presentation, shortcuts with a widget focused, screenshots
//! of what does not exist.

use super::*;

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

/// A screenshot told to open the tree walk at a node the tree does not have, or to show a
/// replay visit the ray does not make, ends with an error naming it instead of a shot of
/// something else.
#[test]
fn a_screenshot_of_a_node_or_visit_that_does_not_exist_fails() {
    use bvhlab::app::Launch;
    use bvhlab::app::screenshot::{ReplayShot, ScreenshotPlan, Shot};
    let dir = common::TempDir::new("never");
    let out = dir.join("never.png");
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
