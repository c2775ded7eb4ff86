//! UI tests of the lecture presets: the digit and page keys, every step of the built-in
//! lecture in the real app, saving and loading a preset file, a bad file leaving the state
//! alone, and the camera bookmarks.

use bvhlab_testkit as common;

use bvhlab::accel::AccelKind;
use bvhlab::app::{BvhLabApp, Tool};
use bvhlab::render::ViewMode;
use common::app::{launch, settle};
use eframe::egui::{self, Key, Modifiers};
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
fn digit_keys_open_presets_and_page_keys_step_through_them() {
    let mut h = app("cornell");
    assert_eq!(h.state().lecture.current, None);
    h.key_press(Key::Num2);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(1));
    assert_eq!(h.state().settings.structure.kind, AccelKind::BruteForceBbox);
    assert_eq!(h.state().settings.mode, ViewMode::Triangles);
    // The caption bar shows the title and the question.
    assert!(h.query_by_label("Early out").is_some());
    assert!(
        h.query_by_label_contains("What does testing a box first save?")
            .is_some()
    );
    h.key_press(Key::PageDown);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(2));
    assert_eq!(h.state().settings.scene, "teapot-in-stadium");
    assert_eq!(
        h.state().bvh_report.as_ref().unwrap().params.strategy,
        bvhlab::accel::bvh::Strategy::ObjectMedian
    );
    h.key_press(Key::PageUp);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(1));
    assert_eq!(h.state().settings.scene, "cornell");
    h.key_press(Key::Num9);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(8));
    // The caption's buttons step too: the refit step takes the move tool.
    h.get_by_label("next preset >").click();
    settle(&mut h);
    let refit = h.state().lecture.sequence.presets[9].clone();
    assert_eq!(h.state().lecture.current, Some(9));
    assert_eq!(h.state().tool, refit.tool);
    assert_eq!(h.state().tool, Tool::Move);
    h.get_by_label("next preset >").click();
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(10));
    assert_eq!(h.state().settings.structure.kind, AccelKind::KdTree);
    assert!(!h.state().settings.structure.mailbox);
    // Two digits typed quickly: step 17, which compares (A pinned).
    h.key_press(Key::Num1);
    h.key_press(Key::Num7);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(16));
    assert!(h.state().pinned.is_some());
    // Step 5 is about the SAH's prediction: the panel scrolled to it (the focus is used
    // up once its section is drawn).
    h.key_press(Key::Num5);
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(4));
    assert_eq!(h.state().panel_focus, None);
    let section = h.get_by_label("SAH predicted against measured").rect();
    assert!(
        section.top() >= 0.0 && section.bottom() <= 900.0,
        "the section is in sight: {section:?}"
    );
}

/// The steps meant to be compared with the step before them pin it as A.
#[test]
fn comparing_steps_pin_the_step_before_as_a() {
    let h = app("cornell");
    let steps = &h.state().lecture.sequence.presets;
    for (step, before) in [(2, 1), (7, 6), (12, 11)] {
        let pinned = steps[step - 1].pinned.expect("A pinned");
        let a = &steps[before - 1].settings.structure;
        assert_eq!(pinned.kind, a.kind, "step {step}");
        assert_eq!(pinned.mailbox, a.mailbox, "step {step}");
        assert_eq!(pinned.order, a.order, "step {step}");
    }
}

/// What is kept at exit while a lecture step is shown is the state from before the
/// lecture (the personal settings as they are now), so the next plain launch opens that.
#[test]
fn a_lecture_step_is_not_what_the_next_launch_opens() {
    let mut h = app("cornell");
    let before = h.state().settings.clone();
    h.key_press(Key::Num4);
    settle(&mut h);
    h.key_press(Key::Tab);
    settle(&mut h);
    let app = h.state();
    assert_ne!(app.settings, before, "the step changed the settings");
    let kept = app.lecture.settings_to_keep(&app.settings);
    assert!(kept.presentation, "the layout is the user's");
    assert_eq!(
        kept,
        bvhlab::app::settings::Settings {
            presentation: true,
            ..before
        }
    );
}

#[test]
fn shift_digits_pick_the_view_modes() {
    let mut h = app("cornell");
    h.key_press_modifiers(Modifiers::SHIFT, Key::Num4);
    h.run_steps(2);
    assert_eq!(h.state().settings.mode, ViewMode::Nodes);
    h.key_press_modifiers(Modifiers::SHIFT, Key::Num6);
    h.run_steps(2);
    assert_eq!(h.state().settings.mode, ViewMode::Triangles);
    h.key_press_modifiers(Modifiers::SHIFT, Key::Num0);
    h.run_steps(2);
    assert_eq!(h.state().settings.mode, ViewMode::Instances);
    // No preset was opened on the way.
    assert_eq!(h.state().lecture.current, None);
    assert_eq!(h.state().settings.scene, "cornell");
}

#[test]
fn every_step_of_the_lecture_shows_its_view() {
    let mut h = app("cornell");
    let steps = h.state().lecture.sequence.presets.clone();
    for (i, p) in steps.iter().enumerate() {
        assert!(h.state_mut().go_to_preset(i));
        settle(&mut h);
        let s = h.state();
        let step = format!("step {} ({})", i + 1, p.title);
        assert_eq!(s.load_error, None, "{step}");
        assert_eq!(s.build_error, None, "{step}");
        assert_eq!(s.settings.scene, p.scene, "{step}");
        assert_eq!(
            s.settings.structure.kind, p.settings.structure.kind,
            "{step}"
        );
        assert_eq!(
            s.report.as_ref().unwrap().structure,
            p.settings.structure.kind.label(),
            "{step}"
        );
        assert_eq!(s.settings.mode, p.settings.mode, "{step}");
        assert_eq!(s.walk, p.walk, "{step}");
        let shown = s.shown.as_ref().expect("a frame");
        assert!(shown.frame.summary.counted(), "{step}");
        // A heatmap step shows something to count.
        if p.settings.mode.is_heatmap() {
            assert!(shown.heat_max.unwrap_or(0) > 0, "{step}");
        }
    }
}

/// The cracks step: the worker's crack view of the shown frame, Möller–Trumbore's leaks
/// marked, and none when the watertight test is chosen (the same rays for both).
#[test]
fn the_cracks_step_marks_the_fast_tests_leaks_and_none_of_the_watertight_tests() {
    use bvhlab::geometry::IntersectorKind;
    let mut h = app("cornell");
    let steps = h.state().lecture.sequence.presets.clone();
    let step = steps
        .iter()
        .position(|p| p.settings.show_cracks)
        .expect("a step shows the cracks");
    assert!(h.state_mut().go_to_preset(step));
    settle(&mut h);
    let made = |h: &mut Harness<'static, BvhLabApp>, kind: IntersectorKind| {
        for _ in 0..40 {
            h.run_steps(1);
            let ctx = h.ctx.clone();
            h.state_mut().wait_for_worker(&ctx);
            if let Some((request, shown)) = &h.state().cracks
                && request.intersector == kind
            {
                return shown.clone().expect("a crack view");
            }
        }
        panic!("no crack view for {kind:?}");
    };
    let fast = made(&mut h, IntersectorKind::MollerTrumbore);
    let leaks = |kind| {
        fast.reports
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, r)| r.leaks())
            .unwrap()
    };
    assert!(fast.rays > 1000, "{} rays", fast.rays);
    assert!(leaks(IntersectorKind::MollerTrumbore) > 0);
    let marked = fast.markers.iter().filter(|m| m.leaked).count() as u64;
    assert_eq!(marked, leaks(IntersectorKind::MollerTrumbore));
    assert_eq!(leaks(IntersectorKind::Watertight), 0);
    assert_eq!(leaks(IntersectorKind::F64), 0);
    h.get_by_label("cracks: rays at every shared edge and vertex");
    // The test is chosen over the view (the View section has the same choice, further
    // left and maybe below the fold).
    let choices: Vec<_> = h.get_all_by_label("watertight").collect();
    assert_eq!(choices.len(), 2, "in the View section and over the view");
    let over_view = choices
        .into_iter()
        .max_by(|a, b| a.rect().left().total_cmp(&b.rect().left()))
        .unwrap();
    over_view.click();
    let tight = made(&mut h, IntersectorKind::Watertight);
    assert_eq!(tight.rays, fast.rays, "the same rays");
    assert!(tight.markers.iter().all(|m| !m.leaked));
}

#[test]
fn a_saved_preset_loads_back_to_the_same_state() {
    let mut h = app("cornell");
    let dir = common::TempDir::new("app-presets");
    let file = dir.join("camera.toml");
    std::fs::write(
        &file,
        "title = \"Close\"\nscene = \"walls\"\ntool = \"replay\"\nwalk = 2\ncamera = { eye = [3.0, 4.0, 9.0], look = [0.5, 0.5, 0.0], fov = 40 }\n[settings]\naccel = \"Octree\"\nmode = \"Boxes\"\nshow_levels = true\nlevel = 2\n",
    )
    .unwrap();
    h.state_mut().load_presets(&file).unwrap();
    settle(&mut h);
    let loaded = h.state().preset_here("Close");
    let cam = loaded.camera.unwrap();
    for (a, b) in cam.eye.iter().zip([3.0, 4.0, 9.0]) {
        assert!((a - b).abs() < 1e-4, "{cam:?}");
    }
    assert_eq!(loaded.settings.structure.kind, AccelKind::Octree);
    assert_eq!(loaded.tool, Tool::Replay);
    assert_eq!(loaded.walk, Some(2));
    assert!(loaded.pinned.is_none());
    // Pin A, then change B: the pinned configuration is part of the saved preset.
    h.state_mut().pin();
    h.state_mut().settings.structure.kind = AccelKind::Grid;
    settle(&mut h);
    let loaded = h.state().preset_here("Close");
    assert_eq!(loaded.pinned.as_ref().unwrap().kind, AccelKind::Octree);
    // Save it, go elsewhere, load the saved file: the same state again.
    let saved = dir.join("saved.toml");
    h.state_mut().save_preset(&saved).unwrap();
    h.state_mut().open_lecture();
    settle(&mut h);
    assert_eq!(h.state().lecture.current, Some(0));
    h.key_press(Key::Num1);
    settle(&mut h);
    assert_eq!(h.state().settings.structure.kind, AccelKind::BruteForce);
    // The lecture's first step pins nothing.
    assert!(h.state().pinned.is_none());
    h.state_mut().load_presets(&saved).unwrap();
    settle(&mut h);
    let again = h.state().preset_here("Close");
    assert_eq!(again.settings, loaded.settings);
    assert_eq!(again.pinned, loaded.pinned);
    // A is traced beside B: the comparison's summary is there.
    assert!(h.state().compared.is_some());
    assert_eq!((again.tool, again.walk), (loaded.tool, loaded.walk));
    let (a, b) = (again.camera.unwrap(), loaded.camera.unwrap());
    for (x, y) in a.eye.iter().chain(&a.look).zip(b.eye.iter().chain(&b.look)) {
        assert!((x - y).abs() < 1e-4, "{a:?} {b:?}");
    }
    assert_eq!(a.fov, b.fov);
}

#[test]
fn a_bad_preset_file_is_an_error_and_the_state_stays() {
    let mut h = app("cornell");
    h.key_press(Key::Num3);
    settle(&mut h);
    let before = h.state().settings.clone();
    let sequence = h.state().lecture.sequence.clone();
    let dir = common::TempDir::new("app-presets");
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[preset]]\ntitle = \"A\"\nscene = \"cornell\"\n[[preset]]\ntitle = \"B\"\nscene = \"no-such-scene\"\n",
    )
    .unwrap();
    let err = h.state_mut().load_presets(&bad).unwrap_err().to_string();
    assert!(
        err.contains("bad.toml") && err.contains("preset 2 ('B')"),
        "{err}"
    );
    settle(&mut h);
    assert_eq!(h.state().settings, before);
    assert_eq!(h.state().lecture.sequence, sequence);
    assert_eq!(h.state().lecture.current, Some(2));
    // The controls show the error.
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("unknown scene 'no-such-scene'")
            .is_some()
    );
    assert!(h.query_by_label("Nothing was changed.").is_some());
}

#[test]
fn bookmarks_keep_views_of_each_scene() {
    let mut h = app("cornell");
    h.get_by_label("Lecture").click();
    h.run_steps(2);
    h.get_by_label("Bookmark view").click();
    h.run_steps(2);
    let kept = h.state().bookmarks()[0].view;
    // Turn away (F frames the scene from another distance), then Ctrl+1 comes back.
    h.state_mut().frame_all();
    h.run_steps(1);
    let away = h.state().preset_here("x").camera.unwrap();
    assert!(
        (away.eye[2] - kept.eye[2]).abs() > 1e-3,
        "{away:?} {kept:?}"
    );
    h.key_press_modifiers(Modifiers::COMMAND, Key::Num1);
    settle(&mut h);
    let here = h.state().preset_here("x").camera.unwrap();
    for (a, b) in here.eye.iter().zip(kept.eye) {
        assert!((a - b).abs() < 1e-4, "{here:?} {kept:?}");
    }
    // Ctrl+1 recalled a bookmark and opened no preset.
    assert_eq!(h.state().lecture.current, None);
    h.get_by_label("Lecture").click();
    h.run_steps(2);
    assert!(h.query_by_label("view 1  (Ctrl+1)").is_some());
    h.key_press(Key::Escape);
    h.run_steps(2);
    // Another scene has its own (none yet); back on the Cornell box it is there.
    h.state_mut().load("walls".into());
    settle(&mut h);
    assert!(h.state().bookmarks().is_empty());
    h.state_mut().load("cornell".into());
    settle(&mut h);
    assert_eq!(h.state().bookmarks().len(), 1);
    h.get_by_label("Lecture").click();
    h.run_steps(2);
    h.get_by_label("×").click();
    h.run_steps(2);
    assert!(h.state().bookmarks().is_empty());
    assert!(h.state().settings.bookmarks.is_empty());
}

/// A preset that compares, opened at launch (`app --preset lecture:4`), pins its A as
/// stepping to it does.
#[test]
fn a_comparing_preset_opened_at_launch_pins_its_a() {
    let sequence = bvhlab::app::preset::Sequence::lecture();
    let (index, preset) = sequence
        .presets
        .iter()
        .enumerate()
        .find(|(_, p)| p.pinned.is_some())
        .expect("the lecture has a step that compares");
    let expected = preset.pinned;
    let scene = preset.scene.clone();
    let launch = bvhlab::app::Launch {
        scene: Some(scene),
        preset: Some((sequence, index)),
        fresh: true,
        ..Default::default()
    };
    let mut h = common::app::open(1280.0, 720.0, launch);
    settle(&mut h);
    assert_eq!(h.state().pinned, expected);
}

/// A step about a section of the statistics opens with that section in sight, at the
/// projector's 1280×720, even though the sections above it grow as the build and the
/// counted frame arrive: step 5's "SAH predicted against measured", step 7's replay.
#[test]
fn a_step_opens_with_its_section_in_sight() {
    let sequence = bvhlab::app::preset::Sequence::lecture();
    for (index, heading) in [(4, "SAH predicted against measured"), (6, "Ray replay")] {
        let launch = bvhlab::app::Launch {
            scene: Some(sequence.presets[index].scene.clone()),
            preset: Some((sequence.clone(), index)),
            fresh: true,
            ..Default::default()
        };
        let mut h = common::app::open(1280.0, 720.0, launch);
        settle(&mut h);
        h.run_steps(2);
        assert_eq!(h.state().panel_focus, None, "step {}", index + 1);
        let section = h.get_by_label(heading).rect();
        assert!(
            section.top() >= 0.0 && section.bottom() <= 720.0,
            "step {}: {heading} in sight: {section:?}",
            index + 1
        );
    }
}
