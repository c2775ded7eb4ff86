//! Bad input through the binary, as a user would give it: every case ends with a non-zero
//! exit and one clear message naming the problem, no panic, and no file left behind; the
//! cases beside them that must work, work.

use bvhlab::accel::rayfile;
use bvhlab::geometry::Ray;
use bvhlab_testkit::TempDir;
use glam::Vec3;
use std::path::Path;
use std::process::{Command, Output};

fn bvhlab(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("the binary runs")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

const SMALL: [&str; 4] = ["--width", "16", "--height", "12"];

#[test]
fn bad_parameters_and_outputs_fail_first_with_one_clear_message_and_no_file() {
    let dir = TempDir::new("bad-table");
    // A ray file whose second ray starts its interval below zero.
    let rays = [
        Ray::new(Vec3::new(0.0, 1.0, 3.0), -Vec3::Z),
        Ray::segment(Vec3::new(0.0, 1.0, 3.0), -Vec3::Z, -1.0, 10.0),
    ];
    std::fs::write(dir.join("rays.bin"), rayfile::encode_rays(&rays)).unwrap();
    // Geometry where ray arithmetic overflows f32, and beyond f32 itself.
    std::fs::write(
        dir.join("far.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1e20 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("huge.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(dir.join("noise.glb"), [7u8, 1, 2, 3, 250, 0, 9]).unwrap();
    std::fs::write(
        dir.join("far.toml"),
        "title = \"t\"\nscene = \"cornell\"\ncamera = { eye = [1e30, 0, 0], look = [0, 0, 0] }\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("tiny.bin"),
        rayfile::encode_rays(&[Ray::new(Vec3::ZERO, Vec3::new(1e-42, 2e-42, -1e-40))]),
    )
    .unwrap();
    std::fs::write(dir.join("escape.obj"), "v \x1b[31mRED 0 0\n").unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.obj")).unwrap();
    std::fs::write(
        dir.join("notes.txt"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("two_level_mode.toml"),
        "title = \"T\"\nscene = \"cornell\"\n[settings]\naccel = \"Grid\"\nmode = \"TopNodes\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("line.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("island.toml"),
        "title = \"t\"\nscene = \"island:99999999\"\n",
    )
    .unwrap();
    let before = files_in(dir.path());
    let cases: &[(&[&str], &str)] = &[
        (
            &["bench", "--scene", "cornell", "--threads", "0"],
            "at least 1 thread",
        ),
        (
            &["bench", "--scene", "cornell", "--threads", "100000"],
            "per core",
        ),
        (
            &["bench", "--scene", "cornell", "--builds", "0"],
            "at least 1",
        ),
        (
            &["bench", "--scene", "cornell", "--runs", "0"],
            "at least 1",
        ),
        (
            &["bench", "--scene", "cornell", "--embree-quality", "low"],
            "does nothing without --embree",
        ),
        (
            &["bench", "--scene", "cornell", "--embree-quality", "lowest"],
            "invalid value 'lowest'",
        ),
        (
            &["frames", "--scene", "cornell", "--runs", "0"],
            "at least 1",
        ),
        (&["stress", "--quick", "--leak-rays", "0"], "at least 1"),
        (&["stress", "--quick", "--scene-rays", "0"], "at least 1"),
        (
            &["render", "--scene", "cornell", "-o", "x.jpg"],
            ".jpg files are not written",
        ),
        (
            &["render", "--scene", "cornell", "-o", "nodir/x.png"],
            "does not exist",
        ),
        (
            &["render", "--scene", "cornell", "-o", "."],
            "it is a folder",
        ),
        (
            &[
                "render",
                "--scene",
                "cornell",
                "--compare",
                "--buckets 1",
                "-o",
                "c.png",
            ],
            "--buckets <BUCKETS>': 1 is not in 2..=256",
        ),
        (
            &["screenshot", "--scene", "cornell", "--out", "shot.jpg"],
            ".jpg files are not written",
        ),
        (
            &[
                "bench",
                "scaling",
                "--scene",
                "soup",
                "--csv",
                "ok.csv",
                "--plot",
                "nodir/a.png",
            ],
            "does not exist",
        ),
        (
            &["bench", "accuracy", "--scene", "cornell", "--plot", "a.svg"],
            "use .png",
        ),
        (
            &[
                "trace",
                "--scene",
                "cornell",
                "--rays",
                "rays.bin",
                "--out",
                "nodir/h.bin",
            ],
            "does not exist",
        ),
        (
            &[
                "trace", "--scene", "cornell", "--rays", "rays.bin", "--out", "h.bin",
            ],
            "tmin is negative",
        ),
        (
            &["bench", "builders", "--scene", "cornell", "--accel", "grid"],
            "bench builders",
        ),
        // Sized before they are made: past the memory budget, one line and no allocation.
        (
            &[
                "render", "--scene", "cornell", "--width", "16384", "--height", "16384",
            ],
            "memory limit",
        ),
        (
            &[
                "bench", "--scene", "cornell", "--width", "16384", "--height", "16384",
            ],
            "memory limit",
        ),
        (
            &[
                "bench",
                "accuracy",
                "--scene",
                "cornell",
                "--random-rays",
                "10000000000",
            ],
            "--random-rays 10000000000 would need about",
        ),
        (
            &["stress", "--quick", "--scene-rays", "10000000000"],
            "memory limit",
        ),
        (
            &["stress", "--quick", "--leak-rays", "10000000000"],
            "memory limit",
        ),
        (
            &[
                "stats",
                "--scene",
                "island:50",
                "--accel",
                "bvh",
                "--memory-limit",
                "64M",
            ],
            "placed triangles would need about",
        ),
        // The structure must fit beside the scene, not alone (74 MiB of BVH2 and 12 MiB of
        // triangles against 80 MiB).
        (
            &[
                "stats",
                "--scene",
                "soup:300000",
                "--accel",
                "bvh",
                "--memory-limit",
                "80M",
            ],
            "with what is loaded already",
        ),
        (
            &["stats", "--scene", "soup:1000000", "--memory-limit", "16M"],
            "soup:1000000 (1000000 triangles) would need",
        ),
        (
            &["stats", "--scene", "cornell", "--memory-limit", "12Q"],
            "unit",
        ),
        // What a screenshot is told to show exists.
        (
            &[
                "screenshot",
                "--scene",
                "cornell",
                "--out",
                "s.png",
                "--replay",
                "0.5,0.5",
                "--replay-visit",
                "0",
            ],
            "at least 1",
        ),
        (
            &[
                "screenshot",
                "--scene",
                "island:3",
                "--accel",
                "two-level",
                "--instance",
                "99999",
                "--out",
                "s.png",
            ],
            "there is no instance 99999",
        ),
        // A preset's scene is checked when the file is read, and the file is named.
        (
            &["frames", "--preset", "island.toml"],
            "island.toml: preset 1",
        ),
        (&["frames", "--preset", "far.toml"], "within ±1e18"),
        // An output that is an input, or another output of the same run.
        (
            &[
                "trace", "--scene", "cornell", "--rays", "rays.bin", "--out", "rays.bin",
            ],
            "it is also the ray file read",
        ),
        (
            &[
                "bench", "accuracy", "--scene", "cornell", "--csv", "x.png", "--plot", "x.png",
            ],
            "use .csv",
        ),
        // Values that cannot mean anything, said as such.
        (
            &[
                "render",
                "--scene",
                "cornell",
                "--mode",
                "nodes",
                "--heat-max",
                "0",
            ],
            "at least 1",
        ),
        (
            &["render", "--scene", "cornell", "--fov", "0"],
            "not an angle from 1 to 170",
        ),
        (
            &["bench", "--scene", "cornell", "--builds", "99999999999"],
            "too large",
        ),
        (&["frames", "--runs", "1"], "say what to time"),
        // A structure's parameter given for another structure, or a builder's for another
        // builder, is not ignored.
        (
            &["render", "--scene", "cornell", "--lambda", "1"],
            "--lambda is the grid's; the structure here is",
        ),
        (
            &[
                "stats",
                "--scene",
                "cornell",
                "--builder",
                "lbvh",
                "--buckets",
                "4",
            ],
            "--buckets is not used by the LBVH builder",
        ),
        (
            &[
                "stats", "--scene", "cornell", "--accel", "bvh", "--simd", "avx2",
            ],
            "--simd is BVH4's, BVH8's and the two levels'",
        ),
        (
            &[
                "stats",
                "--scene",
                "cornell",
                "--accel",
                "bvh",
                "--direct-wide",
                "true",
            ],
            "--direct-wide is BVH4's, BVH8's and the two levels'; the structure here is BVH2",
        ),
        (
            &[
                "stats",
                "--scene",
                "cornell",
                "--accel",
                "bvh8",
                "--builder",
                "sah-sweep",
                "--direct-wide",
                "true",
            ],
            "--direct-wide is not used by the full-sweep SAH builder",
        ),
        (
            &[
                "stats",
                "--scene",
                "cornell",
                "--accel",
                "bvh8",
                "--builder",
                "lbvh",
                "--direct-wide",
                "true",
                "--presplit",
                "0.5",
            ],
            "the pre-split budget (--presplit) must be 0 for wide nodes built straight from the splits (--direct-wide)",
        ),
        (
            &[
                "stats",
                "--scene",
                "cornell",
                "--accel",
                "two-level",
                "--builder",
                "lbvh",
                "--direct-wide",
                "true",
                "--presplit",
                "0.5",
            ],
            "the pre-split budget (--presplit) must be 0 for wide nodes built straight from the splits (--direct-wide)",
        ),
        (
            &["stats", "--scene", "cornell", "--direct-wide", "yes"],
            "invalid value 'yes'",
        ),
        (
            &["frames", "--scene", "cornell", "--width", "16"],
            "are for --preset",
        ),
        (
            &["frames", "--preset", "lecture:1", "--accel", "grid"],
            "sets its own scene, camera and structure",
        ),
        (
            &[
                "stress",
                "--scene",
                "cornell",
                "--scenes-dir",
                "/nonexistent",
            ],
            "cannot be used with",
        ),
        (
            &[
                "trace", "--scene", "cornell", "--rays", "tiny.bin", "--out", "h.bin",
            ],
            "direction is too short",
        ),
        (&["stats", "--scene", "escape.obj"], "\\u{1b}[31m"),
        (
            &["bench", "scaling", "--scene", "soup", "--sizes", "100,100"],
            "given twice",
        ),
        (
            &[
                "--memory-limit",
                "1G",
                "stats",
                "--scene",
                "cornell",
                "--memory-limit",
                "2G",
            ],
            "cannot be used multiple times",
        ),
        (&["render", "--shadow", "--out", "a.png"], "is for heatmaps"),
        (
            &["render", "--heat-max", "3", "--mode", "depth"],
            "is for heatmaps",
        ),
        (
            &["render", "--mode", "repeated"],
            "shows nothing under BVH8",
        ),
        (
            &[
                "render",
                "--accel",
                "two-level",
                "--mode",
                "top-nodes",
                "--compare",
                "--accel bvh",
            ],
            "--mode top-nodes shows nothing under B (BVH2)",
        ),
        (
            &["render", "--width", "-5"],
            "invalid value '-5' for '--width",
        ),
        (
            &["frames", "--preset", "lecture:abc"],
            "'abc' is not a preset number",
        ),
        (&["stats", "--scene", "zero.obj"], "not a regular file"),
        (
            &[
                "trace",
                "--scene",
                "cornell",
                "--rays",
                "/dev/zero",
                "--out",
                "h.bin",
            ],
            "not a regular file",
        ),
        (
            &["stats", "--scene", "notes.txt"],
            "unknown scene 'notes.txt'",
        ),
        (
            &["bench", "--runs", "4294967295"],
            "at most 1000 repetitions",
        ),
        (&["render", "--compare", ""], "needs B's build flags"),
        (
            &["stress", "--quick", "--seed", "abc"],
            "'abc' is not a whole number",
        ),
        (
            &["bench", "scaling", "--scene", "soup", "--sizes", "1e3,2e3"],
            "'1e3' is not a whole number",
        ),
        (
            &["bench", "scaling", "--scene", "sphere", "--sizes", "1,2"],
            "both make 6 triangles",
        ),
        (
            &["render", "--max-leaf", "0"],
            "'--max-leaf <MAX_LEAF>': 0 is not in 1..=4096",
        ),
        (
            &["render", "--accel", "kdtree", "--kd-max-depth", "999"],
            "'--kd-max-depth <KD_MAX_DEPTH>': 999 is not in 0..=64",
        ),
        (&["render", "--scene", "walls@30"], "as walls-rotated@30"),
        (
            &["stress", "--quick", "--scenes-dir", "/nonexistent"],
            "has no sponza.obj",
        ),
        (&["frames", "--preset", ""], "no preset named"),
        (
            &[
                "--memory-limit",
                "125M",
                "render",
                "--scene",
                "soup:300000",
                "--width",
                "1000",
                "--height",
                "1000",
            ],
            "with what is loaded already",
        ),
        (
            &["render", "--accel", "bvh8", "--compare", "--accel bvh8"],
            "changes nothing",
        ),
        (
            &["bench", "tradeoff", "--scene", "cornell", "--csv", "x.png"],
            "use .csv",
        ),
        (
            &["frames", "--preset", "two_level_mode.toml"],
            "shows nothing here",
        ),
        (
            &[
                "trace", "--scene", "cornell", "--rays", "tiny.bin", "--out", "hits.png",
            ],
            "binary hits",
        ),
    ];
    for (args, expected) in cases {
        let mut all: Vec<&str> = args.to_vec();
        if matches!(args[0], "render" | "bench") && !args.contains(&"--width") {
            all.extend(SMALL);
        }
        let out = bvhlab(dir.path(), &all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(expected),
            "{args:?}: expected '{expected}' in:\n{err}"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked:\n{err}");
        // One cause, said once.
        let first = err.lines().next().unwrap_or_default();
        assert_eq!(
            err.matches(first).count(),
            1,
            "{args:?} repeats itself:\n{err}"
        );
        assert_eq!(files_in(dir.path()), before, "{args:?} left a file behind");
    }
    // The same commands with their outputs fixed write whole files.
    let out = bvhlab(
        dir.path(),
        &[
            "render", "--scene", "cornell", "-o", "ok.png", "--width", "16", "--height", "12",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(image::open(dir.join("ok.png")).is_ok());
    // A negative coordinate is a value, and a sphere rounded up says so.
    let out = bvhlab(
        dir.path(),
        &[
            "render", "--scene", "sphere:1", "--eye", "-1,0.5,3", "-o", "ok2.png", "--width", "16",
            "--height", "12",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("sphere:1 has 6 triangles"), "{err}");
    // A face of two corners is skipped with a word.
    std::fs::write(
        dir.join("line.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n",
    )
    .unwrap();
    let out = bvhlab(dir.path(), &["stats", "--scene", "line.obj"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("1 face of fewer than three vertices skipped") && err.contains("line 5"),
        "{err}"
    );
    // A scene of zero-area triangles loads, and says nothing can hit it.
    std::fs::write(dir.join("flat.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    let out = bvhlab(dir.path(), &["stats", "--scene", "flat.obj"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("all 1 triangles have zero area"), "{err}");
    std::fs::write(dir.join("good.bin"), rayfile::encode_rays(&rays[..1])).unwrap();
    let out = bvhlab(
        dir.path(),
        &[
            "trace", "--scene", "cornell", "--rays", "good.bin", "--out", "h.bin",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(dir.join("h.bin")).unwrap().len(), 8);
    // A study may follow bench's options.
    let out = bvhlab(
        dir.path(),
        &[
            "bench", "--scene", "cornell", "--builds", "1", "--runs", "1", "builders", "--width",
            "8", "--height", "6", "--json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["scene"], "cornell");
}
