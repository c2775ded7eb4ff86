//! `bench --accel all`: every structure on the same ray sets; and the rows of the peers
//! (Embree) beside bvhlab's.

use super::BenchArgs;
use anyhow::Result;
use bvhlab::accel::AccelKind;
use bvhlab::bench::{self, BenchConfig};
use bvhlab::scene::Scene;

/// `--accel all`: every structure on the same ray sets, as one table (or one JSON object
/// with a `structures` array).
pub(super) fn run_all(
    args: &BenchArgs,
    scene: &Scene,
    cfg: &BenchConfig,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let quiet = args.json;
    let results = pool.install(|| {
        bench::run_all(scene, cfg, &AccelKind::ALL, &mut |r| {
            if !quiet {
                eprintln!("  done: {}", r.params.kind.label());
            }
        })
    })?;
    if args.json {
        let json = bench::json::AllJson {
            scene: scene.name.clone(),
            triangles: scene.placed_triangles(),
            threads: results.first().map_or(0, |r| r.threads),
            structures: results.iter().map(|r| r.json()).collect(),
            instancing: bench::json::InstancingJson::of(scene),
        };
        out!("{}", serde_json::to_string(&json)?);
        return Ok(());
    }
    out!(
        "{}: {} triangles, {} threads, {}×{} ray sets (Mrays/s; mean nodes visited / triangle tests per ray)",
        scene.name,
        scene.placed_triangles(),
        results.first().map_or(0, |r| r.threads),
        cfg.width,
        cfg.height
    );
    out!(
        "  {:<17} {:>9} {:>8} {:>23} {:>23} {:>23}",
        "structure",
        "build ms",
        "MiB",
        "primary",
        "diffuse",
        "shadow"
    );
    for r in &results {
        let cell = |s: &bench::RaySetResult| {
            let m = s.mean.unwrap_or_default();
            format!(
                "{:>7.2} {:>7.1} /{:>7.1}",
                s.mrays_per_s(),
                m.nodes,
                m.triangle_tests
            )
        };
        let note = if r.sampled > 1 {
            format!("  (1 in {} rays)", r.sampled)
        } else {
            String::new()
        };
        out!(
            "  {:<17} {:>9.2} {:>8.2} {:>23} {:>23} {:>23}{note}",
            r.params.kind.label(),
            r.report.build_ms(),
            r.report.mib(),
            cell(&r.primary),
            cell(&r.diffuse),
            cell(&r.shadow)
        );
    }
    // Same rays and one closest-hit rule: every structure that traced every ray must find
    // exactly the first one's hits.
    let counts = |r: &bench::BenchResult| [r.primary.hits, r.diffuse.hits, r.shadow.hits];
    let full: Vec<_> = results.iter().filter(|r| r.sampled == 1).collect();
    let differing: Vec<&str> = full
        .iter()
        .filter(|r| counts(r) != counts(full[0]))
        .map(|r| r.params.kind.label())
        .collect();
    if let Some(first) = full.first() {
        let [p, d, s] = counts(first);
        if differing.is_empty() {
            out!(
                "  hits: {p} primary, {d} diffuse, {s} occluded shadow rays, the same for every structure that traced every ray"
            );
        } else {
            out!(
                "  hit counts differ from the first structure's: {}",
                differing.join(", ")
            );
        }
    }
    Ok(())
}

/// The peer's numbers beside bvhlab's, as ratios bvhlab / peer (above 1: bvhlab is faster).
pub(super) fn print_peer(r: &bench::BenchResult, p: &bench::PeerResult) -> Result<()> {
    let build_ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    out!(
        "  {} on the same rays and threads{} (primary hits on another triangle: {} ties within \
         rounding, {} at another depth or hit against miss):",
        p.name,
        if p.bvhlab.is_some() {
            ", built and traced by both in turns"
        } else {
            ""
        },
        p.tied_primary_hits,
        p.differing_primary_hits
    );
    // The peer's column is as wide as its name ("Embree 3, instanced" is wider than a number)
    // and two spaces.
    let w = p.name.chars().count().max(12) + 2;
    out!(
        "  {:<22} {:>12} {:>w$} {:>10}",
        "",
        "bvhlab",
        p.name,
        "ratio"
    );
    // A build's row: both times and how many times faster bvhlab's is.
    let times = |name: &str, ours: f64, theirs: f64| -> std::io::Result<()> {
        out!(
            "  {name:<22} {ours:>9.2} ms {theirs:>v$.2} ms {:>9.2}×",
            theirs / ours.max(1e-9),
            v = w - 3
        );
        Ok(())
    };
    let ours_build = p.bvhlab.map_or(r.report.build_ms(), |t| build_ms(t.build));
    times("build", ours_build, build_ms(p.build))?;
    if let (Some(ours), Some(theirs)) = (r.top_level_rebuild, p.top_level_build) {
        times("top level build", build_ms(ours), build_ms(theirs))?;
    }
    if let (Some(ours), Some(theirs)) = (r.wide_rebuild, p.rebuild) {
        times("rebuilt per frame", build_ms(ours), build_ms(theirs))?;
    }
    // bvhlab's rays as timed in turns with the peer's (the ratios' own minutes), where it was.
    let ours = p.bvhlab.unwrap_or(bench::InTurns {
        build: r.report.build_time,
        primary: r.primary,
        primary_packets: r.primary_packets,
        diffuse: r.diffuse,
        shadow: r.shadow,
    });
    for (name, a, b) in [
        ("primary", &ours.primary, Some(&p.primary)),
        (
            "primary in packets",
            &ours.primary_packets,
            p.primary_packets.as_ref(),
        ),
        ("diffuse", &ours.diffuse, Some(&p.diffuse)),
        ("shadow", &ours.shadow, Some(&p.shadow)),
    ] {
        let x = a.mrays_per_s();
        let Some(b) = b else {
            out!(
                "  {name:<22} {x:>7.2} Mr/s {:>w$}",
                "no packet query",
                w = w + 5
            );
            continue;
        };
        let y = b.mrays_per_s();
        out!(
            "  {name:<22} {x:>7.2} Mr/s {y:>v$.2} Mr/s {:>9.2}×",
            x / y.max(1e-9),
            v = w - 5
        );
    }
    Ok(())
}
