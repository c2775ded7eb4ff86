//! `bvhlab stats`: the build report of a structure as a table.

use super::{BuildArgs, load_scene};
use anyhow::Result;
use clap::Args;

#[derive(Args)]
pub struct StatsArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: StatsArgs) -> Result<()> {
    let scene = load_scene(&args.scene)?;
    // The structure must fit beside the scene it is built over.
    let _held = scene.hold_budget();
    let report = args.build.build(&scene)?.report;
    out!("scene: {} ({} objects)", scene.name, scene.objects.len());
    let rows: Vec<_> = scene
        .instancing_rows()
        .into_iter()
        .map(|(k, v)| (format!("scene {k}"), v))
        .chain(report.rows())
        .collect();
    let width = rows
        .iter()
        .map(|(k, _)| k.chars().count())
        .max()
        .unwrap_or(0);
    for (k, v) in rows {
        out!("  {k:<width$}  {v}");
    }
    Ok(())
}
