//! `bvhlab trace`: a batch query for users who bring their own rays. Reads a binary ray
//! file, traces every ray (closest hit, or occlusion with --any) and writes the answers in
//! input order; the formats are those of `bvhlab::accel::rayfile`.

use super::{BuildArgs, load_scene, thread_pool};
use anyhow::{Context, Result, bail};
use bvhlab::accel::rayfile::{self, HitFormat};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::geometry::IntersectorKind;
use bvhlab::geometry::{Intersector, Ray};
use bvhlab::with_intersector;
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
#[command(long_about = "Trace a file of rays against a scene.\n\n\
        rays.bin: per ray 8 little-endian f32: ox oy oz dx dy dz tmin tmax (hits with t in \
        the open interval (tmin, tmax), t in units of the unnormalised direction).\n\
        hits.bin: per ray, in input order, f32 t (+inf on a miss) then the triangle's number \
        as a u32 (0xFFFFFFFF on a miss), 8 bytes a ray; for a scene that places more \
        triangles than 32 bits number (instancing, `island`), or with --hit-bits 64, as a \
        u64 (all ones on a miss), 12 bytes a ray. Triangles are counted in OBJ file order \
        after triangulation, an instanced scene's as in its flattened copy.\n\
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
    #[arg(long, value_enum, default_value_t = IntersectorKind::Watertight)]
    pub intersector: IntersectorKind,
    /// Bits of a triangle's number in the hit file (default: 32, or 64 for a scene that
    /// places more triangles than 32 bits number).
    #[arg(long, value_enum, conflicts_with = "any")]
    pub hit_bits: Option<HitBits>,
    /// Worker threads, at most 4 × the cores (default: all cores).
    #[arg(long, value_parser = crate::cli::parse_threads)]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub build: BuildArgs,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum HitBits {
    #[value(name = "32")]
    U32,
    #[value(name = "64")]
    U64,
}

/// The hit file's format for a scene placing `triangles`: the one asked for, if it numbers
/// them all, else the smallest that does.
fn hit_format(asked: Option<HitBits>, triangles: u64) -> Result<HitFormat> {
    let fits = HitFormat::for_triangles(triangles);
    match asked {
        None => Ok(fits),
        Some(HitBits::U64) => Ok(HitFormat::U64),
        Some(HitBits::U32) if fits == HitFormat::U32 => Ok(HitFormat::U32),
        Some(HitBits::U32) => bail!(
            "the scene places {triangles} triangles, more than a 32-bit hit file numbers; \
             use --hit-bits 64"
        ),
    }
}

/// Names that promise a picture or text a viewer would try to open; the hits are binary.
const NOT_HITS: [&str; 9] = [
    "png", "jpg", "jpeg", "svg", "gif", "csv", "json", "txt", "obj",
];

pub fn run(args: TraceArgs) -> Result<()> {
    bvhlab::output::check(&args.out, &[])?;
    if let Some(ext) = args
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        && NOT_HITS.contains(&ext.as_str())
    {
        anyhow::bail!(
            "{}: trace writes binary hits (the README's hit format), not a .{ext} file; \
             name it e.g. hits.bin",
            args.out.display()
        );
    }
    bvhlab::output::check_distinct(&args.out, &args.rays, "the ray file read")?;
    // The file, its rays decoded and their hits are held at once: about three times its size.
    let bytes = bvhlab::input::read(&args.rays, 3)
        .with_context(|| format!("cannot read {}", args.rays.display()))?;
    let rays = rayfile::decode_rays(&bytes)
        .with_context(|| format!("bad ray file {}", args.rays.display()))?;
    // The rays and their hits stay while the scene loads and its structure is built: the
    // estimates of both count them.
    let _rays_held = bvhlab::budget::hold(bvhlab::budget::times(bytes.len() as u64, 3));
    let scene = load_scene(&args.scene)?;
    let _scene_held = scene.hold_budget();
    let format = hit_format(args.hit_bits, scene.placed_triangles() as u64)?;
    let pool = thread_pool(args.threads)?;
    let start = Instant::now();
    let (output, answered) = pool.install(|| -> Result<(Vec<u8>, usize)> {
        let built = args.build.build_to_trace(&scene)?;
        let s = &built.structure;
        with_intersector!(args.intersector, I => trace_all::<_, I>(s, &rays, args.any, format))
    })?;
    let elapsed = start.elapsed();
    bvhlab::output::write(&args.out, &output)?;
    let answers = if args.any {
        "occluded".to_string()
    } else {
        format!("hits, {}-bit triangle numbers", format.bits())
    };
    out!(
        "wrote {}: {} rays, {} {} ({} triangles, {}), {:.1} ms including the build",
        args.out.display(),
        rays.len(),
        answered,
        answers,
        scene.placed_triangles(),
        args.intersector.label(),
        elapsed.as_secs_f64() * 1e3
    );
    Ok(())
}

/// The output bytes and the number of hits (or occluded rays).
fn trace_all<A: Accel, I: Intersector>(
    accel: &A,
    rays: &[Ray],
    any: bool,
    format: HitFormat,
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
        Ok((rayfile::encode_hits(&hits, format)?, count))
    }
}
