//! `render`'s views of a tree: its hierarchy, cracks, and triangles coloured by cost and
//! tests.

use super::*;

#[test]
fn render_tree_draws_the_hierarchy_of_every_tree_and_refuses_the_rest() {
    let dir = TempDir::new("tree");
    for accel in ["bvh", "bvh8", "kdtree", "octree", "two-level"] {
        let png = dir.join(format!("{accel}.png"));
        let out = bvhlab(&[
            "render",
            "--scene",
            "soup:500",
            "--accel",
            accel,
            "--tree",
            "--tree-width",
            "sah",
            "--tree-color",
            "area",
            "--width",
            "400",
            "--height",
            "300",
            "--out",
            png.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{accel}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(text.contains("nodes drawn"), "{text}");
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), (400, 300));
        assert!(png.with_extension("svg").exists());
    }
    assert_refused(
        dir.path(),
        &[
            (&["--accel", "grid", "--tree"][..], "has no hierarchy"),
            (&["--tree-width", "sah"][..], "--tree"),
            (&["--tree", "--mode", "nodes"][..], "cannot be used with"),
        ],
    );
}

#[test]
fn render_cracks_marks_the_leaks_and_refuses_bad_offsets_and_other_views() {
    let dir = TempDir::new("cracks");
    let png = dir.join("cracks.png");
    let out = bvhlab(&[
        "render",
        "--scene",
        "sphere:2000",
        "--cracks",
        "--offset",
        "1e3",
        "--intersector",
        "moller-trumbore",
        "--held",
        "--width",
        "320",
        "--height",
        "240",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 4, "{text}");
    // The chosen intersector first, then the other two on the same rays.
    assert!(
        lines[1].starts_with("moller-trumbore at offset 1e3: ")
            && lines[1].contains("edge and vertex rays slip through"),
        "{text}"
    );
    let rays = lines[1]
        .split(" of ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap();
    for (line, kind) in [(lines[2], "watertight"), (lines[3], "f64")] {
        assert!(
            line.contains(&format!(
                "{kind} at offset 1e3: 0 of {rays} edge and vertex rays"
            )) && line.ends_with("any hit missed 0"),
            "{text}"
        );
    }
    let image = image::open(&png).unwrap();
    assert_eq!((image.width(), image.height()), (320, 240));
    assert_refused(
        dir.path(),
        &[
            (&["--cracks", "--offset", "nan"][..], "not a finite number"),
            (&["--cracks", "--offset", "inf"][..], "not a finite number"),
            (&["--cracks", "--offset", "1e30"][..], "too coarse"),
            (&["--cracks", "--offset", "-1e7"][..], "too coarse"),
            (&["--offset", "1e3"][..], "--cracks"),
            (&["--held"][..], "--cracks"),
            (&["--cracks", "--mode", "nodes"][..], "cannot be used with"),
            (&["--cracks", "--tree"][..], "cannot be used with"),
            (&["--cracks", "--shadow"][..], "cannot be used with"),
            (
                &["--cracks", "--compare", "--builder sbvh"][..],
                "cannot be used with",
            ),
        ],
    );
}

/// The views that colour each triangle: the SAH cost per triangle on every tree (summing
/// to the tree's cost, as `stats` prints it) and the tests per triangle on every structure
/// (summing to the frame's triangle tests); the cost refused where there is no SAH cost.
#[test]
fn render_colours_triangles_by_their_cost_and_their_tests() {
    let dir = TempDir::new("tricost");
    let render = |accel: &str, mode: &str, extra: &[&str]| {
        let png = dir.join(format!("{accel}-{mode}.png"));
        let mut args = vec![
            "render", "--scene", "soup:500", "--accel", accel, "--mode", mode, "--width", "64",
            "--height", "48", "--out",
        ];
        args.push(png.to_str().unwrap());
        args.extend_from_slice(extra);
        let out = bvhlab(&args);
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{accel} {mode}: {err}");
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), (64, 48));
        text
    };
    // The number after `before` in `text`, up to `after`.
    let number = |text: &str, before: &str, after: &str| -> f64 {
        let rest = &text[text.find(before).unwrap_or_else(|| panic!("{text}")) + before.len()..];
        rest[..rest.find(after).unwrap()].trim().parse().unwrap()
    };
    for accel in ["bvh", "bvh4", "kdtree", "octree", "two-level"] {
        let text = render(accel, "triangle-cost", &[]);
        let cost = number(&text, "SAH cost per triangle: the tree's ", " over");
        let stats = bvhlab(&["stats", "--scene", "soup:500", "--accel", accel, "--json"]);
        let stats: serde_json::Value = serde_json::from_slice(&stats.stdout).unwrap();
        let expected = stats["sah_cost"].as_f64().unwrap();
        assert!(
            (cost - expected).abs() <= 1e-3 * expected,
            "{accel}: {text}"
        );
        assert!(text.contains("colour scale (log)"), "{text}");
    }
    for accel in ["bvh8", "grid", "brute-force", "two-level"] {
        let text = render(accel, "tests-received", &[]);
        let tests = number(&text, "tests per triangle: ", " tests by");
        let rays = number(&text, " tests by ", " rays");
        assert_eq!(rays, 64.0 * 48.0, "{text}");
        // The frame's mean triangle tests of a primary ray, printed to one decimal: the tests
        // summed over the triangles are the frame's triangle tests.
        let primary = text
            .lines()
            .find(|l| l.trim_start().starts_with("primary rays"))
            .unwrap();
        let frame_mean = number(primary, "box tests, ", " (");
        assert!(
            (tests / rays - frame_mean).abs() <= 0.051,
            "{accel}: {tests} tests: {text}"
        );
        assert!(text.contains("colour scale: 0 (dark purple) to"), "{text}");
    }
    render("bvh", "tests-received", &["--shadow", "--heat-max", "5"]);
    assert_refused(
        dir.path(),
        &[
            (
                &["--mode", "triangle-cost", "--accel", "grid"][..],
                "use --accel bvh, bvh4, bvh8, kdtree, octree or two-level",
            ),
            (
                &["--mode", "triangle-cost", "--heat-max", "4"][..],
                "is for heatmaps",
            ),
            (
                &["--mode", "tests-received", "--compare", "--builder sbvh"][..],
                "--compare does not compare --mode tests-received",
            ),
            (&["--mode", "triangle-costs"][..], "invalid value"),
        ],
    );
}
