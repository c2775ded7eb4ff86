//! The part of the treelet dynamic program's cost that does not depend on the partitions:
//! for every subset S of the treelet's leaves, C_trav·A(S) and the cost of S as one leaf.
//!
//! Every subset's box is the union of the box of its high leaves and that of its low leaves,
//! so with the low leaves' subset boxes in lanes (one lane per subset of the low 3 or 4
//! leaves), each subset of the high leaves gives 8 or 16 subsets in one pass with no
//! dependence between them. The surface area takes the same operations in the same order as
//! `Aabb::surface_area`, and a box union (min and max) is exact in any order, so every term
//! has the bits of the scalar formula. (The order of a union could only show in the sign of
//! a zero; boxes are finite, the build rejects other triangles.)

use super::linked_tree::SahCost;
use super::treelet::{MAX_TREELET, TreeletLeaf};
use crate::geometry::Aabb;
use crate::geometry::simd::SimdLevel;

const SUBSETS: usize = 1 << MAX_TREELET;

/// Per subset S (indexed by its bit mask): `trav[S]` = C_trav·A(S), `leaf[S]` = C_isect·A(S)·N(S)
/// where N(S) fits in a leaf and NaN where it does not, so that `SahCost::interior` is
/// `(trav[S] + children).min(leaf[S])` with the same bits (`f64::min` ignores a NaN).
pub struct SubsetTerms {
    pub trav: [f64; SUBSETS],
    pub leaf: [f64; SUBSETS],
    /// Scratch: the box and count of each subset of the high leaves (at least 3 are low).
    high: [(Aabb, u32); SUBSETS >> 3],
}

impl SubsetTerms {
    pub const EMPTY: SubsetTerms = SubsetTerms {
        trav: [0.0; SUBSETS],
        leaf: [0.0; SUBSETS],
        high: [(Aabb::EMPTY, 0); SUBSETS >> 3],
    };

    /// Fills the terms of every subset of `leaves` (entries of other subsets are scratch)
    /// with the kernels of `level` (the portable code where the level is not supported).
    pub fn fill_with(&mut self, level: SimdLevel, leaves: &[TreeletLeaf], sah: &SahCost) {
        assert!(
            leaves.len() <= MAX_TREELET,
            "{} treelet leaves",
            leaves.len()
        );
        match level {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has AVX-512 F and VL (checked just before).
            SimdLevel::Avx512 if level.supported() => unsafe { self.fill_avx512(leaves, sah) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has AVX2 (checked just before).
            SimdLevel::Avx2 if level.supported() => unsafe { self.fill_avx2(leaves, sah) },
            _ => self.fill_lanes::<8>(leaves, sah),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn fill_avx512(&mut self, leaves: &[TreeletLeaf], sah: &SahCost) {
        self.fill_lanes::<16>(leaves, sah);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn fill_avx2(&mut self, leaves: &[TreeletLeaf], sah: &SahCost) {
        self.fill_lanes::<8>(leaves, sah);
    }

    /// The pass with the subsets of the low log2(`LANES`) leaves in lanes: plain loops over
    /// fixed lanes, which the compiler turns into vector instructions of the enabled width.
    #[inline(always)]
    fn fill_lanes<const LANES: usize>(&mut self, leaves: &[TreeletLeaf], sah: &SahCost) {
        const { assert!(LANES.is_power_of_two() && LANES >= 8) };
        let low = LANES.trailing_zeros() as usize;
        let m = leaves.len();
        // Leaves past the treelet's count as empty: their subsets lie beyond 2^m.
        let leaf = |k: usize| {
            leaves
                .get(k)
                .map_or((Aabb::EMPTY, 0), |l| (l.bounds, l.count))
        };
        // The low leaves' subsets, one per lane, as rows of coordinates.
        let mut lo = [[0f32; LANES]; 6];
        let mut lo_count = [0u32; LANES];
        let mut lo_box = [Aabb::EMPTY; LANES];
        for l in 1..LANES {
            let bit = l & l.wrapping_neg();
            let (b, c) = leaf(bit.trailing_zeros() as usize);
            lo_box[l] = lo_box[l ^ bit].union(b);
            lo_count[l] = lo_count[l ^ bit] + c;
        }
        for (l, b) in lo_box.iter().enumerate() {
            let row = [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z];
            for (r, v) in lo.iter_mut().zip(row) {
                r[l] = v;
            }
        }
        // The high leaves' subsets, one at a time, each with all the low ones.
        let highs = 1usize << m.saturating_sub(low);
        self.high[0] = (Aabb::EMPTY, 0);
        for h in 0..highs {
            if h > 0 {
                let bit = h & h.wrapping_neg();
                let (b, c) = leaf(low + bit.trailing_zeros() as usize);
                let (rest, rest_count) = self.high[h ^ bit];
                self.high[h] = (rest.union(b), rest_count + c);
            }
            let (hb, hc) = self.high[h];
            // The areas in f32 lanes first, then the f64 terms: two loops, each of the
            // full vector width.
            let mut area = [0f32; LANES];
            for (l, area) in area.iter_mut().enumerate() {
                let (min_x, min_y, min_z) = (
                    hb.min.x.min(lo[0][l]),
                    hb.min.y.min(lo[1][l]),
                    hb.min.z.min(lo[2][l]),
                );
                let (max_x, max_y, max_z) = (
                    hb.max.x.max(lo[3][l]),
                    hb.max.y.max(lo[4][l]),
                    hb.max.z.max(lo[5][l]),
                );
                // `Aabb::extent`: zero for an empty box.
                let empty = (min_x > max_x) | (min_y > max_y) | (min_z > max_z);
                let (ex, ey, ez) = if empty {
                    (0.0, 0.0, 0.0)
                } else {
                    (max_x - min_x, max_y - min_y, max_z - min_z)
                };
                // `Aabb::surface_area`, term for term.
                *area = 2.0 * (ex * ey + ey * ez + ez * ex);
            }
            let at = h * LANES;
            let trav: &mut [f64; LANES] = (&mut self.trav[at..at + LANES]).try_into().unwrap();
            let leaf: &mut [f64; LANES] = (&mut self.leaf[at..at + LANES]).try_into().unwrap();
            for l in 0..LANES {
                let area = area[l] as f64;
                let count = hc + lo_count[l];
                trav[l] = sah.c_trav * area;
                leaf[l] = if count <= sah.max_leaf_size {
                    sah.leaf(area, count)
                } else {
                    f64::NAN
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Every level's terms have the bits of the scalar formula over the subset's box.
    #[test]
    fn terms_match_the_scalar_formula_bit_for_bit() {
        // Uniform in [0, 1) in f32: the top 24 bits of the crate's seeded generator.
        let mut rng = crate::random::Rng(0x2545_f491_4f6c_dd1d);
        let mut next = move || (rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        for trial in 0..200 {
            let m = 1 + trial % MAX_TREELET;
            let sah = SahCost {
                c_trav: [1.0, 0.3, 1.7][trial % 3],
                c_isect: [1.0, 2.1][trial % 2],
                max_leaf_size: [1, 4, 16][trial % 3],
            };
            let leaves: Vec<TreeletLeaf> = (0..m)
                .map(|_| {
                    let c = Vec3::new(next(), next(), next()) * 20.0 - 10.0;
                    // Some boxes flat or a point, some inverted (empty).
                    let mut h = Vec3::new(next(), next(), next()) * 3.0;
                    if next() < 0.2 {
                        h.y = 0.0;
                    }
                    if next() < 0.1 {
                        h = -h;
                    }
                    TreeletLeaf {
                        bounds: Aabb {
                            min: c - h,
                            max: c + h,
                        },
                        count: 1 + (next() * 5.0) as u32,
                        cost: 0.0,
                        height: 0,
                    }
                })
                .collect();
            for level in SimdLevel::available() {
                let mut t = Box::new(SubsetTerms::EMPTY);
                t.fill_with(level, &leaves, &sah);
                for s in 1usize..1 << m {
                    let (mut b, mut count) = (Aabb::EMPTY, 0);
                    for (k, l) in leaves.iter().enumerate().rev() {
                        if s >> k & 1 == 1 {
                            b = b.union(l.bounds);
                            count += l.count;
                        }
                    }
                    let area = b.surface_area() as f64;
                    assert_eq!(
                        t.trav[s].to_bits(),
                        (sah.c_trav * area).to_bits(),
                        "{level:?}"
                    );
                    let children = 0.25 + next() as f64;
                    let cost = sah.interior(area, count, children);
                    let fast = (t.trav[s] + children).min(t.leaf[s]);
                    assert_eq!(fast.to_bits(), cost.to_bits(), "{level:?} subset {s:#b}");
                }
            }
        }
    }
}
