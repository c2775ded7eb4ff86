//! `bvhlab trace` end to end: rays in, hits out, in input order, against the library's own
//! closest-hit and any-hit answers; bad ray files are errors naming the rays.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildParams, build};
use bvhlab::accel::rayfile::{self, HitFormat, RayFileError};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::Scene;
use common::TempDir;
use glam::Vec3;
use std::path::Path;
use std::process::Command;

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .output()
        .expect("bvhlab runs")
}

/// `bvhlab trace --scene S --rays R --out O` and `extra`, which must succeed.
fn trace_ok(scene: &str, rays: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "trace",
        "--scene",
        scene,
        "--rays",
        rays.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = bvhlab(&args);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

#[test]
fn ray_files_round_trip_and_reject_bad_rays() {
    let rays = vec![
        Ray::segment(
            Vec3::new(1.0, -2.0, 3.5),
            Vec3::new(0.0, -0.0, 1.0),
            0.0,
            f32::INFINITY,
        ),
        Ray::segment(Vec3::ZERO, Vec3::X, 0.5, 2.0),
    ];
    let bytes = rayfile::encode_rays(&rays);
    assert_eq!(bytes.len(), 64);
    let back = rayfile::decode_rays(&bytes).unwrap();
    assert_eq!(back.len(), 2);
    assert_eq!(back[0].direction.y.to_bits(), (-0.0f32).to_bits());
    assert_eq!(back, rays);
    assert_eq!(
        rayfile::decode_rays(&bytes[..63]),
        Err(RayFileError::Truncated {
            len: 63,
            complete: 1
        })
    );
    let bad = vec![
        rays[0],
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X),
        Ray::segment(Vec3::ZERO, Vec3::X, f32::NAN, 1.0),
        Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)),
        // The interval: tmin finite and ≥ 0, tmax beyond it (+∞ is fine, above).
        Ray::segment(Vec3::ZERO, Vec3::X, -1.0, 1.0),
        Ray::segment(Vec3::ZERO, Vec3::X, f32::INFINITY, f32::INFINITY),
        Ray::segment(Vec3::ZERO, Vec3::X, 0.0, f32::NEG_INFINITY),
        Ray::segment(Vec3::ZERO, Vec3::X, 2.0, 2.0),
    ];
    match rayfile::decode_rays(&rayfile::encode_rays(&bad)) {
        Err(RayFileError::InvalidRays { count, first }) => {
            assert_eq!(count, 8);
            let indices: Vec<usize> = first.iter().map(|f| f.0).collect();
            assert_eq!(indices[..4], [1, 2, 3, 4]);
            assert!(
                first.iter().any(|f| f.1.contains("tmin is negative")),
                "{first:?}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn trace_writes_closest_hits_and_occlusion_in_input_order() {
    let dir = TempDir::new("trace");
    let scene = Scene::load("teapot-in-stadium").unwrap();
    let rays = common::rays(&scene.bounds(), 5000, 31);
    let rays_path = dir.join("rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let (bvh, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
    for accel in ["bvh", "brute-force"] {
        let hits_path = dir.join(format!("hits-{accel}.bin"));
        trace_ok(
            "teapot-in-stadium",
            &rays_path,
            &hits_path,
            &["--accel", accel],
        );
        let hits = rayfile::decode_hits(&std::fs::read(&hits_path).unwrap(), HitFormat::U32);
        assert_eq!(hits.len(), rays.len());
        for (ray, &(t, tri)) in rays.iter().zip(&hits) {
            let expected = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
            let got = (tri != u64::from(rayfile::MISS)).then_some(bvhlab::accel::Hit {
                t,
                u: 0.0,
                v: 0.0,
                triangle: tri,
            });
            assert!(
                common::same_hit(got, expected),
                "{accel}: {ray:?}: {got:?} vs {expected:?}"
            );
            if tri == u64::from(rayfile::MISS) {
                assert_eq!(t, f32::INFINITY);
            } else {
                assert!((tri as usize) < scene.triangles.len());
            }
        }
    }
    let any_path = dir.join("any.bin");
    trace_ok(
        "teapot-in-stadium",
        &rays_path,
        &any_path,
        &["--any", "--intersector", "f64"],
    );
    let occluded = std::fs::read(&any_path).unwrap();
    assert_eq!(occluded.len(), rays.len());
    for (ray, &o) in rays.iter().zip(&occluded) {
        assert!(o <= 1);
        let expected = bvh.any_hit::<bvhlab::geometry::ReferenceF64, _>(ray, &mut NoStats);
        assert_eq!(o == 1, expected, "{ray:?}");
    }
}

#[test]
fn trace_counts_triangles_in_obj_file_order() {
    let dir = TempDir::new("trace");
    // Two objects, the first a quad (two triangles after triangulation).
    let obj = dir.join("order.obj");
    std::fs::write(
        &obj,
        "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no b\nv 0 0 2\nv 1 0 2\nv 0 1 2\nf 5 6 7\n",
    )
    .unwrap();
    let rays = [
        // Through the quad's second triangle (1, 3, 4) at z = 0, from below.
        Ray::new(Vec3::new(0.2, 0.7, -1.0), Vec3::Z),
        // Through the third triangle only, from above.
        Ray::new(Vec3::new(0.2, 0.2, 3.0), Vec3::NEG_Z),
        Ray::new(Vec3::new(5.0, 5.0, 5.0), Vec3::X),
    ];
    let rays_path = dir.join("order-rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let hits_path = dir.join("order-hits.bin");
    trace_ok(obj.to_str().unwrap(), &rays_path, &hits_path, &[]);
    let hits = rayfile::decode_hits(&std::fs::read(&hits_path).unwrap(), HitFormat::U32);
    assert_eq!(
        hits,
        vec![
            (1.0, 1),
            (1.0, 2),
            (f32::INFINITY, u64::from(rayfile::MISS))
        ]
    );
}

#[test]
fn trace_rejects_truncated_and_invalid_ray_files() {
    let dir = TempDir::new("trace");
    let path = dir.join("bad.bin");
    std::fs::write(&path, [0u8; 40]).unwrap();
    let out = bvhlab(&[
        "trace",
        "--scene",
        "cornell",
        "--rays",
        path.to_str().unwrap(),
        "--out",
        dir.join("x.bin").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a multiple of 32"));
    let bad = [
        Ray::new(Vec3::ZERO, Vec3::X),
        Ray::new(Vec3::ONE, Vec3::ZERO),
    ];
    std::fs::write(&path, rayfile::encode_rays(&bad)).unwrap();
    let out = bvhlab(&[
        "trace",
        "--scene",
        "cornell",
        "--rays",
        path.to_str().unwrap(),
        "--out",
        dir.join("x.bin").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ray 1: direction is zero"), "{err}");
}

#[test]
fn hit_files_number_triangles_in_64_bits_when_32_do_not_reach() {
    let dir = TempDir::new("trace");
    // The default island places 1.76 × 10^10 triangles: its hits need 64-bit numbers.
    let scene = bvhlab::scene::builtin::by_name("island").unwrap().unwrap();
    assert!(scene.placed_triangles() as u64 > u64::from(u32::MAX));
    let b = scene.bounds();
    // Straight down onto the island's middle, where trees stand on the terrain.
    let rays: Vec<Ray> = (0..400)
        .map(|i| {
            let (x, z) = ((i % 20) as f32 / 20.0, (i / 20) as f32 / 20.0);
            let p = b.min + (b.max - b.min) * Vec3::new(0.3 + 0.4 * x, 1.0, 0.3 + 0.4 * z);
            Ray::new(p + Vec3::Y, Vec3::NEG_Y)
        })
        .collect();
    let rays_path = dir.join("island-rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let hits_path = dir.join("island-hits.bin");
    let out = trace_ok("island", &rays_path, &hits_path, &["--threads", "2"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("64-bit triangle numbers"));
    let bytes = std::fs::read(&hits_path).unwrap();
    assert_eq!(bytes.len(), rays.len() * HitFormat::U64.record_bytes());
    let hits = rayfile::decode_hits(&bytes, HitFormat::U64);
    let params = bvhlab::accel::structure::StructureParams::of_kind(
        bvhlab::accel::structure::AccelKind::TwoLevel,
    );
    let built =
        bvhlab::accel::structure::build_scene(&scene, &params, &Default::default()).unwrap();
    let mut beyond_32_bits = 0;
    for (ray, &(t, tri)) in rays.iter().zip(&hits) {
        let expected = built
            .structure
            .closest_hit::<Watertight, _>(ray, &mut NoStats);
        let got = (tri != rayfile::MISS_U64).then_some(bvhlab::accel::Hit {
            t,
            u: 0.0,
            v: 0.0,
            triangle: tri,
        });
        assert!(
            common::same_hit(got, expected),
            "{ray:?}: {got:?} vs {expected:?}"
        );
        beyond_32_bits += usize::from(tri != rayfile::MISS_U64 && tri > u64::from(u32::MAX));
    }
    assert!(beyond_32_bits > 40, "{beyond_32_bits} hits beyond 32 bits");
    // Asked for 32 bits, the island is refused before anything is traced.
    std::fs::remove_file(&hits_path).unwrap();
    let out = bvhlab(&[
        "trace",
        "--scene",
        "island",
        "--rays",
        rays_path.to_str().unwrap(),
        "--out",
        hits_path.to_str().unwrap(),
        "--hit-bits",
        "32",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("17570287050 triangles") && err.contains("--hit-bits 64"),
        "{err}"
    );
    assert!(!hits_path.exists());
}

#[test]
fn a_64_bit_hit_file_holds_the_32_bit_files_hits() {
    let dir = TempDir::new("trace");
    let rays: Vec<Ray> = (0..64)
        .map(|i| Ray::new(Vec3::new(i as f32 * 0.1 - 3.0, 1.0, -10.0), Vec3::Z))
        .collect();
    let rays_path = dir.join("wide-rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let mut files = Vec::new();
    for bits in ["32", "64"] {
        let hits_path = dir.join(format!("wide-hits-{bits}.bin"));
        trace_ok("cornell", &rays_path, &hits_path, &["--hit-bits", bits]);
        files.push(std::fs::read(&hits_path).unwrap());
    }
    let narrow = rayfile::decode_hits(&files[0], HitFormat::U32);
    let wide = rayfile::decode_hits(&files[1], HitFormat::U64);
    assert_eq!(files[1].len(), 12 * rays.len());
    assert_eq!(narrow.len(), wide.len());
    let mut hits = 0;
    for (&(t32, tri32), &(t64, tri64)) in narrow.iter().zip(&wide) {
        assert_eq!(t32.to_bits(), t64.to_bits());
        if tri32 == u64::from(rayfile::MISS) {
            assert_eq!(tri64, rayfile::MISS_U64);
        } else {
            assert_eq!(tri32, tri64);
            hits += 1;
        }
    }
    assert!(hits > 0 && hits < rays.len(), "{hits}");
    // --hit-bits numbers closest hits; occlusion files have no triangle numbers.
    let out = bvhlab(&[
        "trace",
        "--scene",
        "cornell",
        "--rays",
        rays_path.to_str().unwrap(),
        "--out",
        dir.join("wide-any.bin").to_str().unwrap(),
        "--any",
        "--hit-bits",
        "64",
    ]);
    assert!(!out.status.success());
}
