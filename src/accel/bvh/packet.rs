//! Packet traversal for coherent rays, such as a tile of primary rays: the rays of a packet
//! walk the tree together, so each node is fetched once per packet instead of once per ray
//! (Wald, Boulos and Shirley 2007, "Ray tracing deformable scenes using dynamic bounding
//! volume hierarchies").
//!
//! At each node the packet looks for its first ray that enters the box:
//! - early hit: the ray that entered the parent is tested first, and for coherent rays it
//!   usually enters the child too, so one slab test decides for the whole packet;
//! - early miss: otherwise the interval test (`RayInterval`) tells in one test that no ray
//!   of the packet enters it;
//! - only if both fail are the remaining rays tested one by one.
//!
//! Rays before that first one are known to miss the node (they missed an ancestor, which
//! contains it), so a node carries the index of its first active ray down the tree. In a
//! leaf each remaining ray that enters the leaf's box tests its triangles.
//!
//! The hits are exactly those of `closest_hit` ray by ray: both keep, of equal distances,
//! the lowest triangle index (`BestHit`), so the order of the visit does not matter.

use super::Bvh;
use super::traverse::{STACK_SIZE, T_SCALE};
use crate::accel::{BestHit, Hit};
use crate::geometry::aabb::{SlabRay, slab_entry};
use crate::geometry::frustum::RayInterval;
use crate::geometry::{Intersector, Ray};

/// Rays per packet: an 8 × 8 tile of pixels.
pub const PACKET_SIZE: usize = crate::geometry::simd::PACKET_RAYS;

/// The pixels of the 8 × 8 tile whose corner is (x0, y0), clipped to a `width` × `height`
/// image, in the order a packet holds their rays: four quads of 4 × 4 pixels (the upper
/// two, then the lower two), each row by row. A group of 16 rays that a SIMD kernel tests
/// at once is then a square of pixels, whose rays enter more of the same boxes and
/// triangles than two rows of eight do.
pub fn tile_pixels(x0: u32, y0: u32, width: u32, height: u32) -> impl Iterator<Item = (u32, u32)> {
    (0..4).flat_map(move |q| {
        let (qx, qy) = (x0 + 4 * (q % 2), y0 + 4 * (q / 2));
        (qy..(qy + 4).min(height)).flat_map(move |y| (qx..(qx + 4).min(width)).map(move |x| (x, y)))
    })
}

/// The per-ray state of a packet.
struct PacketRays<'a, I: Intersector> {
    rays: &'a [Ray],
    slabs: [SlabRay; PACKET_SIZE],
    data: [I::RayData; PACKET_SIZE],
    best: [BestHit; PACKET_SIZE],
    /// Each ray's box-test limit: its best t, widened by the rounding of the box test.
    box_tmax: [f32; PACKET_SIZE],
}

impl<I: Intersector> PacketRays<'_, I> {
    /// Whether ray `i` enters the box `corners` before its best hit.
    #[inline(always)]
    fn entry(&self, corners: &[glam::Vec3; 2], i: usize) -> f32 {
        slab_entry(corners, &self.slabs[i], self.rays[i].tmin, self.box_tmax[i])
    }

    #[inline(always)]
    fn enters(&self, corners: &[glam::Vec3; 2], i: usize) -> bool {
        self.entry(corners, i) != f32::INFINITY
    }
}

impl Bvh {
    /// The closest hit of each ray, as `closest_hit` would find it, traced in packets of
    /// `PACKET_SIZE` consecutive rays. Coherent packets (rays from one origin through
    /// neighbouring pixels) go fastest.
    pub fn closest_hits_packet<I: Intersector>(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (rays, hits) in rays.chunks(PACKET_SIZE).zip(hits.chunks_mut(PACKET_SIZE)) {
            self.trace_packet::<I>(rays, hits);
        }
    }

    fn trace_packet<I: Intersector>(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        let n = rays.len().min(PACKET_SIZE).min(out.len());
        if n == 0 {
            return;
        }
        // Unused slots copy the last ray; only the first `n` are ever read.
        let ray = |i: usize| &rays[i.min(n - 1)];
        let mut p = PacketRays::<I> {
            rays: &rays[..n],
            slabs: std::array::from_fn(|i| SlabRay::new(ray(i))),
            data: std::array::from_fn(|i| I::prepare(ray(i))),
            best: std::array::from_fn(|i| BestHit::new(ray(i))),
            box_tmax: std::array::from_fn(|i| ray(i).tmax * T_SCALE),
        };
        let interval = RayInterval::new(&rays[..n]);
        // The largest box-test limit of the packet, for the interval test.
        let mut packet_tmax = p.box_tmax[..n]
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max);
        let nodes = &self.nodes;
        // Nodes still to visit, each with its first ray that may enter it.
        let mut stack = [(0u32, 0u32); STACK_SIZE];
        let mut sp = 0;
        let (mut index, mut first) = (0usize, 0usize);
        // Whether ray `first` is already known to enter node `index`.
        let mut known = false;
        loop {
            let node = &nodes[index];
            let corners = &node.corners;
            let active = if known || p.enters(corners, first) {
                Some(first)
            } else if interval.is_some_and(|iv| iv.misses(corners, packet_tmax)) {
                None
            } else {
                (first + 1..n).find(|&i| p.enters(corners, i))
            };
            if let Some(f) = active {
                if node.is_leaf() {
                    for i in f..n {
                        if i != f && !p.enters(corners, i) {
                            continue;
                        }
                        let r = &p.rays[i];
                        for k in node.prim_range() {
                            let tri = &self.triangles[k];
                            if let Some(h) =
                                I::intersect(&p.data[i], r, tri, r.tmin, p.best[i].limit)
                            {
                                p.best[i].offer(h, self.prim_indices[k]);
                                p.box_tmax[i] = p.best[i].t * T_SCALE;
                            }
                        }
                    }
                    packet_tmax = p.box_tmax[..n]
                        .iter()
                        .copied()
                        .fold(f32::NEG_INFINITY, f32::max);
                } else {
                    // Visit first the child that the first active ray enters first.
                    let l = node.left_first as usize;
                    let [a, b] = nodes.pair(l);
                    let (da, db) = (p.entry(&a.corners, f), p.entry(&b.corners, f));
                    let (near, far, d_near) = if db < da {
                        (l + 1, l, db)
                    } else {
                        (l, l + 1, da)
                    };
                    stack[sp] = (far as u32, f as u32);
                    sp += 1;
                    index = near;
                    first = f;
                    known = d_near != f32::INFINITY;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            let (next, next_first) = stack[sp];
            index = next as usize;
            first = next_first as usize;
            known = false;
        }
        for (o, b) in out.iter_mut().zip(&p.best[..n]) {
            *o = b.hit();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_holds_each_pixel_once_in_squares_of_sixteen() {
        let full: Vec<(u32, u32)> = tile_pixels(8, 16, 64, 48).collect();
        assert_eq!(full.len(), PACKET_SIZE);
        let mut sorted = full.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), PACKET_SIZE);
        for (q, quad) in full.chunks(16).enumerate() {
            let (qx, qy) = (8 + 4 * (q as u32 % 2), 16 + 4 * (q as u32 / 2));
            assert!(
                quad.iter()
                    .all(|&(x, y)| (qx..qx + 4).contains(&x) && (qy..qy + 4).contains(&y))
            );
        }
        // A tile at the image's corner keeps only the pixels inside it.
        let corner: Vec<(u32, u32)> = tile_pixels(8, 8, 13, 10).collect();
        assert_eq!(corner.len(), 5 * 2);
        assert!(corner.iter().all(|&(x, y)| x < 13 && y < 10));
    }
}
