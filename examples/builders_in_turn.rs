//! Builders' trees traced in turn over the same ray sets, on one thread, round after round,
//! the best round of each kept: on a shared machine a load that comes and goes then slows
//! every tree alike, where consecutive `bench builders` runs of one tree differ by ±30 %
//! (docs/build-quality.md, "LBVH + treelets against SBVH").
//!
//! ```sh
//! cargo build --release --example builders_in_turn
//! target/release/examples/builders_in_turn ../shared/scenes/sponza.obj -14,3,0 10,5,0 0,14,0 bvh8 12
//! ```
//!
//! Arguments: scene, eye, look-at, light, layout (`bvh` or `bvh8`), rounds, and the image
//! size (512 × 384 unless given). Prints each tree's primary, diffuse and shadow Mrays/s
//! (by the thread's CPU time) and its share of SBVH's; then, per ray set, each tree's time
//! per ray beside the work that the SAH predicts (nodes visited, triangle tests), so that
//! what a node visit and a triangle test really cost can be fitted across trees.

use bvhlab::accel::bvh::wide::CollapseParams;
use bvhlab::accel::bvh::{Strategy, WideBvh};
use bvhlab::accel::{Accel, BuildParams, Counters, NoStats};
use bvhlab::bench::cpu_time::thread_cpu_seconds;
use bvhlab::bench::rays::RaySets;
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::{Camera, Scene};
use glam::Vec3;
use std::rc::Rc;

fn vec3(s: &str) -> Vec3 {
    let p: Vec<f32> = s.split(',').map(|x| x.parse().expect("x,y,z")).collect();
    Vec3::new(p[0], p[1], p[2])
}

/// Mrays/s of one pass over `rays`; a checksum keeps the answers alive.
fn trace(accel: &dyn Fn(&Ray) -> u64, rays: &[Ray]) -> f64 {
    let start = thread_cpu_seconds();
    let sum = rays.iter().fold(0u64, |s, r| s.wrapping_add(accel(r)));
    std::hint::black_box(sum);
    rays.len() as f64 / (thread_cpu_seconds() - start) / 1e6
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 7 {
        eprintln!("usage: builders_in_turn SCENE EYE LOOK LIGHT bvh|bvh8 ROUNDS [W H]");
        std::process::exit(2);
    }
    let scene = Scene::load(&a[1]).expect("scene");
    let camera = Camera::new(vec3(&a[2]), vec3(&a[3]));
    let wide = a[5] == "bvh8";
    let rounds: usize = a[6].parse().expect("rounds");
    let (w, h) = match (a.get(7), a.get(8)) {
        (Some(w), Some(h)) => (w.parse().expect("width"), h.parse().expect("height")),
        _ => (512, 384),
    };
    let with = |strategy, presplit| BuildParams {
        presplit,
        ..BuildParams::with_strategy(strategy)
    };
    let builders = [
        ("SBVH", with(Strategy::Sbvh, 0.0)),
        ("binned SAH", with(Strategy::SahBinned, 0.0)),
        ("LBVH + treelets", with(Strategy::LbvhTreelet, 0.0)),
        (
            "LBVH + treelets, pre-split 0.1",
            with(Strategy::LbvhTreelet, 0.1),
        ),
        (
            "LBVH + treelets, pre-split 0.2",
            with(Strategy::LbvhTreelet, 0.2),
        ),
        // Plain LBVH and median splits: far more work per ray, for the fit's spread.
        ("LBVH", with(Strategy::Lbvh, 0.0)),
        ("spatial median", with(Strategy::SpatialMedian, 0.0)),
    ];
    type Walk = Box<dyn Fn(&Ray, bool) -> u64>;
    type CountedWalk = Box<dyn Fn(&Ray, bool) -> Counters>;
    let trees: Vec<(&str, Walk, CountedWalk)> = builders
        .iter()
        .map(|(name, p)| {
            let (bvh, _) = bvhlab::accel::bvh::build(&scene.triangles, p).expect("build");
            let (walk, counted): (Walk, CountedWalk) = if wide {
                let t = Rc::new(WideBvh::<8>::collapse(&bvh, &CollapseParams::default()));
                let c = t.clone();
                (
                    Box::new(move |r: &Ray, any: bool| answer(&*t, r, any)),
                    Box::new(move |r: &Ray, any: bool| work(&*c, r, any)),
                )
            } else {
                let bvh = Rc::new(bvh);
                let c = bvh.clone();
                (
                    Box::new(move |r: &Ray, any: bool| answer(&*bvh, r, any)),
                    Box::new(move |r: &Ray, any: bool| work(&*c, r, any)),
                )
            };
            (*name, walk, counted)
        })
        .collect();
    let (sbvh, _) = bvhlab::accel::bvh::build(&scene.triangles, &builders[0].1).expect("build");
    let sets = RaySets::standard(&sbvh, &scene, &camera, vec3(&a[4]), w, h);
    let named = [
        ("primary", &sets.primary, false),
        ("diffuse", &sets.diffuse, false),
        ("shadow", &sets.shadow, true),
    ];
    let mut best = vec![[0.0f64; 3]; trees.len()];
    for _ in 0..rounds {
        for (k, (_, walk, _)) in trees.iter().enumerate() {
            for (s, (_, rays, any)) in named.iter().enumerate() {
                let m = trace(&|r: &Ray| walk(r, *any), rays);
                best[k][s] = best[k][s].max(m);
            }
        }
    }
    println!(
        "{} ({}), {w}×{h}, one thread, best of {rounds} rounds in turn: Mrays/s (% of SBVH's)",
        scene.name,
        if wide { "BVH8" } else { "BVH2" }
    );
    for (k, (name, _, _)) in trees.iter().enumerate() {
        let cells: Vec<String> = (0..3)
            .map(|s| {
                format!(
                    "{} {:.3} ({:.1} %)",
                    named[s].0,
                    best[k][s],
                    100.0 * best[k][s] / best[0][s]
                )
            })
            .collect();
        println!("  {name:<32} {}", cells.join("   "));
    }
    println!("ns per ray (best round), and per ray: nodes visited, triangle tests");
    for (s, (set, rays, any)) in named.iter().enumerate() {
        for (k, (name, _, counted)) in trees.iter().enumerate() {
            let sum = rays.iter().fold(Counters::default(), |mut c, r| {
                c += counted(r, *any);
                c
            });
            let n = rays.len() as f64;
            println!(
                "  {set:<8} {name:<32} {:8.1} ns {:8.2} nodes {:8.2} tests",
                1e3 / best[k][s],
                sum.nodes_visited as f64 / n,
                sum.triangle_tests as f64 / n
            );
        }
    }
}

/// One ray's work, counted.
fn work<A: Accel>(accel: &A, r: &Ray, any: bool) -> Counters {
    let mut c = Counters::default();
    if any {
        accel.any_hit::<Watertight, _>(r, &mut c);
    } else {
        accel.closest_hit::<Watertight, _>(r, &mut c);
    }
    c
}

/// One ray's answer as a number: the closest hit's distance and triangle, or whether it
/// is blocked.
fn answer<A: Accel>(accel: &A, r: &Ray, any: bool) -> u64 {
    if any {
        u64::from(accel.any_hit::<Watertight, _>(r, &mut NoStats))
    } else {
        accel
            .closest_hit::<Watertight, _>(r, &mut NoStats)
            .map_or(0, |h| u64::from(h.t.to_bits()) ^ h.triangle)
    }
}
