//! Quality metrics of BVHs. Every function here is a pure function of a tree (and the
//! triangles and cost model it needs): **metrics never mutate trees**.
//!
//! * [`CostModel`]: the constants `c_t` (traversal step) and `c_i` (primitive test);
//! * [`sah()`]: the surface area heuristic cost of a tree (Eq. 1 of Wodniok & Goesele);
//! * [`epo()`]: the exact end-point overlap of Aila, Karras and Laine (2013), parallel and
//!   deterministic ([`epo_breakdown`], [`endpoint_overlap`] for any end-point distribution);
//! * [`lcv()`]: leaf count variability of traced rays;
//! * [`SahEpoPredictor`]: the SAH-EPO trace-cost predictor, its least-squares fit per ray type
//!   and its forecasting error ([`spearman`] rank correlation with ties);
//! * [`weighted`]: SAH weighted by a ray type's real distribution (per-node weights, ray
//!   segments), the basis of our reading of the improved primary-ray predictor (whose camera
//!   and hit-driven parts are `sahara_trace::weighted`).
//!
//! `docs/metrics.md` explains the definitions, the algorithms and the predictor fit.
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Aabb, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let unit = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
//! let leaf = Bvh { nodes: vec![Node::leaf(&unit, 0, 3)], prim_indices: vec![0, 1, 2], spatial_splits: false, ref_cuts: None };
//! assert_eq!(sah(&leaf, &CostModel::default()), 3.0);
//! ```
#![warn(missing_docs)]

mod cost;
pub mod epo;
mod lcv;
pub mod predictor;
mod sah;
pub mod weighted;

pub use cost::CostModel;
pub use epo::{
    endpoint_overlap, epo, epo_breakdown, epo_with_node_weights, sample_surface_endpoints,
    total_area, Endpoint, EpoBreakdown,
};
pub use lcv::lcv;
pub use predictor::{
    average_ranks, pearson, spearman, FitError, ForecastReport, PredictorSample, SahEpoPredictor,
};
pub use sah::{sah, sah_of_subtree};
pub use weighted::{
    node_weights, segment_node_weights, weighted_sah, weighted_sah_from_node_weights, SegmentSet,
};

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
