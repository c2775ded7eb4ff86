//! One scene's default BVH8 built again and again in one process, each phase of the build
//! report averaged and its fastest kept: the bench's best build moves by several
//! milliseconds from run to run on a shared machine, and two binaries run in turns this
//! way tell a change of 1–2 % apart (docs/wide-bvh.md, "The build's serial pieces and
//! bounds checks").
//!
//! ```sh
//! cargo build --release --example build_phases
//! RAYON_NUM_THREADS=2 target/release/examples/build_phases ../shared/scenes/conference.obj 25
//! ```
//!
//! Arguments: scene and the number of builds (20 unless given); the first build, which
//! faults its memory in, is left out of the figures.

use bvhlab::accel::report::Detail;
use bvhlab::accel::structure;
use bvhlab::accel::{AccelKind, StructureParams};
use bvhlab::scene::Scene;

/// The trees' large arrays on huge pages, as in the `bvhlab` binary.
#[global_allocator]
static ALLOCATOR: bvhlab::huge_pages::HugePages = bvhlab::huge_pages::HugePages;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: build_phases SCENE [BUILDS]");
        std::process::exit(2);
    };
    let builds: usize = match args.get(2).map(|s| s.parse()) {
        None => 20,
        Some(Ok(n)) if n >= 2 => n,
        Some(_) => {
            eprintln!("BUILDS is a whole number of at least 2");
            std::process::exit(2);
        }
    };
    let scene = Scene::load(path).unwrap_or_else(|e| {
        eprintln!("{path}: {e}");
        std::process::exit(1);
    });
    let params = StructureParams::of_kind(AccelKind::Bvh8);
    // (phase, sum of the timed builds, fastest), in the report's order.
    let mut phases: Vec<(String, f64, f64)> = Vec::new();
    for build in 0..builds {
        let built = structure::build(&scene.triangles, &params, &Default::default())
            .unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(1);
            });
        let report = &built.report;
        let rows = std::iter::once(("build".to_string(), report.build_ms())).chain(
            report
                .details
                .iter()
                .filter_map(|(name, detail)| match detail {
                    Detail::Time(t) => Some((name.clone(), t.as_secs_f64() * 1e3)),
                    _ => None,
                }),
        );
        if build == 0 {
            phases = rows.map(|(name, _)| (name, 0.0, f64::MAX)).collect();
            continue;
        }
        for (phase, (_, ms)) in phases.iter_mut().zip(rows) {
            phase.1 += ms;
            phase.2 = phase.2.min(ms);
        }
    }
    let timed = (builds - 1) as f64;
    for (name, sum, fastest) in phases {
        println!(
            "{name:36} mean {:8.2} ms   fastest {fastest:8.2} ms",
            sum / timed
        );
    }
}
