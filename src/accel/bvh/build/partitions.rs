//! The treelet dynamic program's scan over partitions: for every subset S of the leaves, in
//! increasing order, min over the partitions {P, S∖P} of C(P) + C(S∖P), and from that C(S).
//!
//! The vector kernels take 4 (AVX2) or 8 (AVX-512) partitions per instruction from a table
//! of every subset's partitions (`PartitionTable`), C(P) and C(S∖P) gathered from the
//! costs. The scalar kernel is the plain scan split four ways. A lane keeps the value
//! below its running minimum (`min_pd(x, m)` is `x < m ? x : m`, so a NaN is never
//! taken), as the scalar scan does, and the lanes' minima are merged the same way: the
//! minimum of the values that are not NaN is one value whatever the order, so the bits are
//! the scalar scan's. (Only the sign of a zero could tell, and no cost is −0: an area is
//! never −0 and C_trav, C_isect ≥ 0 — unless one of them is −0.0 itself.)

use super::subset_terms::SubsetTerms;
use super::treelet::MAX_TREELET;
use crate::geometry::simd::SimdLevel;
use std::sync::OnceLock;

const SUBSETS: usize = 1 << MAX_TREELET;

/// Fills `cost[S]` and `children[S]` (the minimum over S's partitions) for every subset S
/// of two or more of `m` leaves, given the leaves' own costs in `cost` and the terms of
/// every subset. `cost[0]` is set to infinity (the empty set is no part of a partition).
pub fn solve(
    level: SimdLevel,
    m: usize,
    cost: &mut [f64; SUBSETS],
    children: &mut [f64; SUBSETS],
    terms: &SubsetTerms,
) {
    assert!(m <= MAX_TREELET, "{m} treelet leaves");
    cost[0] = f64::INFINITY;
    match level {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the CPU has AVX-512 F and VL (checked just before).
        SimdLevel::Avx512 if level.supported() => unsafe { solve_avx512(m, cost, children, terms) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the CPU has AVX2 (checked just before).
        SimdLevel::Avx2 if level.supported() => unsafe { solve_avx2(m, cost, children, terms) },
        _ => solve_portable(m, cost, children, terms),
    }
}

/// The subsets by size, as the table orders them, each scanned with the scalar scan.
fn solve_portable(
    m: usize,
    cost: &mut [f64; SUBSETS],
    children: &mut [f64; SUBSETS],
    terms: &SubsetTerms,
) {
    for &(s, _, _) in &PartitionTable::get(4, m).subsets {
        let best = min_children(cost, s);
        finish(s as usize, best, cost, children, terms);
    }
}

/// Every partition {P, S∖P} of every subset S of two or more of a treelet's m leaves, as
/// the indices of P and S∖P, each subset's run padded to a whole number of vectors with
/// P = S∖P = ∅ (C(∅) = ∞ never lowers a minimum). The subsets come by size, smallest first:
/// every subset's parts are smaller, so they come before it, and subsets of one size never
/// wait on each other — the processor overlaps their scans, where in increasing order each
/// subset's cost would often wait on the one just computed.
struct PartitionTable {
    /// (S, first, end) of each subset's run in `p` and `q`.
    subsets: Vec<(u32, u32, u32)>,
    p: Vec<i32>,
    q: Vec<i32>,
}

impl PartitionTable {
    fn new(lanes: usize, m: usize) -> Self {
        let mut t = PartitionTable {
            subsets: Vec::new(),
            p: Vec::new(),
            q: Vec::new(),
        };
        let mut order: Vec<u32> = (1u32..1 << m).filter(|s| !s.is_power_of_two()).collect();
        order.sort_by_key(|&s| (s.count_ones(), s));
        for s in order {
            let first = t.p.len() as u32;
            // P over the non-empty subsets of S without its lowest leaf: each partition once.
            let delta = (s - 1) & s;
            let mut p = delta & delta.wrapping_neg();
            while p != 0 {
                t.p.push(p as i32);
                t.q.push((s ^ p) as i32);
                p = p.wrapping_sub(delta) & s;
            }
            while !t.p.len().is_multiple_of(lanes) {
                t.p.push(0);
                t.q.push(0);
            }
            t.subsets.push((s, first, t.p.len() as u32));
        }
        t
    }

    /// The table of `m` leaves for vectors of `lanes` (4 or 8), built on first use.
    fn get(lanes: usize, m: usize) -> &'static PartitionTable {
        static TABLES: [[OnceLock<PartitionTable>; MAX_TREELET + 1]; 2] =
            [const { [const { OnceLock::new() }; MAX_TREELET + 1] }; 2];
        TABLES[(lanes == 8) as usize][m].get_or_init(|| PartitionTable::new(lanes, m))
    }

    /// Every subset's run.
    fn runs(&self) -> impl Iterator<Item = (usize, &[i32], &[i32])> {
        self.subsets.iter().map(|&(s, first, end)| {
            let r = first as usize..end as usize;
            // SAFETY: `new` makes every run a range within `p` and `q`.
            unsafe {
                (
                    s as usize,
                    self.p.get_unchecked(r.clone()),
                    self.q.get_unchecked(r),
                )
            }
        })
    }
}

/// C(S) from the minimum over S's partitions, with the bits of `SahCost::interior`.
#[inline(always)]
fn finish(
    s: usize,
    best: f64,
    cost: &mut [f64; SUBSETS],
    children: &mut [f64; SUBSETS],
    terms: &SubsetTerms,
) {
    children[s] = best;
    cost[s] = (terms.trav[s] + best).min(terms.leaf[s]);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve_avx2(
    m: usize,
    cost: &mut [f64; SUBSETS],
    children: &mut [f64; SUBSETS],
    terms: &SubsetTerms,
) {
    use std::arch::x86_64::*;
    for (s, ps, qs) in PartitionTable::get(4, m).runs() {
        let mut best = _mm256_set1_pd(f64::INFINITY);
        for (p, q) in ps.chunks_exact(4).zip(qs.chunks_exact(4)) {
            // SAFETY: each chunk holds four i32; P and S∖P are subsets of S, and S is below
            // 2^MAX_TREELET: in the table.
            let (cp, cq) = unsafe {
                let (p, q) = (
                    _mm_loadu_si128(p.as_ptr().cast()),
                    _mm_loadu_si128(q.as_ptr().cast()),
                );
                (
                    _mm256_i32gather_pd::<8>(cost.as_ptr(), p),
                    _mm256_i32gather_pd::<8>(cost.as_ptr(), q),
                )
            };
            best = _mm256_min_pd(_mm256_add_pd(cp, cq), best);
        }
        let mut lanes = [0.0; 4];
        // SAFETY: `lanes` holds four f64.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), best) };
        finish(s, merge(&lanes), cost, children, terms);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
fn solve_avx512(
    m: usize,
    cost: &mut [f64; SUBSETS],
    children: &mut [f64; SUBSETS],
    terms: &SubsetTerms,
) {
    use std::arch::x86_64::*;
    for (s, ps, qs) in PartitionTable::get(8, m).runs() {
        let mut best = _mm512_set1_pd(f64::INFINITY);
        for (p, q) in ps.chunks_exact(8).zip(qs.chunks_exact(8)) {
            // SAFETY: each chunk holds eight i32; P and S∖P are subsets of S, and S is below
            // 2^MAX_TREELET: in the table.
            let (cp, cq) = unsafe {
                let (p, q) = (
                    _mm256_loadu_si256(p.as_ptr().cast()),
                    _mm256_loadu_si256(q.as_ptr().cast()),
                );
                (
                    _mm512_i32gather_pd::<8>(p, cost.as_ptr()),
                    _mm512_i32gather_pd::<8>(q, cost.as_ptr()),
                )
            };
            best = _mm512_min_pd(_mm512_add_pd(cp, cq), best);
        }
        let mut lanes = [0.0; 8];
        // SAFETY: `lanes` holds eight f64.
        unsafe { _mm512_storeu_pd(lanes.as_mut_ptr(), best) };
        finish(s, merge(&lanes), cost, children, terms);
    }
}

/// The lanes' minima merged in lane order, keeping only strictly lower values.
#[inline(always)]
fn merge(lanes: &[f64]) -> f64 {
    let mut best = f64::INFINITY;
    for &x in lanes {
        if x < best {
            best = x;
        }
    }
    best
}

/// min over the partitions {P, S∖P} of subset `s` of C(P) + C(S∖P), with the bits (and NaN
/// handling) of a scan that keeps the first value strictly below the running minimum.
///
/// P runs over the non-empty subsets of S without its lowest leaf (which stays in S∖P), so
/// every partition comes once. The scan is split four ways by the two highest leaves h1 < h2
/// of those: P = Q, Q + h1, Q + h2, Q + h1 + h2 for Q over the subsets of the rest. The four
/// minima are independent (no single chain of dependent compares), and every P of one way
/// comes before every P of the next in the plain order, so merging them in that order with
/// the same strict compare gives the plain scan's value.
#[inline(always)]
fn min_children(cost: &[f64; SUBSETS], s: u32) -> f64 {
    // (Masked so the compiler sees the indices in range: the hot loop of the build.)
    let c = |p: u32| cost[p as usize & (SUBSETS - 1)] + cost[(s ^ p) as usize & (SUBSETS - 1)];
    let delta = (s - 1) & s;
    if delta.is_power_of_two() {
        let x = c(delta);
        return if x < f64::INFINITY { x } else { f64::INFINITY };
    }
    let h2 = 1 << (31 - delta.leading_zeros());
    let h1 = 1 << (31 - (delta ^ h2).leading_zeros());
    let rest = delta ^ h1 ^ h2;
    let mut m = [f64::INFINITY; 4];
    let keep = |m: &mut f64, x: f64| {
        if x < *m {
            *m = x;
        }
    };
    // Q = 0: P = Q itself is empty, not a partition.
    keep(&mut m[1], c(h1));
    keep(&mut m[2], c(h2));
    keep(&mut m[3], c(h1 | h2));
    let mut q = rest & rest.wrapping_neg();
    while q != 0 {
        keep(&mut m[0], c(q));
        keep(&mut m[1], c(q | h1));
        keep(&mut m[2], c(q | h2));
        keep(&mut m[3], c(q | h1 | h2));
        q = q.wrapping_sub(rest) & rest;
    }
    let mut best = m[0];
    for x in &m[1..] {
        keep(&mut best, *x);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every level's costs and minima have the bits of the portable scan, ties, infinities
    /// and NaNs included.
    #[test]
    fn every_level_matches_the_portable_scan() {
        let mut rng = crate::random::Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = move || rng.next_u64();
        for trial in 0..300 {
            let m = 2 + trial % (MAX_TREELET - 1);
            let mut terms = Box::new(SubsetTerms::EMPTY);
            let mut leaf_cost = [0.0; MAX_TREELET];
            // Few distinct values, so that ties are common; some infinite or NaN.
            let mut value = || match next() % 16 {
                0 => f64::INFINITY,
                1 if trial % 3 == 0 => f64::NAN,
                v => (v % 5) as f64 * 0.5 + 0.25,
            };
            for s in 0..SUBSETS {
                terms.trav[s] = value();
                terms.leaf[s] = value();
            }
            for c in &mut leaf_cost {
                *c = value();
            }
            let mut results = Vec::new();
            for level in SimdLevel::available() {
                let mut cost = [f64::from_bits(next()); SUBSETS];
                let mut children = [0.0; SUBSETS];
                for k in 0..m {
                    cost[1 << k] = leaf_cost[k];
                }
                solve(level, m, &mut cost, &mut children, &terms);
                let bits = |t: &[f64]| t[..1 << m].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                results.push((level, bits(&cost), bits(&children)));
            }
            for (level, cost, children) in &results[1..] {
                assert_eq!(cost, &results[0].1, "{level:?}, {m} leaves");
                assert_eq!(children, &results[0].2, "{level:?}, {m} leaves");
            }
        }
    }
}
