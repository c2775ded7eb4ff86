//! What a build produced, in the lecture's measures: node counts, depth, leaf sizes, the SAH
//! cost of the tree and its memory.

use super::Bvh;
use super::build::BuildParams;
use crate::accel::report::Detail;
use std::time::Duration;

/// Shape statistics of a tree, recomputed after a refit as well.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeStats {
    pub nodes: usize,
    pub leaves: usize,
    pub max_leaf_depth: u32,
    pub mean_leaf_depth: f64,
    /// `leaf_size_histogram[k]` = number of leaves with k triangles.
    pub leaf_size_histogram: Vec<usize>,
    pub sah_cost: f64,
    pub bytes: usize,
}

impl TreeStats {
    pub fn new(bvh: &Bvh, c_trav: f32, c_isect: f32) -> Self {
        let depths = bvh.node_depths();
        let mut histogram = Vec::new();
        let (mut leaves, mut max_depth, mut depth_sum) = (0usize, 0u32, 0u64);
        for (n, &d) in bvh.nodes.iter().zip(&depths) {
            if n.is_leaf() {
                leaves += 1;
                max_depth = max_depth.max(d);
                depth_sum += d as u64;
                let size = n.count as usize;
                if histogram.len() <= size {
                    histogram.resize(size + 1, 0);
                }
                histogram[size] += 1;
            }
        }
        TreeStats {
            nodes: bvh.nodes.len(),
            leaves,
            max_leaf_depth: max_depth,
            mean_leaf_depth: depth_sum as f64 / leaves.max(1) as f64,
            leaf_size_histogram: histogram,
            sah_cost: bvh.sah_cost(c_trav, c_isect),
            bytes: bvh.bytes(),
        }
    }
}

/// Where a multi-pass build spent its time, and how treelet restructuring lowered the SAH
/// cost round by round. Empty for the top-down builders, which are one recursion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildPhases {
    /// (phase, time) in the order they ran.
    pub times: Vec<(String, Duration)>,
    /// The SAH cost of the LBVH before the first treelet round.
    pub sah_before_rounds: Option<f64>,
    /// The SAH cost after each treelet round.
    pub sah_after_round: Vec<f64>,
    /// SBVH: nodes split by a spatial split, and straddling references sent whole to one
    /// side by reference unsplitting.
    pub spatial_splits: Option<(usize, usize)>,
}

impl BuildPhases {
    pub fn add(&mut self, phase: &str, time: Duration) {
        self.times.push((phase.to_string(), time));
    }

    /// One ("time: phase", "x ms") row per phase.
    pub fn time_rows(&self) -> impl Iterator<Item = (String, Detail)> + '_ {
        self.times
            .iter()
            .map(|(phase, time)| (format!("time: {phase}"), Detail::Time(*time)))
    }

    pub fn add_round(&mut self, time: Duration, sah_cost: f64) {
        self.sah_after_round.push(sah_cost);
        let round = self.sah_after_round.len();
        self.add(&format!("treelet round {round}"), time);
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct BuildReport {
    pub params: BuildParams,
    pub triangles: usize,
    /// Triangle references in the leaves: more than `triangles` when spatial splits or
    /// pre-splitting duplicated some.
    pub references: usize,
    pub build_time: Duration,
    pub tree: TreeStats,
    pub phases: BuildPhases,
}

impl BuildReport {
    pub fn new(bvh: &Bvh, params: &BuildParams, build_time: Duration) -> Self {
        BuildReport {
            params: *params,
            triangles: bvh.triangle_count,
            references: bvh.prim_indices.len(),
            build_time,
            tree: TreeStats::new(bvh, params.c_trav, params.c_isect),
            phases: BuildPhases::default(),
        }
    }

    /// References beyond one per triangle.
    pub fn duplicated_references(&self) -> usize {
        self.references.saturating_sub(self.triangles)
    }

    pub fn build_ms(&self) -> f64 {
        self.build_time.as_secs_f64() * 1e3
    }

    /// The report as (label, value) rows, for the CLI table and the app's stats panel.
    pub fn rows(&self) -> Vec<(String, String)> {
        let p = &self.params;
        let t = &self.tree;
        let mut rows = vec![("strategy".to_string(), p.strategy.label().to_string())];
        // The SBVH's object splits are binned SAH's.
        if matches!(
            p.strategy,
            super::Strategy::SahBinned | super::Strategy::Sbvh
        ) {
            rows.push(("buckets B".into(), p.buckets.to_string()));
        }
        if p.strategy == super::Strategy::LbvhTreelet {
            rows.push(("treelet size n".into(), p.treelet_size.to_string()));
            rows.push(("treelet rounds".into(), p.treelet_rounds.to_string()));
        }
        if p.strategy == super::Strategy::Sbvh {
            rows.push(("overlap threshold α".into(), format!("{:e}", p.split_alpha)));
            rows.push(("overlap penalty κ".into(), p.overlap_penalty.to_string()));
            rows.push(("split budget".into(), format!("{} × N", p.split_budget)));
        }
        if p.strategy.takes_presplit() && p.presplit > 0.0 {
            rows.push(("pre-split budget".into(), format!("{} × N", p.presplit)));
        }
        rows.extend([
            ("max leaf size".into(), p.max_leaf_size.to_string()),
            (
                "C_trav / C_isect".into(),
                format!("{} / {}", p.c_trav, p.c_isect),
            ),
            ("triangles".into(), self.triangles.to_string()),
            (
                "duplicated references".into(),
                format!(
                    "{} (+{:.1} %)",
                    self.duplicated_references(),
                    100.0 * self.duplicated_references() as f64 / self.triangles.max(1) as f64
                ),
            ),
            ("build time".into(), format!("{:.2} ms", self.build_ms())),
            ("nodes".into(), t.nodes.to_string()),
            ("leaves".into(), t.leaves.to_string()),
            ("max leaf depth".into(), t.max_leaf_depth.to_string()),
            (
                "mean leaf depth".into(),
                format!("{:.2}", t.mean_leaf_depth),
            ),
            ("SAH cost".into(), format!("{:.3}", t.sah_cost)),
            (
                "memory".into(),
                format!("{:.2} MiB", t.bytes as f64 / (1024.0 * 1024.0)),
            ),
        ]);
        let hist: Vec<String> = t
            .leaf_size_histogram
            .iter()
            .enumerate()
            .filter(|&(_, &c)| c > 0)
            .map(|(size, c)| format!("{size}:{c}"))
            .collect();
        rows.push(("leaf sizes (size:count)".into(), hist.join(" ")));
        rows.push(("threads".into(), rayon::current_num_threads().to_string()));
        rows.extend((self.phases.time_rows()).map(|(k, v)| (k, v.to_string())));
        if let Some(before) = self.phases.sah_before_rounds {
            rows.push(("SAH cost before treelets".into(), format!("{before:.3}")));
        }
        if let Some((spatial, unsplit)) = self.phases.spatial_splits {
            rows.push(("spatial splits".into(), spatial.to_string()));
            rows.push(("unsplit references".into(), unsplit.to_string()));
        }
        for (k, cost) in self.phases.sah_after_round.iter().enumerate() {
            rows.push((
                format!("SAH cost after round {}", k + 1),
                format!("{cost:.3}"),
            ));
        }
        rows
    }
}

impl BuildReport {
    /// The measures every structure reports, with this report's rows as details.
    pub fn summary(&self, bvh: &Bvh) -> crate::accel::StructureReport {
        let t = &self.tree;
        let empty = t.leaf_size_histogram.first().copied().unwrap_or(0);
        let rows = self.rows();
        let skip = [
            "triangles",
            "build time",
            "memory",
            "nodes",
            "leaves",
            "max leaf depth",
        ];
        crate::accel::StructureReport {
            structure: "bvh",
            triangles: self.triangles,
            build_time: self.build_time,
            bytes: t.bytes,
            nodes: t.nodes,
            leaves: t.leaves,
            empty_leaves: empty,
            max_depth: t.max_leaf_depth,
            references: bvh.prim_indices.len(),
            largest_leaf: t.leaf_size_histogram.len().saturating_sub(1),
            details: rows
                .into_iter()
                .filter(|(k, _)| !skip.contains(&k.as_str()))
                .map(|(k, v)| (k, v.into()))
                .collect(),
            caps_hit: Vec::new(),
        }
    }
}
