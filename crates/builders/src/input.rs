use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_metrics::CostModel;

use crate::split::spatial::{Clipper, SplitPrimitive};

/// Why a build failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A triangle has a NaN or infinite coordinate.
    #[error("triangle {triangle} has a non-finite coordinate")]
    NonFinite {
        /// Its index.
        triangle: usize,
    },
    /// A primitive box has a NaN or infinite coordinate, or its minimum exceeds its maximum.
    #[error("primitive {primitive} has a non-finite or inverted box")]
    InvalidBox {
        /// Its index.
        primitive: usize,
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

/// What a builder gets: the primitives' bounds and centroids, how to cut a primitive for
/// spatial splits, and the cost model. Construct it from triangles with [`BuildInput::new`] or
/// from any primitives' boxes with [`BuildInput::from_boxes`] (plus
/// [`with_splitter`](BuildInput::with_splitter) for spatial splits); both reject non-finite
/// input up front so that no builder ever computes a NaN cost.
#[derive(Clone, Debug)]
pub struct BuildInput<'a> {
    clipper: Option<Clipper<'a>>,
    count: usize,
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
        check_cost(&cost)?;
        if let Some(i) = triangles.iter().position(|t| !t.is_finite()) {
            return Err(BuildError::NonFinite { triangle: i });
        }
        let bounds: Vec<Aabb> = triangles.iter().map(|t| t.bounds()).collect();
        let centroids = bounds.iter().map(|b| b.centroid()).collect();
        Ok(Self {
            clipper: Some(Clipper::Triangles(triangles)),
            count: triangles.len(),
            bounds,
            centroids,
            cost,
        })
    }

    /// The input of primitives of any kind given by their boxes: builders bin and split them
    /// by these boxes and their centres. Spatial-split builders make no spatial split (they
    /// build object splits only) unless a [`SplitPrimitive`] is given with
    /// [`with_splitter`](Self::with_splitter).
    pub fn from_boxes(boxes: &[Aabb], cost: CostModel) -> Result<Self, BuildError> {
        if boxes.len() >= u32::MAX as usize {
            return Err(BuildError::TooManyPrimitives(boxes.len()));
        }
        check_cost(&cost)?;
        let bad = |b: &Aabb| !(b.min.is_finite() && b.max.is_finite()) || b.min.cmpgt(b.max).any();
        if let Some(i) = boxes.iter().position(bad) {
            return Err(BuildError::InvalidBox { primitive: i });
        }
        Ok(Self {
            clipper: None,
            count: boxes.len(),
            bounds: boxes.to_vec(),
            centroids: boxes.iter().map(|b| b.centroid()).collect(),
            cost,
        })
    }

    /// This input with `splitter` cutting its primitives for spatial splits (replacing the
    /// exact triangle clipping of [`BuildInput::new`]).
    #[must_use]
    pub fn with_splitter(mut self, splitter: &'a dyn SplitPrimitive) -> Self {
        self.clipper = Some(Clipper::Custom(splitter));
        self
    }

    /// How primitives are cut for spatial splits (`None`: they are not).
    pub fn clipper(&self) -> Option<Clipper<'a>> {
        self.clipper
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
        self.count
    }

    /// True when there is nothing to build.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
}

fn check_cost(cost: &CostModel) -> Result<(), BuildError> {
    if !(cost.traversal.is_finite()
        && cost.intersection.is_finite()
        && cost.traversal >= 0.0
        && cost.intersection > 0.0)
    {
        return Err(BuildError::InvalidCostModel);
    }
    Ok(())
}
