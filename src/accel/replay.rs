//! The steps of one ray's traversal, as the lecture draws them: the node (or cell, or the
//! scene) visited, the children tested and which is taken first, the nodes pushed, popped,
//! and skipped because they start beyond the best hit so far, and each triangle test.
//!
//! Every structure's own traversal reports its steps to a `Recorder` (a statistics sink
//! that also counts), so a replay is the same walk as the counted and the fast ones.

use super::stats::{Counters, Stats};
use crate::geometry::Aabb;
use serde::Serialize;

/// What a visit step visits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Visited {
    /// An interior node of a tree.
    Node,
    /// A leaf of a tree (for a wide BVH, named by its first triangle slot).
    Leaf,
    /// A grid cell (named by its linear index).
    Cell,
    /// The whole scene: brute force's one step.
    Scene,
}

/// Which tree of the two levels a visit belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    /// A structure with one level.
    Single,
    /// The TLAS over the instances' world boxes.
    Top,
    /// The BLAS of the instance entered last, in its object space.
    Bottom,
}

/// Why the children of a node are taken in the order they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Order {
    /// Front to back: the child the ray enters first.
    Nearest,
    /// Naive order: the first child in memory, whatever the distances.
    Fixed,
    /// Any hit: the first hit ends the search, so the order is not worth a sort.
    AnyHit,
    /// The cells the ray passes through, in the order it enters them (k-d tree, octree).
    AlongRay,
}

impl Order {
    pub fn reason(self) -> &'static str {
        match self {
            Order::Nearest => "front to back: the ray enters it first",
            Order::Fixed => "naive order: first in memory",
            Order::AnyHit => "any hit: the first hit ends the search, order does not matter",
            Order::AlongRay => "the ray passes through it first",
        }
    }
}

/// A child box tested at an interior node: where the ray enters it, or `None` when it
/// misses it or enters it beyond the best hit so far; and the box itself (in the space of
/// its level), so a replay can draw the slab test of a missed child too.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Child {
    pub node: u32,
    pub leaf: bool,
    pub entry: Option<f32>,
    #[serde(serialize_with = "corners")]
    pub bounds: Aabb,
}

/// One step of a traversal.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Step {
    /// The ray against the box around everything (the root, the grid, the scene): one box
    /// test. `None`: it misses, and the query ends here.
    Bounds { entry: Option<f32> },
    /// A traversal step (one "nodes visited"): the node, cell or scene taken, with its box
    /// in its own space (object space for a BLAS), and where the ray enters and leaves it
    /// (filled in by the replay, which knows the ray).
    Visit {
        node: u32,
        what: Visited,
        level: Level,
        #[serde(serialize_with = "corners")]
        bounds: Aabb,
        entry: Option<f32>,
        exit: Option<f32>,
    },
    /// The child boxes of an interior node tested (one box test each), in the order they
    /// will be taken; `first` is the one taken next.
    Children {
        children: Vec<Child>,
        first: Option<u32>,
        order: Order,
    },
    /// k-d tree: the ray's distance to the node's split plane (one plane test); the near
    /// cell is taken, the far one kept for later if the ray reaches it before its exit
    /// and the best hit.
    Plane {
        axis: u8,
        t: f32,
        near: u32,
        far: Option<u32>,
    },
    /// Octree: the ray's distances to a cell's three mid planes (three plane tests) cut its
    /// interval into the octants it passes through, in order.
    Octants { children: Vec<Child> },
    /// Grid: the ray crosses the face on `axis` at `t` into the next cell (one plane test).
    Cross { axis: u8, t: f32 },
    /// Grid: the walk ends, as the next cell starts at `t`, beyond the best hit or the grid.
    Stop { t: f32 },
    /// A node kept for later, with the distance at which the ray enters it.
    Push { node: u32, leaf: bool, entry: f32 },
    /// A node taken from the stack to be visited (with its entry distance where the
    /// stack keeps it: an any-hit stack does not, as it never prunes).
    Pop {
        node: u32,
        leaf: bool,
        entry: Option<f32>,
    },
    /// A node taken from the stack and dropped: the ray enters it beyond the best hit so
    /// far (`best`), so nothing in it can be closer. The pruning of front-to-back order.
    Skip {
        node: u32,
        leaf: bool,
        entry: f32,
        best: f32,
    },
    /// Brute force with the early out: a triangle's own box against the ray (one box test).
    TriangleBox { triangle: u64, pierced: bool },
    /// A ray–triangle test (one triangle test) and the distance of its hit, if any; the
    /// triangle numbered as in the flattened scene.
    Triangle { triangle: u64, t: Option<f32> },
    /// A triangle this ray tested already in another cell, skipped by the mailbox.
    Mailboxed { triangle: u64 },
    /// Two levels: the ray enters instance `instance` (carried into its object space) and
    /// walks its BLAS.
    Instance { instance: u32 },
}

fn corners<S: serde::Serializer>(b: &Aabb, s: S) -> Result<S::Ok, S::Error> {
    [b.min.to_array(), b.max.to_array()].serialize(s)
}

impl Step {
    pub fn label(&self) -> &'static str {
        match self {
            Step::Bounds { .. } => "bounds",
            Step::Visit { .. } => "visit",
            Step::Children { .. } => "children",
            Step::Plane { .. } => "plane",
            Step::Octants { .. } => "octants",
            Step::Cross { .. } => "cross",
            Step::Stop { .. } => "stop",
            Step::Push { .. } => "push",
            Step::Pop { .. } => "pop",
            Step::Skip { .. } => "skip",
            Step::TriangleBox { .. } => "triangle_box",
            Step::Triangle { .. } => "triangle",
            Step::Mailboxed { .. } => "mailboxed",
            Step::Instance { .. } => "instance",
        }
    }

    /// The box (or plane) tests this step stands for.
    pub fn box_tests(&self) -> u32 {
        match self {
            Step::Bounds { .. } | Step::Plane { .. } | Step::Cross { .. } => 1,
            Step::TriangleBox { .. } => 1,
            Step::Children { children, .. } => children.len() as u32,
            Step::Octants { .. } => 3,
            _ => 0,
        }
    }

    pub fn is_visit(&self) -> bool {
        matches!(self, Step::Visit { .. })
    }

    pub fn is_triangle_test(&self) -> bool {
        matches!(self, Step::Triangle { .. })
    }

    /// A visit of `node`, its interval left for the replay to fill in.
    pub fn visit(node: usize, what: Visited, level: Level, bounds: Aabb) -> Step {
        Step::Visit {
            node: node as u32,
            what,
            level,
            bounds,
            entry: None,
            exit: None,
        }
    }
}

/// The entry distance as a step reports it: `None` for a miss (+∞).
pub fn entered(t: f32) -> Option<f32> {
    (t != f32::INFINITY).then_some(t)
}

/// A statistics sink that counts like `Counters` and keeps every step.
#[derive(Clone, Debug, Default)]
pub struct Recorder {
    pub counters: Counters,
    pub steps: Vec<Step>,
}

impl Stats for Recorder {
    const COUNTING: bool = true;
    const RECORDING: bool = true;
    fn node_visit(&mut self) {
        self.counters.node_visit();
    }
    fn box_tests(&mut self, n: u32) {
        self.counters.box_tests(n);
    }
    fn triangle_test(&mut self) {
        self.counters.triangle_test();
    }
    fn repeated_test(&mut self) {
        self.counters.repeated_test();
    }
    fn top_node_visit(&mut self) {
        self.counters.top_node_visit();
    }
    fn top_box_tests(&mut self, n: u32) {
        self.counters.top_box_tests(n);
    }
    fn instance_entered(&mut self) {
        self.counters.instance_entered();
    }
    fn absorb(&mut self, other: Recorder) {
        self.counters.absorb(other.counters);
        self.steps.extend(other.steps);
    }
    fn record(&mut self, step: Step) {
        self.steps.push(step);
    }
}

/// The counters a list of steps re-creates: one node visit per visit step, the box tests
/// each step stands for, one triangle test per triangle step (repeats are not told apart).
pub fn counters_of(steps: &[Step]) -> Counters {
    Counters {
        nodes_visited: steps.iter().filter(|s| s.is_visit()).count() as u32,
        box_tests: steps.iter().map(Step::box_tests).sum(),
        triangle_tests: steps.iter().filter(|s| s.is_triangle_test()).count() as u32,
        ..Counters::default()
    }
}
