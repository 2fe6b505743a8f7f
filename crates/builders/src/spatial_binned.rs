//! Binned SAH with spatial splits, built in place with a replication budget: the spatial-split
//! builder made for rebuilding (`Quality::High` of the façade).
//!
//! [`crate::sbvh`] gives every node its own list of references and every child a freshly
//! allocated one; its object splits bin 48-byte references without SIMD. This builder is the
//! binned builder ([`crate::binned`]) taught to cut references, on the design of Embree's
//! spatial-split builder (documented facts, not its code):
//!
//! * **one array, extended ranges**: the references live in one array of
//!   `n × (1 + budget)` slots. A node owns a range of it: its references first, then spare
//!   slots, which are all the duplicates its subtree may still make. A split shares the spare
//!   slots between the children in proportion to their reference counts
//!   ([`crate::split::spatial::share_budget`]), moving the right child's references to the
//!   start of its range. So the budget limits replication where it is spent, without a
//!   global counter, and the tree does not depend on the order in which subtrees are built;
//! * **object splits by the binned builder's search**: 32 centroid bins per axis over the
//!   32-byte references (SIMD fill), the in-place partition;
//! * **spatial splits only where they can pay**: only in nodes with spare slots, and only
//!   where the sides of the best object split overlap by more than `alpha` times the root's
//!   area (Stich et al.) and by at least `overlap_ratio` of the sides' own areas (Embree's
//!   gate); then 16 equal-width spatial bins per axis over the node's box
//!   ([`crate::split::spatial::spatial_search`], triangles clipped into the bins);
//! * **only straddling references are cut**, exactly at the plane
//!   ([`crate::split::spatial::apply_spatial`], with reference unsplitting), the others are
//!   moved whole.
//!
//! The defaults (budget, bins, gate) were chosen from measurements: `docs/builders-classic.md`,
//! "Spatial splits at Embree HIGH's pace".
//!
//! ```
//! use sahara_builders::spatial_binned::{SpatialBinnedBuilder, SpatialBinnedConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! // Long thin triangles crossing each other: spatial splits pay here.
//! let tris: Vec<Triangle> = (0..200)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 20) as f32, (i / 20) as f32, 0.0);
//!         Triangle::new(o, o + Vec3A::new(8.0, 0.5, 0.0), o + Vec3A::new(0.0, 0.2, 1.0))
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = SpatialBinnedBuilder::new(SpatialBinnedConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! assert!(bvh.spatial_splits);
//! ```

use sahara_bvh::RefCuts;
use sahara_geom::Aabb;
use sahara_metrics::CostModel;

use crate::split::binned::partition::split_refs;
use crate::split::binned::plane::{best_plane, Plane, PlaneScratch};
use crate::split::binned::refs::{ref_bounds, RefBounds};
use crate::split::binned::{FillBackend, PrimRef};
use crate::split::half_area;
use crate::split::object::Ref;
use crate::split::spatial::{
    apply_spatial, estimated_spatial_search, share_budget, spatial_search, Clipper, CutLog,
    EstimateScratch, SpatialCand,
};
use crate::topdown::{self, Rule, Step};
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// Configuration of the in-place binned spatial-split builder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpatialBinnedConfig {
    /// Centroid bins per axis of the object split search (at least 2). Default 32.
    pub object_bins: usize,
    /// Equal-width bins per axis of the spatial split search; below 2, no spatial splits (the
    /// builder is then the binned builder). Default 16.
    pub spatial_bins: usize,
    /// Extra references allowed, relative to the number of primitives: `0.3` lets the tree
    /// hold up to 1.3 references per primitive. Default 0.3.
    pub budget: f32,
    /// How a node's best spatial split is searched: `0` cuts every reference into every bin
    /// it spans on each axis (Stich et al.'s binning, [`spatial_search`]); `k >= 1` bins the
    /// references by their boxes only and re-rates the `k` best planes of the three axes with
    /// the straddling primitives cut at the plane ([`estimated_spatial_search`]). The split
    /// that is applied always cuts exactly. Default 2.
    pub refine_planes: usize,
    /// Spatial splits are searched only where the two sides of the best object split overlap
    /// by more than `alpha` times the half area of the root. Default `1e-5`.
    pub alpha: f32,
    /// ... and by at least this fraction of the sum of the two sides' half areas. Default 0.2.
    pub overlap_ratio: f32,
    /// Reference unsplitting when a spatial split is applied (Stich et al.). Default `true`.
    pub unsplitting: bool,
    /// Largest leaf (at least 1): nodes with more references are always split. Default 8.
    pub max_leaf_size: usize,
    /// Nodes at this depth or deeper are split at the object median only (when they must be
    /// split), bounding the depth on adversarial input. Default 96.
    pub fallback_depth: usize,
}

impl Default for SpatialBinnedConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SpatialBinnedConfig {
    /// 32 object bins, 16 spatial bins searched by the box estimate with the 2 best planes
    /// re-rated, 30% extra references, Embree's overlap gate, leaves of at most 8.
    pub const DEFAULT: SpatialBinnedConfig = SpatialBinnedConfig {
        object_bins: 32,
        spatial_bins: 16,
        refine_planes: 2,
        budget: 0.3,
        alpha: 1e-5,
        overlap_ratio: 0.2,
        unsplitting: true,
        max_leaf_size: 8,
        fallback_depth: 96,
    };

    /// The number of reference slots for `n` primitives: `n` plus the budget's extra ones.
    pub fn slots_for(&self, n: usize) -> usize {
        let extra = (self.budget as f64 * n as f64).floor();
        // At most 2^31 references in all (the trees' indices are 32-bit).
        let cap = (u32::MAX / 2) as f64;
        n + extra.min((cap - n as f64).max(0.0)) as usize
    }
}

impl Strategy for SpatialBinnedConfig {
    const NAME: &'static str = "spatial-binned";

    fn check(&self) -> Result<(), BuildError> {
        let bad = |m: &str| Err(BuildError::InvalidConfig(format!("spatial-binned: {m}")));
        if self.object_bins < 2 {
            return bad("object_bins must be at least 2");
        }
        if self.max_leaf_size < 1 {
            return bad("max_leaf_size must be at least 1");
        }
        if !(self.budget.is_finite() && self.budget >= 0.0) {
            return bad("budget must be finite and non-negative");
        }
        if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            return bad("alpha must be finite and non-negative");
        }
        if !(self.overlap_ratio.is_finite() && self.overlap_ratio >= 0.0) {
            return bad("overlap_ratio must be finite and non-negative");
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "binned SAH with spatial splits, in place: {} object bins, {} spatial bins ({}), \
             budget {}x extra refs, spatial splits where the object split's sides overlap by > \
             {:e} of the root and >= {} of their areas, unsplitting {}, leaves <= {}",
            self.object_bins,
            self.spatial_bins,
            if self.refine_planes == 0 {
                "every reference cut into its bins".to_string()
            } else {
                format!("box estimate, {} best planes re-rated", self.refine_planes)
            },
            self.budget,
            self.alpha,
            self.overlap_ratio,
            if self.unsplitting { "on" } else { "off" },
            self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let n = input.len();
        let mut slots: Vec<PrimRef> = Vec::with_capacity(self.slots_for(n));
        slots.extend(
            input
                .bounds()
                .iter()
                .enumerate()
                .map(|(i, b)| PrimRef::new(b, i as u32)),
        );
        let nb = ref_bounds(&slots);
        slots.resize(self.slots_for(n), PrimRef::new(&Aabb::EMPTY, 0));
        let log = CutLog::default();
        let rule = SpatialBinnedRule {
            clipper: input.clipper(),
            cost: input.cost,
            cfg: *self,
            root_area: half_area(&nb.bounds),
            log: &log,
        };
        let root = Task {
            slots: &mut slots,
            n,
            nb,
            depth: 0,
        };
        Ok(topdown::build(&rule, root, rule.clipper.is_some()))
    }
}

/// The in-place binned spatial-split builder. Parallel on rayon; the tree does not depend on
/// the number of threads.
pub type SpatialBinnedBuilder = Configured<SpatialBinnedConfig>;

struct SpatialBinnedRule<'a> {
    clipper: Option<Clipper<'a>>,
    cost: CostModel,
    cfg: SpatialBinnedConfig,
    root_area: f64,
    /// Where the references were cut, for the tree's cut records (refit replays them).
    log: &'a CutLog,
}

/// A node still to build: its range of slots (its `n` references first, then the spare slots
/// its subtree may fill with duplicates), their bounds and its depth.
struct Task<'a> {
    slots: &'a mut [PrimRef],
    n: usize,
    nb: RefBounds,
    depth: usize,
}

/// Scratch memory: the object search's bins, the partition's misplaced positions, and the
/// node's references in the spatial search's form.
#[derive(Default)]
struct Scratch {
    plane: PlaneScratch,
    wrong: Vec<u32>,
    refs: Vec<Ref>,
    estimate: EstimateScratch,
}

impl SpatialBinnedRule<'_> {
    /// Whether a spatial split is worth searching, given the best object split's sides: they
    /// overlap by more than `alpha` times the root's area and by at least `overlap_ratio` of
    /// their own areas.
    fn gate(&self, p: &Plane) -> bool {
        let i = p.left.intersection(&p.right);
        if i.is_empty() {
            return false;
        }
        let overlap = half_area(&i);
        overlap > self.cfg.alpha as f64 * self.root_area
            && overlap >= self.cfg.overlap_ratio as f64 * (half_area(&p.left) + half_area(&p.right))
    }

    /// The best spatial split of a node of box `bounds` whose duplication fits `spare`: by
    /// the box estimate with the [`SpatialBinnedConfig::refine_planes`] best planes re-rated
    /// with their straddling primitives cut, or by cutting every reference into every bin
    /// when `refine_planes` is 0.
    fn spatial_search(
        &self,
        clipper: &Clipper,
        refs: &[Ref],
        bounds: &Aabb,
        spare: usize,
        scratch: &mut EstimateScratch,
    ) -> Option<SpatialCand> {
        let (area, bins) = (half_area(bounds), self.cfg.spatial_bins);
        if self.cfg.refine_planes == 0 {
            return spatial_search(clipper, refs, bounds, area, 1, spare, bins, &self.cost)
                .first()
                .copied();
        }
        estimated_spatial_search(
            clipper,
            refs,
            bounds,
            area,
            spare,
            bins,
            self.cfg.refine_planes,
            &self.cost,
            scratch,
        )
    }

    fn object_cost(&self, nb: &RefBounds, n: usize, p: &Plane) -> f64 {
        self.cost.split_cost(
            half_area(&nb.bounds),
            half_area(&p.left),
            p.n_left,
            half_area(&p.right),
            n - p.n_left,
        )
    }
}

/// The two children of a node whose references are split into `slots[..nl]` and
/// `slots[nl..nl + nr]`: the spare slots after them shared in proportion to the counts, the
/// right child's references moved to the start of its range.
fn children<'a>(
    slots: &'a mut [PrimRef],
    nl: usize,
    nr: usize,
    lb: RefBounds,
    rb: RefBounds,
    depth: usize,
) -> (Task<'a>, Task<'a>) {
    let spare = slots.len() - nl - nr;
    let (sl, _) = share_budget(spare, nl, nr);
    if sl > 0 {
        slots.copy_within(nl..nl + nr, nl + sl);
    }
    let (left, right) = slots.split_at_mut(nl + sl);
    (
        Task {
            slots: left,
            n: nl,
            nb: lb,
            depth,
        },
        Task {
            slots: right,
            n: nr,
            nb: rb,
            depth,
        },
    )
}

impl<'a> Rule for SpatialBinnedRule<'a> {
    type Task = Task<'a>;
    type Scratch = Scratch;

    fn size(&self, t: &Task<'a>) -> usize {
        t.n
    }

    fn split(&self, t: Task<'a>, sc: &mut Scratch) -> Step<Task<'a>> {
        let n = t.n;
        let nb = t.nb;
        let bounds = nb.bounds;
        let can_leaf = n <= self.cfg.max_leaf_size;
        if n == 1 || (can_leaf && t.depth >= self.cfg.fallback_depth) {
            return Step::Leaf { bounds, task: t };
        }
        let depth = t.depth + 1;
        let plane = if t.depth >= self.cfg.fallback_depth {
            None
        } else {
            best_plane(
                &t.slots[..n],
                &nb.centroids,
                self.cfg.object_bins,
                FillBackend::Simd,
                &mut sc.plane,
            )
        };
        let object_cost = plane.as_ref().map(|p| self.object_cost(&nb, n, p));
        let spare = t.slots.len() - n;
        let spatial = match (&self.clipper, &plane, object_cost) {
            (Some(clipper), Some(p), Some(oc))
                if spare > 0 && self.cfg.spatial_bins >= 2 && self.gate(p) =>
            {
                sc.refs.clear();
                sc.refs.extend(t.slots[..n].iter().map(|r| Ref {
                    bounds: r.bounds(),
                    prim: r.id(),
                    cut: r.cut(),
                }));
                self.spatial_search(clipper, &sc.refs, &bounds, spare, &mut sc.estimate)
                    .filter(|s| s.cost < oc)
                    .map(|s| (clipper, s))
            }
            _ => None,
        };
        let best = spatial
            .as_ref()
            .map(|(_, s)| s.cost)
            .or(object_cost)
            .unwrap_or(f64::INFINITY);
        if can_leaf && self.cost.leaf_cost(n) <= best {
            return Step::Leaf { bounds, task: t };
        }
        let slots = t.slots;
        if let Some((clipper, s)) = spatial {
            let log = Some((self.log, t.depth));
            if let Some((l, r)) = apply_spatial(clipper, &sc.refs, &s, self.cfg.unsplitting, log) {
                if l.len() + r.len() <= slots.len() {
                    let put = |dst: &mut [PrimRef], src: &[Ref]| {
                        for (d, r) in dst.iter_mut().zip(src) {
                            *d = PrimRef::new(&r.bounds, r.prim).with_cut(r.cut);
                        }
                    };
                    let (nl, nr) = (l.len(), r.len());
                    put(&mut slots[..nl], &l);
                    put(&mut slots[nl..nl + nr], &r);
                    let lb = ref_bounds(&slots[..nl]);
                    let rb = ref_bounds(&slots[nl..nl + nr]);
                    let (left, right) = children(slots, nl, nr, lb, rb, depth);
                    return Step::Split {
                        bounds,
                        left,
                        right,
                    };
                }
            }
        }
        let (nl, lb, rb) = split_refs(&mut slots[..n], plane.as_ref(), &nb, &mut sc.wrong);
        debug_assert!(nl > 0 && nl < n);
        let (left, right) = children(slots, nl, n - nl, lb, rb, depth);
        Step::Split {
            bounds,
            left,
            right,
        }
    }

    fn leaf_refs(&self, t: &Task<'a>, out: &mut Vec<u32>) {
        out.extend(t.slots[..t.n].iter().map(PrimRef::id));
    }

    fn leaf_cuts(&self, t: &Task<'a>, out: &mut Vec<u32>) {
        if self.clipper.is_some() {
            out.extend(t.slots[..t.n].iter().map(PrimRef::cut));
        }
    }

    fn ref_cuts(&self, heads: &[u32]) -> Option<RefCuts> {
        self.clipper.as_ref().map(|_| self.log.resolve(heads))
    }

    fn parallel_threshold(&self) -> usize {
        2048
    }
}
