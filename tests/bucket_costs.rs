//! The bucket-cost plot: the cheapest candidate it shows at a node is the split the SAH
//! builder took there, on every built-in scene, for binned SAH (several B) and the full sweep.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildParams, Bvh, Strategy, build, split_costs};
use bvhlab::accel::split_costs::SplitMethod;
use bvhlab::scene::Scene;

const SCENES: &[&str] = &[
    "cornell",
    "teapot-in-stadium",
    "grass:3000",
    "walls",
    "walls-rotated",
    "soup:3000",
    "sphere:3000",
];

/// For every interior node: the candidates' minimum has the left child's triangle count and
/// the cost of the node's actual split, and no candidate is cheaper.
fn assert_cheapest_is_the_builders_split(
    bvh: &Bvh,
    triangles: &[bvhlab::geometry::Triangle],
    p: &BuildParams,
    what: &str,
) -> usize {
    let mut checked = 0;
    for i in 0..bvh.nodes.len() {
        let node = &bvh.nodes[i];
        if node.is_leaf() {
            continue;
        }
        let under = bvh.triangles_under(i);
        let costs = split_costs(triangles, &under, p);
        assert_eq!(costs.bounds, node.bounds(), "{what}: node {i}'s box");
        let Some(cheapest) = costs.cheapest else {
            // No plane separates the centroids: the builder halved by count instead.
            continue;
        };
        let left = &bvh.nodes[node.left_first as usize];
        let right = &bvh.nodes[node.left_first as usize + 1];
        let n_left = bvh.triangles_under(node.left_first as usize).len();
        let area = node.bounds().surface_area();
        let actual = p.c_trav
            + (left.bounds().surface_area() * n_left as f32
                + right.bounds().surface_area() * (under.len() - n_left) as f32)
                / area
                * p.c_isect;
        assert_eq!(
            cheapest.left as usize, n_left,
            "{what}: node {i} left count"
        );
        assert!(
            (cheapest.cost - actual).abs() <= 1e-4 * actual.abs(),
            "{what}: node {i}: plot minimum {} against the split's cost {actual}",
            cheapest.cost
        );
        for c in &costs.candidates {
            assert!(
                c.cost >= cheapest.cost,
                "{what}: node {i}: {c:?} below the minimum"
            );
            assert_eq!(c.left + c.right, under.len() as u32);
        }
        checked += 1;
    }
    checked
}

#[test]
fn the_plots_minimum_is_the_split_the_builder_chose() {
    for name in SCENES {
        let scene = Scene::load(name).expect("built-in scene");
        for (strategy, buckets) in [
            (Strategy::SahBinned, 4),
            (Strategy::SahBinned, 16),
            (Strategy::SahBinned, 64),
            (Strategy::SahSweep, 16),
        ] {
            let p = BuildParams {
                buckets,
                ..BuildParams::with_strategy(strategy)
            };
            let (bvh, _) = build(&scene.triangles, &p).expect("build");
            let what = format!("{name} {strategy:?} B={buckets}");
            let checked = assert_cheapest_is_the_builders_split(&bvh, &scene.triangles, &p, &what);
            assert!(
                checked > 0 || bvh.nodes.len() == 1,
                "{what}: no node checked"
            );
        }
    }
}

#[test]
fn binned_candidates_are_the_bucket_boundaries_and_the_sweep_every_position() {
    let tris = common::soup(500, 3);
    let all: Vec<u32> = (0..tris.len() as u32).collect();
    for buckets in [2, 8, 32] {
        let p = BuildParams {
            buckets,
            ..BuildParams::with_strategy(Strategy::SahBinned)
        };
        let costs = split_costs(&tris, &all, &p);
        assert_eq!(costs.method, SplitMethod::Binned { buckets });
        // 500 random centroids fill every bucket: B − 1 boundaries on each axis.
        assert_eq!(costs.candidates.len(), 3 * (buckets as usize - 1));
        for c in &costs.candidates {
            assert!(
                costs.bounds.min[c.axis] <= c.position && c.position <= costs.bounds.max[c.axis]
            );
        }
    }
    let p = BuildParams::with_strategy(Strategy::SahSweep);
    let costs = split_costs(&tris, &all, &p);
    assert_eq!(costs.method, SplitMethod::Sweep);
    assert_eq!(costs.candidates.len(), 3 * (tris.len() - 1));
    assert_eq!(costs.leaf_cost, p.c_isect * tris.len() as f32);
    // The sweep sees every binned boundary's partition among its positions, so its minimum
    // is never above binned SAH's.
    let binned = split_costs(
        &tris,
        &all,
        &BuildParams::with_strategy(Strategy::SahBinned),
    );
    assert!(costs.cheapest.unwrap().cost <= binned.cheapest.unwrap().cost * (1.0 + 1e-6));
}

#[test]
fn a_median_tree_is_shown_what_binned_sah_would_choose() {
    let scene = Scene::load("teapot-in-stadium").unwrap();
    let p = BuildParams::with_strategy(Strategy::ObjectMedian);
    let (bvh, _) = build(&scene.triangles, &p).unwrap();
    let costs = split_costs(&scene.triangles, &bvh.triangles_under(0), &p);
    assert_eq!(costs.method, SplitMethod::Binned { buckets: p.buckets });
    // The median splits the stadium's triangles in half, which SAH would not.
    let cheapest = costs.cheapest.unwrap();
    assert!(cheapest.left.abs_diff(cheapest.right) > 1);
    assert!(costs.split_pays());
}

/// Every interior node of a k-d tree with the path that reaches it.
fn kd_interior_paths(tree: &bvhlab::accel::KdTree) -> Vec<(usize, Vec<bool>)> {
    let mut out = Vec::new();
    let mut stack = vec![(0usize, Vec::new())];
    while let Some((i, path)) = stack.pop() {
        let n = tree.nodes[i];
        if n.is_leaf() {
            continue;
        }
        let mut below = path.clone();
        below.push(false);
        let mut above = path.clone();
        above.push(true);
        stack.push((i + 1, below));
        stack.push((n.above_child(), above));
        out.push((i, path));
    }
    out
}

#[test]
fn a_kd_nodes_plot_minimum_is_its_split_plane_with_the_empty_space_bonus() {
    use bvhlab::accel::{KdParams, KdSplit, kdtree};
    for name in ["cornell", "teapot-in-stadium", "walls-rotated", "soup:1500"] {
        let scene = Scene::load(name).unwrap();
        for split in [KdSplit::Sweep, KdSplit::Binned(16)] {
            let p = KdParams {
                split,
                ..KdParams::default()
            };
            let (tree, _) = kdtree::build(&scene.triangles, &p).unwrap();
            let paths = kd_interior_paths(&tree);
            assert!(!paths.is_empty(), "{name}: no interior node");
            // Each replay starts at the root: the top levels and a spread of deeper nodes.
            let step = (paths.len() / 40).max(1);
            let sample = paths
                .into_iter()
                .enumerate()
                .filter(|(k, (_, path))| path.len() <= 4 || k % step == 0);
            for (_, (i, path)) in sample {
                let what = format!("{name} {split:?} node {i}");
                let costs = tree.split_costs(&p, &path).expect(&what);
                let cheapest = costs.cheapest.expect(&what);
                let n = tree.nodes[i];
                assert_eq!(
                    (cheapest.axis, cheapest.position),
                    (n.axis(), n.split()),
                    "{what}"
                );
                assert!(
                    costs.candidates.iter().all(|c| c.cost >= cheapest.cost),
                    "{what}"
                );
            }
        }
    }
    // Parameters other than the build's do not replay its splits.
    let scene = Scene::load("teapot-in-stadium").unwrap();
    let (tree, _) = kdtree::build(&scene.triangles, &KdParams::default()).unwrap();
    let other = KdParams {
        empty_bonus: 0.0,
        split: KdSplit::Binned(4),
        ..KdParams::default()
    };
    let deep = kd_interior_paths(&tree)
        .into_iter()
        .map(|(_, p)| p)
        .max_by_key(|p| p.len())
        .unwrap();
    assert!(tree.split_costs(&other, &deep).is_none());
}
