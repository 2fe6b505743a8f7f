//! The rules several builders share, so that no builder imports another: each is a
//! [`Rule`](crate::topdown::Rule) (or the pieces of one) that two or more builder modules
//! specialise.
//!
//! * [`binned`]: the binned SAH rule (Wald 2007), the `binned` builder's rule and the rule of
//!   the `cluster-binned` builder, over clusters and inside them.
//! * [`greedy`]: the greedy full-sweep rule (Eq. 2 at every position), the `sweep` builder's
//!   rule, the paper's builders' rule at small nodes, and costed without storing a node, their
//!   sweep temporaries (`sweep_cost`).
//! * [`rated`]: the rule of the paper's builders and of the look-ahead builders: candidates
//!   from the sweep, rated by a builder's `Rater` in parallel, the cheapest by the same
//!   tie-break.
//! * [`sbvh`]: the SBVH rule (object and spatial splits, duplication budget), the `sbvh`
//!   builder's rule and the rule of the spatial temporary-subtree builder's small nodes and
//!   exact temporaries.

pub mod binned;
pub mod greedy;
pub mod rated;
pub mod sbvh;
