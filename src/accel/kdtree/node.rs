//! The compact k-d tree node (pbrt's layout): 8 bytes, the split position or a leaf's
//! triangle (or its first reference) in one word, the axis or leaf flag and the above
//! child's index or the leaf's reference count in the other.

/// Low two bits of `flags`: 0, 1, 2 = split axis of an interior node, 3 = leaf.
const LEAF: u32 = 3;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct KdNode {
    /// Interior: the split position's bits. Leaf with one reference: the triangle; leaf
    /// with more: the offset of its references in `KdTree::refs`.
    word: u32,
    /// `above_child << 2 | axis`, or `count << 2 | 3` for a leaf.
    flags: u32,
}

impl KdNode {
    /// An interior node; its below child is the next node.
    pub fn interior(axis: usize, split: f32, above_child: u32) -> Self {
        debug_assert!(axis < 3 && above_child < (1 << 30));
        KdNode {
            word: split.to_bits(),
            flags: (above_child << 2) | axis as u32,
        }
    }

    /// A leaf: `word` is the single triangle if `count` is 1, else the references' offset.
    pub fn leaf(word: u32, count: u32) -> Self {
        debug_assert!(count < (1 << 30));
        KdNode {
            word,
            flags: (count << 2) | LEAF,
        }
    }

    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.flags & 3 == LEAF
    }

    #[inline(always)]
    pub fn axis(&self) -> usize {
        (self.flags & 3) as usize
    }

    #[inline(always)]
    pub fn split(&self) -> f32 {
        f32::from_bits(self.word)
    }

    #[inline(always)]
    pub fn above_child(&self) -> usize {
        (self.flags >> 2) as usize
    }

    /// A leaf's reference count.
    #[inline(always)]
    pub fn count(&self) -> u32 {
        self.flags >> 2
    }

    /// A leaf's references: the inline triangle, or a range of `refs`.
    #[inline(always)]
    pub fn leaf_refs<'a>(&'a self, refs: &'a [u32]) -> &'a [u32] {
        let n = self.count() as usize;
        if n == 1 {
            std::slice::from_ref(&self.word)
        } else {
            let first = self.word as usize;
            &refs[first..first + n]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packs_interior_and_leaf_nodes_into_eight_bytes() {
        assert_eq!(std::mem::size_of::<KdNode>(), 8);
        let n = KdNode::interior(2, -1.5, 12345);
        assert!(!n.is_leaf());
        assert_eq!((n.axis(), n.split(), n.above_child()), (2, -1.5, 12345));
        let refs = [7, 8, 9];
        let one = KdNode::leaf(42, 1);
        assert!(one.is_leaf());
        assert_eq!(one.leaf_refs(&refs), &[42]);
        let many = KdNode::leaf(1, 2);
        assert_eq!(many.leaf_refs(&refs), &[8, 9]);
        assert_eq!(KdNode::leaf(0, 0).leaf_refs(&refs), &[] as &[u32]);
    }
}
