//! The wide BVHs (BVH4, BVH8) against the BVH2 they are collapsed from: every SIMD kernel
//! this machine has gives the BVH2's hits bit for bit (triangle, t, u, v), any hit agrees,
//! counting changes nothing; the slab kernels equal the scalar slab test and the triangle
//! kernels the scalar watertight test lane for lane; the collapse keeps every box around its
//! subtree and costs no more than a greedy collapse; the wide trees of the default build are
//! the ones recorded, on 1 and 2 threads.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::wide::{CollapseParams, LaneKind, Lanes, NodeWidth};
use bvhlab::accel::bvh::{self, BuildParams, Bvh, Strategy, TraversalOrder, WideBvh};
use bvhlab::accel::progress::BuildProgress;
use bvhlab::accel::{Accel, Counters, Hit, NoStats};
use bvhlab::geometry::aabb::{SlabRay, slab_entry};
use bvhlab::geometry::simd::slab::{Avx2, Avx512, Portable, Sse41, WideSlab, fused_entry};
use bvhlab::geometry::simd::{BLOCK, SimdLevel, TriangleBlock, TriangleKernel, WideRay};
use bvhlab::geometry::{Aabb, Intersector, Ray, Triangle, Watertight};
use bvhlab::scene::Scene;
use common::{Rng, SMALL_BUILTINS, degenerate_cases, rays, soup, view_rays};
use glam::Vec3;

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()))
}

fn bits(h: Option<Hit>) -> Option<(u64, u32, u32, u32)> {
    h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
}

fn bvh2(tris: &[Triangle], strategy: Strategy) -> Bvh {
    bvh::build(tris, &BuildParams::with_strategy(strategy))
        .expect("build")
        .0
}

/// Every kernel and order of a W-wide collapse of `b2` against `b2` itself.
fn assert_wide_equals_bvh2<const W: usize>(b2: &Bvh, rays: &[Ray], what: &str)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    let wide = WideBvh::<W>::collapse(b2, &CollapseParams::default());
    assert_tree_equals_bvh2(wide, b2, rays, what);
}

/// Every kernel and order of the W-wide tree `wide` against the BVH2 `b2` over the same
/// triangles.
fn assert_tree_equals_bvh2<const W: usize>(mut wide: WideBvh<W>, b2: &Bvh, rays: &[Ray], what: &str)
where
    Lanes<W>: NodeWidth,
    WideBvh<W>: Accel,
{
    wide.validate()
        .unwrap_or_else(|e| panic!("{what}: BVH{W}: {e}"));
    wide.outline()
        .validate()
        .unwrap_or_else(|e| panic!("{what}: BVH{W} outline: {e}"));
    for level in SimdLevel::available() {
        wide.set_simd(level).unwrap();
        for order in TraversalOrder::ALL {
            wide.order = order;
            for (i, ray) in rays.iter().enumerate() {
                let expected = b2.closest_hit::<Watertight, _>(ray, &mut NoStats);
                let got = wide.closest_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(
                    bits(got),
                    bits(expected),
                    "{what}: BVH{W} {} {}: ray {i} {ray:?}",
                    level.label(),
                    order.label()
                );
                let mut c = Counters::default();
                let counted = wide.closest_hit::<Watertight, _>(ray, &mut c);
                assert_eq!(bits(counted), bits(got), "{what}: counting changed ray {i}");
                let occluded = wide.any_hit::<Watertight, _>(ray, &mut NoStats);
                assert_eq!(occluded, got.is_some(), "{what}: any hit of ray {i}");
                let occluded_counted = wide.any_hit::<Watertight, _>(ray, &mut Counters::default());
                assert_eq!(
                    occluded_counted, occluded,
                    "{what}: counted any hit of ray {i}"
                );
            }
        }
    }
}

mod collapse;

/// FNV-1a over a wide tree's nodes (boxes, children, counts), leaf blocks, slots and depth:
/// any change to the tree changes it. Each node's lanes are read through their kind and
/// hashed as the rows of the unpacked layout held them (a row of children, node indices or
/// first slots, then a row of counts, `u32::MAX` for an interior child, 0 for an unused
/// lane), so the recorded values name the same trees whatever the lanes' packing.
fn fingerprint<const W: usize>(w: &WideBvh<W>) -> u64
where
    Lanes<W>: NodeWidth,
{
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: u32| {
        for b in x.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for n in &w.nodes {
        n.bounds.iter().flatten().for_each(|x| eat(x.to_bits()));
        let unpacked = |l: usize| match n.lane_kind(l) {
            LaneKind::Unused => (0, 0),
            LaneKind::Interior(c) => (c, u32::MAX),
            LaneKind::Leaf { first, count } => (first, count),
        };
        (0..W).for_each(|l| eat(unpacked(l).0));
        (0..W).for_each(|l| eat(unpacked(l).1));
    }
    for b in &w.blocks {
        b.v.iter()
            .flatten()
            .flatten()
            .for_each(|x| eat(x.to_bits()));
    }
    w.prim_indices.iter().for_each(|&x| eat(x));
    eat(w.depth);
    h
}

mod hits;
mod kernels;
mod refit;
