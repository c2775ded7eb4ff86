//! The phases of the direct Morton build (`--builder lbvh --direct-wide true`), built from
//! nothing and then rebuilt into its own memory, one line a build, with the process's
//! allocator (large arrays on huge pages where the system allows):
//!
//! ```sh
//! cargo run --release --example morton_phases -- soup:10000000 5
//! ```

#[global_allocator]
static ALLOCATOR: bvhlab::huge_pages::HugePages = bvhlab::huge_pages::HugePages;

use bvhlab::accel::bvh::report::BuildPhases;
use bvhlab::accel::bvh::wide::WideBvh;
use bvhlab::accel::bvh::wide::morton::MortonScratch;
use std::time::{Duration, Instant};

fn main() {
    let mut args = std::env::args().skip(1);
    let spec = args.next().unwrap_or_else(|| "soup:1000000".into());
    let builds: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(3);
    let tris = match bvhlab::scene::builtin::by_name(&spec) {
        Ok(Some(scene)) => scene.triangles,
        Ok(None) => {
            eprintln!("morton_phases: {spec} is not a built-in scene (e.g. soup:1000000)");
            std::process::exit(2);
        }
        Err(e) => {
            eprintln!("morton_phases: {e}");
            std::process::exit(2);
        }
    };
    let line = |what: &str, total: Duration, phases: &BuildPhases| {
        let p: Vec<String> = (phases.times.iter())
            .map(|(name, d)| format!("{name} {:.1}", d.as_secs_f64() * 1e3))
            .collect();
        println!(
            "{what}: {:.1} ms [{}]",
            total.as_secs_f64() * 1e3,
            p.join(", ")
        );
    };
    for _ in 0..builds {
        let start = Instant::now();
        let (tree, phases) = WideBvh::<8>::morton(&tris, 4).expect("a finite scene");
        line("from nothing", start.elapsed(), &phases);
        drop(tree);
    }
    let (mut tree, _) = WideBvh::<8>::morton(&tris, 4).expect("a finite scene");
    let mut scratch = MortonScratch::default();
    for _ in 0..builds {
        let start = Instant::now();
        let phases = tree
            .rebuild_morton(&tris, 4, &mut scratch)
            .expect("a finite scene");
        line("rebuilt", start.elapsed(), &phases);
    }
}
