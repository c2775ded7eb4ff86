//! `bvhlab render --tree`: the structure's tree as a hierarchy (icicle) diagram in a PNG,
//! with an SVG beside it.

use super::render::RenderArgs;
use anyhow::{Result, bail};
use bvhlab::accel::AccelKind;
use bvhlab::accel::hierarchy;
use bvhlab::bench::plot::{self, icicle::Icicle};
use bvhlab::render::node_visits::node_visits;
use bvhlab::render::{RayKind, RenderSettings};
use bvhlab::scene::Scene;
use bvhlab::with_intersector;
use std::path::Path;

/// Cells narrower than this many pixels are drawn folded, their subtrees left out.
const FOLD_PX: f64 = 1.5;
/// Rows are at least this tall; deeper rows are folded.
const MIN_ROW_PX: u32 = 3;

pub fn run(scene: &Scene, args: &RenderArgs, settings: &RenderSettings, out: &Path) -> Result<()> {
    let accel = args.build.accel_for(scene).kind()?;
    if matches!(
        accel,
        AccelKind::Grid | AccelKind::BruteForce | AccelKind::BruteForceBbox
    ) {
        bail!(
            "--tree draws a tree: the {} has no hierarchy (its cells or triangles are one \
             level); give --accel bvh, bvh4, bvh8, kdtree, octree or two-level",
            accel.title()
        );
    }
    plot::check(out)?;
    let params = args.build.structure_params(scene)?;
    let built = args.build.build(scene)?;
    let _held = bvhlab::budget::hold(built.structure.bytes() as u64);
    let outline = built.structure.outline();
    let sah = built.structure.sah_cost(&params);
    let costs = sah.map_or(params.sah_constants(), |(_, t, i)| (t, i));
    let size = (args.width, args.height);
    // The measured choices count the visits of the primary rays of the view's frame.
    let measured = args.tree_color.is_measured() || args.tree_width == hierarchy::Width::Visits;
    let visits = measured.then(|| {
        let kind = args.intersector;
        with_intersector!(kind, I => node_visits::<I>(
            &built.structure,
            scene,
            settings,
            RayKind::Primary,
            1,
            outline.nodes.len(),
            &|| false,
        ))
        .unwrap_or_default()
    });
    let drawn_width = f64::from(args.width.saturating_sub(80).max(1));
    let max_rows = (args.height.saturating_sub(146) / MIN_ROW_PX).max(1);
    let diagram = hierarchy::layout(
        &outline,
        args.tree_width,
        args.tree_color,
        FOLD_PX / drawn_width,
        max_rows,
        costs,
        visits.as_ref().map(|v| hierarchy::Visits {
            per_node: &v.per_node,
            rays: v.rays,
        }),
    );
    let folded = diagram.cells.iter().filter(|c| c.folded).count();
    let figure = Icicle {
        title: format!(
            "{} over {}: {} nodes, depth {}{}",
            accel.title(),
            scene.name,
            outline.nodes.len(),
            outline.max_depth(),
            sah.map_or(String::new(), |(cost, _, _)| format!(
                ", SAH cost {cost:.2}"
            ))
        ),
        subtitle: format!(
            "width: {}; {}{} cells drawn; {} too small to draw folded (dark foot)",
            args.tree_width.label(),
            visits.as_ref().map_or(String::new(), |v| format!(
                "visits of the {} primary rays of the {}×{} view; ",
                v.rays, settings.width, settings.height
            )),
            diagram.cells.len(),
            match folded {
                1 => "1 subtree".to_string(),
                n => format!("{n} subtrees"),
            }
        ),
        diagram: &diagram,
        shade: args.tree_color,
        size,
    };
    let svg = plot::save(&figure, out)?;
    out!(
        "wrote {} and {}: {} of {} nodes drawn ({} folded away)",
        out.display(),
        svg.display(),
        diagram.cells.len(),
        outline.nodes.len(),
        diagram.hidden
    );
    Ok(())
}
