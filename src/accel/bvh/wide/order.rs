//! Front-to-back order of a node's entered children, kept in registers: three or four
//! children are ordered by a sorting network and pushed already sorted, farthest first,
//! instead of being pushed and then sorted on the stack.
//!
//! The order is the stack's (`Stack::sort_top` after pushing in lane order): nearest entry
//! first, and of equal entries the higher lane first. A network of compare-exchanges under
//! that strict order sorts exactly as the insertion sort does, ±0 included (they compare
//! equal, so the lanes decide). Entered children never have a NaN entry.

use super::stack::Entry;

/// A child the ray enters, with the lane that holds it (the tie-break).
#[derive(Clone, Copy)]
pub(crate) struct Lane {
    pub child: Entry,
    pub lane: u32,
}

/// Whether `a` is visited before `b`.
#[inline(always)]
fn nearer(a: &Lane, b: &Lane) -> bool {
    a.child.entry < b.child.entry || (a.child.entry == b.child.entry && a.lane > b.lane)
}

/// Leaves the nearer of `v[i]` and `v[j]` at `i`.
#[inline(always)]
fn exchange<const N: usize>(v: &mut [Lane; N], i: usize, j: usize) {
    let (a, b) = (v[i], v[j]);
    let swap = nearer(&b, &a);
    v[i] = if swap { b } else { a };
    v[j] = if swap { a } else { b };
}

/// Three children, nearest first.
#[inline(always)]
pub(crate) fn nearest_first3(mut v: [Lane; 3]) -> [Lane; 3] {
    exchange(&mut v, 0, 1);
    exchange(&mut v, 1, 2);
    exchange(&mut v, 0, 1);
    v
}

/// Four children, nearest first.
#[inline(always)]
pub(crate) fn nearest_first4(mut v: [Lane; 4]) -> [Lane; 4] {
    exchange(&mut v, 0, 1);
    exchange(&mut v, 2, 3);
    exchange(&mut v, 0, 2);
    exchange(&mut v, 1, 3);
    exchange(&mut v, 1, 2);
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::wide::stack::{STACK_SIZE, Stack};
    use std::mem::MaybeUninit;

    /// The children as the stack orders them: pushed in lane order, sorted, popped.
    fn by_stack(lanes: &[Lane]) -> Vec<u32> {
        let mut storage = MaybeUninit::<[Entry; STACK_SIZE]>::uninit();
        let mut stack = Stack::new(&mut storage);
        for l in lanes {
            stack.push(l.child);
        }
        stack.sort_top(lanes.len());
        std::iter::from_fn(|| stack.pop())
            .map(|e| e.child)
            .collect()
    }

    fn lanes(entries: &[f32]) -> Vec<Lane> {
        entries
            .iter()
            .enumerate()
            .map(|(i, &entry)| Lane {
                // The child names the lane, so the orders can be compared.
                child: Entry {
                    child: i as u32,
                    count: 0,
                    entry,
                },
                lane: i as u32,
            })
            .collect()
    }

    #[test]
    fn networks_order_as_the_stack_does() {
        // Every assignment of these values (ties, ±0, infinity) to three and four lanes.
        let values = [0.0, -0.0, 1.0, 1.0 + f32::EPSILON, 2.0, f32::INFINITY];
        let k = values.len();
        for code in 0..k.pow(4) {
            let e: Vec<f32> = (0..4).map(|i| values[code / k.pow(i) % k]).collect();
            let four = lanes(&e);
            let sorted: Vec<u32> = nearest_first4([four[0], four[1], four[2], four[3]])
                .iter()
                .map(|l| l.child.child)
                .collect();
            assert_eq!(sorted, by_stack(&four), "entries {e:?}");
            let three = lanes(&e[..3]);
            let sorted: Vec<u32> = nearest_first3([three[0], three[1], three[2]])
                .iter()
                .map(|l| l.child.child)
                .collect();
            assert_eq!(sorted, by_stack(&three), "entries {:?}", &e[..3]);
        }
    }
}
