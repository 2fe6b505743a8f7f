//! Inputs and checks shared by the sweep, temporary-subtree and look-ahead builder tests.
#![allow(dead_code)]

use sahara_builders::{BuildInput, Builder, Bvh};
use sahara_geom::rng::Pcg32;
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::CostModel;

fn point(r: &mut Pcg32, lo: f32, hi: f32) -> Vec3A {
    Vec3A::new(
        r.range_f32(lo, hi),
        r.range_f32(lo, hi),
        r.range_f32(lo, hi),
    )
}

/// Random triangles of widely varying sizes in a box.
pub fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| {
            let o = point(&mut r, -10.0, 10.0);
            let s = 0.05 + 3.0 * r.next_f32().powi(3);
            Triangle::new(o, o + point(&mut r, -s, s), o + point(&mut r, -s, s))
        })
        .collect()
}

/// Clusters of triangles that share their bounds' centroid exactly (boxes symmetric about
/// the cluster centre), plus some scattered ones.
pub fn clustered(n: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Pcg32::new(seed, 2);
    let centres: Vec<Vec3A> = (0..4).map(|_| point(&mut r, -5.0, 5.0)).collect();
    (0..n)
        .map(|i| {
            if i % 5 == 4 {
                let o = point(&mut r, -5.0, 5.0);
                return Triangle::new(o, o + Vec3A::X * 0.3, o + Vec3A::Y * 0.3);
            }
            let c = centres[i % centres.len()];
            let e = Vec3A::new(
                r.range_f32(0.01, 2.0),
                r.range_f32(0.01, 2.0),
                r.range_f32(0.01, 2.0),
            );
            let t = point(&mut r, -1.0, 1.0);
            Triangle::new(c - e, c + e, c + e * t)
        })
        .collect()
}

/// A "procedural-like" scene: a finely tessellated height field (a mesh) around a few large
/// triangles, the teapot-in-a-stadium pattern of very different triangle sizes.
pub fn mesh_like(grid: usize, seed: u64) -> Vec<Triangle> {
    let mut r = Pcg32::new(seed, 3);
    let h = |x: f32, z: f32| (x * 3.1).sin() * (z * 2.3).cos() * 0.2;
    let mut tris = Vec::new();
    let step = 1.0 / grid as f32;
    for i in 0..grid {
        for j in 0..grid {
            let (x0, z0) = (i as f32 * step, j as f32 * step);
            let (x1, z1) = (x0 + step, z0 + step);
            let p = |x: f32, z: f32| Vec3A::new(x, h(x, z), z);
            tris.push(Triangle::new(p(x0, z0), p(x1, z0), p(x1, z1)));
            tris.push(Triangle::new(p(x0, z0), p(x1, z1), p(x0, z1)));
        }
    }
    for _ in 0..6 {
        let o = point(&mut r, -40.0, 40.0);
        tris.push(Triangle::new(
            o,
            o + point(&mut r, -30.0, 30.0),
            o + point(&mut r, -30.0, 30.0),
        ));
    }
    tris
}

/// Named degenerate inputs.
pub fn degenerate_cases() -> Vec<(&'static str, Vec<Triangle>)> {
    let mut v = Vec::new();
    v.push(("empty", Vec::new()));
    v.push((
        "single",
        vec![Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)],
    ));
    // Zero-area (collinear) triangles.
    v.push((
        "zero-area",
        (0..40)
            .map(|i| {
                let o = Vec3A::new(i as f32 * 0.1, (i % 3) as f32, 0.0);
                Triangle::new(o, o + Vec3A::X, o + Vec3A::X * 2.0)
            })
            .collect(),
    ));
    // Exact duplicates.
    let base = soup(7, 11);
    v.push((
        "duplicates",
        (0..60).map(|i| base[i % base.len()]).collect(),
    ));
    // Index-degenerate: two equal vertices.
    v.push((
        "index-degenerate",
        (0..50)
            .map(|i| {
                let o = Vec3A::new((i % 7) as f32, (i / 7) as f32, 0.5);
                Triangle::new(o, o, o + Vec3A::Z)
            })
            .collect(),
    ));
    // Everything at one point.
    let p = Vec3A::new(1.0, 2.0, 3.0);
    v.push(("one-point", vec![Triangle::new(p, p, p); 37]));
    // All on one line (flat root box).
    v.push((
        "one-line",
        (0..33)
            .map(|i| {
                let o = Vec3A::X * (i % 5) as f32;
                Triangle::new(o, o + Vec3A::X, o)
            })
            .collect(),
    ));
    v.push(("clustered", clustered(120, 5)));
    v
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
