//! The builders' unsafe paths on inputs small enough for Miri (`cargo xtask miri` runs this
//! file under Miri, once at the baseline ISA and once built with AVX2 and FMA; it also runs in
//! the ordinary suite, in well under a second).
//!
//! What it reaches: the SIMD plane searches and partitions of the binned builder
//! (`split/binned/`), the batched SSE2 sweep (`split/sweep/`), the stable partitions of the
//! sorted orders (`split/orders.rs`), the spatial binning (`split/spatial/`, with its AVX2
//! kernel in the AVX2 build), the parallel reductions, partitions and radix sorts. Under Miri
//! the parallel thresholds are a few dozen references (`split/mod.rs`), so these inputs take
//! the parallel paths; outside Miri they do not. Every tree must equal, bit for bit, the one
//! recorded below outside Miri: the parallel paths build the same trees as the serial ones.

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_fixtures::soups::mixed_soup;
use sahara_geom::{Triangle, Vec3A};

/// `(builder, fingerprint)` of each builder's tree of [`input`], recorded outside Miri
/// (serial paths). A change of a builder's trees on purpose updates these with
/// `tests/tree_hashes.tsv`.
const TREES: &[(&str, u64)] = &[
    ("binned", 0x2eac42ff1dfc8894),
    ("binned-8", 0xd5956aa466f3d8a5),
    ("sweep", 0x9adb7eb53d80fa8c),
    ("sbvh", 0xea135c7c2e3ce7ed),
    ("sbvh-fast", 0xec18899f2049e314),
    ("ploc", 0xa4781e872d499101),
    ("tsah-binned", 0x4ec0a0e0a1250127),
];

/// 160 triangles of three sizes, a duplicate and a degenerate one.
fn input() -> Vec<Triangle> {
    let mut tris = mixed_soup(158, 11);
    tris.push(tris[5]);
    tris.push(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 3.0));
    tris
}

fn build(name: &str, tris: &[Triangle], threads: usize) -> sahara_bvh::Bvh {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    let builder = registry::by_name(name).unwrap();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| builder.build(&input))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn miri_builders_build_the_recorded_trees() {
    let tris = input();
    let mut got = Vec::new();
    for &(name, _) in TREES {
        let two = build(name, &tris, 2);
        two.validate(&tris)
            .unwrap_or_else(|e| panic!("{name}: invalid tree: {e}"));
        let one = build(name, &tris, 1);
        assert_eq!(
            two.fingerprint(),
            one.fingerprint(),
            "{name}: one and two threads differ"
        );
        got.push((name, two.fingerprint()));
    }
    let want: Vec<(&str, u64)> = TREES.to_vec();
    assert_eq!(
        got, want,
        "the trees differ from those recorded outside Miri (a builder changed on purpose \
         updates TREES)"
    );
}
