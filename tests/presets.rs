//! Lecture presets as files: the built-in lecture, saving and loading again to the same
//! preset, and bad files rejected with an error that names the problem.

use bvhlab::accel::{AccelKind, Strategy, StructureParams};
use bvhlab::app::Tool;
use bvhlab::app::preset::{Preset, Sequence, View, parse};
use bvhlab::app::settings::{Bookmark, Settings};
use bvhlab::render::ViewMode;
use bvhlab::scene::Scene;
use bvhlab_testkit::TempDir;
use std::path::PathBuf;
use std::process::Command;

#[test]
fn the_lecture_follows_the_slides_in_order() {
    let lecture = Sequence::lecture();
    let titles: Vec<String> = lecture
        .presets
        .iter()
        .map(|p| p.title.to_lowercase())
        .collect();
    let topics = [
        "brute force",
        "early out",
        "median",
        "sah",
        "front to back",
        "any hit",
        "troublesome",
        "refit",
        "k-d tree",
        "mailboxing",
        "grid",
        "octree",
        "wide bvh",
        "two levels",
        "rotated walls",
        "watertight",
    ];
    let mut from = 0;
    for topic in topics {
        let at = titles[from..]
            .iter()
            .position(|t| t.contains(topic))
            .unwrap_or_else(|| panic!("no step on '{topic}' after step {from}: {titles:?}"));
        from += at;
    }
    assert!(lecture.presets.len() >= 14);
    assert!(lecture.presets.iter().all(|p| !p.caption.is_empty()));
}

#[test]
fn every_step_of_the_lecture_loads_and_builds() {
    for (i, p) in Sequence::lecture().presets.iter().enumerate() {
        let scene = Scene::load(&p.scene).unwrap_or_else(|e| panic!("step {}: {e}", i + 1));
        let params = p.settings.structure;
        params.validate().unwrap();
        // The island is traced through its two levels only (the app test builds it).
        if scene.is_flattened() {
            bvhlab::accel::structure::build(&scene.triangles, &params, &Default::default())
                .unwrap_or_else(|e| panic!("step {} ({}): {e}", i + 1, p.title));
        } else {
            assert_eq!(p.settings.structure.kind, AccelKind::TwoLevel);
        }
    }
}

/// A preset with every part set away from its default.
fn full_preset() -> Preset {
    let mut settings = Settings {
        mode: ViewMode::Repeated,
        shadow_rays: true,
        heat_max: Some(40),
        show_levels: true,
        level: 3,
        see_through: true,
        auto_rebuild_percent: Some(12.5),
        ..Settings::default()
    };
    settings.structure.kind = AccelKind::KdTree;
    settings.structure.mailbox = false;
    settings.structure.bvh.strategy = Strategy::ObjectMedian;
    settings.structure.bvh.buckets = 7;
    settings.structure.kdtree.c_isect = 1.7;
    settings.scene = "soup:500".into();
    Preset {
        title: "Mailboxing off".into(),
        caption: "How often is a triangle tested again?".into(),
        scene: "soup:500".into(),
        camera: Some(View {
            eye: [1.5, 2.25, -3.0],
            look: [0.1, 0.2, 0.3],
            fov: 45.0,
        }),
        tool: Tool::Replay,
        walk: Some(5),
        focus: Some(bvhlab::app::preset::Focus::Replay),
        settings,
        pinned: Some(StructureParams {
            kind: AccelKind::Grid,
            grid: bvhlab::accel::grid::GridParams {
                lambda: 2.5,
                ..Default::default()
            },
            ..StructureParams::default()
        }),
    }
}

/// A preset pins configuration A from a `[pinned]` table that names only what differs from
/// the defaults; a pinned configuration that cannot be built is an error naming it.
#[test]
fn a_preset_pins_configuration_a() {
    let text = "title = \"Median against SAH\"\nscene = \"cornell\"\n\
                [settings]\nstrategy = \"SahBinned\"\n\
                [pinned]\nstrategy = \"ObjectMedian\"\nmax_leaf_size = 2\n";
    let seq = parse(text, "pin.toml", None).unwrap();
    let a = seq.presets[0].pinned.unwrap();
    assert_eq!(a.bvh.strategy, Strategy::ObjectMedian);
    assert_eq!(a.bvh.max_leaf_size, 2);
    assert_eq!(a.bvh.buckets, StructureParams::default().bvh.buckets);
    // A table without `accel` pins the fastest layout here, as the app starts with.
    assert_eq!(a.kind, AccelKind::fastest());
    let bad = text.replace("max_leaf_size = 2", "buckets = 0");
    let err = parse(&bad, "pin.toml", None).unwrap_err().to_string();
    assert!(err.contains("pinned"), "{err}");
    let unknown = text.replace("max_leaf_size = 2", "leaf_size = 2");
    let err = parse(&unknown, "pin.toml", None).unwrap_err().to_string();
    assert!(err.contains("leaf_size"), "{err}");
}

#[test]
fn a_saved_preset_loads_back_the_same() {
    let p = full_preset();
    let text = p.to_toml();
    let back = parse(&text, "saved.toml", None).unwrap();
    assert_eq!(back.presets, vec![p.clone()], "{text}");
    // Saving what was loaded gives the same file.
    assert_eq!(back.presets[0].to_toml(), text);
    // Through a file on disk too, and as a sequence.
    let dir = TempDir::new("presets-roundtrip");
    let path = dir.join("one.toml");
    std::fs::write(&path, &text).unwrap();
    assert_eq!(Sequence::load(&path).unwrap().presets, vec![p]);
    for step in Sequence::lecture().presets {
        let again = parse(&step.to_toml(), "step", None).unwrap();
        assert_eq!(again.presets, vec![step]);
    }
}

#[test]
fn a_file_holds_one_preset_or_a_sequence() {
    let one = parse("title = \"A\"\nscene = \"cornell\"\n", "one", None).unwrap();
    assert_eq!(one.presets.len(), 1);
    // Missing settings take their defaults.
    assert_eq!(one.presets[0].settings.mode, ViewMode::Shaded);
    assert_eq!(one.presets[0].tool, Tool::Orbit);
    let two = parse(
        "[[preset]]\ntitle = \"A\"\nscene = \"cornell\"\n\n[[preset]]\ntitle = \"B\"\nscene = \"walls\"\ntool = \"move\"\n[preset.settings]\nmode = \"Nodes\"\n",
        "two",
        None,
    )
    .unwrap();
    assert_eq!(two.presets.len(), 2);
    assert_eq!(two.presets[1].settings.mode, ViewMode::Nodes);
    assert_eq!(two.presets[1].tool, Tool::Move);
    let (lecture, i) = Sequence::open("lecture:3").unwrap();
    assert_eq!(i, 2);
    assert_eq!(
        lecture.presets[i].settings.structure.bvh.strategy,
        Strategy::ObjectMedian
    );
}

#[test]
fn a_scene_file_is_found_beside_the_preset() {
    let dir = TempDir::new("presets-beside");
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let path = dir.join("p.toml");
    std::fs::write(&path, "title = \"T\"\nscene = \"tri.obj\"\n").unwrap();
    let s = Sequence::load(&path).unwrap();
    assert_eq!(PathBuf::from(&s.presets[0].scene), dir.join("tri.obj"));
}

/// The error of a bad preset text, without the backtrace.
fn error_of(text: &str) -> String {
    parse(text, "bad.toml", None)
        .expect_err("a bad preset must not load")
        .to_string()
}

#[test]
fn bad_files_say_what_is_wrong() {
    let syntax = error_of("title = \"A\nscene = \"cornell\"\n");
    assert!(
        syntax.starts_with("bad.toml: ") && syntax.contains("line 1"),
        "{syntax}"
    );
    let scene = error_of("title = \"A\"\nscene = \"nowhere\"\n");
    assert!(scene.contains("unknown scene 'nowhere'"), "{scene}");
    let value = error_of("title = \"A\"\nscene = \"cornell\"\n[settings]\naccel = \"Bhv\"\n");
    assert!(value.contains("line 4") && value.contains("Bhv"), "{value}");
    let key = error_of("title = \"A\"\nscene = \"cornell\"\n[settings]\nacel = \"Bvh\"\n");
    assert!(key.contains("unknown setting 'acel'"), "{key}");
    let top = error_of("title = \"A\"\nscene = \"cornell\"\nmood = 1\n");
    assert!(top.contains("mood"), "{top}");
    let range = error_of("title = \"A\"\nscene = \"cornell\"\n[settings]\nbuckets = 1\n");
    assert!(range.contains("bucket count 1"), "{range}");
    // Where it is written: the line of the setting, in the preset that holds it.
    assert!(range.contains("line 4: setting 'buckets'"), "{range}");
    let second_range = error_of(
        "[[preset]]\ntitle = \"A\"\nscene = \"cornell\"\n[preset.settings]\nbuckets = 8\n\
         [[preset]]\ntitle = \"B\"\nscene = \"cornell\"\n[preset.settings]\nmode = \"Nodes\"\nbuckets = 1\n",
    );
    assert!(
        second_range.contains("preset 2 ('B'): line 11: setting 'buckets'"),
        "{second_range}"
    );
    // Every error is one line, the parser's own included.
    for e in [&syntax, &top, &range] {
        assert!(!e.trim_end().contains('\n'), "one line: {e}");
    }
    // The build-quality parameters out of range, as TOML can spell them.
    for (setting, reason) in [
        ("treelet_size = 4", "treelet size 4"),
        ("treelet_rounds = 17", "17 treelet rounds"),
        ("split_budget = -1.0", "split budget -1"),
        ("split_alpha = nan", "overlap threshold α NaN"),
        ("presplit = inf", "presplit budget inf"),
    ] {
        let e = error_of(&format!(
            "title = \"A\"\nscene = \"cornell\"\n[settings]\n{setting}\n"
        ));
        assert!(e.contains(reason), "{setting}: {e}");
    }
    let fov = error_of(
        "title = \"A\"\nscene = \"cornell\"\ncamera = { eye = [0, 0, 1], look = [0, 0, 0], fov = 0 }\n",
    );
    assert!(fov.contains("fov"), "{fov}");
    let personal = error_of("title = \"A\"\nscene = \"cornell\"\n[settings]\nscene = \"walls\"\n");
    assert!(
        personal.contains("'scene' is not set by a preset"),
        "{personal}"
    );
    let second = error_of(
        "[[preset]]\ntitle = \"A\"\nscene = \"cornell\"\n[[preset]]\ntitle = \"B\"\nscene = \"nope\"\n",
    );
    assert!(second.contains("preset 2 ('B')"), "{second}");
    let empty = error_of("preset = []\n");
    assert!(empty.contains("no preset"), "{empty}");
    let missing = Sequence::load(std::path::Path::new("/no/such/preset.toml")).unwrap_err();
    assert!(
        missing
            .to_string()
            .contains("/no/such/preset.toml: cannot read it")
    );
    let step = Sequence::open("lecture:99").unwrap_err().to_string();
    assert!(step.contains("no preset 99"), "{step}");
}

#[test]
fn bookmarks_are_kept_with_the_settings() {
    let mut s = Settings::default();
    s.bookmarks.insert(
        "cornell".into(),
        vec![Bookmark {
            name: "view 1".into(),
            view: View {
                eye: [0.0, 1.0, 3.0],
                look: [0.0, 1.0, 0.0],
                fov: 50.0,
            },
        }],
    );
    let stored = serde_json::to_string(&s).unwrap();
    let back: Settings = serde_json::from_str(&stored).unwrap();
    assert_eq!(back, s);
    // Settings stored before bookmarks existed still load.
    let mut old: serde_json::Value = serde_json::from_str(&stored).unwrap();
    old.as_object_mut().unwrap().remove("bookmarks");
    let back: Settings = serde_json::from_value(old).unwrap();
    assert!(back.bookmarks.is_empty());
    // A preset neither saves nor sets them.
    let p = Preset {
        settings: s.clone(),
        ..full_preset()
    };
    assert!(!p.to_toml().contains("bookmarks"));
}

#[test]
fn a_bad_preset_on_the_command_line_opens_no_window() {
    let dir = TempDir::new("presets-cli");
    let path = dir.join("bad.toml");
    std::fs::write(
        &path,
        "title = \"A\"\nscene = \"cornell\"\n[settings]\nmode = \"Nodez\"\n",
    )
    .unwrap();
    // Never written: the preset fails first.
    let never = dir.join("never.png");
    for command in ["app", "screenshot"] {
        let mut args = vec![command, "--preset", path.to_str().unwrap()];
        if command == "screenshot" {
            args.extend(["--out", never.to_str().unwrap()]);
        }
        let out = Command::new(env!("CARGO_BIN_EXE_bvhlab"))
            .args(&args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("bad.toml") && err.contains("line 4") && err.contains("Nodez"),
            "{err}"
        );
        assert!(!err.contains("window"), "{err}");
        assert!(!never.exists());
    }
    let out = Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(["app", "--preset", "lecture:0"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no preset 0"));
}

#[test]
fn the_readme_example_is_a_valid_preset() {
    let readme = include_str!("../README.md");
    let start = readme.find("```toml\n").expect("the README shows a preset") + 8;
    let text = &readme[start..start + readme[start..].find("```").unwrap()];
    let p = &parse(text, "README.md", None).unwrap().presets[0];
    assert_eq!(p.settings.structure.kind, AccelKind::Grid);
    assert_eq!(p.camera.unwrap().fov, 50.0);
}

/// Settings saved by an earlier version of the app (RON written by eframe, each parameter a
/// field of its own) load into today's settings with every value kept.
#[test]
fn settings_saved_by_an_earlier_version_load() {
    use bvhlab::accel::TraversalOrder;
    use bvhlab::accel::kdtree::KdSplit;
    use bvhlab::geometry::simd::SimdLevel;
    use bvhlab::render::compare::CompareView;
    let text = include_str!("data/settings-saved.ron");
    let s = Settings::from_ron(text).expect("the saved settings load");
    let p = &s.structure;
    assert_eq!(s.scene, "teapot-in-stadium");
    assert_eq!(
        (p.kind, p.mailbox, p.simd),
        (AccelKind::KdTree, false, SimdLevel::Portable)
    );
    let kd = &p.kdtree;
    assert_eq!((kd.c_trav, kd.c_isect, kd.empty_bonus), (1.5, 3.0, 0.5));
    assert_eq!((kd.max_depth, kd.max_leaf_size), (20, 2));
    assert_eq!(kd.split, KdSplit::Binned(32));
    assert_eq!(p.grid.lambda, 2.0);
    assert_eq!((p.octree.max_leaf_size, p.octree.max_depth), (4, 9));
    let b = &p.bvh;
    assert_eq!((b.strategy, b.buckets), (Strategy::Sbvh, 24));
    assert_eq!((b.treelet_size, b.treelet_rounds), (8, 2));
    assert_eq!(
        (b.split_alpha, b.overlap_penalty, b.split_budget),
        (0.001, 0.5, 0.25)
    );
    assert_eq!((b.presplit, b.rebraid, b.max_leaf_size), (0.1, 2.0, 4));
    assert_eq!((b.c_trav, b.c_isect), (1.25, 2.0));
    assert_eq!(p.order, TraversalOrder::Naive);
    assert_eq!(
        (s.mode, s.shadow_rays, s.heat_max),
        (ViewMode::Nodes, true, Some(50))
    );
    assert_eq!((s.show_levels, s.level, s.see_through), (true, 3, true));
    assert!(s.color_by_node && s.move_whole_object);
    assert_eq!(s.compare_view, CompareView::Difference);
    assert_eq!((s.auto_rebuild_percent, s.ui_scale), (Some(5.0), 1.25));
    assert_eq!(s.recent, ["../shared/scenes/sponza.obj"]);
    assert_eq!(s.bookmarks["cornell"][0].view.fov, 45.0);
    // Saved again, they load again the same.
    assert_eq!(Settings::from_ron(&s.to_ron().unwrap()), Some(s));
}
