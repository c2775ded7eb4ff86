//! Micro benchmarks of the pieces a ray's time goes to, so a regression shows in the piece
//! that regressed: the slab test (scalar and each SIMD kernel), the watertight triangle
//! test (scalar, and four at a time with each SIMD kernel), the BVH2 build, the collapse into
//! BVH4 and BVH8, single-ray traversal of each, and the wide trees' refit of 10^6 triangles.
//! `cargo bench --bench kernels` (add a name to filter, e.g. `cargo bench --bench kernels slab`).

use bvhlab::accel::bvh::wide::{CollapseParams, Lanes, NodeWidth};
use bvhlab::accel::bvh::{self, BuildParams, Bvh, WideBvh};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::geometry::aabb::{SlabRay, slab_entry};
use bvhlab::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab};
use bvhlab::geometry::simd::{BLOCK, SimdLevel, TriangleBlock, TriangleKernel, WideRay};
use bvhlab::geometry::{Intersector, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use divan::{Bencher, black_box};
use glam::Vec3;
use std::sync::OnceLock;

fn main() {
    divan::main();
}

/// A closed sphere of 100,000 triangles and rays through its view, built once.
struct Fixture {
    triangles: Vec<Triangle>,
    rays: Vec<Ray>,
    bvh2: Bvh,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let scene = Scene::load("sphere:100000").expect("built-in scene");
        let cam = scene.camera().rays(128, 96);
        let rays = (0..96)
            .flat_map(|y| (0..128).map(move |x| (x, y)))
            .map(|(x, y)| cam.pixel_center(x, y))
            .collect();
        let bvh2 = bvh::build(&scene.triangles, &BuildParams::default())
            .unwrap()
            .0;
        Fixture {
            triangles: scene.triangles,
            rays,
            bvh2,
        }
    })
}

/// Eight boxes around the origin and rays from every direction.
fn boxes_and_rays() -> ([[f32; 8]; 6], Vec<Ray>) {
    // Box i is centred on (i − 3.5, i mod 3 − 1, i mod 2), 1.2 wide.
    let centre = |axis: usize, i: usize| match axis {
        0 => i as f32 - 3.5,
        1 => (i % 3) as f32 - 1.0,
        _ => (i % 2) as f32,
    };
    let rows: [[f32; 8]; 6] = std::array::from_fn(|row| {
        std::array::from_fn(|i| centre(row % 3, i) + if row < 3 { -0.6 } else { 0.6 })
    });
    let rays = (0..1024)
        .map(|k| {
            let a = k as f32 * 0.37;
            let o = Vec3::new(a.cos() * 10.0, (a * 1.3).sin() * 4.0, a.sin() * 10.0);
            Ray::new(o, -o)
        })
        .collect();
    (rows, rays)
}

#[divan::bench]
fn slab_scalar_8_boxes(b: Bencher) {
    let (rows, rays) = boxes_and_rays();
    let corners: Vec<[Vec3; 2]> = (0..8)
        .map(|i| {
            [
                Vec3::new(rows[0][i], rows[1][i], rows[2][i]),
                Vec3::new(rows[3][i], rows[4][i], rows[5][i]),
            ]
        })
        .collect();
    b.bench_local(|| {
        let mut hits = 0;
        for r in &rays {
            let s = SlabRay::new(r);
            for c in &corners {
                hits +=
                    u32::from(slab_entry(black_box(c), &s, 0.0, f32::INFINITY) != f32::INFINITY);
            }
        }
        hits
    });
}

/// The rays against the eight boxes with kernel K.
#[inline(always)]
fn slab_rays<K: WideSlab<8>>(rows: &[[f32; 8]; 6], rays: &[Ray]) -> u32 {
    let mut hits = 0;
    let mut entry = [0.0f32; 8];
    for r in rays {
        let w = WideRay::new(r);
        // SAFETY: every caller checked that the CPU supports K.
        let mask = unsafe { K::entries(black_box(rows), &w, 0.0, f32::INFINITY, &mut entry) };
        hits += mask.count_ones();
    }
    hits
}

// The kernels inline into code compiled for their instruction set, as in the traversal.
#[target_feature(enable = "sse4.1")]
fn slab_rays_sse41(rows: &[[f32; 8]; 6], rays: &[Ray]) -> u32 {
    slab_rays::<Sse41>(rows, rays)
}

#[target_feature(enable = "avx2")]
fn slab_rays_avx2(rows: &[[f32; 8]; 6], rays: &[Ray]) -> u32 {
    slab_rays::<Avx2>(rows, rays)
}

#[target_feature(enable = "avx512f,avx512vl")]
fn slab_rays_avx512(rows: &[[f32; 8]; 6], rays: &[Ray]) -> u32 {
    slab_rays::<Avx512>(rows, rays)
}

#[divan::bench(args = SimdLevel::ALL.map(|l| l.label()))]
fn slab_wide_8_boxes(b: Bencher, level: &str) {
    let level = SimdLevel::from_label(level).unwrap();
    if !level.supported() {
        return;
    }
    let (rows, rays) = boxes_and_rays();
    b.bench_local(|| match level {
        SimdLevel::Portable => slab_rays::<Portable>(&rows, &rays),
        // SAFETY: `level.supported()` was checked above.
        SimdLevel::Sse41 => unsafe { slab_rays_sse41(&rows, &rays) },
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { slab_rays_avx2(&rows, &rays) },
        // SAFETY: as above.
        SimdLevel::Avx512 => unsafe { slab_rays_avx512(&rows, &rays) },
    });
}

#[divan::bench]
fn triangle_watertight(b: Bencher) {
    let f = fixture();
    let tris = &f.triangles[..1024];
    let ray = f.rays[f.rays.len() / 2];
    let data = Watertight::prepare(&ray);
    b.bench_local(|| {
        tris.iter()
            .filter(|t| {
                Watertight::intersect(&data, &ray, black_box(t), 0.0, f32::INFINITY).is_some()
            })
            .count()
    });
}

/// The same 1024 triangles as 256 blocks of four.
fn blocks(tris: &[Triangle]) -> Vec<TriangleBlock> {
    tris.chunks(BLOCK)
        .map(|c| {
            let mut block = TriangleBlock::EMPTY;
            for (lane, t) in c.iter().enumerate() {
                block.set(lane, t);
            }
            block
        })
        .collect()
}

/// The ray against every block with kernel K: the lanes hit.
#[inline(always)]
fn block_hits<K: TriangleKernel>(blocks: &[TriangleBlock], ray: &Ray) -> u32 {
    let data = Watertight::prepare(ray);
    let mut hits = 0;
    for block in blocks {
        // SAFETY: every caller checked that the CPU supports K.
        let h = unsafe {
            Watertight::intersect_block::<K>(&data, ray, black_box(block), 0.0, f32::INFINITY)
        };
        hits += (h.hit | h.retest).count_ones();
    }
    hits
}

#[target_feature(enable = "sse4.1")]
fn block_hits_sse41(blocks: &[TriangleBlock], ray: &Ray) -> u32 {
    block_hits::<Sse41>(blocks, ray)
}

#[target_feature(enable = "avx2")]
fn block_hits_avx2(blocks: &[TriangleBlock], ray: &Ray) -> u32 {
    block_hits::<Avx2>(blocks, ray)
}

#[target_feature(enable = "avx512f,avx512vl")]
fn block_hits_avx512(blocks: &[TriangleBlock], ray: &Ray) -> u32 {
    block_hits::<Avx512>(blocks, ray)
}

#[divan::bench(args = SimdLevel::ALL.map(|l| l.label()))]
fn triangle_watertight_blocks(b: Bencher, level: &str) {
    let level = SimdLevel::from_label(level).unwrap();
    if !level.supported() {
        return;
    }
    let f = fixture();
    let blocks = blocks(&f.triangles[..1024]);
    let ray = f.rays[f.rays.len() / 2];
    b.bench_local(|| match level {
        SimdLevel::Portable => block_hits::<Portable>(&blocks, &ray),
        // SAFETY: `level.supported()` was checked above.
        SimdLevel::Sse41 => unsafe { block_hits_sse41(&blocks, &ray) },
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { block_hits_avx2(&blocks, &ray) },
        // SAFETY: as above.
        SimdLevel::Avx512 => unsafe { block_hits_avx512(&blocks, &ray) },
    });
}

#[divan::bench(sample_count = 10)]
fn build_bvh2_binned_sah(b: Bencher) {
    let f = fixture();
    b.bench(|| bvh::build(black_box(&f.triangles), &BuildParams::default()).unwrap());
}

#[divan::bench(consts = [4, 8], sample_count = 20)]
fn collapse<const W: usize>(b: Bencher)
where
    Lanes<W>: NodeWidth,
{
    let f = fixture();
    b.bench_local(|| WideBvh::<W>::collapse(black_box(&f.bvh2), &CollapseParams::default()));
}

fn trace<A: Accel>(b: Bencher, a: &A) {
    let f = fixture();
    b.bench_local(|| {
        f.rays
            .iter()
            .filter(|r| a.closest_hit::<Watertight, _>(r, &mut NoStats).is_some())
            .count()
    });
}

#[divan::bench(sample_count = 20)]
fn traverse_bvh2(b: Bencher) {
    trace(b, &fixture().bvh2);
}

#[divan::bench(consts = [4, 8], sample_count = 20)]
fn traverse_wide<const W: usize>(b: Bencher)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    let wide = WideBvh::<W>::collapse(&fixture().bvh2, &CollapseParams::default());
    trace(b, &wide);
}

/// A wide tree over a built-in scene, and the scene's triangles all moved (scaled by 1 %).
fn moved_wide<const W: usize>(scene: &str) -> (WideBvh<W>, Vec<Triangle>)
where
    Lanes<W>: NodeWidth,
{
    let scene = Scene::load(scene).expect("built-in scene");
    let b2 = bvh::build(&scene.triangles, &BuildParams::default())
        .unwrap()
        .0;
    let wide = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
    let moved = scene
        .triangles
        .iter()
        .map(|t| Triangle::new(t.v[0] * 1.01, t.v[1] * 1.01, t.v[2] * 1.01))
        .collect();
    (wide, moved)
}

/// A refit of a wide tree over 10^6 triangles after all of them moved (on the machine's
/// threads: rayon's pool): a random soup, whose scene order is unrelated to the tree's (the
/// triangles are gathered from all over memory), and a sphere mesh, whose order is coherent.
#[divan::bench(consts = [4, 8], args = ["soup:1000000", "sphere:1000000"], sample_count = 10)]
fn refit_wide_1m<const W: usize>(b: Bencher, scene: &str)
where
    Lanes<W>: NodeWidth,
{
    let (mut wide, moved) = moved_wide::<W>(scene);
    b.bench_local(|| wide.refit(black_box(&moved), 1.0, 1.0).unwrap());
}

/// The same refits without the SAH report (`refit_boxes`), as a scene refitted every frame
/// runs them: the goal of 1.5× the memory-traffic floor is measured on this one.
#[divan::bench(consts = [4, 8], args = ["soup:1000000", "sphere:1000000"], sample_count = 10)]
fn refit_boxes_wide_1m<const W: usize>(b: Bencher, scene: &str)
where
    Lanes<W>: NodeWidth,
{
    let (mut wide, moved) = moved_wide::<W>(scene);
    b.bench_local(|| wide.refit_boxes(black_box(&moved)).unwrap());
}
