//! The walls with every triangle cut into real triangles no longer than L (halving the
//! longest edge), built by binned SAH or SBVH and traced as a BVH8 over the view's primary
//! and diffuse rays: how far fine axis-aligned pieces alone bring the rotated walls towards
//! the axis-aligned ones (docs/build-quality.md, "The rotated walls, measured").
//!
//! ```sh
//! cargo build --release --example chopped_walls
//! target/release/examples/chopped_walls walls-rotated 0.5 [sah-binned|sbvh]
//! ```
use bvhlab::accel::bvh::WideBvh;
use bvhlab::accel::bvh::wide::CollapseParams;
use bvhlab::accel::{Accel, BuildParams, Counters, NoStats};
use bvhlab::bench::rays::RaySets;
use bvhlab::geometry::{Triangle, Watertight};
use bvhlab::scene::{Camera, Scene};
use std::time::Instant;

/// Appends `t` cut at the middle of its longest edge until no edge is longer than `l`.
fn chop(t: Triangle, l: f32, out: &mut Vec<Triangle>) {
    let e = [(0, 1), (1, 2), (2, 0)];
    let (k, len) = e
        .iter()
        .enumerate()
        .map(|(k, &(a, b))| (k, (t.v[a] - t.v[b]).length()))
        .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    if len <= l {
        out.push(t);
        return;
    }
    let (a, b) = e[k];
    let c = 3 - a - b;
    let m = (t.v[a] + t.v[b]) * 0.5;
    chop(Triangle::new(t.v[a], m, t.v[c]), l, out);
    chop(Triangle::new(m, t.v[b], t.v[c]), l, out);
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        eprintln!("usage: chopped_walls SCENE L [sah-binned|sbvh]");
        std::process::exit(2);
    }
    let scene = Scene::load(&a[1]).expect("scene");
    let l: f32 = a[2].parse().expect("L, a length");
    let strategy = a.get(3).map(String::as_str).unwrap_or("sah-binned");
    let mut tris = Vec::new();
    for t in &scene.triangles {
        chop(*t, l, &mut tris);
    }
    let mut chopped = scene.clone();
    chopped.triangles = tris.clone();
    let params = match strategy {
        "sbvh" => BuildParams::with_strategy(bvhlab::accel::bvh::Strategy::Sbvh),
        _ => BuildParams::default(),
    };
    let (bvh, _) = bvhlab::accel::bvh::build(&tris, &params).expect("build");
    let bvh8 = WideBvh::<8>::collapse(&bvh, &CollapseParams::default());
    let camera: Camera = scene.view.expect("the walls have a view");
    let sets = RaySets::standard(&bvh8, &chopped, &camera, scene.light.unwrap(), 512, 384);
    for (name, rays) in [("primary", &sets.primary), ("diffuse", &sets.diffuse)] {
        let mut c = Counters::default();
        for r in rays.iter() {
            bvh8.closest_hit::<Watertight, _>(r, &mut c);
        }
        let mut best = f64::MAX;
        for _ in 0..7 {
            let s = Instant::now();
            let mut n = 0u64;
            for r in rays.iter() {
                n += bvh8
                    .closest_hit::<Watertight, _>(r, &mut NoStats)
                    .map_or(0, |h| h.triangle);
            }
            std::hint::black_box(n);
            best = best.min(s.elapsed().as_secs_f64());
        }
        let per = |x: u32| f64::from(x) / rays.len() as f64;
        println!(
            "{} L={l} {strategy} {} tris ({} refs): {name} {:.2} nodes {:.2} tests, {:.2} Mrays/s (1 thread)",
            a[1],
            tris.len(),
            bvh8.references(),
            per(c.nodes_visited),
            per(c.triangle_tests),
            rays.len() as f64 / best / 1e6
        );
    }
}
