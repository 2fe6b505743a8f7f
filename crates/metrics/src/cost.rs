use serde::{Deserialize, Serialize};

/// The constants of the surface area heuristic.
///
/// The default is `c_t = 1.2`, `c_i = 1`, as used by Aila, Karras and Laine (2013, "On quality
/// metrics of bounding volume hierarchies"). NVIDIA's reference builders use 1 and 1
/// ([`CostModel::UNIT`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostModel {
    /// `c_t`: the cost of one traversal step (visiting an inner node).
    pub traversal: f32,
    /// `c_i`: the cost of one primitive intersection test.
    pub intersection: f32,
}

impl Default for CostModel {
    fn default() -> Self {
        Self::AILA
    }
}

impl CostModel {
    /// `c_t = 1.2`, `c_i = 1` (Aila et al. 2013), the default.
    pub const AILA: CostModel = CostModel {
        traversal: 1.2,
        intersection: 1.0,
    };
    /// `c_t = 1`, `c_i = 1`.
    pub const UNIT: CostModel = CostModel {
        traversal: 1.0,
        intersection: 1.0,
    };

    /// The cost of a leaf with `n` primitives: `n c_i`.
    #[inline]
    pub fn leaf_cost(&self, n: usize) -> f64 {
        n as f64 * self.intersection as f64
    }

    /// Eq. 2 of the paper, the greedy cost of a split in which both children stay leaves:
    /// `c_t + (A_l n_l + A_r n_r) c_i / A_p`.
    #[inline]
    pub fn split_cost(
        &self,
        parent_area: f64,
        left_area: f64,
        n_left: usize,
        right_area: f64,
        n_right: usize,
    ) -> f64 {
        self.split_cost_counts(
            parent_area,
            left_area,
            n_left as f64,
            right_area,
            n_right as f64,
        )
    }

    /// [`split_cost`](Self::split_cost) with the counts as `f64` (exact below 2^53, so the
    /// result is the same), for sweeps that keep their counts in floating point: converting a
    /// `usize` to `f64` at every candidate costs more than the rest of the formula.
    #[inline]
    pub fn split_cost_counts(
        &self,
        parent_area: f64,
        left_area: f64,
        n_left: f64,
        right_area: f64,
        n_right: f64,
    ) -> f64 {
        if parent_area <= 0.0 {
            return self.traversal as f64 + (n_left + n_right) * self.intersection as f64;
        }
        self.traversal as f64
            + (left_area * n_left + right_area * n_right) * self.intersection as f64 / parent_area
    }

    /// Eq. 1 for an inner node whose children cost `c_l` and `c_r`.
    #[inline]
    pub fn inner_cost(
        &self,
        parent_area: f64,
        left_area: f64,
        c_l: f64,
        right_area: f64,
        c_r: f64,
    ) -> f64 {
        if parent_area <= 0.0 {
            return self.traversal as f64 + c_l + c_r;
        }
        self.traversal as f64 + (left_area * c_l + right_area * c_r) / parent_area
    }
}
