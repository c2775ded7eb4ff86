//! `bvhlab render --cracks`: the crack study of the view (`render::cracks`) as a PNG, and
//! the counts of every intersector on the same edge and vertex rays.

use super::render::RenderArgs;
use anyhow::{Context, Result};
use bvhlab::geometry::IntersectorKind;
use bvhlab::render::RenderSettings;
use bvhlab::render::cracks::{self, CrackSetup, CrackView, Cracks, PictureStyle, group};
use bvhlab::scene::Scene;
use std::path::Path;
use std::time::Instant;

pub fn run(scene: &Scene, args: &RenderArgs, settings: &RenderSettings, out: &Path) -> Result<()> {
    bvhlab::output::check(out, &["png"])?;
    // Refused before the structure is built.
    cracks::check_offset(&scene.bounds(), args.offset)?;
    let params = args
        .build
        .structure_params_for(args.build.accel_to_trace(scene).kind()?);
    super::check_given_apply(&params)?;
    let start = Instant::now();
    let setup = CrackSetup::new(settings, args.offset);
    let view = CrackView::new(scene, &setup, &params, cracks::SEED)
        .context("cannot make the crack study")?;
    let made = start.elapsed();
    let start = Instant::now();
    let all = IntersectorKind::ALL.map(|kind| view.classify(kind));
    let traced = start.elapsed();
    let chosen = all
        .iter()
        .find(|c| c.kind == args.intersector)
        .context("every intersector is classified")?;
    let frame = view.render(args.intersector);
    let style = PictureStyle {
        held: args.held,
        ..PictureStyle::default()
    };
    let rgba = cracks::picture(&frame, &view.markers(chosen), style);
    bvhlab::output::write_png(&rgba, frame.width, frame.height, out)?;
    eprintln!(
        "{} over {} moved triangles, {} shared edges and {} closed fans, rays in view: {:.2} s; \
         the three intersectors on them: {:.2} s",
        params.kind.title(),
        view.scene.triangles.len(),
        group(view.shared_edges as u64),
        group(view.closed_fans as u64),
        made.as_secs_f64(),
        traced.as_secs_f64()
    );
    out!(
        "wrote {} ({}×{}, {} in view at offset {}, leaks of {} in red)",
        out.display(),
        frame.width,
        frame.height,
        scene.name,
        offset_label(args.offset),
        args.intersector.label()
    );
    out!("{}", line(chosen, args.offset));
    for other in all.iter().filter(|c| c.kind != args.intersector) {
        out!("  on the same rays: {}", line(other, args.offset));
    }
    Ok(())
}

/// `moller-trumbore at offset 1e5: 1,234 of 56,789 edge and vertex rays slip through
/// (2.17 %): 1,000 missed, 234 hit beyond the surface; any hit missed 1,100`.
fn line(c: &Cracks, offset: f64) -> String {
    let r = &c.report;
    format!(
        "{} at offset {}: {} of {} edge and vertex rays slip through ({:.2} %): {} missed, {} \
         hit beyond the surface; any hit missed {}",
        c.kind.label(),
        offset_label(offset),
        group(r.missed + r.passed_through),
        group(r.rays),
        100.0 * r.leak_rate(),
        group(r.missed),
        group(r.passed_through),
        group(r.any_missed)
    )
}

/// 100000 as `1e5`, 250 as `250`.
fn offset_label(d: f64) -> String {
    let plain = format!("{d}");
    let short = format!("{d:e}");
    if short.len() < plain.len() {
        short
    } else {
        plain
    }
}
