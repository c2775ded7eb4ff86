//! Which object owns a triangle, found in a few memory reads. Shading asks it for every
//! hit: a binary search over the island's 200 002 objects (56 bytes apart) waits on about
//! 18 cache misses, one per halving. The index keeps the objects' ends packed together,
//! and a table of buckets of triangle numbers, each pointing at the first object that
//! reaches into it; a lookup reads the bucket, then searches the few objects it holds.

use super::Object;

#[derive(Clone, Debug, Default)]
pub struct ObjectIndex {
    /// Object k's end (one past its last triangle), in object order.
    ends: Vec<u64>,
    /// Bucket b covers the triangles `b << shift ..` `(b + 1) << shift`; it holds the
    /// first object whose end is past the bucket's first triangle.
    buckets: Vec<u32>,
    shift: u32,
}

impl ObjectIndex {
    /// The index of `objects`, which are ordered and do not overlap (gaps are allowed).
    pub fn new(objects: &[Object]) -> Self {
        let ends: Vec<u64> = objects.iter().map(|o| (o.first + o.count) as u64).collect();
        let total = ends.last().copied().unwrap_or(0);
        // About two buckets an object: most buckets then meet one or two objects.
        let wanted = (2 * ends.len() as u64).max(1);
        let shift = (total.div_ceil(wanted))
            .max(1)
            .next_power_of_two()
            .trailing_zeros();
        let count = (total >> shift) + 1;
        let mut buckets = Vec::with_capacity(count as usize + 1);
        let mut o = 0usize;
        for b in 0..=count {
            let first = b << shift;
            while o < ends.len() && ends[o] <= first {
                o += 1;
            }
            buckets.push(o as u32);
        }
        ObjectIndex {
            ends,
            buckets,
            shift,
        }
    }

    /// How many objects the index was made for.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// The first object whose end is past `triangle`: its owner, if any object owns it
    /// (the caller checks the object's start, as a triangle may fall in a gap).
    pub fn candidate(&self, triangle: u64) -> Option<usize> {
        let b = (triangle >> self.shift) as usize;
        if b + 1 >= self.buckets.len() {
            return None;
        }
        let (lo, hi) = (self.buckets[b] as usize, self.buckets[b + 1] as usize);
        // The owner ends past the triangle, so it is at most the first object reaching
        // into the next bucket.
        let hi = (hi + 1).min(self.ends.len());
        let k = lo + self.ends[lo..hi].partition_point(|&e| e <= triangle);
        (k < self.ends.len()).then_some(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn objects(ranges: &[(usize, usize)]) -> Vec<Object> {
        ranges
            .iter()
            .map(|&(first, count)| Object {
                name: String::new(),
                first,
                count,
                color: Vec3::ONE,
            })
            .collect()
    }

    /// The owner by the plain search, as `Scene::object_of` once did.
    fn searched(objects: &[Object], i: usize) -> Option<usize> {
        let k = objects.partition_point(|o| o.first + o.count <= i);
        (k < objects.len() && objects[k].range().contains(&i)).then_some(k)
    }

    fn owner(index: &ObjectIndex, objects: &[Object], i: usize) -> Option<usize> {
        index
            .candidate(i as u64)
            .filter(|&k| objects[k].range().contains(&i))
    }

    #[test]
    fn finds_the_owner_of_every_triangle_as_the_search_does() {
        let mut rng = crate::random::Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = |n: u64| rng.below(n) as usize;
        for case in 0..40 {
            // Objects of 1 to thousands of triangles, some with gaps between them.
            let (mut ranges, mut first) = (Vec::new(), next(5));
            for _ in 0..next(60) + (case % 3) {
                let count = if next(4) == 0 {
                    next(3000) + 1
                } else {
                    next(8) + 1
                };
                ranges.push((first, count));
                first += count + if next(5) == 0 { next(100) } else { 0 };
            }
            let objects = objects(&ranges);
            let index = ObjectIndex::new(&objects);
            assert_eq!(index.len(), objects.len());
            for i in 0..first + 50 {
                assert_eq!(
                    owner(&index, &objects, i),
                    searched(&objects, i),
                    "case {case}, {i}"
                );
            }
        }
    }

    #[test]
    fn large_triangle_numbers_and_no_objects() {
        let objects = objects(&[(0, 3), (5_000_000_000, 1), (5_000_000_001, 7_000_000_000)]);
        let index = ObjectIndex::new(&objects);
        for (i, want) in [
            (0usize, Some(0)),
            (3, None),
            (4_999_999_999, None),
            (5_000_000_000, Some(1)),
            (5_000_000_001, Some(2)),
            (12_000_000_000, Some(2)),
            (12_000_000_001, None),
        ] {
            assert_eq!(owner(&index, &objects, i), want, "{i}");
        }
        let none = ObjectIndex::new(&[]);
        assert!(none.is_empty());
        assert_eq!(none.candidate(0), None);
    }
}
