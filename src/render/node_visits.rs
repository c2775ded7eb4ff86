//! What a frame's rays did, counted per node of the structure's outline and per scene
//! triangle. Per node, the visits: the measured counterpart of the surface-area probability
//! SA(n)/SA(root), which predicts the share of rays that enter a node's box (the hierarchy
//! diagram colours and sizes its cells by it). Per triangle, the ray–triangle tests it
//! received: the measured counterpart of its share of the SAH cost (the "tests per
//! triangle" view). Each ray is traced with the recording sink, the same walk as the
//! frame's and the replay's, and its visits are mapped to the outline as the replay maps
//! them.

use super::{RayKind, RenderSettings, ray_of_kind};
use crate::accel::visit_index::VisitIndex;
use crate::accel::{Accel, Recorder, Step, Structure};
use crate::geometry::Intersector;
use crate::scene::Scene;
use rayon::prelude::*;

/// Visits per outline node, over `rays` rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeVisits {
    pub per_node: Vec<u64>,
    /// The rays traced: a frame's sampled pixels (for shadow rays, those whose primary ray
    /// hit something).
    pub rays: u64,
}

impl NodeVisits {
    /// All visits counted (of the outline's level: a two-level structure's top level).
    pub fn total(&self) -> u64 {
        self.per_node.iter().sum()
    }
}

/// What a tally counts: the visits per node of an outline of `nodes` nodes, and the
/// triangle tests per triangle of a scene of `triangles` triangles (0: not counted).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TallySize {
    pub nodes: usize,
    pub triangles: usize,
}

/// Visits per outline node and tests per scene triangle, over `rays` rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally {
    pub per_node: Vec<u64>,
    /// The ray–triangle tests each triangle received (a test the mailbox skipped is none),
    /// numbered as in the flattened scene.
    pub per_triangle: TriangleCounts,
    /// The rays traced: a frame's sampled pixels (for shadow rays, those whose primary ray
    /// hit something).
    pub rays: u64,
}

/// Scenes placing more triangles than this count only the triangles tested, not a zero for
/// each of the rest (the island places 10^10).
pub const EVERY_TRIANGLE_MAX: usize = 1 << 22;

/// Tests per triangle: a count for every triangle of the scene, or for a scene placing
/// more than `EVERY_TRIANGLE_MAX` only the tested triangles' counts.
#[derive(Clone, Debug, PartialEq)]
pub enum TriangleCounts {
    Every(Vec<u64>),
    Tested(std::collections::HashMap<u64, u64>),
}

impl Default for TriangleCounts {
    fn default() -> Self {
        TriangleCounts::Every(Vec::new())
    }
}

impl TriangleCounts {
    fn new(triangles: usize) -> Self {
        match triangles <= EVERY_TRIANGLE_MAX {
            true => TriangleCounts::Every(vec![0; triangles]),
            false => TriangleCounts::Tested(Default::default()),
        }
    }

    /// One test of triangle `t` (of a scene of `triangles`).
    fn count(&mut self, t: u64, triangles: usize) {
        match self {
            TriangleCounts::Every(v) => {
                if let Some(n) = usize::try_from(t).ok().and_then(|t| v.get_mut(t)) {
                    *n += 1;
                }
            }
            TriangleCounts::Tested(m) if t < triangles as u64 => *m.entry(t).or_default() += 1,
            TriangleCounts::Tested(_) => {}
        }
    }

    fn add(&mut self, b: &TriangleCounts) {
        match (self, b) {
            (TriangleCounts::Every(a), TriangleCounts::Every(b)) => {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
            }
            (TriangleCounts::Tested(a), TriangleCounts::Tested(b)) => {
                for (t, n) in b {
                    *a.entry(*t).or_default() += n;
                }
            }
            _ => {}
        }
    }

    /// The tests of triangle `t`.
    pub fn get(&self, t: u64) -> u64 {
        match self {
            TriangleCounts::Every(v) => usize::try_from(t)
                .ok()
                .and_then(|t| v.get(t))
                .copied()
                .unwrap_or(0),
            TriangleCounts::Tested(m) => m.get(&t).copied().unwrap_or(0),
        }
    }

    /// All tests counted.
    pub fn total(&self) -> u64 {
        match self {
            TriangleCounts::Every(v) => v.iter().sum(),
            TriangleCounts::Tested(m) => m.values().sum(),
        }
    }

    /// The triangles tested at least once.
    pub fn tested(&self) -> u64 {
        match self {
            TriangleCounts::Every(v) => v.iter().filter(|&&n| n > 0).count() as u64,
            TriangleCounts::Tested(m) => m.len() as u64,
        }
    }
}

impl Tally {
    fn empty(size: TallySize) -> Tally {
        Tally {
            per_node: vec![0; size.nodes],
            per_triangle: TriangleCounts::new(size.triangles),
            rays: 0,
        }
    }

    fn add(mut self, b: Tally) -> Tally {
        for (x, y) in self.per_node.iter_mut().zip(&b.per_node) {
            *x += y;
        }
        self.per_triangle.add(&b.per_triangle);
        self.rays += b.rays;
        self
    }
}

/// Counts the visits of the rays of every `stride`-th pixel, across and down, of the frame
/// `settings` describes, for an outline of `nodes` nodes. `None` if `abandon` says so
/// between rows.
pub fn node_visits<I: Intersector>(
    structure: &Structure,
    scene: &Scene,
    settings: &RenderSettings,
    rays: RayKind,
    stride: u32,
    nodes: usize,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<NodeVisits> {
    let size = TallySize {
        nodes,
        triangles: 0,
    };
    tally::<I>(structure, scene, settings, rays, stride, size, abandon).map(|t| NodeVisits {
        per_node: t.per_node,
        rays: t.rays,
    })
}

/// Counts what the rays of every `stride`-th pixel, across and down, of the frame
/// `settings` describes did: their visits per outline node and their tests per triangle,
/// as `size` asks. `None` if `abandon` says so between rows.
pub fn tally<I: Intersector>(
    structure: &Structure,
    scene: &Scene,
    settings: &RenderSettings,
    rays: RayKind,
    stride: u32,
    size: TallySize,
    abandon: &(dyn Fn() -> bool + Sync),
) -> Option<Tally> {
    let index = (size.nodes > 0).then(|| VisitIndex::of(structure));
    let stride = stride.max(1);
    let (width, height) = (settings.width.max(1), settings.height.max(1));
    let camera = settings.camera.rays(width, height);
    let rows: Vec<u32> = (0..height).step_by(stride as usize).collect();
    let empty = || Tally::empty(size);
    // Each thread counts into one tally of its own; the tallies are added at the end.
    let count_row = |mut out: Tally, y: u32| -> Option<Tally> {
        if abandon() {
            return None;
        }
        let mut recorder = Recorder::default();
        for x in (0..width).step_by(stride as usize) {
            let primary = camera.pixel_center(x, y);
            let Some(ray) = ray_of_kind::<I>(structure, scene, &primary, rays, settings.light)
            else {
                continue;
            };
            // One recorder per row, emptied for each ray: its steps' room is kept.
            recorder.steps.clear();
            recorder.counters = Default::default();
            match rays {
                RayKind::Primary => {
                    structure.closest_hit::<I, _>(&ray, &mut recorder);
                }
                RayKind::Shadow => {
                    structure.any_hit::<I, _>(&ray, &mut recorder);
                }
            }
            out.rays += 1;
            // A BLAS numbers its triangles from 0: the scene's number adds its instance's
            // first (as the replay numbers them).
            let mut first_triangle = 0u64;
            for step in &recorder.steps {
                if let Step::Instance { instance } = step {
                    first_triangle = structure
                        .instance_first_triangle(*instance as usize)
                        .unwrap_or(0);
                }
                if let Some(n) = index
                    .as_ref()
                    .and_then(|index| index.node(step))
                    .filter(|&n| (n as usize) < size.nodes)
                {
                    out.per_node[n as usize] += 1;
                }
                if let Step::Triangle { triangle, .. } = step
                    && size.triangles > 0
                {
                    out.per_triangle
                        .count(first_triangle + triangle, size.triangles);
                }
            }
        }
        Some(out)
    };
    rows.into_par_iter()
        .try_fold(empty, count_row)
        .try_reduce(empty, |a, b| Some(a.add(b)))
}
