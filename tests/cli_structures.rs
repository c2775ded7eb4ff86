//! The structure selector on the command line: `--accel` on every subcommand that builds,
//! `bench --accel all` as one table or one JSON object over every structure, and clear
//! errors for what a subcommand cannot do.

use bvhlab::accel::AccelKind;
use std::process::Command;

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("bvhlab runs")
}

const SMALL_BENCH: [&str; 10] = [
    "--width",
    "32",
    "--height",
    "24",
    "--builds",
    "1",
    "--runs",
    "1",
    "--threads",
    "2",
];

#[test]
fn bench_accel_all_reports_every_structure_on_the_same_rays() {
    let mut args = vec!["bench", "--scene", "soup:400", "--accel", "all", "--json"];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let structures = json["structures"].as_array().expect("a structures array");
    assert_eq!(structures.len(), AccelKind::ALL.len());
    let hits = |s: &serde_json::Value, set: &str, key: &str| s[set][key].as_u64().unwrap();
    for (s, kind) in structures.iter().zip(AccelKind::ALL) {
        assert_eq!(s["accel"], kind.label());
        for key in ["build_ms", "bytes", "nodes", "references_per_triangle"] {
            assert!(s[key].is_number(), "{}: {key}", kind.label());
        }
        for set in ["primary", "diffuse", "shadow"] {
            for key in ["mrays_per_s", "mean_nodes", "mean_triangle_tests"] {
                assert!(s[set][key].is_number(), "{} {set} {key}", kind.label());
            }
        }
        // Same rays, same closest-hit rule: the same hit counts everywhere.
        assert_eq!(
            hits(s, "primary", "hits"),
            hits(&structures[0], "primary", "hits")
        );
        assert_eq!(
            hits(s, "diffuse", "hits"),
            hits(&structures[0], "diffuse", "hits")
        );
        assert_eq!(
            hits(s, "shadow", "occluded"),
            hits(&structures[0], "shadow", "occluded")
        );
    }
    let brute = &structures[AccelKind::ALL
        .iter()
        .position(|k| *k == AccelKind::BruteForce)
        .unwrap()];
    assert_eq!(
        brute["primary"]["mean_triangle_tests"].as_f64(),
        Some(400.0)
    );

    let mut args = vec!["bench", "--scene", "soup:400", "--accel", "all"];
    args.extend(SMALL_BENCH);
    let table = String::from_utf8(bvhlab(&args).stdout).unwrap();
    for kind in AccelKind::ALL {
        assert!(
            table.contains(kind.label()),
            "the table names {}",
            kind.label()
        );
    }
}

#[test]
fn single_structure_bench_json_keeps_its_keys_and_adds_the_structure() {
    for kind in AccelKind::ALL {
        let mut args = vec![
            "bench",
            "--scene",
            "sphere:500",
            "--accel",
            kind.label(),
            "--json",
        ];
        args.extend(SMALL_BENCH);
        let out = bvhlab(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["accel"], kind.label());
        for key in [
            "scene",
            "triangles",
            "threads",
            "build_ms",
            "bytes",
            "primary",
            "primary_packets",
            "diffuse",
            "shadow",
        ] {
            assert!(!json[key].is_null(), "{}: {key}", kind.label());
        }
        // The SAH cost of every structure that has one, the same as its SAH check's.
        assert_eq!(json["sah_cost"].is_number(), !json["sah_check"].is_null());
        assert_eq!(
            json["sah_cost"].is_number(),
            matches!(
                kind,
                AccelKind::Bvh
                    | AccelKind::Bvh4
                    | AccelKind::Bvh8
                    | AccelKind::KdTree
                    | AccelKind::Octree
                    | AccelKind::TwoLevel
            ),
            "{}",
            kind.label()
        );
    }
}

/// A wide tree built straight from the Morton order is also rebuilt into its own memory, as
/// every frame of a moving scene: `bench` prints that time and `--json` gives it as
/// `rebuild_ms`; a tree built otherwise has neither.
#[test]
fn bench_times_the_direct_wide_rebuild_per_frame() {
    for (accel, direct) in [("bvh8", true), ("bvh4", true), ("bvh8", false)] {
        let mut args = vec![
            "bench",
            "--scene",
            "sphere:2000",
            "--accel",
            accel,
            "--builder",
            "lbvh",
        ];
        if direct {
            args.extend(["--direct-wide", "true"]);
        }
        args.extend(SMALL_BENCH);
        let text = bvhlab(&args);
        assert!(
            text.status.success(),
            "{}",
            String::from_utf8_lossy(&text.stderr)
        );
        let text = String::from_utf8_lossy(&text.stdout).to_string();
        assert_eq!(
            text.contains("rebuilt into its own memory, as every frame of a moving scene"),
            direct,
            "{accel}, direct {direct}: {text}"
        );
        args.push("--json");
        let out = bvhlab(&args);
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["rebuild_ms"].is_number(), direct, "{accel}: {json}");
        if direct {
            assert!(json["rebuild_ms"].as_f64().unwrap() > 0.0);
        }
    }
}

/// `--rebraid f` reaches the two levels' build: `bench --json` reports the budget and the
/// top level's references (one per object with 0), `stats` the opened instances, and a
/// budget out of range is an error naming it.
#[test]
fn rebraid_sets_the_two_levels_references_and_bad_budgets_are_errors() {
    let references = |rebraid: &str| {
        let mut args = vec![
            "bench",
            "--scene",
            "cornell",
            "--accel",
            "two-level",
            "--rebraid",
            rebraid,
            "--json",
        ];
        args.extend(SMALL_BENCH);
        let out = bvhlab(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["rebraid"].as_f64(), rebraid.parse().ok());
        json["references"].as_u64().expect("references")
    };
    // The Cornell box's objects, each one instance of its own mesh.
    let objects = bvhlab::scene::Scene::load("cornell").unwrap().objects.len() as u64;
    assert_eq!(references("0"), objects);
    let opened = references("0.1");
    assert!(opened > objects, "{opened} references");
    let out = bvhlab(&["stats", "--scene", "cornell", "--accel", "two-level"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains(&format!("TLAS references          {opened}")),
        "{text}"
    );
    assert!(
        text.contains("instances opened, extra references ≤ 0.1 × max("),
        "{text}"
    );
    let out = bvhlab(&[
        "stats",
        "--scene",
        "cornell",
        "--accel",
        "two-level",
        "--rebraid",
        "0",
    ]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("off (one reference per instance)"), "{text}");
    for bad in ["17", "-1", "NaN"] {
        let flag = format!("--rebraid={bad}");
        let out = bvhlab(&["stats", "--scene", "cornell", "--accel", "two-level", &flag]);
        assert!(!out.status.success(), "{flag}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("re-braiding budget {bad} is outside 0..=16")),
            "{err}"
        );
    }
}

#[test]
fn every_building_subcommand_takes_accel_and_all_is_for_bench_only() {
    let dir = std::env::temp_dir().join(format!("bvhlab-cli-structures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for kind in AccelKind::ALL {
        let out = bvhlab(&["stats", "--scene", "soup:300", "--accel", kind.label()]);
        assert!(out.status.success());
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(text.contains("references per triangle"), "{text}");
        let png = dir.join(format!("{}.png", kind.label()));
        let out = bvhlab(&[
            "render",
            "--scene",
            "soup:300",
            "--accel",
            kind.label(),
            "--mode",
            "triangles",
            "--width",
            "40",
            "--height",
            "30",
            "--out",
            png.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(png.exists());
    }
    for cmd in ["render", "stats", "trace", "frames"] {
        let mut args = vec![cmd, "--scene", "soup:300", "--accel", "all"];
        if cmd == "trace" {
            args.extend(["--rays", "none.bin", "--out", "none.out"]);
        }
        let out = bvhlab(&args);
        assert!(!out.status.success(), "{cmd} --accel all must fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--accel all is only for `bvhlab bench`") || cmd == "trace",
            "{cmd}: {err}"
        );
    }
}

#[test]
fn wide_bvhs_name_their_simd_kernel_and_trace_the_bvh2_hits_with_each() {
    let json = |accel: &str, simd: Option<&str>| {
        let mut args = vec![
            "bench",
            "--scene",
            "sphere:2000",
            "--accel",
            accel,
            "--json",
        ];
        if let Some(s) = simd {
            args.extend(["--simd", s]);
        }
        args.extend(SMALL_BENCH);
        let out = bvhlab(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).expect("one JSON object")
    };
    let bvh2 = json("bvh", None);
    assert!(bvh2["simd"].is_null());
    let mut levels = vec!["portable"];
    levels.extend(
        bvhlab::geometry::simd::SimdLevel::available()
            .iter()
            .map(|l| l.label()),
    );
    for accel in ["bvh4", "bvh8"] {
        for simd in &levels {
            let wide = json(accel, Some(simd));
            assert_eq!(wide["accel"], accel);
            assert_eq!(wide["simd"], *simd);
            for (set, key) in [
                ("primary", "hits"),
                ("diffuse", "hits"),
                ("shadow", "occluded"),
            ] {
                assert_eq!(wide[set][key], bvh2[set][key], "{accel} {simd} {set}");
                assert!(wide[set]["ns_per_step"].is_number(), "{accel} {set}");
            }
            // Fewer, wider steps than the BVH2.
            assert!(
                wide["primary"]["mean_nodes"].as_f64() < bvh2["primary"]["mean_nodes"].as_f64(),
                "{accel}"
            );
        }
    }
    // Without --simd, the widest kernel the machine has.
    let best = bvhlab::geometry::simd::SimdLevel::detect().label();
    assert_eq!(json("bvh8", None)["simd"], best);
    let out = bvhlab(&[
        "render", "--scene", "cornell", "--accel", "bvh4", "--simd", "avx1024",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("avx512"));
}

#[test]
fn bench_builders_reports_every_builder_on_the_same_rays() {
    use bvhlab::accel::bvh::{BuildParams, Strategy};
    let mut args = vec!["bench", "builders", "--scene", "soup:600", "--json"];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let builders = json["builders"].as_array().expect("a builders array");
    let variants = bvhlab::bench::builder_variants(&BuildParams::default());
    assert_eq!(builders.len(), variants.len());
    assert_eq!(
        variants.len(),
        Strategy::ALL.len() + 3,
        "three take pre-splits"
    );
    for (b, p) in builders.iter().zip(&variants) {
        assert_eq!(b["builder"], bvhlab::bench::builder_label(p));
        assert!(b["sah_cost"].as_f64().is_some_and(|c| c >= 1.0));
        for set in ["primary", "diffuse"] {
            assert_eq!(b[set]["hits"], builders[0][set]["hits"], "{set}");
        }
        assert_eq!(b["shadow"]["occluded"], builders[0]["shadow"]["occluded"]);
    }

    let mut args = vec!["bench", "builders", "--scene", "soup:600"];
    args.extend(SMALL_BENCH);
    let table = String::from_utf8(bvhlab(&args).stdout).unwrap();
    for p in &variants {
        assert!(table.contains(&bvhlab::bench::builder_label(p)), "{p:?}");
    }
    assert!(table.contains("% of SBVH's"), "{table}");
    assert!(table.contains("the same for every builder"), "{table}");

    // The same builders collapsed to BVH8s: the same hits, every tree's SAH cost that of
    // the wide tree, and the spatial splits' duplicates counted in its leaves.
    let mut args = vec![
        "bench",
        "builders",
        "--scene",
        "walls-rotated",
        "--json",
        "--accel",
        "bvh8",
    ];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let wide: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let wide = wide["builders"].as_array().expect("a builders array");
    assert_eq!(wide.len(), variants.len());
    for (b, p) in wide.iter().zip(&variants) {
        assert_eq!(b["accel"], AccelKind::Bvh8.label());
        assert_eq!(b["primary"]["hits"], wide[0]["primary"]["hits"]);
        let (cost, predicted) = (b["sah_cost"].as_f64(), b["sah_check"]["predicted"].as_f64());
        assert!((cost.unwrap() - predicted.unwrap()).abs() < 1e-3, "{b}");
        let duplicated = b["duplicated_references"].as_u64().unwrap();
        if p.strategy == Strategy::Sbvh {
            assert!(duplicated > 1000, "{b}");
        }
        if p.presplit == 0.0 && p.strategy != Strategy::Sbvh {
            assert_eq!(duplicated, 0, "{b}");
        }
    }

    let err = bvhlab(&["bench", "builders", "--scene", "soup:10", "--accel", "grid"]);
    assert!(!err.status.success());
    assert!(String::from_utf8_lossy(&err.stderr).contains("bench builders"));
}

#[test]
fn treelet_flags_reach_the_build_and_bad_values_are_errors() {
    let out = bvhlab(&[
        "stats",
        "--scene",
        "soup:2000",
        "--builder",
        "lbvh-treelet",
        "--treelet-size",
        "5",
        "--rounds",
        "2",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for row in [
        "LBVH + treelets",
        "treelet size n",
        "time: Morton codes",
        "SAH cost after round 2",
    ] {
        assert!(text.contains(row), "{row} in {text}");
    }
    assert!(!text.contains("round 3"));
    for (flag, value, message) in [
        ("--treelet-size", "4", "treelet size 4 is outside 5..=9"),
        ("--rounds", "17", "17 treelet rounds is more than 16"),
    ] {
        let out = bvhlab(&[
            "stats",
            "--scene",
            "cornell",
            "--builder",
            "lbvh-treelet",
            flag,
            value,
        ]);
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(message), "{stderr}");
    }
}

/// `--overlap-penalty` reaches the SBVH: the report names κ, the JSON carries it, the
/// builder's label says it, and values outside 0..=16 are refused with the parameter's name.
#[test]
fn the_overlap_penalty_reaches_the_sbvh_and_bad_values_are_errors() {
    let out = bvhlab(&[
        "stats",
        "--scene",
        "walls-rotated",
        "--builder",
        "sbvh",
        "--overlap-penalty",
        "1",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.lines()
            .any(|l| l.contains("overlap penalty κ") && l.trim_end().ends_with(" 1")),
        "{text}"
    );
    let mut args = vec![
        "bench",
        "--scene",
        "walls-rotated:50",
        "--accel",
        "bvh",
        "--builder",
        "sbvh",
        "--overlap-penalty",
        "2",
        "--json",
    ];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["overlap_penalty"], 2.0);
    assert_eq!(json["builder"], "SBVH (κ = 2; budget 1 N)");
    for bad in ["-1", "17", "NaN"] {
        let flag = format!("--overlap-penalty={bad}");
        let out = bvhlab(&[
            "stats",
            "--scene",
            "walls-rotated",
            "--builder",
            "sbvh",
            &flag,
        ]);
        assert!(!out.status.success(), "{bad} accepted");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("overlap penalty κ"), "{bad}: {stderr}");
    }
}

#[test]
fn negative_budgets_name_their_flag_and_presplit_says_where_it_applies() {
    // `--flag -1`, as a user types it, reaches the parameter check (not "unexpected
    // argument '-1'").
    for (flag, name) in [
        ("--split-budget", "split budget"),
        ("--presplit", "presplit budget"),
        ("--split-alpha", "overlap threshold α"),
        ("--c-trav", "C_trav"),
    ] {
        let out = bvhlab(&[
            "stats",
            "--scene",
            "soup:50",
            "--builder",
            "sbvh",
            flag,
            "-1",
        ]);
        assert!(!out.status.success(), "{flag} -1 accepted");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(name), "{flag}: {stderr}");
    }
    // A pre-split budget for a builder that does not take one is an error naming it.
    let stats = |builder: &str| {
        bvhlab(&[
            "stats",
            "--scene",
            "soup:50",
            "--builder",
            builder,
            "--presplit",
            "0.3",
        ])
    };
    for (builder, label) in [("sbvh", "SBVH"), ("object-median", "object median")] {
        let out = stats(builder);
        assert!(!out.status.success(), "{builder}");
        let err = String::from_utf8_lossy(&out.stderr);
        let said = format!("--presplit is not used by the {label} builder");
        assert!(err.contains(&said), "{err}");
    }
    assert!(stats("lbvh").status.success());
}

#[test]
fn tradeoff_and_rotation_sweep_write_their_csv_and_plot() {
    let dir = std::env::temp_dir().join(format!("bvhlab-tradeoff-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
    std::fs::remove_dir_all(&dir).ok();
}

/// `screenshot --instance` names an instance of the two levels: under another structure it
/// is refused before a window opens, with the flag to use.
#[test]
fn screenshot_instance_needs_the_two_levels() {
    let never = std::env::temp_dir().join(format!("bvhlab-never-{}.png", std::process::id()));
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
    let dir = std::env::temp_dir().join(format!("bvhlab-sah-scatter-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
    std::fs::remove_dir_all(&dir).ok();
}

/// The two levels' heatmaps count the two levels' work: asked of a flat structure they are
/// an error, not a black image; with the two levels they are drawn.
#[test]
fn two_level_heatmaps_need_the_two_levels() {
    let dir = std::env::temp_dir().join(format!("bvhlab-heat-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
    std::fs::remove_dir_all(&dir).ok();
}

/// `bench` on the two levels prints each level's build time, as --json has them.
#[test]
fn bench_prints_the_blas_and_tlas_build_times() {
    let mut args = vec!["bench", "--scene", "cornell", "--accel", "two-level"];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = text
        .lines()
        .find(|l| l.contains("of which BLAS builds"))
        .unwrap_or_else(|| panic!("no BLAS/TLAS line: {text}"));
    assert!(
        line.contains("ms, TLAS build") && line.ends_with(" ms"),
        "{line}"
    );
    let mut args = vec!["bench", "--scene", "cornell", "--accel", "bvh"];
    args.extend(SMALL_BENCH);
    let text = String::from_utf8(bvhlab(&args).stdout).unwrap();
    assert!(
        !text.contains("BLAS"),
        "a flat structure has no levels: {text}"
    );
}

/// An island too large is refused for its instances, not for a triangle count it never
/// stores.
#[test]
fn island_size_is_bounded_by_its_instances() {
    let out = bvhlab(&["stats", "--scene", "island:100000000"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("at most 2000000 instances"), "{err}");
}

/// The Embree peers: in a build without Embree, `bench --embree-robust` and `stress
/// --embree` are a clear error; with it, `bench --embree --embree-robust` reports both peers,
/// named, and `stress --embree` every tracer's leaks.
#[test]
fn embree_peers_are_reported_or_refused_clearly() {
    let mut bench = vec![
        "bench",
        "--scene",
        "sphere:500",
        "--accel",
        "bvh8",
        "--json",
        "--embree",
        "--embree-robust",
    ];
    bench.extend(SMALL_BENCH);
    let stress = [
        "stress",
        "--embree",
        "--quick",
        "--leak-rays",
        "2000",
        "--json",
    ];
    for args in [&bench[..], &stress[..]] {
        let out = bvhlab(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        if cfg!(feature = "embree") {
            assert!(out.status.success(), "{args:?}: {stderr}");
            let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            if args[0] == "bench" {
                let names: Vec<&str> = json["peers"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|p| p["name"].as_str().unwrap())
                    .collect();
                assert_eq!(names, ["Embree 3", "Embree 3 robust"]);
                assert_eq!(json["peer"], json["peers"][0]);
            } else {
                assert_eq!(json["total"]["bvhlab"]["closest"], 0);
                assert!(json["total"]["rays"].as_u64().unwrap() > 10_000);
            }
        } else {
            assert!(!out.status.success(), "{args:?}");
            assert!(
                stderr.contains("built without Embree"),
                "{args:?}: {stderr}"
            );
        }
    }
}

/// The tinybvh peer: in a build without it, `bench --tinybvh` is a clear error naming the
/// feature; with it, both of its builds are reported, named, with no packet figure (its CPU
/// layout has none) and their primary hits against bvhlab's.
#[test]
fn the_tinybvh_peer_is_reported_or_refused_clearly() {
    let mut args = vec!["bench", "--scene", "sphere:500", "--json", "--tinybvh"];
    args.extend(SMALL_BENCH);
    let out = bvhlab(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if cfg!(feature = "tinybvh") {
        assert!(out.status.success(), "{stderr}");
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let peers = json["peers"].as_array().unwrap();
        let names: Vec<&str> = peers.iter().map(|p| p["name"].as_str().unwrap()).collect();
        assert_eq!(
            names,
            [
                "tinybvh BVH8_CPU (default build)",
                "tinybvh BVH8_CPU (BuildHQ: SBVH)"
            ]
        );
        for p in peers {
            assert!(p["primary_packets"].is_null());
            assert!(p["primary"]["mrays_per_s"].as_f64().unwrap() > 0.0);
            let differing = p["differing_primary_hits"].as_u64().unwrap();
            let rays = p["primary"]["rays"].as_u64().unwrap();
            assert!(differing * 100 <= rays, "{differing} of {rays}");
        }
    } else {
        assert!(!out.status.success());
        assert!(
            stderr.contains("built without tinybvh") && stderr.contains("--features tinybvh"),
            "{stderr}"
        );
        // One line, as written for a reader (no escaped line break left in it).
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    }
    // Island places its instances: tinybvh, given triangles, is refused with the reason.
    let out = bvhlab(&["bench", "--scene", "island", "--tinybvh"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("without storing them") || stderr.contains("built without tinybvh"),
        "{stderr}"
    );
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

#[test]
fn render_tree_draws_the_hierarchy_of_every_tree_and_refuses_the_rest() {
    let dir = std::env::temp_dir().join(format!("bvhlab-tree-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
        &dir,
        &[
            (&["--accel", "grid", "--tree"][..], "has no hierarchy"),
            (&["--tree-width", "sah"][..], "--tree"),
            (&["--tree", "--mode", "nodes"][..], "cannot be used with"),
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn render_cracks_marks_the_leaks_and_refuses_bad_offsets_and_other_views() {
    let dir = std::env::temp_dir().join(format!("bvhlab-cracks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
        &dir,
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
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The views that colour each triangle: the SAH cost per triangle on every tree (summing
/// to the tree's cost, as `stats` prints it) and the tests per triangle on every structure
/// (summing to the frame's triangle tests); the cost refused where there is no SAH cost.
#[test]
fn render_colours_triangles_by_their_cost_and_their_tests() {
    let dir = std::env::temp_dir().join(format!("bvhlab-tricost-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
        &dir,
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
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Each of `cases` (flags added to `render --scene cornell --out …`) fails with a message
/// containing its text, without a panic and without leaving the PNG behind.
fn assert_refused(dir: &std::path::Path, cases: &[(&[&str], &str)]) {
    let png = dir.join("refused.png");
    for &(args, says) in cases {
        let mut all = vec![
            "render",
            "--scene",
            "cornell",
            "--out",
            png.to_str().unwrap(),
        ];
        all.extend_from_slice(args);
        let out = bvhlab(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert!(!png.exists(), "{args:?} left a file");
    }
}
