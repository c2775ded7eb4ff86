//! Treelet restructuring pinned: fingerprints of a few LBVH + treelets trees and the bits of
//! their SAH cost after every round, recorded from the straightforward dynamic program, so a
//! faster one that changes any tree (topology, child order or a single cost bit) fails.

use bvhlab_testkit as common;

use bvhlab::accel::bvh::{BuildParams, Strategy, build};
use bvhlab::geometry::Triangle;
use bvhlab::scene::Scene;
use common::soup;

/// FNV-1a over the nodes' and leaf order's debug text: exact, since floats print round-trip.
fn fingerprint(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// (scene, treelet size, rounds, max leaf size, tree fingerprint, SAH bits per round).
type Pin = (Vec<Triangle>, u32, u32, u32, u64, Vec<u64>);

fn pinned() -> Vec<Pin> {
    let teapot = Scene::load("teapot-in-stadium").unwrap().triangles;
    let grass = Scene::load("grass:4000").unwrap().triangles;
    let random = soup(20_000, 5);
    vec![
        (
            teapot.clone(),
            7,
            3,
            8,
            0xfbecc1e8bb06025c,
            vec![0x40324c2bd776f534, 0x403057458f55e9bc, 0x402f54b8272c7c83],
        ),
        (
            teapot,
            9,
            2,
            4,
            0xb55e24f704ad7a4b,
            vec![0x4031e54dbd3d0e8b, 0x402f9955e202c3c3],
        ),
        (
            grass.clone(),
            5,
            4,
            1,
            0x2956d07d62b0cf4d,
            vec![
                0x4042f11034b913db,
                0x4040d06622b7b36c,
                0x403e4718dc38e5dd,
                0x403c84add5cd5501,
            ],
        ),
        (
            grass,
            7,
            3,
            8,
            0x860698f34af16c3c,
            vec![0x40410c9635f83184, 0x403c5ce72e9017e2, 0x403990f5b9201a1f],
        ),
        (
            random.clone(),
            7,
            3,
            8,
            0x8b178d9b2ec6f40f,
            vec![0x407840182479bb81, 0x4077fc1a7d9d7865, 0x4077f11d9c0addcd],
        ),
        (
            random,
            8,
            2,
            16,
            0x8b140137340b0e36,
            vec![0x40781fd4cfe53a1c, 0x4077ddaf42b9d46d],
        ),
    ]
}

#[test]
fn treelet_trees_are_pinned_bit_for_bit() {
    let mut failed = Vec::new();
    for (tris, treelet_size, treelet_rounds, max_leaf_size, tree, rounds) in pinned() {
        let p = BuildParams {
            treelet_size,
            treelet_rounds,
            max_leaf_size,
            ..BuildParams::with_strategy(Strategy::LbvhTreelet)
        };
        let (bvh, report) = build(&tris, &p).expect("valid parameters");
        let got_tree = fingerprint(&format!("{:?} {:?}", bvh.nodes, bvh.prim_indices));
        let got_rounds: Vec<u64> = report
            .phases
            .sah_after_round
            .iter()
            .map(|c| c.to_bits())
            .collect();
        if got_tree != tree || got_rounds != rounds {
            failed.push(format!(
                "({} tris, {treelet_size}, {treelet_rounds}, {max_leaf_size}): \
                 {got_tree:#x}, {got_rounds:#x?}",
                tris.len()
            ));
        }
    }
    assert!(failed.is_empty(), "changed trees:\n{}", failed.join("\n"));
}
