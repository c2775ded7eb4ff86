//! The scaling study behind `bvhlab bench scaling`: a tiny run gives a row per structure
//! and size, brute force tests every triangle for every ray, and the CSV and plots are
//! written. Timings are produced but never asserted.

use bvhlab::accel::{AccelKind, StructureParams};
use bvhlab::bench::plot;
use bvhlab::bench::scaling::{self, CSV_HEADER, ScalingConfig, ScalingError};
use bvhlab::geometry::IntersectorKind;
use bvhlab_testkit::TempDir;

fn config(scene: &str, sizes: &[usize]) -> ScalingConfig {
    ScalingConfig {
        scene: scene.into(),
        sizes: sizes.to_vec(),
        kinds: AccelKind::ALL.to_vec(),
        params: StructureParams::default(),
        width: 32,
        height: 24,
        runs: 1,
        intersector: IntersectorKind::Watertight,
    }
}

#[test]
fn a_tiny_run_has_a_row_per_structure_and_size() {
    let rows = scaling::run(&config("soup", &[800, 200]), &mut |_| {}).unwrap();
    assert_eq!(rows.len(), 2 * AccelKind::ALL.len());
    for (i, &size) in [200, 800].iter().enumerate() {
        for (j, &kind) in AccelKind::ALL.iter().enumerate() {
            let r = &rows[i * AccelKind::ALL.len() + j];
            assert_eq!((r.size, r.triangles, r.kind), (size, size, kind));
            assert_eq!((r.rays, r.traced, r.sampled), (32 * 24, 32 * 24, 1));
            assert!(r.ns_per_ray > 0.0 && r.nodes >= 1.0);
        }
    }
    // Every structure finds the same hits.
    for size_rows in rows.chunks(AccelKind::ALL.len()) {
        assert!(size_rows.iter().all(|r| r.hits == size_rows[0].hits));
        assert!(size_rows[0].hits > 0);
    }
    // Brute force tests every triangle with every ray, exactly.
    for r in rows.iter().filter(|r| r.kind == AccelKind::BruteForce) {
        assert_eq!(r.triangle_tests, r.triangles as f64);
    }
    // A tree tests far fewer.
    for r in rows.iter().filter(|r| r.kind == AccelKind::Bvh) {
        assert!(r.triangle_tests < r.triangles as f64 / 4.0);
    }

    let slopes = scaling::slopes(&rows);
    assert_eq!(slopes.len(), AccelKind::ALL.len());
    let brute = slopes
        .iter()
        .find(|s| s.kind == AccelKind::BruteForce)
        .unwrap();
    assert!((brute.all[0].unwrap() - 1.0).abs() < 1e-9);

    let csv = scaling::csv(&rows);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), rows.len() + 1);
    let columns = CSV_HEADER.split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == columns));

    let dir = TempDir::new("scaling");
    let png = dir.join("scaling-soup.png");
    let svg = plot::save(&scaling::figure(&rows), &png).unwrap();
    assert_eq!(svg, dir.join("scaling-soup.svg"));
    assert!(std::fs::metadata(&png).unwrap().len() > 0);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("<svg"));
    // The labels are text elements, not paths.
    let texts: Vec<&str> = text
        .split("</text>")
        .filter_map(|part| {
            let body = &part[part.rfind("<text")?..];
            Some(body[body.find('>')? + 1..].trim())
        })
        .collect();
    for label in [
        "triangles N",
        "mean triangle tests per ray",
        "BVH2",
        "brute force",
    ] {
        assert!(texts.contains(&label), "{label}: {texts:?}");
    }
}

#[test]
fn grass_and_the_stadium_are_sized_by_triangles() {
    let cfg = ScalingConfig {
        kinds: vec![AccelKind::Bvh],
        ..config("grass", &[1000])
    };
    let rows = scaling::run(&cfg, &mut |_| {}).unwrap();
    assert_eq!(rows[0].triangles, 1000);
    let cfg = ScalingConfig {
        kinds: vec![AccelKind::Bvh],
        ..config("teapot-in-stadium", &[1000])
    };
    let rows = scaling::run(&cfg, &mut |_| {}).unwrap();
    assert_eq!(
        rows[0].triangles,
        bvhlab::scene::builtin::TEAPOT_IN_STADIUM_MIN_TRIANGLES
    );
}

#[test]
fn scenes_without_a_size_are_refused() {
    for scene in ["cornell", "assets/teapot.obj", "soup:1000", "nope"] {
        let err = scaling::run(&config(scene, &[200]), &mut |_| {}).unwrap_err();
        assert!(
            matches!(err, ScalingError::NotScalable(_)),
            "{scene}: {err}"
        );
        assert!(
            err.to_string()
                .contains("soup, sphere, grass, teapot-in-stadium")
        );
    }
    assert!(matches!(
        scaling::run(&config("soup", &[]), &mut |_| {}),
        Err(ScalingError::Empty)
    ));
    // A size the scene cannot take is the scene's own error.
    assert!(matches!(
        scaling::run(&config("soup", &[0]), &mut |_| {}),
        Err(ScalingError::Scene(_))
    ));
}
