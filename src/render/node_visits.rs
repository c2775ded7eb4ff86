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
    pub per_triangle: Vec<u64>,
    /// The rays traced: a frame's sampled pixels (for shadow rays, those whose primary ray
    /// hit something).
    pub rays: u64,
}

impl Tally {
    fn empty(size: TallySize) -> Tally {
        Tally {
            per_node: vec![0; size.nodes],
            per_triangle: vec![0; size.triangles],
            rays: 0,
        }
    }

    fn add(mut self, b: Tally) -> Tally {
        for (x, y) in self.per_node.iter_mut().zip(&b.per_node) {
            *x += y;
        }
        for (x, y) in self.per_triangle.iter_mut().zip(&b.per_triangle) {
            *x += y;
        }
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
            for step in &recorder.steps {
                if let Some(n) = index
                    .as_ref()
                    .and_then(|index| index.node(step))
                    .filter(|&n| (n as usize) < size.nodes)
                {
                    out.per_node[n as usize] += 1;
                }
                if let Step::Triangle { triangle, .. } = step
                    && let Some(t) = usize::try_from(*triangle)
                        .ok()
                        .and_then(|t| out.per_triangle.get_mut(t))
                {
                    *t += 1;
                }
            }
        }
        Some(out)
    };
    rows.into_par_iter()
        .try_fold(empty, count_row)
        .try_reduce(empty, |a, b| Some(a.add(b)))
}
