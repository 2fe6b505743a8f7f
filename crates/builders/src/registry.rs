//! Builders by name. The xtask, the benches and the test suites enumerate [`entries`], so a
//! builder registered here appears in every table, plot and test.

use crate::Builder;

/// A registered builder preset.
pub struct Entry {
    /// The name used on the command line (`--builder NAME`).
    pub name: &'static str,
    /// What the preset is.
    pub summary: &'static str,
    /// True when the builder duplicates references (spatial splits); such builders are
    /// compared against `sbvh` as well as `sweep`.
    pub spatial: bool,
    /// True when the preset is only practical for small inputs (an exhaustive reference).
    pub small_inputs_only: bool,
    /// Above this many triangles the preset takes many minutes on two cores: the evaluation
    /// and `cargo xtask scaling` skip it there unless it is asked for by name, and `cargo xtask
    /// bvh` refuses without `--force` (`None`: no limit).
    pub max_practical_triangles: Option<usize>,
    /// Creates the builder.
    pub make: fn() -> Box<dyn Builder>,
}

/// Every registered builder preset, in a fixed order.
pub fn entries() -> Vec<Entry> {
    let mut v = Vec::new();
    v.extend(crate::binned::registry_entries());
    v.extend(crate::sweep::registry_entries());
    v.extend(crate::sbvh::registry_entries());
    v.extend(crate::tsah::registry_entries());
    v.extend(crate::tsah_spatial::registry_entries());
    v.extend(crate::popov::registry_entries());
    v
}

/// The preset registered as `name`.
pub fn by_name(name: &str) -> Option<Box<dyn Builder>> {
    entries()
        .into_iter()
        .find(|e| e.name == name)
        .map(|e| (e.make)())
}

/// The registered names, in order.
pub fn names() -> Vec<&'static str> {
    entries().iter().map(|e| e.name).collect()
}
