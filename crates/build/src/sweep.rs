//! (to be written)

use crate::registry::Entry;

/// Registry entries of this module.
pub fn registry_entries() -> Vec<Entry> {
    Vec::new()
}
