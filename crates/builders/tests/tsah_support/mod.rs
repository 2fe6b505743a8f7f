//! Checks shared by the sweep, temporary-subtree and look-ahead builder tests (their inputs
//! are `sahara_fixtures`' generators).
#![allow(dead_code)]

use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::soups::{box_soup, clustered_boxes, named_degenerates};
use sahara_geom::Triangle;
use sahara_metrics::CostModel;

/// Named test inputs followed by `sahara_fixtures::soups::named_degenerates()`.
pub fn with_degenerates(named: Vec<(&str, Vec<Triangle>)>) -> Vec<(String, Vec<Triangle>)> {
    named
        .into_iter()
        .chain(named_degenerates())
        .map(|(n, t)| (n.to_string(), t))
        .collect()
}

/// The inputs of the sweep and PLOC tests: box soups of 3000 and 20 000, 3000 clustered boxes,
/// a 40 × 40 mesh, and the degenerates.
pub fn soups_mesh_and_degenerates() -> Vec<(String, Vec<Triangle>)> {
    with_degenerates(vec![
        ("soup-3000", box_soup(3000, 1)),
        ("soup-20000", box_soup(20_000, 2)),
        ("clustered-3000", clustered_boxes(3000, 3)),
        ("mesh-40", mesh_like(40, 4)),
    ])
}

/// Builds in a rayon pool of `threads` threads.
pub fn build_in(builder: &dyn Builder, tris: &[Triangle], threads: usize) -> Bvh {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| builder.build(&input).unwrap())
}

/// Builds with 1 and 2 threads; checks both trees are identical, valid, and have no leaf
/// above `max_leaf`. Returns the tree.
pub fn check_builder(builder: &dyn Builder, tris: &[Triangle], max_leaf: usize, what: &str) -> Bvh {
    let one = build_in(builder, tris, 1);
    let two = build_in(builder, tris, 2);
    assert_eq!(
        one,
        two,
        "{}: {what}: 1- and 2-thread trees differ",
        builder.name()
    );
    one.validate(tris)
        .unwrap_or_else(|e| panic!("{}: {what}: invalid tree: {e}", builder.name()));
    if tris.is_empty() {
        assert_eq!(one, Bvh::empty());
    }
    for n in &one.nodes {
        assert!(
            n.count as usize <= max_leaf,
            "{}: {what}: leaf of {} > {max_leaf}",
            builder.name(),
            n.count
        );
    }
    one
}

/// The leaves of a tree as sorted primitive lists, in depth-first order, with the tree shape
/// (a string of `(` for inner nodes and `L` for leaves).
pub fn shape(bvh: &Bvh) -> (String, Vec<Vec<u32>>) {
    let mut s = String::new();
    let mut leaves = Vec::new();
    if bvh.nodes.is_empty() {
        return (s, leaves);
    }
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let n = &bvh.nodes[i];
        if n.is_leaf() {
            s.push('L');
            let mut p = bvh.leaf_prims(n).to_vec();
            p.sort_unstable();
            leaves.push(p);
        } else {
            s.push('(');
            let (l, r) = bvh.children(i);
            stack.push(r);
            stack.push(l);
        }
    }
    (s, leaves)
}
