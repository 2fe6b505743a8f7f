//! Checks shared by the tests of every builder family (`spatial_support` and `tsah_support`
//! hold each family's own).
#![allow(dead_code)]

use std::fmt::Debug;

use sahara_builders::{BuildError, BuildInput, Builder, Bvh};
use sahara_geom::Triangle;
use sahara_metrics::CostModel;

/// Asserts that building `tris` with `make(config)` is a typed
/// [`BuildError::InvalidConfig`] for every configuration of `bad`.
pub fn assert_rejected<C: Debug, B: Builder>(
    tris: &[Triangle],
    bad: impl IntoIterator<Item = C>,
    make: impl Fn(C) -> B,
) {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    for config in bad {
        let what = format!("{config:?}");
        let result = make(config).build(&input);
        assert!(
            matches!(result, Err(BuildError::InvalidConfig(_))),
            "{what} must be rejected: {:?}",
            result.err()
        );
    }
}

/// Asserts that `builder` builds the empty tree from no primitive.
pub fn assert_empty_input_builds_empty_tree(builder: &dyn Builder) {
    let input = BuildInput::new(&[], CostModel::default()).unwrap();
    assert_eq!(builder.build(&input).unwrap(), Bvh::empty());
}
