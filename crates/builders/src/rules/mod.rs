//! The rules several builders share, so that no builder imports another: each is a
//! [`Rule`](crate::topdown::Rule) (or the pieces of one) that two or more builder modules
//! specialise.
//!
//! * [`greedy`]: the greedy full-sweep rule (Eq. 2 at every position), the `sweep` builder's
//!   rule, the paper's builders' rule at small nodes, and costed without storing a node, their
//!   sweep temporaries (`sweep_cost`).

pub mod greedy;
