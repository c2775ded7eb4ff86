//! `bvhlab trace`: a batch query for users who bring their own rays. Reads a binary ray
//! file, traces every ray (closest hit, or occlusion with --any) and writes the answers in
//! input order; the formats are those of `bvhlab::geometry::rayfile`.

use super::{BuildArgs, IntersectorArg, load_scene, thread_pool};
use anyhow::{Context, Result};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::geometry::{Intersector, Ray, rayfile};
use bvhlab::with_intersector;
use clap::Args;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
#[command(long_about = "Trace a file of rays against a scene.\n\n\
        rays.bin: per ray 8 little-endian f32: ox oy oz dx dy dz tmin tmax (hits with t in \
        the open interval (tmin, tmax), t in units of the unnormalised direction).\n\
        hits.bin: per ray, in input order, f32 t (+inf on a miss) then u32 triangle index \
        (0xFFFFFFFF on a miss); triangles are counted in OBJ file order after triangulation.\n\
        With --any: one byte per ray, 1 occluded, 0 not.\n\
        A file whose size is not a multiple of 32 bytes, or any ray with a NaN or infinite \
        value or a zero direction, is an error naming the rays.")]
pub struct TraceArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long)]
    pub scene: String,
    /// Input rays (8 little-endian f32 per ray).
    #[arg(long)]
    pub rays: PathBuf,
    /// Output file.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Occlusion only: one byte per ray.
    #[arg(long)]
    pub any: bool,
    /// Ray–triangle test.
    #[arg(long, value_enum, default_value_t = IntersectorArg::Watertight)]
    pub intersector: IntersectorArg,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub build: BuildArgs,
}

pub fn run(args: TraceArgs) -> Result<()> {
    let bytes = std::fs::read(&args.rays)
        .with_context(|| format!("cannot read {}", args.rays.display()))?;
    let rays = rayfile::decode_rays(&bytes)
        .with_context(|| format!("bad ray file {}", args.rays.display()))?;
    let scene = load_scene(&args.scene)?;
    let pool = thread_pool(args.threads)?;
    let start = Instant::now();
    let (output, answered) = pool.install(|| -> Result<(Vec<u8>, usize)> {
        let built = args.build.build_to_trace(&scene)?;
        let s = &built.structure;
        with_intersector!(args.intersector.kind(), I => trace_all::<_, I>(s, &rays, args.any))
    })?;
    let elapsed = start.elapsed();
    std::fs::write(&args.out, &output)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    out!(
        "wrote {}: {} rays, {} {} ({} triangles, {}), {:.1} ms including the build",
        args.out.display(),
        rays.len(),
        answered,
        if args.any { "occluded" } else { "hits" },
        scene.placed_triangles(),
        args.intersector.kind().label(),
        elapsed.as_secs_f64() * 1e3
    );
    Ok(())
}

/// The output bytes and the number of hits (or occluded rays).
fn trace_all<A: Accel, I: Intersector>(
    accel: &A,
    rays: &[Ray],
    any: bool,
) -> Result<(Vec<u8>, usize)> {
    if any {
        let occluded: Vec<bool> = rays
            .par_iter()
            .map(|r| accel.any_hit::<I, _>(r, &mut NoStats))
            .collect();
        let count = occluded.iter().filter(|&&o| o).count();
        Ok((rayfile::encode_occlusion(&occluded), count))
    } else {
        let hits: Vec<_> = rays
            .par_iter()
            .map(|r| accel.closest_hit::<I, _>(r, &mut NoStats))
            .collect();
        let count = hits.iter().filter(|h| h.is_some()).count();
        Ok((rayfile::encode_hits(&hits)?, count))
    }
}
