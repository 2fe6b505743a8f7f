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

/// A grid of `cells × cells` small triangles `spacing` apart, crossed by `diagonals` long thin
/// triangles from one side to the other (and as many in the other direction when `crossing`):
/// object splits cannot separate the diagonals from the grid, spatial splits can.
pub fn grid_crossed_by_diagonals(
    cells: usize,
    spacing: f32,
    diagonals: usize,
    crossing: bool,
) -> Vec<Triangle> {
    let mut tris = Vec::new();
    for i in 0..cells {
        for j in 0..cells {
            let o = Vec3A::new(i as f32 * spacing, j as f32 * spacing, (i + j) as f32 % 3.0);
            tris.push(Triangle::new(o, o + Vec3A::X * 0.5, o + Vec3A::Y * 0.5));
        }
    }
    let step = 100.0 / diagonals as f32;
    for k in 0..diagonals {
        let t = k as f32 * step;
        let a = Vec3A::new(0.0, t, 0.5);
        let b = Vec3A::new(100.0, 100.0 - t, 1.5);
        tris.push(Triangle::new(a, b, b + Vec3A::Z * 0.3));
        if crossing {
            let a = Vec3A::new(t, 0.0, 2.0);
            let b = Vec3A::new(100.0 - t, 100.0, 0.0);
            tris.push(Triangle::new(a, b, b + Vec3A::X * 0.3));
        }
    }
    tris
}

/// The spatial-split builders' common input: a 40 × 40 grid crossed by 100 diagonals each way.
pub fn needs_spatial() -> Vec<Triangle> {
    grid_crossed_by_diagonals(40, 2.5, 100, true)
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
