//! The stack of a wide traversal (a wide BVH's own, or the two levels' 8-wide top level):
//! children still to visit with their entry distances, left uninitialised, the top few
//! sorted nearest first.

use super::node::{MAX_LEAF_COUNT, Subtree};
use crate::accel::bvh::build::{MAX_DEPTH, MAX_LEAF_SIZE};
use std::mem::MaybeUninit;

/// A child still to visit, as its parent's lane names it (a node, or a leaf's triangles),
/// and the distance at which the ray enters its box.
#[derive(Clone, Copy)]
pub(crate) struct Entry {
    pub child: Subtree,
    pub entry: f32,
}

/// Each level leaves at most W − 1 ≤ 7 children on the stack, and no wide tree is deeper
/// than the BVH2 it was collapsed from but for the levels a leaf larger than a lane holds
/// adds (`collapse`).
pub(crate) const STACK_SIZE: usize = 7 * (MAX_DEPTH + LARGE_LEAF_LEVELS) + 1;

/// The levels of the subtree a BVH2 leaf of `MAX_LEAF_SIZE` triangles becomes, four lanes
/// to a node (the narrowest tree, so the deepest).
const LARGE_LEAF_LEVELS: usize = {
    let leaves = MAX_LEAF_SIZE.div_ceil(MAX_LEAF_COUNT) as usize;
    let (mut levels, mut held) = (0, 1);
    while held < leaves {
        held *= 4;
        levels += 1;
    }
    levels
};

/// The traversal stack, left uninitialised: a BVH8 stack is 8 KiB, and clearing it for
/// every ray would cost more than many rays' whole traversal. Its storage is a local of the
/// traversal (`MaybeUninit` inside a struct value was measured to be zeroed anyway). A
/// packet's stack holds its own entries (`T`), which carry the rays of each child.
pub(crate) struct Stack<'a, T: Copy = Entry> {
    storage: &'a mut MaybeUninit<[T; STACK_SIZE]>,
    len: usize,
}

impl<'a, T: Copy> Stack<'a, T> {
    #[inline(always)]
    pub(crate) fn new(storage: &'a mut MaybeUninit<[T; STACK_SIZE]>) -> Self {
        Stack { storage, len: 0 }
    }

    #[inline(always)]
    fn slots(&mut self) -> *mut T {
        self.storage.as_mut_ptr().cast()
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, e: T) {
        assert!(self.len < STACK_SIZE);
        // SAFETY: in bounds (checked above); writing needs no initialised value.
        unsafe { self.slots().add(self.len).write(e) };
        self.len += 1;
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push` and not popped since.
        Some(unsafe { self.slots().add(self.len).read() })
    }
}

impl Stack<'_> {
    /// Orders the top `n` entries so the nearest is on top (insertion sort: n ≤ 8).
    #[inline(always)]
    pub(crate) fn sort_top(&mut self, n: usize) {
        let base = self.len - n;
        // SAFETY: the top n entries were just pushed, so they are initialised and in bounds.
        let top = unsafe { std::slice::from_raw_parts_mut(self.slots().add(base), n) };
        for i in 1..top.len() {
            let e = top[i];
            let mut j = i;
            while j > 0 && top[j - 1].entry < e.entry {
                top[j] = top[j - 1];
                j -= 1;
            }
            top[j] = e;
        }
    }
}

/// The entry distances of a node's W children, which the slab kernel writes with one vector
/// store and the walk then reads lane by lane. Aligned to the vector, so that the store never
/// straddles two cache lines: a straddling store cannot be forwarded to the loads after it,
/// and where a plain array fell in the walk's frame depended on its callers' frames. Two
/// builds that differed only in a caller gave the bench's primary rays on two threads 20 %
/// apart (docs/wide-bvh.md, "A measurement hazard, found").
#[repr(C, align(32))]
pub(crate) struct EntryRow<const W: usize>(pub(crate) [f32; W]);

// The row must take one vector store without straddling a line: at least the widest (8 × f32).
const _: () = assert!(std::mem::align_of::<EntryRow<8>>() >= 32);
