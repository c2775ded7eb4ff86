//! Statistics sinks: the same traversal code counts the work it does when given `Counters`,
//! and compiles the counting away when given the zero-sized `NoStats`. A `Recorder` (see
//! `replay`) also keeps every step, so the replay of a ray comes from the same code.

use super::replay::Step;
use std::ops::AddAssign;

pub trait Stats: Default {
    /// Whether this sink records anything: structures skip bookkeeping that only feeds the
    /// counters (such as noting repeated tests with mailboxing off) when it does not.
    const COUNTING: bool;
    /// A traversal step: a node (or, for brute force, the scene; for a grid, a cell) was
    /// taken and processed.
    fn node_visit(&mut self);
    /// `n` ray–box slab tests (or ray–plane distance tests) were done.
    fn box_tests(&mut self, n: u32);
    /// One ray–triangle test was done.
    fn triangle_test(&mut self);
    /// The triangle about to be tested was tested before by the same ray: a structure that
    /// references a triangle from several cells repeats the test unless it mailboxes.
    fn repeated_test(&mut self);
    /// A step in the top level of a two-level structure: counted as a node visit and, by
    /// sinks that split the levels, as a top-level one.
    #[inline(always)]
    fn top_node_visit(&mut self) {
        self.node_visit();
    }
    /// `n` box tests in the top level (counted as box tests, and split as above).
    #[inline(always)]
    fn top_box_tests(&mut self, n: u32) {
        self.box_tests(n);
    }
    /// The ray was carried into an instance's space to walk its bottom-level structure.
    #[inline(always)]
    fn instance_entered(&mut self) {}
    /// Adds the counts of `other`: a query counts into a sink of its own, which stays in
    /// registers while it runs, and adds it to the caller's once at the end.
    fn absorb(&mut self, other: Self);
    /// Whether this sink keeps the traversal's steps (the replay): structures build a
    /// `Step` only when it does, so the other sinks pay nothing for it.
    const RECORDING: bool = false;
    /// One step of the traversal, in the order it happened.
    #[inline(always)]
    fn record(&mut self, _step: Step) {}
}

/// Hands `step()` to a recording sink; compiled away for the others.
#[inline(always)]
pub fn record<S: Stats>(stats: &mut S, step: impl FnOnce() -> Step) {
    if S::RECORDING {
        stats.record(step());
    }
}

/// Runs `query` with a sink of its own, which stays in registers while the query runs, and
/// adds its counts to `stats` once at the end: how every structure's traversal counts.
#[inline(always)]
pub fn count_locally<S: Stats, R>(stats: &mut S, query: impl FnOnce(&mut S) -> R) -> R {
    let mut local = S::default();
    let result = query(&mut local);
    stats.absorb(local);
    result
}

/// Counts nothing and costs nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl Stats for NoStats {
    const COUNTING: bool = false;
    #[inline(always)]
    fn node_visit(&mut self) {}
    #[inline(always)]
    fn box_tests(&mut self, _n: u32) {}
    #[inline(always)]
    fn triangle_test(&mut self) {}
    #[inline(always)]
    fn repeated_test(&mut self) {}
    #[inline(always)]
    fn absorb(&mut self, _: NoStats) {}
}

/// The lecture's measures of work for one ray (or a sum over many).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub nodes_visited: u32,
    pub box_tests: u32,
    pub triangle_tests: u32,
    /// Triangle tests that repeated a test the same ray had already done (included in
    /// `triangle_tests`); always 0 for structures that reference each triangle once, and
    /// for spatial structures with mailboxing on.
    pub repeated_tests: u32,
    /// Of `nodes_visited` and `box_tests`, those in the top level of a two-level structure
    /// (the rest were in its bottom levels); 0 for every other structure.
    pub top_nodes_visited: u32,
    pub top_box_tests: u32,
    /// Instances whose bottom-level structure the ray walked.
    pub instances_entered: u32,
}

impl Stats for Counters {
    const COUNTING: bool = true;
    #[inline(always)]
    fn node_visit(&mut self) {
        self.nodes_visited += 1;
    }
    #[inline(always)]
    fn box_tests(&mut self, n: u32) {
        self.box_tests += n;
    }
    #[inline(always)]
    fn triangle_test(&mut self) {
        self.triangle_tests += 1;
    }
    #[inline(always)]
    fn repeated_test(&mut self) {
        self.repeated_tests += 1;
    }
    #[inline(always)]
    fn top_node_visit(&mut self) {
        self.nodes_visited += 1;
        self.top_nodes_visited += 1;
    }
    #[inline(always)]
    fn top_box_tests(&mut self, n: u32) {
        self.box_tests += n;
        self.top_box_tests += n;
    }
    #[inline(always)]
    fn instance_entered(&mut self) {
        self.instances_entered += 1;
    }
    #[inline(always)]
    fn absorb(&mut self, other: Counters) {
        *self += other;
    }
}

/// Nothing was counted: all zeros.
impl From<NoStats> for Counters {
    fn from(_: NoStats) -> Counters {
        Counters::default()
    }
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.nodes_visited += o.nodes_visited;
        self.box_tests += o.box_tests;
        self.triangle_tests += o.triangle_tests;
        self.repeated_tests += o.repeated_tests;
        self.top_nodes_visited += o.top_nodes_visited;
        self.top_box_tests += o.top_box_tests;
        self.instances_entered += o.instances_entered;
    }
}

impl Counters {
    /// One of the counters, chosen by a heatmap mode.
    pub fn get(&self, which: Counter) -> u32 {
        match which {
            Counter::NodesVisited => self.nodes_visited,
            Counter::BoxTests => self.box_tests,
            Counter::TriangleTests => self.triangle_tests,
            Counter::RepeatedTests => self.repeated_tests,
            Counter::TopNodesVisited => self.top_nodes_visited,
            Counter::BottomNodesVisited => self.nodes_visited - self.top_nodes_visited,
            Counter::InstancesEntered => self.instances_entered,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Counter {
    NodesVisited,
    BoxTests,
    TriangleTests,
    RepeatedTests,
    /// Two-level structures: the nodes visited in the top level, in the bottom levels, and
    /// the instances entered.
    TopNodesVisited,
    BottomNodesVisited,
    InstancesEntered,
}

impl Counter {
    pub const ALL: [Counter; 7] = [
        Counter::NodesVisited,
        Counter::BoxTests,
        Counter::TriangleTests,
        Counter::RepeatedTests,
        Counter::TopNodesVisited,
        Counter::BottomNodesVisited,
        Counter::InstancesEntered,
    ];

    /// Whether the counter splits the levels of a two-level structure (always 0 or the
    /// whole count for the others).
    pub fn is_two_level(self) -> bool {
        matches!(
            self,
            Counter::TopNodesVisited | Counter::BottomNodesVisited | Counter::InstancesEntered
        )
    }

    pub fn label(self) -> &'static str {
        match self {
            Counter::NodesVisited => "nodes visited",
            Counter::BoxTests => "box tests",
            Counter::TriangleTests => "triangle tests",
            Counter::RepeatedTests => "repeated triangle tests",
            Counter::TopNodesVisited => "top-level nodes visited",
            Counter::BottomNodesVisited => "bottom-level nodes visited",
            Counter::InstancesEntered => "instances entered",
        }
    }
}
