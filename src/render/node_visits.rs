//! The nodes a frame's rays visit, counted per node of the structure's outline: the
//! measured counterpart of the surface-area probability SA(n)/SA(root), which predicts the
//! share of rays that enter a node's box. The hierarchy diagram colours and sizes its cells
//! by it. Each ray is traced with the recording sink, the same walk as the frame's and the
//! replay's, and its visits are mapped to the outline as the replay maps them.

use super::{RayKind, RenderSettings, shadow_ray};
use crate::accel::visit_index::VisitIndex;
use crate::accel::{Accel, NoStats, Recorder, Structure};
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
    let index = VisitIndex::of(structure);
    let stride = stride.max(1);
    let (width, height) = (settings.width.max(1), settings.height.max(1));
    let camera = settings.camera.rays(width, height);
    let rows: Vec<u32> = (0..height).step_by(stride as usize).collect();
    let empty = || NodeVisits {
        per_node: vec![0; nodes],
        rays: 0,
    };
    // Each thread counts into one tally of its own; the tallies are added at the end.
    let count_row = |mut out: NodeVisits, y: u32| -> Option<NodeVisits> {
        if abandon() {
            return None;
        }
        for x in (0..width).step_by(stride as usize) {
            let primary = camera.pixel_center(x, y);
            let ray = match rays {
                RayKind::Primary => primary,
                RayKind::Shadow => {
                    let hit = structure.closest_hit::<I, _>(&primary, &mut NoStats);
                    let Some((hit, tri)) = hit.and_then(|h| Some((h, scene.triangle(h.triangle)?)))
                    else {
                        continue;
                    };
                    let normal = tri.facing_normal(primary.direction);
                    shadow_ray(&tri, normal, &hit, settings.light)
                }
            };
            let mut recorder = Recorder::default();
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
                if let Some(n) = index.node(step).filter(|&n| (n as usize) < nodes) {
                    out.per_node[n as usize] += 1;
                }
            }
        }
        Some(out)
    };
    rows.into_par_iter()
        .try_fold(empty, count_row)
        .try_reduce(empty, |mut a, b| {
            for (x, y) in a.per_node.iter_mut().zip(&b.per_node) {
                *x += y;
            }
            a.rays += b.rays;
            Some(a)
        })
}
