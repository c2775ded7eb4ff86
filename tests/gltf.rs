//! glTF loading against files the tests write: indexed and non-indexed primitives, node
//! matrices and translation/rotation/scale composed down the tree, meshes shared by nodes,
//! external, embedded and binary buffers; and each kind of broken file rejected with its
//! own error naming the file (and the node, where one is to blame).

use bvhlab_testkit as common;

use bvhlab::geometry::Triangle;
use bvhlab::scene::gltf::AccessorProblem;
use bvhlab::scene::{GltfError, Scene, load_gltf};
use common::TempDir;
use common::gltf::{GltfBuilder, UNSIGNED_BYTE, UNSIGNED_INT, UNSIGNED_SHORT};
use glam::{Affine3A, Mat4, Quat, Vec3};
use serde_json::json;

const QUAD: [Vec3; 4] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(1.0, 0.0, 0.0),
    Vec3::new(1.0, 1.0, 0.0),
    Vec3::new(0.0, 1.0, 0.0),
];
const QUAD_INDICES: [u32; 6] = [0, 1, 2, 0, 2, 3];

fn quad_triangles() -> Vec<Triangle> {
    QUAD_INDICES
        .chunks(3)
        .map(|c| {
            Triangle::new(
                QUAD[c[0] as usize],
                QUAD[c[1] as usize],
                QUAD[c[2] as usize],
            )
        })
        .collect()
}

/// One mesh: an indexed quad (index type `component`) and a non-indexed triangle.
fn two_primitive_mesh(b: &mut GltfBuilder, component: u32) -> usize {
    let quad = b.positions(&QUAD);
    let indices = b.indices(&QUAD_INDICES, component);
    let tri = b.positions(&[Vec3::Z, Vec3::Z + Vec3::X, Vec3::Z + Vec3::Y]);
    b.mesh(&[(quad, Some(indices)), (tri, None)])
}

fn mesh_triangles() -> Vec<Triangle> {
    let mut t = quad_triangles();
    t.push(Triangle::new(Vec3::Z, Vec3::Z + Vec3::X, Vec3::Z + Vec3::Y));
    t
}

fn placed(m: Affine3A, triangles: &[Triangle]) -> Vec<Triangle> {
    triangles
        .iter()
        .map(|t| {
            Triangle::new(
                m.transform_point3(t.v[0]),
                m.transform_point3(t.v[1]),
                m.transform_point3(t.v[2]),
            )
        })
        .collect()
}

fn assert_triangles_close(got: &[Triangle], want: &[Triangle]) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        for k in 0..3 {
            assert!((g.v[k] - w.v[k]).length() < 1e-5, "{g:?} vs {w:?}");
        }
    }
}

#[test]
fn indexed_and_non_indexed_primitives_load_in_order() {
    let dir = TempDir::new("gltf-primitives");
    for (k, component) in [UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT]
        .into_iter()
        .enumerate()
    {
        let mut b = GltfBuilder::default();
        let mesh = two_primitive_mesh(&mut b, component);
        let node = b.node(json!({"mesh": mesh, "name": "thing"}));
        b.roots.push(node);
        let path = b.write_external(dir.path(), &format!("primitives{k}"));
        let scene = load_gltf(&path).unwrap();
        assert_eq!(scene.triangles, mesh_triangles());
        assert_eq!(scene.meshes.len(), 1);
        assert_eq!(scene.meshes[0].triangles, mesh_triangles());
        assert_eq!(scene.instances.len(), 1);
        assert_eq!(scene.objects.len(), 1);
        assert!(scene.objects[0].name.contains("thing"));
        assert_eq!(scene.name, format!("primitives{k}"));
    }
}

#[test]
fn matrices_and_trs_compose_down_the_tree() {
    let mut b = GltfBuilder::default();
    let mesh = two_primitive_mesh(&mut b, UNSIGNED_SHORT);
    let rotation = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let parent_trs = Affine3A::from_scale_rotation_translation(
        Vec3::new(2.0, 1.0, 0.5),
        rotation,
        Vec3::new(1.0, 2.0, 3.0),
    );
    let child_matrix = Mat4::from_cols_array(&[
        1.0, 0.0, 0.0, 0.0, //
        0.5, 1.0, 0.0, 0.0, // a shear
        0.0, 0.0, -1.0, 0.0, // a mirror
        0.0, 0.0, 5.0, 1.0,
    ]);
    let grandchild_trs =
        Affine3A::from_scale_rotation_translation(Vec3::ONE, Quat::IDENTITY, Vec3::X * 3.0);
    let grandchild = b.node(json!({"mesh": mesh, "translation": [3.0, 0.0, 0.0]}));
    let child = b.node(json!({
        "mesh": mesh, "matrix": child_matrix.to_cols_array(), "children": [grandchild]
    }));
    let parent = b.node(json!({
        "translation": [1.0, 2.0, 3.0],
        "rotation": rotation.to_array(),
        "scale": [2.0, 1.0, 0.5],
        "children": [child],
    }));
    b.roots.push(parent);
    let dir = TempDir::new("gltf-tree");
    let scene = load_gltf(&b.write_glb(dir.path(), "tree")).unwrap();
    let child_world = parent_trs * Affine3A::from_mat4(child_matrix);
    let grandchild_world = child_world * grandchild_trs;
    let mut want = placed(child_world, &mesh_triangles());
    want.extend(placed(grandchild_world, &mesh_triangles()));
    assert_triangles_close(&scene.triangles, &want);
    assert_eq!(scene.meshes.len(), 1, "one mesh, placed twice");
    assert_eq!(scene.instances.len(), 2);
    let inverse_ok = scene
        .instances
        .iter()
        .all(|i| (i.inverse * i.transform).abs_diff_eq(Affine3A::IDENTITY, 1e-5));
    assert!(inverse_ok);
}

#[test]
fn a_mesh_used_by_several_nodes_is_stored_once() {
    let mut b = GltfBuilder::default();
    let mesh = two_primitive_mesh(&mut b, UNSIGNED_INT);
    let other = {
        let p = b.positions(&QUAD[..3]);
        b.mesh(&[(p, None)])
    };
    for k in 0..4 {
        let m = if k == 2 { other } else { mesh };
        let n = b.node(json!({"mesh": m, "translation": [k as f32 * 2.0, 0.0, 0.0]}));
        b.roots.push(n);
    }
    let dir = TempDir::new("gltf-shared");
    let scene = load_gltf(&b.write_embedded(dir.path(), "shared")).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.instances.len(), 4);
    assert_eq!(
        scene.instances.iter().map(|i| i.mesh).collect::<Vec<_>>(),
        [0, 0, 1, 0]
    );
    assert_eq!(scene.triangles.len(), 3 * 3 + 1);
    let instancing = scene.instancing();
    assert_eq!(instancing.unique_triangles(), 4);
    assert_eq!(instancing.instanced_triangles(), 10);
    // The third node's triangle comes after the first two nodes' six.
    let want = placed(
        Affine3A::from_translation(Vec3::X * 4.0),
        &[Triangle::new(QUAD[0], QUAD[1], QUAD[2])],
    );
    assert_triangles_close(&scene.triangles[6..7], &want);
}

#[test]
fn external_embedded_and_binary_files_load_the_same_scene() {
    let dir = TempDir::new("gltf-forms");
    let mut b = GltfBuilder::default();
    let mesh = two_primitive_mesh(&mut b, UNSIGNED_SHORT);
    let child = b.node(json!({"mesh": mesh, "scale": [1.0, 2.0, 3.0]}));
    let root = b.node(json!({"mesh": mesh, "children": [child], "rotation": [0.0, 0.0, 0.6, 0.8]}));
    b.roots.push(root);
    let external = b.write_external(dir.path(), "forms");
    let reference = load_gltf(&external).unwrap();
    assert_eq!(reference.triangles.len(), 6);
    let embedded = b.write_embedded(dir.path(), "forms-embedded");
    let glb = b.write_glb(dir.path(), "FORMS");
    let upper = dir.join("forms-upper.GLB");
    std::fs::copy(&glb, &upper).unwrap();
    for path in [external, embedded, glb, upper] {
        // Through `Scene::load`, which every command and the app use.
        let scene = Scene::load(&path.display().to_string()).unwrap();
        assert_eq!(scene.triangles, reference.triangles, "{}", path.display());
        assert_eq!(scene.instances, reference.instances);
    }
}

/// Writes `doc` (with the builder's buffer embedded) and loads it.
fn load_doc(
    name: &str,
    b: &GltfBuilder,
    edit: impl FnOnce(&mut serde_json::Value),
) -> (String, GltfError) {
    let dir = TempDir::new("gltf-bad");
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        common::gltf::base64(&b.bin)
    );
    let mut doc = b.document(Some(uri));
    edit(&mut doc);
    let path = common::gltf::write_json(dir.path(), name, &doc);
    let error = load_gltf(&path)
        .err()
        .unwrap_or_else(|| panic!("{name} loads"));
    let message = error.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    (message, error)
}

/// A valid file: one node 'part' with the two-primitive mesh.
fn valid() -> GltfBuilder {
    let mut b = GltfBuilder::default();
    let mesh = two_primitive_mesh(&mut b, UNSIGNED_SHORT);
    let n = b.node(json!({"mesh": mesh, "name": "part"}));
    b.roots.push(n);
    b
}

#[test]
fn broken_files_are_each_rejected_with_their_own_error() {
    let b = valid();
    let dir = TempDir::new("gltf-bad");

    // The buffer file is not there.
    let mut doc = b.document(Some("nowhere.bin".into()));
    doc["buffers"][0]["uri"] = json!("nowhere.bin");
    let path = common::gltf::write_json(dir.path(), "missing", &doc);
    let e = load_gltf(&path).unwrap_err();
    assert!(
        matches!(e, GltfError::MissingBuffer { buffer: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("nowhere.bin"), "{e}");

    // A .glb whose buffer points at a binary chunk it does not have.
    let path = dir.join("no-chunk.glb");
    std::fs::write(&path, common::gltf::glb(&b.document(None), &[])).unwrap();
    let e = load_gltf(&path).unwrap_err();
    assert!(matches!(e, GltfError::MissingBuffer { .. }), "{e}");

    // A buffer shorter than it says.
    let (_, e) = load_doc("short", &b, |d| {
        d["buffers"][0]["byteLength"] = json!(b.bin.len() + 64);
    });
    assert!(matches!(e, GltfError::MissingBuffer { .. }), "{e}");

    // POSITION as VEC2, indices as FLOAT.
    let (m, e) = load_doc("vec2", &b, |d| d["accessors"][0]["type"] = json!("VEC2"));
    assert!(
        matches!(
            e,
            GltfError::Accessor {
                problem: AccessorProblem::WrongType {
                    what: "POSITION",
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
    assert!(
        m.contains("node 0 'part'") && m.contains("VEC2 of FLOAT"),
        "{m}"
    );
    let (_, e) = load_doc("float-indices", &b, |d| {
        d["accessors"][1]["componentType"] = json!(common::gltf::FLOAT)
    });
    assert!(
        matches!(
            e,
            GltfError::Accessor {
                problem: AccessorProblem::WrongType {
                    what: "indices",
                    ..
                },
                ..
            }
        ),
        "{e}"
    );

    // An index past the last vertex, an accessor past its view.
    let mut big = valid();
    let positions = big.positions(&QUAD);
    let indices = big.indices(&[0, 1, 7], UNSIGNED_INT);
    let mesh = big.mesh(&[(positions, Some(indices))]);
    big.nodes[0]["mesh"] = json!(mesh);
    let (_, e) = load_doc("index-range", &big, |_| {});
    assert!(
        matches!(
            e,
            GltfError::Accessor {
                problem: AccessorProblem::IndexOutOfRange {
                    index: 7,
                    vertices: 4
                },
                ..
            }
        ),
        "{e}"
    );
    let (_, e) = load_doc("past-view", &b, |d| d["accessors"][0]["count"] = json!(5));
    assert!(
        matches!(
            e,
            GltfError::Accessor {
                problem: AccessorProblem::OutOfBounds { .. },
                ..
            }
        ),
        "{e}"
    );

    // Lines and points.
    for (mode, name) in [(0, "point"), (1, "line"), (5, "triangle strip")] {
        let (m, e) = load_doc("mode", &b, |d| {
            d["meshes"][0]["primitives"][1]["mode"] = json!(mode)
        });
        assert!(matches!(e, GltfError::PrimitiveMode { .. }), "{e}");
        assert!(m.contains(name) && m.contains("node 0 'part'"), "{m}");
    }

    // Transforms: singular, not finite, projective.
    let (m, e) = load_doc("singular", &b, |d| {
        d["nodes"][0]["scale"] = json!([1.0, 0.0, 1.0])
    });
    assert!(matches!(e, GltfError::SingularTransform { .. }), "{e}");
    assert!(m.contains("node 0 'part'"), "{m}");
    let (_, e) = load_doc("huge", &b, |d| {
        d["nodes"][0]["translation"] = json!([1e39, 0.0, 0.0])
    });
    assert!(matches!(e, GltfError::NonFiniteTransform { .. }), "{e}");
    let mut projective = Mat4::IDENTITY.to_cols_array();
    projective[3] = 0.5;
    let (_, e) = load_doc("projective", &b, |d| {
        d["nodes"][0]["matrix"] = json!(projective)
    });
    assert!(matches!(e, GltfError::ProjectiveTransform { .. }), "{e}");
    // A singular parent makes its child's placement singular: the child is named.
    let (m, e) = load_doc("singular-parent", &b, |d| {
        d["nodes"] =
            json!([{"mesh": 0, "name": "part"}, {"scale": [0.0, 0.0, 0.0], "children": [0]}]);
        d["scenes"][0]["nodes"] = json!([1]);
    });
    assert!(matches!(e, GltfError::SingularTransform { .. }), "{e}");
    assert!(m.contains("node 0 'part'"), "{m}");

    // A node that is its own grandchild.
    let (_, e) = load_doc("cycle", &b, |d| {
        d["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    });
    assert!(matches!(e, GltfError::NotATree { .. }), "{e}");

    // A non-finite vertex.
    let mut nan = GltfBuilder::default();
    let p = nan.positions(&[Vec3::ZERO, Vec3::X, Vec3::new(f32::INFINITY, 0.0, 0.0)]);
    let mesh = nan.mesh(&[(p, None)]);
    let n = nan.node(json!({"mesh": mesh}));
    nan.roots.push(n);
    nan.accessors[0]["max"] = json!([1.0, 1.0, 1.0]);
    let (_, e) = load_doc("nan", &nan, |_| {});
    assert!(
        matches!(
            e,
            GltfError::Accessor {
                problem: AccessorProblem::NonFiniteVertex { vertex: 2 },
                ..
            }
        ),
        "{e}"
    );

    // An attribute naming an accessor that does not exist (which the glTF crate's own
    // validation would index out of bounds).
    let (m, e) = load_doc("no-accessor", &b, |d| {
        d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(1215752191)
    });
    assert!(matches!(e, GltfError::Parse { .. }), "{e}");
    assert!(m.contains("accessor 1215752191 does not exist"), "{m}");

    // Not glTF at all, and glTF without a triangle.
    let path = dir.join("text.gltf");
    std::fs::write(&path, "v 0 0 0\n").unwrap();
    assert!(matches!(
        load_gltf(&path).unwrap_err(),
        GltfError::Parse { .. }
    ));
    let (_, e) = load_doc("empty", &b, |d| {
        d["nodes"][0].as_object_mut().unwrap().clear()
    });
    assert!(matches!(e, GltfError::NoTriangles { .. }), "{e}");
    let e = load_gltf(&dir.join("absent.glb")).unwrap_err();
    assert!(matches!(e, GltfError::Io { .. }), "{e}");
}

/// A large uniform scale is not singular (its determinant overflows f32, not the placement):
/// the mesh loads, placed and with the instance's inverse right.
#[test]
fn a_large_uniform_scale_places_the_mesh() {
    let mut b = valid();
    b.nodes[0]["scale"] = json!([1e13, 1e13, 1e13]);
    let dir = TempDir::new("gltf-large-scale");
    let doc = b.document(Some(format!(
        "data:application/octet-stream;base64,{}",
        common::gltf::base64(&b.bin)
    )));
    let path = common::gltf::write_json(dir.path(), "large-scale", &doc);
    let scene = load_gltf(&path).unwrap();
    let placed = scene.flattened().unwrap();
    let want = mesh_triangles();
    assert_eq!(placed.len(), want.len());
    for (g, w) in placed.iter().zip(&want) {
        for k in 0..3 {
            assert!((g.v[k] / 1e13 - w.v[k]).length() < 1e-5, "{g:?} vs {w:?}");
        }
    }
    let instance = &scene.instances[0];
    let back = instance.inverse.transform_point3(Vec3::splat(1e13));
    assert!((back - Vec3::ONE).length() < 1e-5, "{back:?}");
}

#[test]
fn a_gltf_without_a_scene_places_its_root_nodes() {
    let b = valid();
    let dir = TempDir::new("gltf-sceneless");
    let mut doc = b.document(Some(format!(
        "data:application/octet-stream;base64,{}",
        common::gltf::base64(&b.bin)
    )));
    let obj = doc.as_object_mut().unwrap();
    obj.remove("scene");
    obj.remove("scenes");
    let path = common::gltf::write_json(dir.path(), "sceneless", &doc);
    let scene = load_gltf(&path).unwrap();
    assert_eq!(scene.triangles, mesh_triangles());
}

#[test]
fn the_command_line_takes_gltf_scenes_and_names_what_is_wrong() {
    let dir = TempDir::new("gltf-cli");
    let mut b = valid();
    let child = b.node(json!({"mesh": 0, "translation": [0.0, 0.0, 2.0]}));
    b.nodes[0]["children"] = json!([child]);
    let good = b.write_glb(dir.path(), "good");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_bvhlab"))
            .args(args)
            .env_remove("RUST_BACKTRACE")
            .output()
            .expect("bvhlab runs")
    };
    let good = good.display().to_string();
    for accel in ["bvh", "two-level"] {
        let out = run(&["stats", "--scene", &good, "--accel", accel]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains(accel), "{text}");
    }
    let out = run(&["stats", "--scene", &good, "--accel", "two-level"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("instances") && text.contains('2'), "{text}");

    // `bench --json` on an instanced scene says how it is instanced.
    let small = [
        "--width", "16", "--height", "12", "--builds", "1", "--runs", "1", "--json",
    ];
    for accel in ["two-level", "all"] {
        let mut args = vec!["bench", "--scene", &good, "--accel", accel];
        args.extend(small);
        let out = run(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["instances"], 2, "{v}");
        assert_eq!(v["unique_triangles"], 3, "{v}");
        assert_eq!(v["instanced_triangles"], 6, "{v}");
        assert_eq!(v["triangles"], 6, "{v}");
        assert_eq!(v["flattened_bytes"], 6 * 40, "{v}");
    }
    // Without --accel, a scene with instances of its own gets the two levels.
    let out = run(&["stats", "--scene", &good]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("two-level"), "{text}");
    assert!(text.contains("scene instanced triangles  6"), "{text}");

    b.nodes[1]["scale"] = json!([0.0, 1.0, 1.0]);
    let bad = b.write_embedded(dir.path(), "bad").display().to_string();
    let out = run(&["stats", "--scene", &bad]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&bad) && err.contains("node 1") && err.contains("singular"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// A glTF file reads no file outside its own folder: not by an absolute path, not up with
/// `..` (plain or percent-encoded), not through a link that leads out; a buffer beside it
/// or below it, and a data URI, are read.
#[test]
fn buffers_stay_in_the_gltf_files_folder() {
    let root = TempDir::new("gltf-confined");
    let dir = root.join("model");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let mut b = GltfBuilder::default();
    let mesh = two_primitive_mesh(&mut b, UNSIGNED_SHORT);
    let node = b.node(json!({"mesh": mesh}));
    b.roots.push(node);
    // The same buffer outside the folder, below it, and linked to from inside it.
    std::fs::write(root.join("outside.bin"), &b.bin).unwrap();
    std::fs::write(dir.join("sub/inside.bin"), &b.bin).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(root.join("outside.bin"), dir.join("link.bin")).unwrap();
    let outside = root.join("outside.bin").display().to_string();
    let mut refused = vec![
        outside.clone(),
        "../outside.bin".to_string(),
        "%2e%2e/outside.bin".to_string(),
        "sub/../../outside.bin".to_string(),
        format!("file://{outside}"),
    ];
    if cfg!(unix) {
        refused.push("link.bin".into());
    }
    for (k, uri) in refused.iter().enumerate() {
        let path =
            common::gltf::write_json(&dir, &format!("bad{k}"), &b.document(Some(uri.clone())));
        let e = load_gltf(&path).unwrap_err().to_string();
        assert!(
            e.contains("outside the glTF file's folder") || e.contains("unsupported URI"),
            "{uri}: {e}"
        );
    }
    let path = common::gltf::write_json(&dir, "good", &b.document(Some("sub/inside.bin".into())));
    assert_eq!(
        load_gltf(&path).unwrap().triangles.len(),
        mesh_triangles().len()
    );
}
