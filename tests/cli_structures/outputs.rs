//! What the other subcommands write: trade-off and rotation sweeps, screenshots, stress,
//! the SAH scatter, heatmaps, frames and stats.

use super::*;

#[test]
fn tradeoff_and_rotation_sweep_write_their_csv_and_plot() {
    let dir = TempDir::new("tradeoff");
    let (csv, png) = (dir.join("t.csv"), dir.join("t.png"));
    let mut args = vec![
        "bench",
        "tradeoff",
        "--scene",
        "soup:600",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
    ];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("best from 100 k to"), "{text}");
    let rows = std::fs::read_to_string(&csv).unwrap();
    // Ten builders, 61 ray counts from 10^5 to 10^11.
    assert_eq!(rows.lines().count(), 1 + 10 * 61);
    assert!(png.exists() && png.with_extension("svg").exists());

    let (csv, png) = (dir.join("r.csv"), dir.join("r.png"));
    let mut args = vec![
        "bench",
        "rotation-sweep",
        "--scene",
        "walls:24",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
    ];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = std::fs::read_to_string(&csv).unwrap();
    // Four builders at ten angles: SBVH as the paper and with the overlap penalty.
    assert_eq!(rows.lines().count(), 1 + 4 * 10);
    assert!(rows.contains("\n45,SBVH,"), "{rows}");
    assert!(rows.contains("\n45,SBVH (κ = 1; budget 16 N),"), "{rows}");
    assert!(png.exists());

    let err = bvhlab(&["bench", "rotation-sweep", "--scene", "cornell"]);
    assert!(!err.status.success());
    assert!(String::from_utf8_lossy(&err.stderr).contains("--scene walls"));
}

/// `screenshot --instance` names an instance of the two levels: under another structure it
/// is refused before a window opens, with the flag to use.
#[test]
fn screenshot_instance_needs_the_two_levels() {
    let dir = TempDir::new("never");
    let never = dir.join("never.png");
    let out = bvhlab(&[
        "screenshot",
        "--out",
        never.to_str().unwrap(),
        "--scene",
        "cornell",
        "--mode",
        "levels",
        "--accel",
        "bvh",
        "--instance",
        "1",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("use --accel two-level"), "{err}");
    assert!(!never.exists());
}

/// `stress --accel two-level` also places the closed meshes as rotated, scaled and
/// mirrored instances, counts their leaks and mismatches and passes.
#[test]
fn stress_through_the_two_levels_places_closed_meshes_as_instances() {
    let out = bvhlab(&[
        "stress",
        "--quick",
        "--accel",
        "two-level",
        "--leak-rays",
        "1000",
        "--scene-rays",
        "1000",
        "--scene",
        "cornell",
        "--json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cases = json["instanced"].as_array().expect("the instanced part");
    assert_eq!(cases.len(), 3);
    for c in cases {
        assert_eq!(c["placements"].as_array().unwrap().len(), 5);
        for kind in ["watertight", "f64"] {
            let l = &c["leaks"][kind];
            assert_eq!(l["rays"], 1000, "{c}");
            assert_eq!(l["bvh_closest"], 0, "{c}");
            assert_eq!(l["bvh_any"], 0, "{c}");
            assert_eq!(l["brute_closest"], 0, "{c}");
            assert_eq!(c["agreement"][kind]["mismatches"], 0, "{c}");
        }
    }
    assert_eq!(json["passed"], true);
}

/// `bench sah-scatter` gathers scenes in one CSV (a scene run again replaces its rows), prints
/// the SAH check table, and refuses a CSV it did not write without touching it.
#[test]
fn sah_scatter_gathers_scenes_in_one_csv() {
    let dir = TempDir::new("sah-scatter");
    let (csv, png) = (dir.join("s.csv"), dir.join("s.png"));
    let run = |scene: &str| {
        let mut args = vec![
            "bench",
            "sah-scatter",
            "--scene",
            scene,
            "--csv",
            csv.to_str().unwrap(),
            "--plot",
            png.to_str().unwrap(),
        ];
        args.extend(SMALL_BENCH);
        bvhlab(&args)
    };
    for scene in ["soup:500", "cornell", "soup:500"] {
        let out = run(scene);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(text.contains("SAH predicted against measured"), "{text}");
    }
    let rows = std::fs::read_to_string(&csv).unwrap();
    // Ten builders on each of two scenes; the soup's second run replaced its first.
    assert_eq!(rows.lines().count(), 1 + 2 * 10, "{rows}");
    assert!(
        rows.lines().nth(1).unwrap().starts_with("\"cornell\""),
        "{rows}"
    );
    assert!(png.exists() && png.with_extension("svg").exists());
    std::fs::write(&csv, "not a scatter\n").unwrap();
    let out = run("cornell");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("is not a SAH scatter CSV"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), "not a scatter\n");
}

/// The two levels' heatmaps count the two levels' work: asked of a flat structure they are
/// an error, not a black image; with the two levels they are drawn.
#[test]
fn two_level_heatmaps_need_the_two_levels() {
    let dir = TempDir::new("heat");
    for mode in ["top-nodes", "bottom-nodes", "instances"] {
        let out_png = dir.join(format!("{mode}.png")).display().to_string();
        let small = ["--width", "16", "--height", "12", "--out", &out_png];
        for accel in [None, Some("bvh"), Some("kdtree")] {
            let mut args = vec!["render", "--scene", "cornell", "--mode", mode];
            args.extend(accel.map(|a| ["--accel", a]).iter().flatten());
            args.extend(small);
            let out = bvhlab(&args);
            assert!(!out.status.success(), "{mode} {accel:?}");
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(
                err.contains(&format!("--mode {mode}")) && err.contains("--accel two-level"),
                "{err}"
            );
        }
        let mut args = vec!["render", "--scene", "cornell", "--mode", mode];
        args.extend(["--accel", "two-level"]);
        args.extend(small);
        let out = bvhlab(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::path::Path::new(&out_png).exists());
    }
}

/// `frames --preset lecture:N --json`: the step as the app shows it, its first image no
/// later than its full frame; the flags of one form are refused with the other.
#[test]
fn frames_times_a_lecture_step_as_the_app_shows_it() {
    let out = bvhlab(&[
        "frames",
        "--preset",
        "lecture:2",
        "--width",
        "320",
        "--height",
        "240",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let steps = json["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 1);
    let step = &steps[0];
    assert_eq!(step["step"], 2);
    assert_eq!(step["title"], "Early out");
    let (first, full) = (
        step["first_image_ms"].as_f64().unwrap(),
        step["full_frame_ms"].as_f64().unwrap(),
    );
    assert!(first > 0.0 && first <= full, "{first} {full}");
    let both = bvhlab(&["frames", "--preset", "lecture", "--scene", "cornell"]);
    assert!(!both.status.success());
    let json_alone = bvhlab(&["frames", "--scene", "cornell", "--json"]);
    assert!(!json_alone.status.success(), "--json is for --preset");
}

#[test]
fn stats_json_gives_the_sah_cost_and_epo_of_trees_and_null_for_the_others() {
    for kind in AccelKind::ALL {
        let out = bvhlab(&[
            "stats",
            "--scene",
            "soup:300",
            "--accel",
            kind.label(),
            "--json",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["accel"], kind.label());
        assert_eq!(json["triangles"], 300);
        let tree = matches!(
            kind,
            AccelKind::Bvh
                | AccelKind::Bvh4
                | AccelKind::Bvh8
                | AccelKind::KdTree
                | AccelKind::Octree
        );
        // The two levels have an SAH cost and an EPO over both levels placed.
        let two_level = kind == AccelKind::TwoLevel;
        for key in ["sah_cost", "c_trav", "c_isect"] {
            let has = json[key].is_number();
            assert_eq!(has, tree || two_level, "{} {key}: {json}", kind.label());
        }
        for key in ["epo", "epo_ms"] {
            assert_eq!(
                json[key].is_number(),
                tree || two_level,
                "{} {key}: {json}",
                kind.label()
            );
        }
        // Clipped exactly: no standard error.
        for key in ["epo_std_error", "epo_end_points"] {
            assert!(json[key].is_null(), "{} {key}: {json}", kind.label());
        }
        // A BVH over a soup overlaps itself; the k-d tree's and octree's cells do not.
        if tree {
            let epo = json["epo"].as_f64().unwrap();
            assert_eq!(
                epo > 1e-6,
                !matches!(kind, AccelKind::KdTree | AccelKind::Octree),
                "{}: {epo}",
                kind.label()
            );
        }
    }
    let out = bvhlab(&["stats", "--scene", "soup:300"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let sah = text.lines().position(|l| l.contains("SAH cost")).unwrap();
    assert!(
        text.lines()
            .nth(sah + 1)
            .unwrap()
            .contains("EPO (end-point overlap)"),
        "{text}"
    );
    // Two levels placing more triangles than are clipped one by one: an estimate, with its
    // standard error and end points, in the table and the JSON.
    let out = bvhlab(&["stats", "--scene", "island:2000", "--accel", "two-level"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let sah = text.lines().position(|l| l.contains("SAH cost")).unwrap();
    let row = text.lines().nth(sah + 1).unwrap();
    assert!(row.contains("EPO, both levels (estimated)"), "{text}");
    assert!(
        row.contains(" ± ") && row.contains("1048576 end points"),
        "{row}"
    );
    let out = bvhlab(&[
        "stats",
        "--scene",
        "island:2000",
        "--accel",
        "two-level",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (epo, se) = (
        json["epo"].as_f64().unwrap(),
        json["epo_std_error"].as_f64().unwrap(),
    );
    assert!(se > 0.0 && se < 0.05 * epo, "{json}");
    assert_eq!(json["epo_end_points"], 1 << 20);
    // A flat tree's EPO estimated from end points: within 4.5 standard errors of the
    // clipped one; nonsense asked for is refused.
    let stats = |extra: &[&str]| {
        let mut args = vec!["stats", "--scene", "teapot-in-stadium", "--json"];
        args.extend_from_slice(extra);
        let out = bvhlab(&args);
        assert!(out.status.success(), "{extra:?}");
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let exact = stats(&[])["epo"].as_f64().unwrap();
    let est = stats(&["--epo", "estimate"]);
    let (value, se) = (
        est["epo"].as_f64().unwrap(),
        est["epo_std_error"].as_f64().unwrap(),
    );
    assert!(
        (value - exact).abs() <= 4.5 * se && se < 0.02 * exact,
        "{est}"
    );
    assert_eq!(est["epo_end_points"], 1 << 14);
    let fewer = stats(&["--epo", "estimate", "--end-points", "500"]);
    assert_eq!(fewer["epo_end_points"], 500);
    for (bad, says) in [
        (
            &["--epo", "guess"][..],
            "invalid value 'guess' for '--epo <EPO>'",
        ),
        (
            &["--epo", "estimate", "--end-points", "1"][..],
            "1 is not in 2..=",
        ),
        (&["--end-points", "many"][..], "invalid value 'many'"),
    ] {
        let mut args = vec!["stats", "--scene", "cornell"];
        args.extend_from_slice(bad);
        let out = bvhlab(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says),
            "{bad:?}: {err}"
        );
    }
}
