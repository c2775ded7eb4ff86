//! `bvhlab trace` end to end: rays in, hits out, in input order, against the library's own
//! closest-hit and any-hit answers; bad ray files are errors naming the rays.

mod common;

use bvhlab::accel::bvh::{BuildParams, build};
use bvhlab::accel::{Accel, NoStats};
use bvhlab::geometry::rayfile::{self, RayFileError};
use bvhlab::geometry::{Ray, Watertight};
use bvhlab::scene::Scene;
use glam::Vec3;
use std::path::PathBuf;
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bvhlab-trace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn bvhlab(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_bvhlab"))
        .args(args)
        .output()
        .expect("bvhlab runs")
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
    ];
    match rayfile::decode_rays(&rayfile::encode_rays(&bad)) {
        Err(RayFileError::InvalidRays { count, first }) => {
            assert_eq!(count, 4);
            assert_eq!(first.iter().map(|f| f.0).collect::<Vec<_>>(), [1, 2, 3, 4]);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn trace_writes_closest_hits_and_occlusion_in_input_order() {
    let scene = Scene::load("teapot-in-stadium").unwrap();
    let rays = common::rays(&scene.bounds(), 5000, 31);
    let rays_path = temp("rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let (bvh, _) = build(&scene.triangles, &BuildParams::default()).unwrap();
    for accel in ["bvh", "brute-force"] {
        let hits_path = temp(&format!("hits-{accel}.bin"));
        let out = bvhlab(&[
            "trace",
            "--scene",
            "teapot-in-stadium",
            "--rays",
            rays_path.to_str().unwrap(),
            "--out",
            hits_path.to_str().unwrap(),
            "--accel",
            accel,
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let hits = rayfile::decode_hits(&std::fs::read(&hits_path).unwrap());
        assert_eq!(hits.len(), rays.len());
        for (ray, &(t, tri)) in rays.iter().zip(&hits) {
            let expected = bvh.closest_hit::<Watertight, _>(ray, &mut NoStats);
            let got = (tri != rayfile::MISS).then_some(bvhlab::accel::Hit {
                t,
                u: 0.0,
                v: 0.0,
                triangle: tri.into(),
            });
            assert!(
                common::same_hit(got, expected),
                "{accel}: {ray:?}: {got:?} vs {expected:?}"
            );
            if tri == rayfile::MISS {
                assert_eq!(t, f32::INFINITY);
            } else {
                assert!((tri as usize) < scene.triangles.len());
            }
        }
    }
    let any_path = temp("any.bin");
    let out = bvhlab(&[
        "trace",
        "--scene",
        "teapot-in-stadium",
        "--rays",
        rays_path.to_str().unwrap(),
        "--out",
        any_path.to_str().unwrap(),
        "--any",
        "--intersector",
        "f64",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
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
    // Two objects, the first a quad (two triangles after triangulation).
    let obj = temp("order.obj");
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
    let rays_path = temp("order-rays.bin");
    std::fs::write(&rays_path, rayfile::encode_rays(&rays)).unwrap();
    let hits_path = temp("order-hits.bin");
    let out = bvhlab(&[
        "trace",
        "--scene",
        obj.to_str().unwrap(),
        "--rays",
        rays_path.to_str().unwrap(),
        "--out",
        hits_path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let hits = rayfile::decode_hits(&std::fs::read(&hits_path).unwrap());
    assert_eq!(
        hits,
        vec![(1.0, 1), (1.0, 2), (f32::INFINITY, rayfile::MISS)]
    );
}

#[test]
fn trace_rejects_truncated_and_invalid_ray_files() {
    let path = temp("bad.bin");
    std::fs::write(&path, [0u8; 40]).unwrap();
    let out = bvhlab(&[
        "trace",
        "--scene",
        "cornell",
        "--rays",
        path.to_str().unwrap(),
        "--out",
        temp("x.bin").to_str().unwrap(),
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
        temp("x.bin").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ray 1: direction is zero"), "{err}");
}
