//! The structure's parameters as controls: one editor function per parameter struct of the
//! library (`BuildParams`, `KdParams`, `GridParams`, `OctreeParams`) and one for the whole
//! `StructureParams`. The same structs are the CLI's flags and the presets' keys, so a
//! parameter has one definition; its control is added here.

use crate::accel::bvh::build::{
    MAX_BUCKETS, MAX_LEAF_SIZE, MAX_OVERLAP_PENALTY, MAX_REBRAID, MAX_SPLIT_BUDGET,
    MAX_TREELET_ROUNDS, MAX_TREELET_SIZE, MIN_BUCKETS, MIN_TREELET_SIZE,
};
use crate::accel::bvh::{BuildParams, Strategy, TraversalOrder};
use crate::accel::grid::GridParams;
use crate::accel::kdtree::{KdParams, KdSplit, MAX_DEPTH as KD_MAX_DEPTH, MIN_BINS as KD_MIN_BINS};
use crate::accel::octree::{MAX_DEPTH as OCTREE_MAX_DEPTH, OctreeParams};
use crate::accel::{AccelKind, StructureParams};
use crate::geometry::simd::SimdLevel;
use eframe::egui;

/// The structure selector and the parameters of the chosen structure.
pub fn structure_params(ui: &mut egui::Ui, p: &mut StructureParams) {
    // The layout this machine traces fastest says so (the default of a fresh start).
    let selected = if p.kind == AccelKind::fastest() {
        format!("{} (fastest here)", p.kind.title())
    } else {
        p.kind.title().to_string()
    };
    egui::ComboBox::from_label("structure")
        .selected_text(selected)
        .show_ui(ui, |ui| {
            for kind in AccelKind::ALL {
                ui.selectable_value(&mut p.kind, kind, kind.title());
            }
        });
    if p.kind.is_spatial() {
        ui.checkbox(
            &mut p.mailbox,
            "mailboxing (test each triangle once per ray)",
        );
    }
    match p.kind {
        AccelKind::Bvh | AccelKind::TwoLevel => {
            bvh_params(ui, &mut p.bvh, p.kind.places_instances());
            traversal_order(ui, &mut p.order);
        }
        AccelKind::Bvh4 | AccelKind::Bvh8 => {
            bvh_params(ui, &mut p.bvh, false);
            traversal_order(ui, &mut p.order);
            simd_level(ui, &mut p.simd);
        }
        AccelKind::KdTree => kd_params(ui, &mut p.kdtree),
        AccelKind::Grid => grid_params(ui, &mut p.grid),
        AccelKind::Octree => octree_params(ui, &mut p.octree),
        AccelKind::BruteForce | AccelKind::BruteForceBbox => {}
    }
}

/// The BVH builders' parameters; each slider is enabled for the builders that use it. The
/// re-braiding budget is shown for the two-level structure only.
pub fn bvh_params(ui: &mut egui::Ui, p: &mut BuildParams, two_level: bool) {
    ui.label("split strategy");
    for strategy in Strategy::ALL {
        let label = match strategy {
            Strategy::Sbvh => "SBVH (spatial splits)",
            s => s.label(),
        };
        ui.radio_value(&mut p.strategy, strategy, label);
    }
    ui.add_enabled(
        matches!(p.strategy, Strategy::SahBinned | Strategy::Sbvh),
        egui::Slider::new(&mut p.buckets, MIN_BUCKETS..=MAX_BUCKETS)
            .logarithmic(true)
            .text("buckets B"),
    );
    let treelets = p.strategy == Strategy::LbvhTreelet;
    ui.add_enabled(
        treelets,
        egui::Slider::new(&mut p.treelet_size, MIN_TREELET_SIZE..=MAX_TREELET_SIZE)
            .text("treelet size n"),
    );
    ui.add_enabled(
        treelets,
        egui::Slider::new(&mut p.treelet_rounds, 0..=MAX_TREELET_ROUNDS).text("treelet rounds"),
    );
    let sbvh = p.strategy == Strategy::Sbvh;
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut p.split_alpha, 1e-8..=1.0)
            .logarithmic(true)
            .text("overlap threshold α"),
    )
    .on_hover_text(
        "spatial splits only where the object split's children overlap by more than α × \
         the root's area",
    );
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut p.overlap_penalty, 0.0..=MAX_OVERLAP_PENALTY)
            .text("overlap penalty κ"),
    )
    .on_hover_text(
        "weighed against a spatial split, an object split costs × (1 + κ × its children's \
         overlap / the node's area): 0 = the plain SAH",
    );
    ui.add_enabled(
        sbvh,
        egui::Slider::new(&mut p.split_budget, 0.0..=MAX_SPLIT_BUDGET).text("split budget × N"),
    )
    .on_hover_text("at most this many duplicated references, per triangle");
    ui.add_enabled(
        p.strategy.takes_presplit(),
        egui::Slider::new(&mut p.presplit, 0.0..=MAX_SPLIT_BUDGET).text("pre-split budget × N"),
    )
    .on_hover_text("extra references for the triangles that waste most box area (0 = off)");
    if two_level {
        ui.add(
            egui::Slider::new(&mut p.rebraid, 0.0..=MAX_REBRAID)
                .logarithmic(true)
                .text("re-braiding budget per instance"),
        )
        .on_hover_text(
            "the top level opens the largest instances into references to their BLAS's \
             subtrees, up to this many extra references per instance, counting at least \
             40 960 instances (0 = whole instances)",
        );
    }
    ui.add(
        egui::Slider::new(&mut p.max_leaf_size, 1..=MAX_LEAF_SIZE.min(64)).text("max leaf size"),
    );
    ui.add(egui::Slider::new(&mut p.c_trav, 0.0..=10.0).text("C_trav"));
    ui.add(egui::Slider::new(&mut p.c_isect, 0.05..=10.0).text("C_isect"));
}

/// Front-to-back or the naive order (a traversal setting: no rebuild).
pub fn traversal_order(ui: &mut egui::Ui, order: &mut TraversalOrder) {
    let mut naive = *order == TraversalOrder::Naive;
    if ui
        .checkbox(&mut naive, "naive traversal order (no front-to-back)")
        .changed()
    {
        *order = if naive {
            TraversalOrder::Naive
        } else {
            TraversalOrder::FrontToBack
        };
    }
}

/// The wide BVHs' slab kernel, among those this CPU has.
pub fn simd_level(ui: &mut egui::Ui, simd: &mut SimdLevel) {
    egui::ComboBox::from_label("SIMD kernel")
        .selected_text(simd.label())
        .show_ui(ui, |ui| {
            for level in SimdLevel::available() {
                ui.selectable_value(simd, level, level.label());
            }
        });
}

pub fn kd_params(ui: &mut egui::Ui, p: &mut KdParams) {
    ui.add(egui::Slider::new(&mut p.c_trav, 0.0..=10.0).text("C_trav"));
    ui.add(
        egui::Slider::new(&mut p.c_isect, 0.05..=100.0)
            .logarithmic(true)
            .text("C_isect"),
    );
    ui.add(egui::Slider::new(&mut p.empty_bonus, 0.0..=0.95).text("empty bonus"));
    ui.add(
        egui::Slider::new(&mut p.max_depth, 0..=KD_MAX_DEPTH)
            .text("depth bound (0: 8 + 1.3 log2 N)"),
    );
    ui.add(egui::Slider::new(&mut p.max_leaf_size, 1..=64).text("max leaf size"));
    let mut sweep = p.split == KdSplit::Sweep;
    if ui
        .checkbox(&mut sweep, "perfect splits by exact event sweep")
        .changed()
    {
        p.split = if sweep {
            KdSplit::Sweep
        } else {
            KdSplit::Binned(32)
        };
    }
    if let KdSplit::Binned(bins) = &mut p.split {
        ui.add(
            egui::Slider::new(bins, KD_MIN_BINS..=256)
                .logarithmic(true)
                .text("bins"),
        );
    }
}

pub fn grid_params(ui: &mut egui::Ui, p: &mut GridParams) {
    ui.add(
        egui::Slider::new(&mut p.lambda, 1.0 / 16.0..=64.0)
            .logarithmic(true)
            .text("λ (cells ≈ λ·N)"),
    );
}

pub fn octree_params(ui: &mut egui::Ui, p: &mut OctreeParams) {
    ui.add(egui::Slider::new(&mut p.max_leaf_size, 1..=64).text("max leaf size"));
    ui.add(egui::Slider::new(&mut p.max_depth, 0..=OCTREE_MAX_DEPTH).text("max depth"));
}
