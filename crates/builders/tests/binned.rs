//! Tests of the binned SAH builder and its cost-only entry point.

use sahara_builders::binned::{BinnedBuilder, BinnedConfig};
use sahara_builders::{registry, BuildInput, Builder, Bvh};
use sahara_fixtures::soups::{self, clustered_centroid, sized_soup};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};

mod common;
mod spatial_support;
use common::{assert_empty_input_builds_empty_tree, assert_rejected};
use spatial_support::{assert_same_tree_whatever_the_threads, build_valid};

/// Random triangles of random sizes (up to 5) in a 100³ box.
fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    sized_soup(n, seed, 5.0)
}

/// The soup followed by 200 rounds of zero-area (collinear), index-degenerate (repeated
/// vertex) and point triangles, and 50 exact duplicates.
fn degenerate_mix() -> Vec<Triangle> {
    soups::degenerate_mix(soup(300, 11), 200, Vec3A::X, Vec3A::Y, 50)
}

fn flat_scene(n: usize) -> Vec<Triangle> {
    soups::flat_scene(n, 1.0)
}

fn build(tris: &[Triangle], config: BinnedConfig) -> Bvh {
    let (builder, max_leaf) = (BinnedBuilder::new(config), config.max_leaf_size);
    build_valid(&builder, tris, CostModel::default(), max_leaf, Some(false))
}

#[test]
fn random_soups_validate() {
    for (n, seed) in [(1, 1), (2, 2), (9, 3), (100, 4), (5000, 5)] {
        for config in [
            BinnedConfig::DEFAULT,
            BinnedConfig::FAST,
            BinnedConfig::FINE,
        ] {
            build(&soup(n, seed), config);
        }
    }
    let tiny_leaves = BinnedConfig {
        max_leaf_size: 1,
        ..BinnedConfig::DEFAULT
    };
    build(&soup(3000, 8), tiny_leaves);
}

#[test]
fn clustered_centroids_respect_max_leaf() {
    let tris = clustered_centroid(4000);
    let bvh = build(&tris, BinnedConfig::DEFAULT);
    assert!(bvh.stats().depth < 200);
}

#[test]
fn degenerate_inputs() {
    build(&degenerate_mix(), BinnedConfig::DEFAULT);
    let p = Vec3A::new(1.0, -2.0, 3.0);
    let point = vec![Triangle::new(p, p, p); 1000];
    let bvh = build(&point, BinnedConfig::DEFAULT);
    // Median splits make a balanced tree.
    assert!(bvh.stats().depth <= 12, "depth {}", bvh.stats().depth);
    build(
        &[Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)],
        BinnedConfig::DEFAULT,
    );
    assert_empty_input_builds_empty_tree(&BinnedBuilder::default());
}

#[test]
fn flat_scene_validates() {
    build(&flat_scene(3000), BinnedConfig::DEFAULT);
}

#[test]
fn adversarial_geometric_spacing_is_depth_bounded() {
    // Centroids at x = 1.01^i: the best plane peels a few triangles per level.
    let tris: Vec<Triangle> = (0..4000)
        .map(|i| {
            let o = Vec3A::new(1.01f32.powi(i), 0.0, 0.0);
            Triangle::new(o, o + Vec3A::Y * 0.01, o + Vec3A::Z * 0.01)
        })
        .collect();
    let bvh = build(&tris, BinnedConfig::DEFAULT);
    assert!(bvh.stats().depth <= 96 + 13, "depth {}", bvh.stats().depth);
}

#[test]
fn invalid_config_is_rejected() {
    assert_rejected(
        &soup(10, 1),
        [
            BinnedConfig::with_bins(1),
            BinnedConfig {
                max_leaf_size: 0,
                ..BinnedConfig::DEFAULT
            },
        ],
        BinnedBuilder::new,
    );
}

#[test]
fn deterministic_across_thread_counts() {
    let tris = soup(60_000, 41);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    assert_same_tree_whatever_the_threads(|| BinnedBuilder::default().build(&input).unwrap());
}

#[test]
fn more_bins_do_not_hurt_much_and_registry_names() {
    let tris = soup(20_000, 51);
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let s8 = sah(
        &BinnedBuilder::new(BinnedConfig::FAST)
            .build(&input)
            .unwrap(),
        &input.cost,
    );
    let s128 = sah(
        &BinnedBuilder::new(BinnedConfig::FINE)
            .build(&input)
            .unwrap(),
        &input.cost,
    );
    assert!(s128 < s8 * 1.02, "128 bins {s128} vs 8 bins {s8}");
    for name in ["binned", "binned-8", "binned-128"] {
        let b = registry::by_name(name).expect(name);
        assert_eq!(b.name(), name);
        b.build(&input).unwrap().validate(&tris).unwrap();
    }
}

/// The SIMD and the scalar bin fill give the bit-identical tree (same fingerprint), on inputs
/// with signed zeros, duplicates and degenerate triangles, and on a node large enough for the
/// parallel fill.
#[test]
fn simd_and_scalar_fills_build_identical_trees() {
    use sahara_builders::binned::{build_with_backend, FillBackend};
    let mut signed_zeros = soup(2000, 21);
    for (i, t) in signed_zeros.iter_mut().enumerate() {
        // Coordinates of exactly -0.0 and +0.0 on every axis, mixed.
        let z = if i % 2 == 0 { -0.0 } else { 0.0 };
        t.v[i % 3].x = z;
        t.v[(i + 1) % 3].y = z;
    }
    let cases = [
        soup(5000, 5),
        degenerate_mix(),
        flat_scene(3000),
        clustered_centroid(3000),
        signed_zeros,
        soup(70_000, 9),
    ];
    for tris in &cases {
        let input = BuildInput::new(tris, CostModel::default()).unwrap();
        for config in [
            BinnedConfig::DEFAULT,
            BinnedConfig::FAST,
            BinnedConfig::FINE,
        ] {
            let simd = build_with_backend(&input, &config, FillBackend::Simd).unwrap();
            let scalar = build_with_backend(&input, &config, FillBackend::Scalar).unwrap();
            assert_eq!(simd.fingerprint(), scalar.fingerprint(), "{config:?}");
            let registered = BinnedBuilder::new(config).build(&input).unwrap();
            assert_eq!(simd, registered);
        }
    }
}
