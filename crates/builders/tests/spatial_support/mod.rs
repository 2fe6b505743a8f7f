//! Checks shared by the binned, SBVH and spatial temporary-subtree builder tests
//! (`binned.rs`, `sbvh.rs`, `tsah_spatial.rs`; their inputs are `sahara_fixtures`'
//! generators).
#![allow(dead_code)]

use sahara_builders::Bvh;
use sahara_fixtures::soups::sized_soup;
use sahara_geom::{Triangle, Vec3A};

/// `n_soup` triangles of `sized_soup(n_soup, 11, 20.0)` followed by `rounds` rounds of
/// zero-area, index-degenerate and point triangles and `dups` copies of triangle 5
/// (`sahara_fixtures::soups::degenerate_mix`).
pub fn degenerate_mix(n_soup: usize, rounds: usize, dups: usize) -> Vec<Triangle> {
    sahara_fixtures::soups::degenerate_mix(
        sized_soup(n_soup, 11, 20.0),
        rounds,
        Vec3A::X * 30.0,
        Vec3A::new(20.0, 30.0, 40.0),
        dups,
    )
}

/// The largest leaf of a tree.
pub fn max_leaf(bvh: &Bvh) -> usize {
    bvh.nodes
        .iter()
        .filter(|n| n.is_leaf())
        .map(|n| n.count as usize)
        .max()
        .unwrap_or(0)
}

/// Asserts that `build` makes the same tree, bit for bit, in rayon pools of 1, 2 and 3 threads.
pub fn assert_same_tree_whatever_the_threads(build: impl Fn() -> Bvh + Sync) {
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bits(&build()))
    };
    let one = run(1);
    for threads in [2, 3] {
        assert!(
            one == run(threads),
            "trees differ between 1 and {threads} threads"
        );
    }
}

/// Every bit of a tree, to compare trees for bit-identity.
pub fn bits(bvh: &Bvh) -> Vec<u32> {
    let mut v = Vec::new();
    for n in &bvh.nodes {
        v.extend(n.min.iter().chain(&n.max).map(|x| x.to_bits()));
        v.extend([n.index, n.count]);
    }
    v.extend(&bvh.prim_indices);
    v
}
