//! What the explorer draws of the two levels: the selected instance's BLAS, the island's
//! outline, the cost per triangle.

use super::*;

/// The explorer's view of the two levels: the selected instance's BLAS hangs below the
/// top-level leaf that holds it, its boxes drawn where the instance's transform places them
/// contain the instance's world-space triangles (every triangle inside the placed root box,
/// each leaf's triangles inside the leaf's placed box), and the walk's children and parents
/// are the structure's.
#[test]
fn the_selected_instances_blas_is_drawn_around_its_world_triangles_and_walked_below_its_leaf() {
    use bvhlab::app::levels::{Levels, WalkNode};
    let scene = instanced_scene(40, 91);
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::default()),
        &Default::default(),
    )
    .unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    let top = tl.outline();
    let leaf_instances = tl.leaf_instances();
    assert_eq!(leaf_instances.len(), top.nodes.len());
    let mut mirrored = 0;
    for (i, placed) in scene.instances.iter().enumerate() {
        let o = tl.instance_outline(i).unwrap();
        assert_eq!((o.instance, o.mesh), (i, placed.mesh));
        assert_eq!(o.transform, placed.transform);
        let mesh = &scene.meshes[placed.mesh].triangles;
        assert_eq!(o.triangle_count, mesh.len());
        mirrored += usize::from(placed.transform.matrix3.determinant() < 0.0);
        // The BLAS outline is the mesh's own BVH8, in the mesh's space.
        let blas = &tl.blases[placed.mesh];
        assert_eq!(o.blas.nodes[0].bounds, blas.nodes[0].bounds());
        // (The outline has a node per lane: its leaves are one below the deepest wide node.)
        if !mesh.is_empty() {
            assert_eq!(o.blas.max_depth(), blas.depth);
        }
        o.blas.validate().unwrap();
        if o.entries.is_empty() {
            // Only an empty mesh's instance is in no leaf.
            assert!(mesh.is_empty(), "instance {i} is in no leaf");
            continue;
        }
        // Every world triangle of the instance lies in the placed root box, and in the
        // world box around it; each leaf's triangles in that leaf's placed box.
        let world: Vec<Triangle> = mesh.iter().map(|t| placed.place(t)).collect();
        let root_box = o.world_bounds(0);
        for t in &world {
            for v in t.v {
                assert!(o.placed_box_contains(0, v, 1e-4), "instance {i}: {v}");
                let pad = 1e-4 * (root_box.max - root_box.min).max_element();
                assert!(
                    (v.cmpge(root_box.min - pad) & v.cmple(root_box.max + pad)).all(),
                    "instance {i}: {v} outside {root_box:?}"
                );
            }
        }
        // Each of the instance's top-level leaves holds one of its references, whose BLAS
        // node's triangles its world box holds; the entries' triangles are the mesh's, each
        // once (the references cut the BLAS).
        let mut reached = vec![0u32; mesh.len()];
        for e in &o.entries {
            assert_eq!(leaf_instances[e.tlas_leaf as usize], i as u32);
            assert!(top.nodes[e.tlas_leaf as usize].is_leaf());
            let leaf_box = top.nodes[e.tlas_leaf as usize].bounds;
            for t in o.triangles_under(e.blas_node as usize) {
                let local = (t - o.first_triangle) as usize;
                reached[local] += 1;
                assert!(world[local].v.iter().all(|&v| leaf_box.contains_point(v)));
            }
        }
        assert!(reached.iter().all(|&n| n == 1), "instance {i}: {reached:?}");
        let mut covered = vec![false; mesh.len()];
        for k in 0..o.blas.nodes.len() {
            if !o.blas.nodes[k].is_leaf() {
                continue;
            }
            for t in o.triangles_under(k) {
                let local = (t - o.first_triangle) as usize;
                covered[local] = true;
                for v in world[local].v {
                    assert!(o.placed_box_contains(k, v, 1e-4), "instance {i} node {k}");
                }
            }
        }
        assert!(covered.iter().all(|&c| c), "every triangle in a leaf");
        assert_eq!(o.first_triangle, tl.first_triangle[i]);
        // Hits name flattened triangles: each is found in its instance again.
        let last = o.first_triangle + mesh.len() as u64 - 1;
        assert_eq!(tl.instance_of_triangle(o.first_triangle), Some(i));
        assert_eq!(tl.instance_of_triangle(last), Some(i));

        // The walk: the levels run on below the top level by the BLAS's levels; a leaf of
        // the instance has its reference's BLAS node as its only child, whose parent is the
        // leaf; below, the BLAS's own.
        let levels = Levels::new(&top, Some(&o));
        assert_eq!(Levels::new(&top, None).max_depth(), top.max_depth());
        assert_eq!(levels.max_depth(), top.max_depth() + 1 + o.blas.max_depth());
        let root = WalkNode::Bottom(0);
        assert_eq!(levels.node(levels.id(root)), Some(root));
        assert_eq!(levels.depth(root), top.max_depth() + 1);
        assert_eq!(levels.level(top.max_depth() + 1), vec![root]);
        for e in &o.entries {
            let (leaf, node) = (
                WalkNode::Top(e.tlas_leaf as usize),
                WalkNode::Bottom(e.blas_node as usize),
            );
            assert_eq!(levels.children(leaf), vec![node]);
            assert_eq!(levels.parent(node), Some(leaf));
            assert_eq!(levels.top_above(node), Some(e.tlas_leaf as usize));
        }
        for k in 0..o.blas.nodes.len() {
            let n = WalkNode::Bottom(k);
            let children: Vec<WalkNode> =
                o.blas.nodes[k].children().map(WalkNode::Bottom).collect();
            assert_eq!(levels.children(n), children);
            for c in children {
                let WalkNode::Bottom(b) = c else {
                    unreachable!()
                };
                let above = match o.leaf_above(b as u32) {
                    Some(l) => WalkNode::Top(l as usize),
                    None => n,
                };
                assert_eq!(levels.parent(c), Some(above));
                assert_eq!(levels.depth(c), levels.depth(n) + 1);
            }
        }
        // The rest of the top level is unchanged.
        for k in 0..top.nodes.len() {
            if o.entry_below(k as u32).is_none() {
                let children: Vec<WalkNode> = top.nodes[k].children().map(WalkNode::Top).collect();
                assert_eq!(levels.children(WalkNode::Top(k)), children);
            }
        }
    }
    assert!(mirrored > 0, "the scene mirrors some instances");
    assert!(tl.instance_outline(scene.instances.len()).is_none());
    assert_eq!(tl.instance_of_triangle(scene.triangles.len() as u64), None);
}

/// On the island, placing billions of triangles, a selected instance's outline is its
/// mesh's BLAS alone: nothing is flattened.
#[test]
fn an_island_instances_outline_is_its_meshs_blas_alone() {
    use bvhlab::scene::island::{self, Detail};
    let scene = island::island(300, &Detail::SMALL);
    assert!(!scene.is_flattened());
    let built = structure::build_scene(
        &scene,
        &two_level_params(TraversalOrder::default()),
        &Default::default(),
    )
    .unwrap();
    let Structure::TwoLevel(tl) = &built.structure else {
        panic!("two levels")
    };
    for i in [0, 1, scene.instances.len() / 2, scene.instances.len() - 1] {
        let o = tl.instance_outline(i).unwrap();
        let mesh = &scene.meshes[o.mesh].triangles;
        assert_eq!(o.blas.refs.len(), tl.blases[o.mesh].prim_indices.len());
        assert!(o.blas.nodes.len() <= 2 * mesh.len() + 1);
        let placed = &scene.instances[i];
        for t in mesh.iter().step_by(7) {
            for v in placed.place(t).v {
                assert!(o.placed_box_contains(0, v, 1e-4), "instance {i}");
            }
        }
    }
}

/// The cost-per-triangle view under the two levels: each pixel's triangle carries its
/// placed share of both levels' SAH cost, worked out for the triangles shown only, the
/// shares of all placed triangles summing to the SAH cost (`PlacedCosts`' unit test).
#[test]
fn the_cost_per_triangle_view_shows_each_placed_triangles_share() {
    use bvhlab::render::per_triangle::PerTriangle;
    use bvhlab::render::{self, Mode, RenderSettings};
    let scene = instanced_scene(40, 5);
    let params = StructureParams::of_kind(AccelKind::TwoLevel);
    let s = structure::build_scene(&scene, &params, &Default::default())
        .unwrap()
        .structure;
    let settings = RenderSettings::for_scene(&scene, 64, 48);
    let frame = render::trace(&s, &scene, &settings);
    let v = frame
        .triangle_values_for::<Watertight>(
            Mode::TriangleCost,
            &s,
            &params,
            &scene,
            &settings,
            1,
            &|| false,
        )
        .unwrap()
        .unwrap();
    let (sah, c_trav, c_isect) = s.sah_cost(&params).unwrap();
    assert_eq!(v.total, sah);
    let Structure::TwoLevel(tl) = &s else {
        unreachable!()
    };
    let costs = tl.placed_costs(c_trav, c_isect);
    let PerTriangle::Some(worked_out) = &v.values else {
        panic!("every placed triangle worked out");
    };
    let hits: Vec<_> = frame.samples.iter().filter(|x| x.is_hit()).collect();
    assert!(hits.len() > 100);
    for x in hits {
        let share = v.of(x).unwrap();
        assert!(
            share > 0.0 && share == costs.of(x.triangle),
            "{}",
            x.triangle
        );
        assert!(worked_out.contains_key(&x.triangle));
    }
    assert!(worked_out.len() < scene.placed_triangles());
}
