//! Checks shared by the binned, SBVH and spatial temporary-subtree builder tests
//! (`binned.rs`, `sbvh.rs`, `tsah_spatial.rs`; their inputs are `sahara_fixtures`'
//! generators).
#![allow(dead_code)]

use sahara_builders::registry::{self, Entry};
use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::soups::sized_soup;
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::CostModel;

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

/// Builds `tris` with `builder` under `cost`, validates the tree and checks that no leaf holds
/// more than `max_leaf_size` references and, with `Some(spatial)`, that the tree has spatial
/// splits exactly when `spatial` and the input is not empty.
pub fn build_valid(
    builder: &dyn Builder,
    tris: &[Triangle],
    cost: CostModel,
    max_leaf_size: usize,
    spatial: Option<bool>,
) -> Bvh {
    let input = BuildInput::new(tris, cost).unwrap();
    let bvh = builder.build(&input).unwrap();
    bvh.validate(tris).unwrap();
    assert!(max_leaf(&bvh) <= max_leaf_size);
    if let Some(spatial) = spatial {
        assert_eq!(bvh.spatial_splits, spatial && !tris.is_empty());
    }
    bvh
}

/// Builds with `build` and every configuration of `configs` the random soups (`sized_soup` of
/// size 8) of 1, 2, 9, 100 and `largest` triangles, seeds 1 to 5.
pub fn build_random_soups<C: Copy>(
    largest: usize,
    configs: &[C],
    build: impl Fn(&[Triangle], C) -> Bvh,
) {
    for (n, seed) in [(1, 1), (2, 2), (9, 3), (100, 4), (largest, 5)] {
        let tris = sized_soup(n, seed, 8.0);
        for &config in configs {
            build(&tris, config);
        }
    }
}

/// The registry's entry named `name`.
pub fn entry(name: &str) -> Entry {
    registry::entries()
        .into_iter()
        .find(|e| e.name == name)
        .unwrap_or_else(|| panic!("{name} is registered"))
}

/// The registered spatial-split builder `name`: its entry says so, its builder has that name,
/// and it builds a valid tree of [`needs_spatial`], which it returns with the triangles.
pub fn registered_spatial_tree(name: &str) -> (Vec<Triangle>, Bvh) {
    assert!(entry(name).spatial);
    let b = registry::by_name(name).unwrap();
    assert_eq!(b.name(), name);
    let tris = needs_spatial();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bvh = b.build(&input).unwrap();
    bvh.validate(&tris).unwrap();
    (tris, bvh)
}

/// Asserts that `builder` makes the same valid tree, bit for bit, whatever the threads, on
/// 30 000 triangles of a soup followed by [`needs_spatial`].
pub fn assert_deterministic_on_a_large_spatial_input(builder: &(dyn Builder + Sync)) {
    let mut tris = sized_soup(30_000, 81, 6.0);
    tris.extend(needs_spatial());
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    assert_same_tree_whatever_the_threads(|| {
        let bvh = builder.build(&input).unwrap();
        bvh.validate(&tris).unwrap();
        bvh
    });
}

/// Builds with `build` the degenerate inputs of the spatial-split builders' tests: the
/// [`degenerate_mix`] of 300 triangles, 500 coincident points (in a tree no deeper than 12),
/// one triangle, none, and 300 collinear zero-area triangles along a diagonal.
pub fn build_degenerate_inputs(build: impl Fn(&[Triangle]) -> Bvh) {
    build(&degenerate_mix(300, 200, 50));
    let p = Vec3A::new(1.0, -2.0, 3.0);
    let bvh = build(&vec![Triangle::new(p, p, p); 500]);
    assert!(bvh.stats().depth <= 12);
    build(&[Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)]);
    build(&[]);
    // Collinear zero-area triangles along a diagonal.
    let line: Vec<Triangle> = (0..300)
        .map(|i| {
            let o = Vec3A::splat(i as f32 * 0.3);
            Triangle::new(o, o + Vec3A::splat(40.0), o + Vec3A::splat(20.0))
        })
        .collect();
    build(&line);
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
