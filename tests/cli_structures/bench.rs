//! `bench`: every structure on the same rays, its JSON, the builders' table, the top
//! level's rebuild and build times, the peers.

use super::*;

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

/// Each peer's ratios come from bvhlab's ray sets timed again in turns with the peer's:
/// the same rays, with the same hits as bvhlab's own timing.
fn same_rays_in_turns(json: &serde_json::Value) {
    for p in json["peers"].as_array().unwrap() {
        assert!(p["bvhlab"]["build_ms"].as_f64().unwrap() > 0.0, "{p}");
        for (set, count) in [
            ("primary", "hits"),
            ("primary_packets", "hits"),
            ("diffuse", "hits"),
            ("shadow", "occluded"),
        ] {
            let turns = &p["bvhlab"][set];
            assert!(turns["mrays_per_s"].as_f64().unwrap() > 0.0, "{p}");
            assert_eq!(turns["rays"], json[set]["rays"], "{set}");
            assert_eq!(turns[count], json[set][count], "{set}");
        }
    }
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
                same_rays_in_turns(&json);
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
        same_rays_in_turns(&json);
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
