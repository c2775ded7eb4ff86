//! Scenes: every built-in is well formed and has the property it is named for; the OBJ loader
//! keeps file order and answers every bad input with the right error and line number.

use bvhlab::scene::obj::DEFAULT_COLOR;
use bvhlab::scene::{ObjError, Scene, SceneError, builtin, load_obj};
use bvhlab_testkit::TempDir;
use glam::Vec3;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------
// Built-in scenes

fn builtin(spec: &str) -> Scene {
    match builtin::by_name(spec) {
        Ok(Some(scene)) => scene,
        Ok(None) => panic!("{spec} is not a built-in"),
        Err(e) => panic!("{spec}: {e}"),
    }
}

fn assert_well_formed(spec: &str, scene: &Scene) {
    assert!(scene.placed_triangles() > 0, "{spec}: no triangles");
    let mesh_triangles = scene.meshes.iter().flat_map(|m| &m.triangles);
    assert!(
        scene
            .triangles
            .iter()
            .chain(mesh_triangles)
            .all(|t| t.is_finite()),
        "{spec}: non-finite triangle"
    );
    if !scene.is_flattened() {
        // Unflattened: one object for each instance.
        assert_eq!(scene.objects.len(), scene.instances.len(), "{spec}");
    }
    let mut next = 0;
    for object in &scene.objects {
        assert_eq!(object.first, next, "{spec}: objects not contiguous");
        assert!(object.count > 0, "{spec}: empty object {}", object.name);
        assert!(
            object.color.is_finite() && object.color.cmpge(Vec3::ZERO).all(),
            "{spec}: bad colour"
        );
        assert!(object.color.cmple(Vec3::ONE).all(), "{spec}: bad colour");
        next += object.count;
    }
    assert_eq!(
        next,
        scene.placed_triangles(),
        "{spec}: objects miss triangles"
    );
    let view = scene.view.unwrap_or_else(|| panic!("{spec}: no view"));
    assert!(view.eye.is_finite() && view.look_at.is_finite() && view.eye != view.look_at);
    assert!(
        scene.light.is_some_and(|l| l.is_finite()),
        "{spec}: no light"
    );
}

#[test]
fn every_builtin_loads_well_formed() {
    for name in builtin::NAMES {
        let scene = Scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_well_formed(name, &scene);
        assert_eq!(&scene.name, name);
    }
}

#[test]
fn sized_builtins_accept_small_sizes() {
    for name in builtin::NAMES {
        if matches!(*name, "cornell" | "teapot-in-stadium") {
            continue;
        }
        for n in [1, 2, 7, 1000] {
            let spec = format!("{name}:{n}");
            assert_well_formed(&spec, &builtin(&spec));
        }
    }
}

#[test]
fn builtins_are_deterministic() {
    for spec in [
        "grass:500",
        "soup:500",
        "same-centroid:500",
        "same-bbox:500",
    ] {
        assert_eq!(builtin(spec).triangles, builtin(spec).triangles, "{spec}");
    }
}

#[test]
fn cornell_is_the_classic_box() {
    let scene = builtin("cornell");
    let bounds = scene.bounds();
    assert_eq!(bounds.min, Vec3::new(-1.0, 0.0, -1.0));
    assert_eq!(bounds.max, Vec3::new(1.0, 2.0, 1.0));
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for part in [
        "floor",
        "left wall",
        "right wall",
        "short box",
        "tall box",
        "light",
    ] {
        assert!(names.contains(&part), "missing {part}");
    }
    assert_eq!(scene.light, Some(Vec3::new(0.0, 1.9, 0.0)));
    assert_eq!(
        builtin::by_name("cornell").unwrap().unwrap().triangles,
        Scene::load("cornell").unwrap().triangles
    );
}

#[test]
fn teapot_is_small_inside_a_huge_stadium() {
    let scene = builtin("teapot-in-stadium");
    let teapot = &scene.objects[0];
    assert_eq!(teapot.name, "teapot");
    assert_eq!(teapot.count, 15_704);
    let teapot_bounds = scene.triangles[teapot.range()]
        .iter()
        .fold(bvhlab::geometry::Aabb::EMPTY, |b, t| b.union(t.bounds()));
    assert!((teapot_bounds.extent().max_element() - 1.0).abs() < 1e-3);
    assert!(
        teapot_bounds.min.y.abs() < 1e-6,
        "teapot stands on the floor"
    );
    assert!(scene.bounds().extent().min_element() >= 50.0);
    assert!(
        scene.triangles.len() - teapot.count < 1000,
        "the stadium is sparse"
    );
}

#[test]
fn walls_and_rotated_walls_match() {
    for spec in ["", ":1", ":37", ":500"] {
        let walls = builtin(&format!("walls{spec}"));
        let rotated = builtin(&format!("walls-rotated{spec}"));
        assert_eq!(walls.triangles.len(), rotated.triangles.len(), "{spec}");
        assert_eq!(walls.objects.len(), rotated.objects.len(), "{spec}");
        // The same set, turned: centroid distances from the vertical axis are kept.
        for (a, b) in walls.triangles.iter().zip(&rotated.triangles) {
            let (a, b) = (a.centroid(), b.centroid());
            assert!((a.y - b.y).abs() < 1e-4);
            assert!((a.x.hypot(a.z) - b.x.hypot(b.z)).abs() < 1e-3);
        }
        // Rotated boxes are much bigger.
        let area =
            |s: &Scene| -> f32 { s.triangles.iter().map(|t| t.bounds().surface_area()).sum() };
        assert!(area(&rotated) > 3.0 * area(&walls), "{spec}");
    }
    assert_eq!(builtin("walls").triangles.len(), 200 * 12);
}

#[test]
fn same_centroid_centroids_are_exactly_equal() {
    for spec in ["same-centroid", "same-centroid:3"] {
        let scene = builtin(spec);
        let first = scene.triangles[0].centroid();
        assert!(scene.triangles.iter().all(|t| t.centroid() == first));
        assert!(scene.triangles.iter().all(|t| t.area() > 0.0));
    }
    assert_eq!(builtin("same-centroid:123").triangles.len(), 123);
}

#[test]
fn same_bbox_bounds_are_exactly_equal() {
    let scene = builtin("same-bbox");
    let first = scene.triangles[0].bounds();
    assert!(scene.triangles.iter().all(|t| t.bounds() == first));
    assert!(scene.triangles.iter().all(|t| t.area() > 0.0));
    let distinct: HashSet<[u32; 9]> = scene.triangles.iter().map(bits).collect();
    assert_eq!(distinct.len(), scene.triangles.len());
}

#[test]
fn soup_has_n_triangles() {
    assert_eq!(builtin("soup:4321").triangles.len(), 4321);
    assert_eq!(builtin("grass:1000").triangles.len(), 2 * 1000 + 2);
}

fn bits(t: &bvhlab::geometry::Triangle) -> [u32; 9] {
    let mut out = [0; 9];
    for (i, p) in t.v.iter().enumerate() {
        out[3 * i..3 * i + 3].copy_from_slice(&p.to_array().map(f32::to_bits));
    }
    out
}

#[test]
fn sphere_is_closed() {
    for spec in ["sphere", "sphere:1", "sphere:100", "sphere:5000"] {
        let scene = builtin(spec);
        let n: usize = spec
            .split_once(':')
            .map_or(20_000, |(_, n)| n.parse().unwrap());
        let count = scene.triangles.len();
        assert!(count >= n, "{spec}: {count} triangles");
        assert!(
            count <= n.max(6) + 2 * (n as f64).sqrt() as usize + 8,
            "{spec}: {count}"
        );
        // Every edge, as a pair of exact vertex bit patterns, belongs to exactly two
        // triangles, once in each direction.
        let mut edges: HashMap<([u32; 3], [u32; 3]), usize> = HashMap::new();
        for t in &scene.triangles {
            let v = t.v.map(|p| p.to_array().map(f32::to_bits));
            assert!(
                v[0] != v[1] && v[1] != v[2] && v[2] != v[0],
                "{spec}: degenerate"
            );
            for i in 0..3 {
                *edges.entry((v[i], v[(i + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &uses) in &edges {
            assert_eq!(uses, 1, "{spec}: directed edge used {uses} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "{spec}: open edge");
        }
    }
}

#[test]
fn bad_parameters_are_rejected() {
    for spec in [
        "soup:0",
        "soup:",
        "soup:abc",
        "soup:-5",
        "soup:1e3",
        "soup:2.5",
        "soup:50000001",
        "soup:99999999999999999999999",
        "grass:25000001",
        "walls:5000000",
        "sphere:0",
        "cornell:5",
        "cornell:",
        "teapot-in-stadium:10",
    ] {
        match builtin::by_name(spec) {
            Err(SceneError::BadParameter { .. }) => {}
            other => panic!("{spec}: expected BadParameter, got {other:?}"),
        }
        assert!(matches!(
            Scene::load(spec),
            Err(SceneError::BadParameter { .. })
        ));
    }
    assert_eq!(builtin("soup:1_000").triangles.len(), 1000);
}

#[test]
fn unknown_names_are_not_builtins() {
    assert!(matches!(builtin::by_name("no-such-scene"), Ok(None)));
    assert!(matches!(builtin::by_name("no-such-scene:5"), Ok(None)));
    assert!(matches!(builtin::by_name(""), Ok(None)));
    assert!(matches!(
        Scene::load("no-such-scene"),
        Err(SceneError::UnknownScene { .. })
    ));
}

// ---------------------------------------------------------------------------------------
// OBJ files

/// A file in a temporary directory of its own, removed with it when dropped.
struct TempFile(PathBuf, TempDir);

impl TempFile {
    fn new(name: &str, contents: &[u8]) -> Self {
        let dir = TempDir::new("scenes");
        let path = dir.join(name);
        std::fs::write(&path, contents).unwrap();
        TempFile(path, dir)
    }

    /// Another file in the same directory (for .mtl files).
    fn sibling(&self, name: &str, contents: &[u8]) {
        std::fs::write(self.1.join(name), contents).unwrap();
    }
}

fn load(text: &str) -> Result<Scene, ObjError> {
    let file = TempFile::new("test.obj", text.as_bytes());
    load_obj(&file.0)
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn missing_file_is_io_error() {
    let path = std::env::temp_dir().join("bvhlab-definitely-missing-file.obj");
    match load_obj(&path) {
        Err(ObjError::Io { path: p, .. }) => assert_eq!(p, path),
        other => panic!("{other:?}"),
    }
    // Through Scene::load as well: an .obj path that does not exist.
    assert!(matches!(
        Scene::load(path.to_str().unwrap()),
        Err(SceneError::Obj(ObjError::Io { .. }))
    ));
}

fn parse_error_line(text: &str) -> usize {
    match load(text) {
        Err(ObjError::Parse { line, .. }) => line,
        other => panic!("expected a parse error for {text:?}, got {other:?}"),
    }
}

#[test]
fn unparsable_lines_name_their_line() {
    assert_eq!(parse_error_line("v 0 0 0\nv 1 2 x\nf 1 2 3\n"), 2);
    assert_eq!(parse_error_line("# comment\nv 1 2\n"), 2);
    assert_eq!(parse_error_line("v 1 2 3 4 5\n"), 1);
    assert_eq!(parse_error_line("v 1 2 3 0\n"), 1);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}f 1 2 x\n")), 4);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}f 1 2 3.0\n")), 4);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}f 1/1/1/1 2 3\n")), 4);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}f\n")), 4);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}\n\nvt 0\n")), 6);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}vn 0 0 a\n")), 4);
    assert_eq!(parse_error_line(&format!("{TRIANGLE}usemtl\nf 1 2 3\n")), 4);
    // An index too large for any integer type is unparsable rather than out of range.
    assert_eq!(
        parse_error_line(&format!("{TRIANGLE}f 1 2 99999999999999999999999\n")),
        4
    );
    match load("v 0 0 0\r\nv 1 2 x\r\n") {
        Err(ObjError::Parse { line, text, .. }) => {
            assert_eq!(line, 2);
            assert_eq!(text, "v 1 2 x");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn non_finite_coordinates_name_their_line() {
    for (text, expected) in [
        ("v 0 0 0\nv nan 0 0\n", 2),
        ("v inf 0 0\n", 1),
        ("v 0 -infinity 0\n", 1),
        ("v 0 0 NaN\n", 1),
        ("v 0 0 1e39\n", 1),
        ("v 1 1 1 1e-45\n", 1),
        ("v 1 1 1 nan\n", 1),
    ] {
        match load(text) {
            Err(ObjError::NonFinite { line, .. }) => assert_eq!(line, expected, "{text:?}"),
            other => panic!("{text:?}: {other:?}"),
        }
    }
}

fn out_of_range(text: &str) -> (usize, i64) {
    match load(text) {
        Err(ObjError::IndexOutOfRange { line, index, .. }) => (line, index),
        other => panic!("expected out of range for {text:?}, got {other:?}"),
    }
}

#[test]
fn out_of_range_indices_name_their_line() {
    assert_eq!(out_of_range(&format!("{TRIANGLE}f 1 2 4\n")), (4, 4));
    assert_eq!(out_of_range(&format!("{TRIANGLE}f -1 -2 -4\n")), (4, -4));
    assert_eq!(out_of_range(&format!("{TRIANGLE}f 0 1 2\n")), (4, 0));
    assert_eq!(
        out_of_range(&format!("{TRIANGLE}f 1 2 9223372036854775807\n")),
        (4, i64::MAX)
    );
    assert_eq!(
        out_of_range(&format!("{TRIANGLE}f 1 2 -9223372036854775808\n")),
        (4, i64::MIN)
    );
    // Indices count only the vertices defined before the face.
    assert_eq!(out_of_range("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n"), (3, 3));
    // Texture coordinate and normal indices are checked too.
    assert_eq!(
        out_of_range(&format!("{TRIANGLE}vt 0 0\nf 1/2 2/1 3/1\n")),
        (5, 2)
    );
    assert_eq!(
        out_of_range(&format!("{TRIANGLE}f 1//1 2//1 3//1\n")),
        (4, 1)
    );
    // Relative indices in range are fine, as are faces of points and lines.
    let scene = load(&format!("{TRIANGLE}f -3 -2 -1\nf 1 2\n")).unwrap();
    assert_eq!(scene.triangles.len(), 1);
}

#[test]
fn files_without_triangles_are_rejected() {
    for text in [
        "",
        "\n\n",
        "# nothing\n",
        TRIANGLE,
        "v 0 0 0\nv 1 1 1\nl 1 2\nf 1 2\n",
    ] {
        assert!(
            matches!(load(text), Err(ObjError::NoTriangles { .. })),
            "{text:?}"
        );
    }
}

#[test]
fn garbage_bytes_are_errors_not_panics() {
    let file = TempFile::new("garbage.obj", b"v 0 0 0\n\xff\xfe\x00\x01garbage\n");
    match load_obj(&file.0) {
        Err(ObjError::Parse { line, .. }) => assert_eq!(line, 2),
        other => panic!("{other:?}"),
    }
    // Random bytes, and random damage to a valid file: any result, never a panic.
    let valid =
        format!("{TRIANGLE}v 1 1 0\ng a\nf 1 2 3\ng b\nf -1 -2 -3 -4\nvt 0 0\nf 1/1 2/1 3/-1\n");
    let mut state = 0x1234_5678_9abc_def0_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let file = TempFile::new("fuzz.obj", b"");
    for round in 0..1500 {
        let bytes: Vec<u8> = if round % 3 == 0 {
            (0..next() % 200).map(|_| next() as u8).collect()
        } else {
            let mut bytes = valid.clone().into_bytes();
            for _ in 0..1 + next() % 4 {
                let i = (next() % bytes.len() as u64) as usize;
                let choices = b"0123456789-+/ \n.eEfvlgnai\xff";
                bytes[i] = choices[(next() % choices.len() as u64) as usize];
            }
            bytes
        };
        std::fs::write(&file.0, &bytes).unwrap();
        if let Ok(scene) = load_obj(&file.0) {
            assert!(scene.triangles.iter().all(|t| t.is_finite()));
        }
    }
}

#[test]
fn polygons_are_fan_triangulated_in_order() {
    let scene =
        load("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\nf 1 2 3 4\nf 1 2 3 4 5\n").unwrap();
    let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    let expected = [
        [v(0., 0.), v(1., 0.), v(1., 1.)],
        [v(0., 0.), v(1., 1.), v(0., 1.)],
        [v(0., 0.), v(1., 0.), v(1., 1.)],
        [v(0., 0.), v(1., 1.), v(0., 1.)],
        [v(0., 0.), v(0., 1.), v(-1., 1.)],
    ];
    let got: Vec<[Vec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
    assert_eq!(got, expected);
}

#[test]
fn groups_become_objects_in_file_order() {
    let text = "mtllib colours.mtl\n\
        v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
        g first\nusemtl red\nf 1 2 3\nf 2 4 3\n\
        usemtl blue\nf 1 2 4\n\
        usemtl red\nf 4 3 1\n\
        o second\nf 3 2 1\n\
        g third\nusemtl nowhere\nf 1 2 3\n";
    let file = TempFile::new("groups.obj", text.as_bytes());
    file.sibling(
        "colours.mtl",
        b"newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n",
    );
    let scene = load_obj(&file.0).unwrap();
    assert_eq!(scene.name, "groups");
    assert!(scene.view.is_none() && scene.light.is_none());
    let objects: Vec<(&str, usize, usize, Vec3)> = scene
        .objects
        .iter()
        .map(|o| (o.name.as_str(), o.first, o.count, o.color))
        .collect();
    let (red, blue) = (Vec3::X, Vec3::Z);
    assert_eq!(
        objects,
        [
            ("first", 0, 2, red),
            ("first", 2, 1, blue),
            ("first", 3, 1, red),
            // A new group keeps the current material.
            ("second", 4, 1, red),
            ("third", 5, 1, DEFAULT_COLOR),
        ]
    );
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
    let expected = [
        [0, 1, 2],
        [1, 3, 2],
        [0, 1, 3],
        [3, 2, 0],
        [2, 1, 0],
        [0, 1, 2],
    ];
    let got: Vec<[Vec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
    let expected: Vec<[Vec3; 3]> = expected.iter().map(|c| c.map(|i| p[i])).collect();
    assert_eq!(got, expected);
}

#[test]
fn missing_or_broken_materials_are_only_warnings() {
    let text = format!("mtllib missing.mtl\n{TRIANGLE}usemtl default\nf 1 2 3\n");
    let scene = load(&text).unwrap();
    assert_eq!(scene.objects.len(), 1);
    assert_eq!(scene.objects[0].color, DEFAULT_COLOR);

    // tobj 4 would panic on `Kd 0.5`; the library is skipped instead.
    let file = TempFile::new("broken.obj", text.replace("missing", "broken").as_bytes());
    file.sibling("broken.mtl", b"newmtl default\nKd 0.5\n");
    let scene = load_obj(&file.0).unwrap();
    assert_eq!(scene.objects[0].color, DEFAULT_COLOR);

    // Out-of-range and non-finite colours are tamed.
    let file = TempFile::new("odd.obj", text.replace("missing", "odd").as_bytes());
    file.sibling("odd.mtl", b"newmtl default\nKd 2 -1 0.5\n");
    assert_eq!(
        load_obj(&file.0).unwrap().objects[0].color,
        Vec3::new(1.0, 0.0, 0.5)
    );

    // `mtllib` naming a directory or nothing at all.
    for library in ["mtllib .", "mtllib", "mtllib \u{0}"] {
        let scene = load(&format!("{library}\n{TRIANGLE}f 1 2 3\n")).unwrap();
        assert_eq!(scene.triangles.len(), 1);
    }
}

#[test]
fn odd_but_valid_lines_load() {
    // Vertex colours on some vertices only, a w coordinate, a polyline, a byte order mark,
    // CRLF line endings and unknown statements.
    let text = "\u{feff}v 0 0 0 1 0 0\r\nv 2 0 0 2\r\nv 0 1 0\r\nvp 1 2\r\ns off\r\n\
        l 1 2 3\r\nf 1 2 3\r\n";
    let scene = load(text).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(scene.triangles[0].v, [Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn errors_name_the_file_and_line() {
    let file = TempFile::new("named.obj", b"v 0 0 0\nv 1 2 x\n");
    let message = load_obj(&file.0).unwrap_err().to_string();
    assert!(message.contains("named.obj:2"), "{message}");
    assert!(message.contains("v 1 2 x"), "{message}");
}

// ---------------------------------------------------------------------------------------
// Reference scenes (only when BVHLAB_SCENES points at them)

#[test]
fn reference_scenes_have_the_documented_triangle_counts() {
    let Some(dir) = std::env::var_os("BVHLAB_SCENES") else {
        return;
    };
    let dir = Path::new(&dir);
    let expected = [
        ("cornell-box.obj", 36),
        ("teapot.obj", 15_704),
        ("bunny.obj", 69_451),
        ("sponza.obj", 66_450),
        ("sibenik.obj", 75_284),
        ("conference.obj", 331_179),
    ];
    for (file, count) in expected {
        let scene = load_obj(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.triangles.len(), count, "{file}");
        assert_well_formed_obj(file, &scene);
    }
    // Any other OBJ there must at least load.
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "obj") {
            let scene = load_obj(&path).unwrap_or_else(|e| panic!("{e}"));
            assert_well_formed_obj(&path.display().to_string(), &scene);
        }
    }
    // The Cornell box's left wall is red, from its .mtl.
    let cornell = load_obj(&dir.join("cornell-box.obj")).unwrap();
    let left = cornell
        .objects
        .iter()
        .find(|o| o.name == "leftWall")
        .unwrap();
    assert_eq!(left.color, Vec3::new(0.63, 0.065, 0.05));
}

fn assert_well_formed_obj(name: &str, scene: &Scene) {
    assert!(scene.triangles.iter().all(|t| t.is_finite()), "{name}");
    let covered: usize = scene.objects.iter().map(|o| o.count).sum();
    assert_eq!(covered, scene.triangles.len(), "{name}");
    assert!(scene.view.is_none() && scene.light.is_none(), "{name}");
}
