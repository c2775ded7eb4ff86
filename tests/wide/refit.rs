//! Refits: the refitted tree traces as a rebuilt one, the parallel refit is exact, the SAH
//! sums carried from refit to refit.

use super::*;

/// Moves some triangles (scene order), returning the moved indices.
fn shake(tris: &mut [Triangle], rng: &mut Rng, every: usize) -> Vec<u32> {
    let mut moved = Vec::new();
    for (i, t) in tris.iter_mut().enumerate() {
        if rng.below(every) == 0 {
            let d = Vec3::new(
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
                rng.range(-0.3, 0.3),
            );
            for v in &mut t.v {
                *v += d;
            }
            moved.push(i as u32);
        }
    }
    moved
}

#[test]
fn refit_then_trace_equals_rebuild_then_trace() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
        WideBvh<W>: Accel,
    {
        let mut rng = Rng::new(seed);
        let mut tris = soup(3000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut full = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut partial = full.clone();
        let mut index = RefitIndex::for_wide(&partial);
        for round in 0..3 {
            let moved = shake(&mut tris, &mut rng, 10);
            full.refit(&tris, 1.0, 1.0).unwrap();
            partial
                .refit_moved(&mut index, &tris, &moved, 1.0, 1.0)
                .unwrap();
            full.validate()
                .unwrap_or_else(|e| panic!("BVH{W} refit round {round}: {e}"));
            partial
                .validate()
                .unwrap_or_else(|e| panic!("BVH{W} partial round {round}: {e}"));
            let rebuilt = WideBvh::<W>::collapse(
                &bvh2(&tris, Strategy::SahBinned),
                &CollapseParams::default(),
            );
            for ray in rays(&bounds(&tris), 1500, seed + round) {
                let expected = bits(rebuilt.closest_hit::<Watertight, _>(&ray, &mut NoStats));
                assert_eq!(
                    bits(full.closest_hit::<Watertight, _>(&ray, &mut NoStats)),
                    expected
                );
                assert_eq!(
                    bits(partial.closest_hit::<Watertight, _>(&ray, &mut NoStats)),
                    expected
                );
                assert_eq!(
                    partial.any_hit::<Watertight, _>(&ray, &mut NoStats),
                    expected.is_some()
                );
            }
        }
        // Partial and full refits give the same boxes.
        assert_eq!(full.nodes, partial.nodes);
        let err = full.refit(&tris[1..], 1.0, 1.0).unwrap_err();
        assert!(err.to_string().contains("rebuild"), "{err}");
    }
    check::<4>(1);
    check::<8>(2);
}

/// The full refit of a tree large enough to run as parallel tasks: every triangle moved,
/// the boxes are exactly their subtrees' (validate), the blocks hold the moved triangles,
/// the SAH costs it reports are the tree's before and after, and it equals the partial refit.
#[test]
fn parallel_refit_is_exact() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
    {
        let mut tris = soup(50_000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut full = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut partial = full.clone();
        let mut index = RefitIndex::for_wide(&partial);
        let before = full.sah_cost(1.0, 2.0);
        let everything: Vec<u32> = (0..tris.len() as u32).collect();
        for t in &mut tris {
            for v in &mut t.v {
                *v = *v * 1.5 + Vec3::new(0.25, -0.5, 1.0);
            }
        }
        let report = full.refit(&tris, 1.0, 2.0).unwrap();
        full.validate().unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        assert!(
            close(report.sah_before, before),
            "{} {before}",
            report.sah_before
        );
        let after = full.sah_cost(1.0, 2.0);
        assert!(
            close(report.sah_after, after),
            "{} {after}",
            report.sah_after
        );
        partial
            .refit_moved(&mut index, &tris, &everything, 1.0, 2.0)
            .unwrap();
        assert_eq!(full.nodes, partial.nodes);
        for (slot, &t) in full.prim_indices.iter().enumerate() {
            if t != u32::MAX {
                let lane = full.blocks[slot / BLOCK].triangle(slot % BLOCK);
                assert_eq!(lane.v, tris[t as usize].v, "slot {slot}");
            }
        }
    }
    check::<4>(7);
    check::<8>(8);
}

/// Partial refits through one index keep the SAH sums from refit to refit: each reports
/// the tree's SAH cost before and after as a pass over every lane gives it, also after the
/// tree was refitted otherwise in between (its root box changed: the sums are made again).
#[test]
fn partial_refits_report_the_sah_cost_of_the_tree() {
    use bvhlab::accel::bvh::refit::RefitIndex;
    fn check<const W: usize>(seed: u64)
    where
        Lanes<W>: NodeWidth,
    {
        let mut tris = soup(5_000, seed);
        let b2 = bvh2(&tris, Strategy::SahBinned);
        let mut tree = WideBvh::<W>::collapse(&b2, &CollapseParams::default());
        let mut index = RefitIndex::for_wide(&tree);
        let moved: Vec<u32> = (0..tris.len() as u32).filter(|t| t % 7 == 3).collect();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        for round in 0..40 {
            let before = tree.sah_cost(1.0, 2.0);
            let offset = Vec3::new(0.3, -0.1, 0.2) * if round % 2 == 0 { 1.0 } else { -0.5 };
            for &t in &moved {
                for v in &mut tris[t as usize].v {
                    *v += offset;
                }
            }
            if round == 20 {
                // Every triangle moves and a full refit runs: the index's sums are stale.
                for t in &mut tris {
                    for v in &mut t.v {
                        *v *= 1.25;
                    }
                }
                tree.refit(&tris, 1.0, 2.0).unwrap();
                continue;
            }
            let report = tree
                .refit_moved(&mut index, &tris, &moved, 1.0, 2.0)
                .unwrap();
            let after = tree.sah_cost(1.0, 2.0);
            assert!(close(report.sah_before, before), "round {round}");
            assert!(close(report.sah_after, after), "round {round}");
        }
        tree.validate().unwrap();
    }
    check::<4>(3);
    check::<8>(4);
}
