//! `bvhlab replay`: one pixel's ray traced again step by step, through the same traversal
//! code as `render`, printed as text or as one JSON object.

use super::{BuildArgs, ViewArgs, check_size, load_scene};
use anyhow::{Context, Result};
use bvhlab::geometry::IntersectorKind;
use bvhlab::render::replay::replay_pixel;
use bvhlab::render::{RayKind, RenderSettings};
use bvhlab::with_intersector;
use clap::Args;

#[derive(Args)]
#[command(
    long_about = "Replay one pixel's ray through the structure, step by step: each \
        node (cell, instance) visited with where the ray enters and leaves it, the children \
        tested and which is taken first and why, the nodes pushed, popped and skipped because \
        they start beyond the best hit so far, and each triangle test.\n\n\
        With --json: one object with \"ray\" {origin, direction, tmin, tmax}, \"steps\" (each \
        with a \"kind\": bounds, visit, children, plane, octants, cross, stop, push, pop, skip, \
        triangle_box, triangle, mailboxed, instance; one \"visit\" per node visited), \
        \"counters\" {nodes_visited, box_tests, triangle_tests, repeated_tests} and \"hit\" \
        {triangle, t} or null, triangles numbered as `bvhlab trace` numbers them."
)]
pub struct ReplayArgs {
    /// Built-in scene name (optionally NAME:N) or path to an .obj, .gltf or .glb file.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    /// The pixel x,y (0,0 is the top left) of a --width × --height image.
    #[arg(long, value_parser = parse_pixel)]
    pub pixel: (u32, u32),
    #[arg(long, default_value_t = 1024, value_parser = crate::cli::parse_side)]
    pub width: u32,
    #[arg(long, default_value_t = 768, value_parser = crate::cli::parse_side)]
    pub height: u32,
    /// Vertical field of view in degrees.
    #[arg(long, value_parser = crate::cli::parse_fov)]
    pub fov: Option<f32>,
    #[command(flatten)]
    pub view: ViewArgs,
    /// Replay the shadow ray from the pixel's hit towards the light (any hit) instead of
    /// its primary ray.
    #[arg(long)]
    pub shadow: bool,
    /// One JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Ray–triangle test.
    #[arg(long, value_enum, default_value_t = IntersectorKind::Watertight)]
    pub intersector: IntersectorKind,
    #[command(flatten)]
    pub build: BuildArgs,
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected the pixel as x,y (two whole numbers), got '{s}'");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    let n = |v: &str| v.trim().parse::<u32>().map_err(|_| bad());
    Ok((n(x)?, n(y)?))
}

pub fn run(args: ReplayArgs) -> Result<()> {
    check_size(args.width, args.height, 1)?;
    let (x, y) = args.pixel;
    if x >= args.width || y >= args.height {
        anyhow::bail!(
            "pixel {x},{y} is outside the {}×{} image (x from 0 to {}, y from 0 to {})",
            args.width,
            args.height,
            args.width - 1,
            args.height - 1
        );
    }
    let scene = load_scene(&args.scene)?;
    let _scene_held = scene.hold_budget();
    let mut camera = args.view.camera(&scene)?;
    if let Some(fov) = args.fov {
        camera.fov_y_deg = fov;
    }
    let settings = RenderSettings {
        camera,
        light: args.view.light(&scene),
        ..RenderSettings::for_scene(&scene, args.width, args.height)
    };
    let rays = if args.shadow {
        RayKind::Shadow
    } else {
        RayKind::Primary
    };
    let built = args.build.build(&scene)?;
    let s = &built.structure;
    let replay = with_intersector!(args.intersector, I => replay_pixel::<I>(s, &scene, &settings, args.pixel, rays))
        .context("cannot replay the pixel")?;
    if args.json {
        out!("{}", replay.to_json());
    } else {
        out!("{}", replay.text().trim_end());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_parsing() {
        assert_eq!(parse_pixel("3, 4"), Ok((3, 4)));
        assert!(parse_pixel("3").is_err());
        assert!(parse_pixel("-1,2").is_err());
        assert!(parse_pixel("a,b").is_err());
    }
}
