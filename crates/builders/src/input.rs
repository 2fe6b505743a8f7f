use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_metrics::CostModel;

/// Why a build failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A triangle has a NaN or infinite coordinate.
    #[error("triangle {triangle} has a non-finite coordinate")]
    NonFinite {
        /// Its index.
        triangle: usize,
    },
    /// More primitives than a 32-bit reference can address.
    #[error("{0} primitives exceed the 2^32 - 1 a BVH can reference")]
    TooManyPrimitives(usize),
    /// The cost model has a non-finite or negative constant.
    #[error("invalid cost model: c_t and c_i must be finite and positive")]
    InvalidCostModel,
    /// A builder's configuration is out of range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
}

/// What a builder gets: the triangles, their precomputed bounds and centroids, and the cost
/// model. Construct it with [`BuildInput::new`], which rejects non-finite input up front so
/// that no builder ever computes a NaN cost.
#[derive(Clone, Debug)]
pub struct BuildInput<'a> {
    triangles: &'a [Triangle],
    bounds: Vec<Aabb>,
    centroids: Vec<Vec3A>,
    /// The SAH constants every builder optimises for.
    pub cost: CostModel,
}

impl<'a> BuildInput<'a> {
    /// Checks the triangles and the cost model, and precomputes per-triangle bounds and
    /// centroids (the centroid of the bounds, as SAH builders bin by).
    pub fn new(triangles: &'a [Triangle], cost: CostModel) -> Result<Self, BuildError> {
        if triangles.len() >= u32::MAX as usize {
            return Err(BuildError::TooManyPrimitives(triangles.len()));
        }
        if !(cost.traversal.is_finite()
            && cost.intersection.is_finite()
            && cost.traversal >= 0.0
            && cost.intersection > 0.0)
        {
            return Err(BuildError::InvalidCostModel);
        }
        if let Some(i) = triangles.iter().position(|t| !t.is_finite()) {
            return Err(BuildError::NonFinite { triangle: i });
        }
        let bounds: Vec<Aabb> = triangles.iter().map(|t| t.bounds()).collect();
        let centroids = bounds.iter().map(|b| b.centroid()).collect();
        Ok(Self {
            triangles,
            bounds,
            centroids,
            cost,
        })
    }

    /// The triangles.
    pub fn triangles(&self) -> &'a [Triangle] {
        self.triangles
    }

    /// Bounds of each triangle.
    pub fn bounds(&self) -> &[Aabb] {
        &self.bounds
    }

    /// Centroid of each triangle's bounds.
    pub fn centroids(&self) -> &[Vec3A] {
        &self.centroids
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there is nothing to build.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}
