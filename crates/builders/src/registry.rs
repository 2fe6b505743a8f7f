//! Builders by name. The xtask, the benches and the test suites enumerate [`entries`], so a
//! builder registered here appears in every table, plot and test.
//!
//! The built-in presets are listed by each builder module's `registry_entries`; a builder of
//! your own joins them with [`register`] (see `examples/median_split.rs`).

use std::sync::RwLock;

use crate::Builder;

/// A registered builder preset.
#[derive(Clone, Debug)]
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

/// Why [`register`] refused an entry.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// The name is taken (by a built-in preset or an earlier registration).
    #[error("a builder named {0:?} is already registered")]
    Duplicate(String),
    /// The entry's `make` builds a builder whose [`Builder::name`] is not the entry's name.
    #[error("entry {entry:?} makes a builder named {builder:?}")]
    NameMismatch {
        /// The entry's name.
        entry: String,
        /// What the builder calls itself.
        builder: String,
    },
}

/// Builders registered at run time, after the built-in ones.
static EXTRA: RwLock<Vec<Entry>> = RwLock::new(Vec::new());

/// Adds a builder to the registry, after the built-in presets: from then on it appears in
/// [`entries`], [`by_name`] and [`names`], hence in every table, plot and test that
/// enumerates them. The name must be new and equal to the builder's [`Builder::name`].
pub fn register(entry: Entry) -> Result<(), RegistryError> {
    let made = (entry.make)();
    if made.name() != entry.name {
        return Err(RegistryError::NameMismatch {
            entry: entry.name.to_string(),
            builder: made.name().to_string(),
        });
    }
    let mut extra = EXTRA.write().unwrap_or_else(|e| e.into_inner());
    if built_in()
        .iter()
        .chain(extra.iter())
        .any(|e| e.name == entry.name)
    {
        return Err(RegistryError::Duplicate(entry.name.to_string()));
    }
    extra.push(entry);
    Ok(())
}

/// Every registered builder preset, in a fixed order: the built-in presets, then those added
/// with [`register`] in the order of registration.
pub fn entries() -> Vec<Entry> {
    let mut v = built_in();
    let extra = EXTRA.read().unwrap_or_else(|e| e.into_inner());
    v.extend(extra.iter().cloned());
    v
}

/// The built-in presets.
fn built_in() -> Vec<Entry> {
    let mut v = Vec::new();
    v.extend(crate::binned::registry_entries());
    v.extend(crate::sweep::registry_entries());
    v.extend(crate::sbvh::registry_entries());
    v.extend(crate::tsah::registry_entries());
    v.extend(crate::tsah_spatial::registry_entries());
    v.extend(crate::popov::registry_entries());
    v.extend(crate::reinsert::registry_entries());
    v.extend(crate::ploc::registry_entries());
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
