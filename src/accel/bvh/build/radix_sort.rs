//! Parallel least-significant-digit radix sort of 64-bit keys, eight bits per pass, as LBVH
//! needs it for its Morton codes. Each pass is stable, so the result is the one stable order
//! of the keys whatever the number of threads or chunks.

use rayon::prelude::*;

/// A key and the value that travels with it (LBVH: a Morton code and a primitive index).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Keyed {
    pub key: u64,
    pub value: u32,
}

const DIGIT_BITS: u32 = 8;
const BUCKETS: usize = 1 << DIGIT_BITS;
/// Each pass splits the input into chunks of at least this many keys: a histogram per chunk,
/// then every chunk scatters its keys into its own reserved places of every bucket.
const MIN_CHUNK: usize = 16 * 1024;
/// At most this many chunks, so the per-pass bookkeeping stays small for huge inputs.
const MAX_CHUNKS: usize = 256;

/// What the sort orders: an item with a 64-bit key.
pub trait Radix: Copy + Default + Send + Sync {
    fn key(&self) -> u64;
}

impl Radix for Keyed {
    #[inline(always)]
    fn key(&self) -> u64 {
        self.key
    }
}

/// A key that carries its own value in its low bits (the direct wide build: a 30-bit
/// Morton code above a 32-bit index), sorted by its high bits only (`sort_high`).
impl Radix for u64 {
    #[inline(always)]
    fn key(&self) -> u64 {
        *self
    }
}

/// Sorts `items` by key, stably.
pub fn sort<T: Radix>(items: &mut Vec<T>) {
    sort_from(items, 0);
}

/// Sorts `items` stably by the key's bits from `low_bit` up (a multiple of eight): half the
/// passes for keys whose low half is a value to carry along.
pub fn sort_from<T: Radix>(items: &mut Vec<T>, low_bit: u32) {
    sort_from_with(items, &mut Vec::new(), low_bit);
}

/// `sort_from` with `other` as the second buffer the passes scatter into: a sort run every
/// frame keeps it, and writes over last frame's keys instead of fresh pages. What it holds
/// after the sort is unspecified.
pub fn sort_from_with<T: Radix>(items: &mut Vec<T>, other: &mut Vec<T>, low_bit: u32) {
    let n = items.len();
    if n < 2 {
        return;
    }
    let chunk = n.div_ceil(MAX_CHUNKS).max(MIN_CHUNK);
    // Only the part beyond what `other` holds is written here; the passes overwrite all.
    other.resize(n, T::default());
    for pass in low_bit / DIGIT_BITS..u64::BITS.div_ceil(DIGIT_BITS) {
        let shift = pass * DIGIT_BITS;
        let digit = move |k: &T| ((k.key() >> shift) as usize) & (BUCKETS - 1);
        let histograms: Vec<[usize; BUCKETS]> = items
            .par_chunks(chunk)
            .map(|c| {
                let mut h = [0usize; BUCKETS];
                for k in c {
                    h[digit(k)] += 1;
                }
                h
            })
            .collect();
        if (0..BUCKETS).any(|d| histograms.iter().map(|h| h[d]).sum::<usize>() == n) {
            // Every key has the same digit here: the pass would not move anything.
            continue;
        }
        // The output in bucket-major, chunk-minor order, cut into one piece per (chunk,
        // bucket): chunk c's keys of bucket d land in piece [c][d], after the keys of bucket
        // d from the chunks before it. That is what makes the pass stable.
        let mut pieces: Vec<Vec<&mut [T]>> = (0..histograms.len())
            .map(|_| Vec::with_capacity(BUCKETS))
            .collect();
        let mut rest: &mut [T] = other.as_mut_slice();
        for d in 0..BUCKETS {
            for (c, h) in histograms.iter().enumerate() {
                let (piece, tail) = std::mem::take(&mut rest).split_at_mut(h[d]);
                pieces[c].push(piece);
                rest = tail;
            }
        }
        items
            .par_chunks(chunk)
            .zip(pieces.par_iter_mut())
            .for_each(|(c, pieces)| {
                let mut next = [0usize; BUCKETS];
                for k in c {
                    let d = digit(k);
                    pieces[d][next[d]] = *k;
                    next[d] += 1;
                }
            });
        std::mem::swap(items, other);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(keys: Vec<u64>) {
        let mut items: Vec<Keyed> = keys
            .iter()
            .enumerate()
            .map(|(i, &key)| Keyed {
                key,
                value: i as u32,
            })
            .collect();
        let mut expected = items.clone();
        expected.sort_by_key(|k| k.key); // stable
        sort(&mut items);
        assert_eq!(items, expected);
    }

    #[test]
    fn sorts_like_a_stable_comparison_sort() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        check(vec![]);
        check(vec![5]);
        for n in [2, 100, 70_000, 300_000] {
            check((0..n).map(|_| next()).collect());
            // Many duplicates and keys that differ only in a few digits.
            check((0..n).map(|_| next() % 7).collect());
            check((0..n).map(|_| (next() % 3) << 40).collect());
        }
        check(vec![u64::MAX, 0, u64::MAX, 1 << 63, 0]);
    }

    /// A sort given a second buffer of any length and contents (last frame's) sorts as
    /// one given none.
    #[test]
    fn a_kept_buffer_of_any_length_sorts_the_same() {
        let mut x = 0x1234_5678_9abc_def1u64;
        let mut other: Vec<u64> = vec![7; 123_456];
        for n in [50_000usize, 200_000, 3, 70_000] {
            let keys: Vec<u64> = (0..n)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x
                })
                .collect();
            let (mut a, mut b) = (keys.clone(), keys);
            sort_from(&mut a, 32);
            sort_from_with(&mut b, &mut other, 32);
            assert_eq!(a, b, "{n} keys");
        }
    }

    /// Sorted by their high half only, keys keep the order of their low halves among
    /// equal high halves: the low half travels as a value.
    #[test]
    fn sorting_from_a_bit_leaves_the_bits_below_it_as_values() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for n in [1usize, 3, 50_000] {
            let mut keys: Vec<u64> = (0..n as u64)
                .map(|i| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    (x % 5) << 32 | (u32::MAX as u64 - i)
                })
                .collect();
            let mut expected = keys.clone();
            expected.sort_by_key(|k| k >> 32); // stable
            sort_from(&mut keys, 32);
            assert_eq!(keys, expected);
        }
    }
}
