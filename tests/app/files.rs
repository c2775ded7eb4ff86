//! Loading and saving: bad and warned OBJ files, dropped OBJ and glTF files, a failed first
//! load, the in-app browser without a desktop portal.

use super::*;

#[test]
fn loading_a_bad_obj_shows_the_error_and_keeps_the_scene() {
    let mut h = app("cornell");
    let dir = common::TempDir::new("app-bad");
    let path = dir.join("bad.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n").unwrap();
    h.state_mut().load(path.display().to_string());
    settle(&mut h);
    let app = h.state();
    let error = app.load_error.clone().expect("an error is shown");
    assert!(error.contains(":3"), "names the line: {error}");
    assert_eq!(app.scene.as_ref().unwrap().name, "cornell");
    assert!(h.query_by_label_contains("Load failed").is_some());
}

/// What the loader skipped is said in the window too, not only on the command line, until
/// dismissed.
#[test]
fn an_obj_loaded_with_warnings_says_so_in_the_window() {
    let mut h = app("cornell");
    let dir = common::TempDir::new("app-warn");
    let path = dir.join("warn.obj");
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
}

#[test]
fn dropping_an_obj_on_the_window_loads_it_and_remembers_it() {
    let mut h = app("cornell");
    let dir = common::TempDir::new("app-drop");
    let path = dir.join("drop.obj");
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
}

/// A .glb dropped on the window loads as the scene, its mesh placed by two nodes, and a
/// dropped broken .gltf shows its error naming the node, keeping the scene.
#[test]
fn dropping_a_gltf_on_the_window_loads_its_instances() {
    use common::gltf::{GltfBuilder, UNSIGNED_SHORT, write_json};
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
    let dir = common::TempDir::new("gltf-app-drop");
    let glb = b.write_glb(dir.path(), "quads");
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
    let bad = write_json(dir.path(), "singular", &doc);
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
}

/// A first scene that cannot be loaded leaves the window without a scene: it says so and
/// offers the built-in scenes, and one click loads one.
#[test]
fn a_failed_first_load_offers_the_built_in_scenes() {
    let dir = common::TempDir::new("missing");
    let missing = dir.join("missing.obj");
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
