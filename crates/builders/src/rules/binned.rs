//! The binned SAH rule (Wald 2007), shared by the `binned` builder (over all triangles) and
//! the `cluster_binned` builder (over Morton clusters, then inside each cluster): the
//! cheapest binned plane by Eq. 2, a leaf when small enough and no plane is cheaper.

use rayon::prelude::*;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::split::binned::partition::split_refs;
use crate::split::binned::plane::{best_plane, PlaneScratch};
use crate::split::binned::refs::RefBounds;
use crate::split::binned::{FillBackend, PrimRef};
use crate::split::{half_area, PAR_NODE_THRESHOLD};
use crate::topdown::{Rule, Step};
use crate::BuildInput;

/// The rule: the cheapest binned plane by Eq. 2, a leaf when small enough and no plane is
/// cheaper, an object median split where no plane separates anything (or below
/// `fallback_depth`).
pub(crate) struct BinnedRule<'a> {
    bounds: &'a [Aabb],
    cost: CostModel,
    bins: usize,
    max_leaf_size: usize,
    fallback_depth: usize,
    backend: FillBackend,
}

/// A node still to build: its primitive references (partitioned in place), their bounds, its
/// depth.
pub(crate) struct BinTask<'a> {
    pub(crate) refs: &'a mut [PrimRef],
    pub(crate) nb: RefBounds,
    pub(crate) depth: usize,
}

/// Scratch memory: the plane search's bins, and the misplaced positions of the partition.
#[derive(Default)]
pub(crate) struct Scratch {
    pub(crate) plane: PlaneScratch,
    pub(crate) wrong: Vec<u32>,
}

impl<'a> BinnedRule<'a> {
    /// The rule over `input` with `bins` bins per axis, leaves of at most `max_leaf_size`,
    /// median splits only from `fallback_depth` on (the fields of
    /// [`BinnedConfig`](crate::binned::BinnedConfig)).
    pub(crate) fn new(
        input: &'a BuildInput,
        bins: usize,
        max_leaf_size: usize,
        fallback_depth: usize,
        backend: FillBackend,
    ) -> Self {
        Self {
            bounds: input.bounds(),
            cost: input.cost,
            bins,
            max_leaf_size,
            fallback_depth,
            backend,
        }
    }

    /// The references of primitives `prims`, in that order.
    pub(crate) fn refs_of(&self, prims: &[u32]) -> Vec<PrimRef> {
        let make = |&p: &u32| PrimRef::new(&self.bounds[p as usize], p);
        if prims.len() >= PAR_NODE_THRESHOLD {
            prims.par_iter().map(make).collect()
        } else {
            prims.iter().map(make).collect()
        }
    }
}

impl<'a> Rule for BinnedRule<'a> {
    type Task = BinTask<'a>;
    type Scratch = Scratch;

    fn size(&self, t: &BinTask<'a>) -> usize {
        t.refs.len()
    }

    fn split(&self, t: BinTask<'a>, scratch: &mut Scratch) -> Step<BinTask<'a>> {
        let n = t.refs.len();
        let nb = t.nb;
        let can_leaf = n <= self.max_leaf_size;
        let plane = if n == 1 || t.depth >= self.fallback_depth {
            None
        } else {
            best_plane(
                t.refs,
                &nb.centroids,
                self.bins,
                self.backend,
                &mut scratch.plane,
            )
        };
        let make_leaf = match &plane {
            _ if n == 1 => true,
            Some(p) => {
                let (nl, nr) = (p.n_left, n - p.n_left);
                let cost = self.cost.split_cost(
                    half_area(&nb.bounds),
                    half_area(&p.left),
                    nl,
                    half_area(&p.right),
                    nr,
                );
                can_leaf && cost >= self.cost.leaf_cost(n)
            }
            None => can_leaf,
        };
        if make_leaf {
            return Step::Leaf {
                bounds: nb.bounds,
                task: t,
            };
        }
        let refs = t.refs;
        let (mid, lb, rb) = split_refs(refs, plane.as_ref(), &nb, &mut scratch.wrong);
        debug_assert!(mid > 0 && mid < n);
        let (left, right) = refs.split_at_mut(mid);
        let depth = t.depth + 1;
        Step::Split {
            bounds: nb.bounds,
            left: BinTask {
                refs: left,
                nb: lb,
                depth,
            },
            right: BinTask {
                refs: right,
                nb: rb,
                depth,
            },
        }
    }

    fn leaf_refs(&self, t: &BinTask<'a>, out: &mut Vec<u32>) {
        out.extend(t.refs.iter().map(PrimRef::id));
    }

    fn parallel_threshold(&self) -> usize {
        2048
    }
}
