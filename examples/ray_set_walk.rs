//! One standard ray set traced on one thread by the BVH8 or by Embree 3, for profiles
//! (`perf record`, `valgrind --tool=callgrind --toggle-collect='ray_set_walk::trace*'`)
//! and single-thread timings by the thread's CPU clock (docs/wide-bvh.md, "Diffuse and
//! shadow rays against Embree, counted"):
//!
//! ```sh
//! cargo build --release --features embree --example ray_set_walk
//! target/release/examples/ray_set_walk ../shared/scenes/sponza.obj -14,3,0 10,5,0 0,14,0 shadow bvh8 5 [1024 768]
//! ```
//!
//! Arguments: scene, eye, look-at, light (each `view` for the scene's own), set (`primary`, `diffuse`, `shadow`, or `packets`:
//! the primary rays 64 at a time through `closest_hits`, `rtcIntersect16` for Embree), walk
//! (`bvh8` or `embree`; `WALK_EMBREE_ROBUST` set, Embree with its robust flag), repeats,
//! and the image size. With `WALK_COUNT` set, the BVH8's
//! nodes, box tests and triangle tests per ray are counted after the timing. The BVH8 is
//! collapsed from binned SAH's tree, or from the builder named in `WALK_BUILDER` (a label
//! as `bench builders` prints it, e.g. `SBVH`) with `WALK_PRESPLIT` as its pre-split
//! budget; with `--cache-sim=yes --LL=2097152,16,64` callgrind then counts each tree's
//! misses in a 2 MiB L2 (docs/build-quality.md, "What a node and a test cost").
//!
//! `WALK_THREADS=n` traces the set on n threads in chunks of 256 rays, as the bench does;
//! with `WALK_STRUCTURE` set, through the structure the bench builds (its `Structure`: the
//! fastest layout, or two levels for a scene of instances) rather than the BVH8 collapsed
//! here, which then also makes the secondary rays (the island:
//! `WALK_STRUCTURE=1 ray_set_walk island view view view packets bvh8 5 640 360`).
//! With `WALK_TILES` set, each 8 × 8 tile of primary rays is timed as a packet and ray by ray, and what taking
//! the faster per tile would save is printed (docs/wide-bvh.md, "Packets or single rays,
//! tile by tile").

use bvhlab::accel::bvh::packet::PACKET_SIZE;
use bvhlab::accel::bvh::wide::CollapseParams;
use bvhlab::accel::bvh::{Strategy, WideBvh};
use bvhlab::accel::{Accel, BuildParams, Counters, NoStats};
use bvhlab::bench::cpu_time::thread_cpu_seconds;
use bvhlab::bench::rays::RaySets;
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::{Camera, Scene};
use glam::Vec3;
use std::time::Instant;

/// The trees' large arrays on huge pages, as in the `bvhlab` binary: without them the walk's
/// speed varies by a fifth from one process to the next with where its pages land.
#[global_allocator]
static ALLOCATOR: bvhlab::huge_pages::HugePages = bvhlab::huge_pages::HugePages;

fn vec3(s: &str) -> Vec3 {
    let p: Vec<f32> = s.split(',').map(|x| x.parse().expect("x,y,z")).collect();
    Vec3::new(p[0], p[1], p[2])
}

/// The set once; a checksum of the answers, so nothing is optimised away. With `packets`,
/// the rays (the primary set in tile order) go 64 at a time through `closest_hits`, as the
/// benchmark's packet row traces them.
#[inline(never)]
fn trace<A: Accel>(accel: &A, any: bool, packets: bool, rays: &[Ray]) -> u64 {
    let mut sum = 0u64;
    if packets {
        let mut hits = [None; PACKET_SIZE];
        for packet in rays.chunks(PACKET_SIZE) {
            let hits = &mut hits[..packet.len()];
            accel.closest_hits::<Watertight>(packet, hits);
            for h in hits.iter().flatten() {
                sum = sum.wrapping_add(u64::from(h.t.to_bits()) ^ h.triangle);
            }
        }
        return sum;
    }
    for r in rays {
        sum = sum.wrapping_add(if any {
            u64::from(accel.any_hit::<Watertight, _>(r, &mut NoStats))
        } else {
            accel
                .closest_hit::<Watertight, _>(r, &mut NoStats)
                .map_or(0, |h| u64::from(h.t.to_bits()) ^ h.triangle)
        });
    }
    sum
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 8 {
        eprintln!(
            "usage: ray_set_walk SCENE EYE LOOK LIGHT primary|diffuse|shadow|packets bvh8|embree REPEATS [W H]"
        );
        std::process::exit(2);
    }
    let scene = Scene::load(&a[1]).expect("scene");
    // `view` for EYE, LOOK or LIGHT: the scene's own.
    let view = scene
        .view
        .unwrap_or_else(|| Camera::new(Vec3::ONE, Vec3::ZERO));
    let point = |arg: &str, own: Vec3| if arg == "view" { own } else { vec3(arg) };
    let camera = Camera::new(point(&a[2], view.eye), point(&a[3], view.look_at));
    let light = point(&a[4], scene.light.unwrap_or(view.eye));
    let (set, walk) = (a[5].as_str(), a[6].as_str());
    let repeats: usize = a[7].parse().expect("repeats");
    let (w, h) = match (a.get(8), a.get(9)) {
        (Some(w), Some(h)) => (w.parse().expect("width"), h.parse().expect("height")),
        _ => (1024, 768),
    };
    let strategy = std::env::var("WALK_BUILDER").map_or(Strategy::SahBinned, |name| {
        *Strategy::ALL
            .iter()
            .find(|s| s.label() == name)
            .expect("WALK_BUILDER: a builder's label")
    });
    let presplit = std::env::var("WALK_PRESPLIT").map_or(0.0, |b| b.parse().expect("budget"));
    let params = BuildParams {
        presplit,
        ..BuildParams::with_strategy(strategy)
    };
    let (bvh, _) = bvhlab::accel::bvh::build(&scene.triangles, &params).expect("build");
    let bvh8 = WideBvh::<8>::collapse(&bvh, &CollapseParams::default());
    // `WALK_THREADS=n`: the set traced by n threads in chunks of 256 rays, as the bench does.
    let threads: usize = std::env::var("WALK_THREADS").map_or(1, |n| n.parse().expect("threads"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let structure = std::env::var_os("WALK_STRUCTURE").map(|_| {
        use bvhlab::accel::AccelKind;
        // A scene of instances gets its two levels, as `bench` gives it.
        let kind = match scene.instances.is_empty() {
            true => AccelKind::fastest(),
            false => AccelKind::TwoLevel,
        };
        let params = bvhlab::accel::StructureParams::of_kind(kind);
        pool.install(|| bvhlab::accel::structure::build_scene(&scene, &params, &Default::default()))
            .expect("structure")
            .structure
    });
    // The secondary rays start where the structure traced finds the primary hits (a
    // scene of instances has them only there).
    let sets = match &structure {
        Some(st) => RaySets::standard(st, &scene, &camera, light, w, h),
        None => RaySets::standard(&bvh8, &scene, &camera, light, w, h),
    };
    let (rays, any) = match set {
        "primary" => (&sets.primary, false),
        "packets" => (&sets.primary_tiles, false),
        "diffuse" => (&sets.diffuse, false),
        _ => (&sets.shadow, true),
    };
    let packets = set == "packets";
    #[cfg(feature = "embree")]
    let embree = {
        use bvhlab::accel::embree::{Embree, EmbreeMode};
        // `WALK_EMBREE_ROBUST` set: Embree with its robust flag.
        let mode = match std::env::var_os("WALK_EMBREE_ROBUST") {
            Some(_) => EmbreeMode::Robust,
            None => EmbreeMode::Default,
        };
        Embree::build(&scene.triangles, 1, mode).expect("Embree")
    };
    let trace_all = |rays: &[Ray]| -> u64 {
        if let Some(st) = &structure {
            use rayon::prelude::*;
            return pool.install(|| {
                rays.par_chunks(256)
                    .map(|c| trace(st, any, packets, c))
                    .reduce(|| 0, u64::wrapping_add)
            });
        }
        if threads == 1 {
            return match walk {
                #[cfg(feature = "embree")]
                "embree" => trace(&embree, any, packets, rays),
                _ => trace(&bvh8, any, packets, rays),
            };
        }
        use rayon::prelude::*;
        pool.install(|| {
            rays.par_chunks(256)
                .map(|c| match walk {
                    #[cfg(feature = "embree")]
                    "embree" => trace(&embree, any, packets, c),
                    _ => trace(&bvh8, any, packets, c),
                })
                .reduce(|| 0, u64::wrapping_add)
        })
    };
    let start = Instant::now();
    let cpu = thread_cpu_seconds();
    let mut sum = 0u64;
    // The fastest pass as well: on a shared machine, the pass least disturbed.
    let mut fastest = f64::INFINITY;
    for _ in 0..repeats {
        let pass = Instant::now();
        sum = sum.wrapping_add(trace_all(rays));
        fastest = fastest.min(pass.elapsed().as_secs_f64());
    }
    let (wall, cpu) = (start.elapsed().as_secs_f64(), thread_cpu_seconds() - cpu);
    let n = (rays.len() * repeats) as f64;
    println!(
        "{walk} {set}: {} rays x {repeats}, {:.3} Mrays/s wall, {:.3} Mrays/s cpu, \
         {:.3} Mrays/s fastest pass, checksum {sum}",
        rays.len(),
        n / wall / 1e6,
        n / cpu / 1e6,
        rays.len() as f64 / fastest / 1e6
    );
    if std::env::var_os("WALK_TILES").is_some() {
        tile_choice(&bvh8, &sets.primary_tiles);
    }
    if std::env::var_os("WALK_COUNT").is_some() {
        let mut c = Counters::default();
        for r in rays {
            if any {
                bvh8.any_hit::<Watertight, _>(r, &mut c);
            } else {
                bvh8.closest_hit::<Watertight, _>(r, &mut c);
            }
        }
        let per_ray = |x: u32| f64::from(x) / rays.len() as f64;
        println!(
            "per ray: {:.3} nodes, {:.3} box tests, {:.3} triangle tests",
            per_ray(c.nodes_visited),
            per_ray(c.box_tests),
            per_ray(c.triangle_tests)
        );
    }
}

/// `WALK_TILES` set: each 8 × 8 tile of primary rays timed as one packet and ray by ray (the
/// fastest of 15 tries each, on this thread), to see what choosing the faster per tile
/// would save over packets everywhere (issue #31, item 3).
fn tile_choice(bvh8: &WideBvh<8>, tiles: &[Ray]) {
    let time = |f: &mut dyn FnMut()| {
        (0..15)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let (mut packets, mut singles, mut best, mut single_wins) = (0.0, 0.0, 0.0, 0);
    let mut hits = [None; PACKET_SIZE];
    for tile in tiles.chunks(PACKET_SIZE) {
        let hits = &mut hits[..tile.len()];
        let p = time(&mut || bvh8.closest_hits::<Watertight>(std::hint::black_box(tile), hits));
        let s = time(&mut || {
            for r in std::hint::black_box(tile) {
                std::hint::black_box(bvh8.closest_hit::<Watertight, _>(r, &mut NoStats));
            }
        });
        packets += p;
        singles += s;
        best += p.min(s);
        single_wins += usize::from(s < p);
    }
    let n = tiles.len().div_ceil(PACKET_SIZE);
    println!(
        "tiles: {n}; ray by ray faster in {single_wins}; all packets {:.2} ms, all single rays {:.2} ms, the faster per tile {:.2} ms ({:.2} % below packets)",
        packets * 1e3,
        singles * 1e3,
        best * 1e3,
        100.0 * (1.0 - best / packets)
    );
}
