//! Build flags on every subcommand: `--accel`, the SIMD kernel, re-braiding, treelets, the
//! overlap penalty and budgets, with clear errors for bad values.

use super::*;

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
    let dir = TempDir::new("cli-structures");
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
