//! The collapse and the build: no dearer than a greedy collapse, unsupported kernels
//! refused, the recorded trees on any thread count.

use super::*;

/// The greedy collapse the dynamic program must beat or tie: open the child with the
/// largest box until W children, leaves where the BVH2 has them.
fn greedy_cost<const W: usize>(b2: &Bvh, p: &CollapseParams) -> f64 {
    let area = |i: usize| b2.nodes[i].bounds().surface_area() as f64;
    let root = area(0);
    let mut cost = p.c_trav as f64 * root;
    let mut open = vec![0usize];
    while let Some(n) = open.pop() {
        let l = b2.nodes[n].left_first as usize;
        let mut children = vec![l, l + 1];
        while children.len() < W {
            let Some((k, _)) = children
                .iter()
                .enumerate()
                .filter(|(_, c)| !b2.nodes[**c].is_leaf())
                .max_by(|a, b| area(*a.1).total_cmp(&area(*b.1)))
            else {
                break;
            };
            let c = children.swap_remove(k);
            let l = b2.nodes[c].left_first as usize;
            children.extend([l, l + 1]);
        }
        for c in children {
            let node = &b2.nodes[c];
            if node.is_leaf() {
                cost += p.c_isect as f64 * node.count as f64 * area(c);
            } else {
                cost += p.c_trav as f64 * area(c);
                open.push(c);
            }
        }
    }
    cost / root
}

#[test]
fn the_sah_optimal_collapse_costs_no_more_than_a_greedy_one() {
    let p = CollapseParams::default();
    for name in [
        "cornell",
        "teapot-in-stadium",
        "sphere:3000",
        "walls-rotated",
    ] {
        let scene = Scene::load(name).unwrap();
        let b2 = bvh2(&scene.triangles, Strategy::SahBinned);
        let w4 = WideBvh::<4>::collapse(&b2, &p);
        let w8 = WideBvh::<8>::collapse(&b2, &p);
        let (c4, g4) = (w4.sah_cost(p.c_trav, p.c_isect), greedy_cost::<4>(&b2, &p));
        let (c8, g8) = (w8.sah_cost(p.c_trav, p.c_isect), greedy_cost::<8>(&b2, &p));
        assert!(c4 <= g4 * (1.0 + 1e-5), "{name}: BVH4 {c4} > greedy {g4}");
        assert!(c8 <= g8 * (1.0 + 1e-5), "{name}: BVH8 {c8} > greedy {g8}");
        // A wider node folds more levels: fewer nodes, and no deeper a tree.
        assert!(w8.nodes.len() < w4.nodes.len(), "{name}");
        assert!(w8.depth <= w4.depth, "{name}");
    }
}

#[test]
fn an_unsupported_kernel_is_refused_and_changes_nothing() {
    let b2 = bvh2(&soup(100, 1), Strategy::SahBinned);
    let mut wide = WideBvh::<8>::collapse(&b2, &CollapseParams::default());
    let before = wide.simd();
    for level in SimdLevel::ALL.into_iter().filter(|l| !l.supported()) {
        let err = wide.set_simd(level).unwrap_err();
        assert!(err.to_string().contains(level.label()), "{err}");
        assert_eq!(wide.simd(), before);
    }
    assert!(wide.set_simd(SimdLevel::Portable).is_ok());
}

/// The binned SAH build and its collapse give the same BVH4 and BVH8 on 1 and 2 threads,
/// and the very trees recorded before the build was made faster: a change of speed must not
/// change a node, a leaf's order or a box.
#[test]
fn wide_builds_are_the_recorded_trees_on_any_thread_count() {
    use bvhlab::accel::structure::{AccelKind, Structure, StructureParams, build};
    let recorded = [
        ("soup:100000", AccelKind::Bvh8, 0xb5bd_cf89_5700_d27a_u64),
        ("soup:100000", AccelKind::Bvh4, 0x8aa9_5e38_135b_bacf),
        ("teapot-in-stadium", AccelKind::Bvh8, 0x7c91_1f64_cc7d_ed76),
        ("sphere:50000", AccelKind::Bvh4, 0xb34d_0db9_3044_6c8f),
    ];
    for (spec, kind, expected) in recorded {
        let scene = Scene::load(spec).unwrap();
        let tris = scene.flattened().unwrap();
        let params = StructureParams {
            kind,
            ..StructureParams::default()
        };
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            let built = pool.install(|| build(&tris, &params, &Default::default()).unwrap());
            let fp = match &built.structure {
                Structure::Bvh8(w) => fingerprint(w),
                Structure::Bvh4(w) => fingerprint(w),
                _ => unreachable!("a wide BVH was asked for"),
            };
            assert_eq!(fp, expected, "{spec}, {kind:?}, {threads} threads: {fp:#x}");
        }
    }
}
