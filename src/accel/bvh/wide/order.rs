//! Front-to-back order of a node's entered children, kept in registers: three to eight
//! children are ordered by a sorting network and pushed already sorted, farthest first,
//! instead of being pushed and then sorted on the stack.
//!
//! The order is the stack's (`Stack::sort_top` after pushing in lane order): nearest entry
//! first, and of equal entries the higher lane first. Each child becomes one integer key
//! that holds both (`key`), so a compare-exchange is a compare and two conditional moves,
//! with no branch the CPU could mispredict; keys of different lanes are never equal, so
//! every network sorts them exactly as the insertion sort does, ±0 included. Entered
//! children never have a NaN entry.

/// The bits of an entry distance made to sort as the distances do: ±0 made one by adding
/// +0, negative values with their bits flipped, the sign bit set on the others.
#[inline(always)]
pub(crate) fn ordered(entry: f32) -> u32 {
    let bits = (entry + 0.0).to_bits();
    bits ^ ((((bits as i32) >> 31) as u32) | 0x8000_0000)
}

/// The order key of the child in `lane` whose box the ray enters at a distance with
/// `ordered` bits: the distance, then the lane, higher lanes first.
#[inline(always)]
pub(crate) fn key_of_ordered(ordered: u32, lane: u32) -> u64 {
    (u64::from(ordered) << 32) | u64::from(!lane)
}

/// The order key of the child in `lane` whose box the ray enters at `entry`.
#[inline(always)]
pub(crate) fn key(entry: f32, lane: u32) -> u64 {
    key_of_ordered(ordered(entry), lane)
}

/// The lane a key was made for, below `W`.
#[inline(always)]
pub(crate) fn lane_of<const W: usize>(key: u64) -> usize {
    (!(key as u32)) as usize % W
}

/// Leaves the smaller of `v[i]` and `v[j]` at `i`.
#[inline(always)]
fn exchange<const N: usize>(v: &mut [u64; N], i: usize, j: usize) {
    let (a, b) = (v[i], v[j]);
    v[i] = a.min(b);
    v[j] = a.max(b);
}

/// Three keys, nearest first.
#[inline(always)]
pub(crate) fn nearest_first3(mut v: [u64; 3]) -> [u64; 3] {
    exchange(&mut v, 0, 1);
    exchange(&mut v, 1, 2);
    exchange(&mut v, 0, 1);
    v
}

/// Four keys, nearest first.
#[inline(always)]
pub(crate) fn nearest_first4(mut v: [u64; 4]) -> [u64; 4] {
    exchange(&mut v, 0, 1);
    exchange(&mut v, 2, 3);
    exchange(&mut v, 0, 2);
    exchange(&mut v, 1, 3);
    exchange(&mut v, 1, 2);
    v
}

/// Eight keys, nearest first (19 compare-exchanges, the fewest for eight); five to seven
/// children fill the other places with `u64::MAX`, which sorts last.
#[inline(always)]
pub(crate) fn nearest_first8(mut v: [u64; 8]) -> [u64; 8] {
    // Written out: a loop over a table of pairs is not unrolled.
    exchange(&mut v, 0, 2);
    exchange(&mut v, 1, 3);
    exchange(&mut v, 4, 6);
    exchange(&mut v, 5, 7);
    exchange(&mut v, 0, 4);
    exchange(&mut v, 1, 5);
    exchange(&mut v, 2, 6);
    exchange(&mut v, 3, 7);
    exchange(&mut v, 0, 1);
    exchange(&mut v, 2, 3);
    exchange(&mut v, 4, 5);
    exchange(&mut v, 6, 7);
    exchange(&mut v, 2, 4);
    exchange(&mut v, 3, 5);
    exchange(&mut v, 1, 4);
    exchange(&mut v, 3, 6);
    exchange(&mut v, 1, 2);
    exchange(&mut v, 3, 4);
    exchange(&mut v, 5, 6);
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::wide::node::Subtree;
    use crate::accel::bvh::wide::stack::{Entry, STACK_SIZE, Stack};
    use std::mem::MaybeUninit;

    /// The lanes as the stack orders them: pushed in lane order, sorted, popped.
    fn by_stack(entries: &[f32]) -> Vec<usize> {
        let mut storage = MaybeUninit::<[Entry; STACK_SIZE]>::uninit();
        let mut stack = Stack::new(&mut storage);
        for (i, &entry) in entries.iter().enumerate() {
            // The child names the lane, so the orders can be compared.
            stack.push(Entry {
                child: Subtree::node(i as u32),
                entry,
            });
        }
        stack.sort_top(entries.len());
        std::iter::from_fn(|| stack.pop())
            .map(|e| e.child.node_index())
            .collect()
    }

    /// The lanes as the networks order them.
    fn by_network(entries: &[f32]) -> Vec<usize> {
        let keys: Vec<u64> = (0..entries.len())
            .map(|i| key(entries[i], i as u32))
            .collect();
        let sorted: Vec<u64> = match keys.len() {
            3 => nearest_first3([keys[0], keys[1], keys[2]]).to_vec(),
            4 => nearest_first4([keys[0], keys[1], keys[2], keys[3]]).to_vec(),
            n => {
                let mut all = [u64::MAX; 8];
                all[..n].copy_from_slice(&keys);
                nearest_first8(all)[..n].to_vec()
            }
        };
        sorted.iter().map(|&k| lane_of::<8>(k)).collect()
    }

    // Ties, ±0, negative entries (a ray starting inside boxes behind it) and infinity.
    const VALUES: [f32; 7] = [0.0, -0.0, 1.0, 1.0 + f32::EPSILON, -2.0, 2.0, f32::INFINITY];

    #[test]
    fn keys_order_as_the_entries_do() {
        for (i, &a) in VALUES.iter().enumerate() {
            for &b in &VALUES {
                assert_eq!(
                    key(a, 0) < key(b, 0),
                    a < b,
                    "entries {a} and {b} ordered wrongly"
                );
            }
            // Of equal entries the higher lane first; the lane comes back.
            assert!(key(a, 5) < key(a, 2));
            assert_eq!(lane_of::<8>(key(a, i as u32)), i);
        }
    }

    #[test]
    fn networks_order_as_the_stack_does() {
        // Every assignment of the values to three and four lanes.
        let k = VALUES.len();
        for code in 0..k.pow(4) {
            let e: Vec<f32> = (0..4).map(|i| VALUES[code / k.pow(i) % k]).collect();
            assert_eq!(by_network(&e), by_stack(&e), "entries {e:?}");
            assert_eq!(
                by_network(&e[..3]),
                by_stack(&e[..3]),
                "entries {:?}",
                &e[..3]
            );
        }
    }

    #[test]
    fn network_of_eight_orders_five_to_eight_as_the_stack_does() {
        // Every 0/1 input of eight (a network that sorts those sorts everything), then
        // many mixed ones of five to eight children with ties.
        for bits in 0u32..256 {
            let e: Vec<f32> = (0..8).map(|i| (bits >> i & 1) as f32).collect();
            assert_eq!(by_network(&e), by_stack(&e), "entries {e:?}");
        }
        let mut state = 12345u64;
        for _ in 0..20_000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let n = 5 + (state >> 60) as usize % 4;
            let e: Vec<f32> = (0..n)
                .map(|i| VALUES[(state >> (4 * i)) as usize % VALUES.len()])
                .collect();
            assert_eq!(by_network(&e), by_stack(&e), "entries {e:?}");
        }
    }
}
