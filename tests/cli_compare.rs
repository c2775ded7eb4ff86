//! `bvhlab render --compare`: the command's own build flags are A, the quoted flags over
//! them B; one PNG (A | B or B − A) and a summary, and clear errors for what cannot be
//! compared.

use bvhlab_testkit::TempDir;
use std::process::Command;

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("bvhlab runs")
}

/// A directory of its own for each test, removed when it ends.
fn scratch(name: &str) -> TempDir {
    TempDir::new(&format!("compare-{name}"))
}

fn render_compare(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "render",
        "--scene",
        "soup:2000",
        "--mode",
        "nodes",
        "--width",
        "64",
        "--height",
        "48",
        "--out",
        out.to_str().unwrap(),
    ];
    if !extra.contains(&"--accel") {
        args.extend(["--accel", "bvh"]);
    }
    args.extend(extra);
    bvhlab(&args)
}

/// The number after `key` in the summary line that starts with `line`.
fn number_after(stdout: &str, line: &str, key: &str) -> f64 {
    let l = stdout
        .lines()
        .find(|l| l.trim_start().starts_with(line))
        .unwrap_or_else(|| panic!("no line {line} in\n{stdout}"));
    let rest = &l[l.find(key).unwrap() + key.len()..];
    let n: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '-' || *c == '+' || *c == '.')
        .collect();
    n.parse().unwrap()
}

#[test]
fn identical_configurations_differ_nowhere_and_a_minus_b_is_minus_b_minus_a() {
    let dir = scratch("same");
    let same = dir.join("same.png");
    // No flags compare nothing: an error, not a picture of A against itself.
    let out = render_compare(&same, &["--compare", "", "--compare-view", "difference"]);
    assert!(!out.status.success());
    // The same tree traced by another SIMD kernel: the same counts everywhere.
    let out = render_compare(
        &same,
        &[
            "--accel",
            "bvh8",
            "--compare",
            "--simd portable",
            "--compare-view",
            "difference",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("B − A: total +0"), "{stdout}");
    assert!(stdout.contains("equal 100.0 %"), "{stdout}");
    let img = image::open(&same).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (64, 48));
    let grey = img.get_pixel(0, 0);
    assert!(img.pixels().all(|p| p == grey));

    // SBVH against object median, both ways round.
    let ab = dir.join("ab.png");
    let out = render_compare(
        &ab,
        &["--builder", "object-median", "--compare", "--builder sbvh"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let forward = String::from_utf8_lossy(&out.stdout).to_string();
    let ba = dir.join("ba.png");
    let out = render_compare(
        &ba,
        &["--builder", "sbvh", "--compare", "--builder object-median"],
    );
    let backward = String::from_utf8_lossy(&out.stdout).to_string();
    let total = |s: &str| number_after(s, "B − A", "total");
    assert_ne!(total(&forward), 0.0);
    assert_eq!(total(&forward), -total(&backward));
    let cheaper = |s: &str| number_after(s, "pixels cheaper", "under B");
    let dearer = |s: &str| number_after(s, "pixels cheaper", "dearer");
    assert_eq!(cheaper(&forward), dearer(&backward));
    // The split is one PNG of the same size, with the divider down the middle.
    let img = image::open(&ab).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (64, 48));
    assert!((0..48).all(|y| img.get_pixel(32, y).0 == [255, 255, 255, 255]));
    assert!(forward.contains("A | B"));
}

#[test]
fn b_keeps_every_flag_of_a_it_does_not_name() {
    let dir = scratch("flags");
    let out = render_compare(
        &dir.join("leaf.png"),
        &["--max-leaf", "1", "--compare", "--builder sah-sweep"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("A: built bvh"), "{stderr}");
    assert!(stderr.contains("B: built bvh"), "{stderr}");
}

#[test]
fn bad_comparisons_are_clear_errors() {
    let dir = scratch("errors");
    let png = dir.join("x.png");
    let err = |extra: &[&str]| {
        let out = render_compare(&png, extra);
        assert!(!out.status.success(), "{extra:?} should fail");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = err(&["--compare", "--builder fastest"]);
    assert!(e.contains("bad --compare flags '--builder fastest'"), "{e}");
    let e = err(&["--compare", "--max-leaf 0"]);
    assert!(e.contains("leaf"), "{e}");
    let e = err(&["--compare-view", "difference"]);
    assert!(e.contains("--compare"), "{e}");
    let out = bvhlab(&[
        "render",
        "--scene",
        "soup:200",
        "--width",
        "16",
        "--height",
        "16",
        "--out",
        png.to_str().unwrap(),
        "--compare",
        "--accel grid",
        "--compare-view",
        "difference",
    ]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("needs a heatmap --mode"), "{e}");
    assert!(!png.exists(), "nothing written");
}

#[test]
fn screenshot_compare_errors_come_before_the_window_opens() {
    let dir = scratch("shot");
    let png = dir.join("shot.png");
    let shot = |extra: &[&str]| {
        let mut args = vec!["screenshot", "--out", png.to_str().unwrap()];
        args.extend(extra);
        let out = bvhlab(&args);
        assert!(!out.status.success(), "{extra:?} should fail");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let e = shot(&["--compare", "--builder fastest"]);
    assert!(e.contains("bad --compare flags '--builder fastest'"), "{e}");
    let e = shot(&["--compare", "--max-leaf 0"]);
    assert!(e.contains("bad --compare flags '--max-leaf 0'"), "{e}");
    let e = shot(&[
        "--compare",
        "--builder sbvh",
        "--compare-view",
        "difference",
    ]);
    assert!(e.contains("needs a heatmap --mode"), "{e}");
    assert!(!png.exists());
}
