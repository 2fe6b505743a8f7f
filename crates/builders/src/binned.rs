//! Binned SAH construction (Wald 2007, "On fast construction of SAH-based bounding volume
//! hierarchies").
//!
//! At every node the centroids of the node's triangles are bounded, and `K` equal-width bins
//! are laid over those *centroid* bounds on each of the three axes (binning over the node's own
//! box would put whole clusters of small triangles into one bin). Each bin records how many
//! triangles it holds and the union of their boxes; a right-to-left sweep over the bins stores
//! the suffix areas and counts, a left-to-right sweep evaluates the greedy cost of Eq. 2 at
//! each of the `K - 1` planes. A node becomes a leaf when it has at most
//! [`BinnedConfig::max_leaf_size`] triangles and no plane is cheaper than the leaf; a larger
//! node is always split, by the best plane or, where no plane separates anything (all
//! centroids coincide), by an object median split.
//!
//! Besides the [`BinnedBuilder`], the module exposes [`binned_cost_only`], which computes the
//! SAH cost `c(T)` of the tree the builder would make over a subset of the primitives without
//! allocating a single node: the paper's builders use it to rate candidate splits with
//! temporary subtrees.
//!
//! ```
//! use sahara_builders::binned::{binned_cost_only, BinnedBuilder, BinnedConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::{sah, CostModel};
//!
//! let tris: Vec<Triangle> = (0..200)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 13) as f32, (i / 13) as f32, (i % 5) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.5, o + Vec3A::Y * 0.5)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = BinnedBuilder::new(BinnedConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//!
//! let mut prims: Vec<u32> = (0..tris.len() as u32).collect();
//! let c = binned_cost_only(&input, &mut prims, &BinnedConfig::default());
//! assert!((c - sah(&bvh, &input.cost)).abs() <= 1e-9 * c);
//! ```

use crate::cost_only;
use crate::split::binned::{self as bins, RefBins};
pub use crate::split::binned::{FillBackend, PrimRef};
use crate::split::{
    float_key, half_area, imbalance, ranks_before, BinMap, PAR_CHUNK, PAR_NODE_THRESHOLD,
};
use crate::topdown::{self, Rule, Step};
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};
use glam::BVec3A;
use rayon::prelude::*;
use sahara_geom::{Aabb, Vec3A};
use sahara_metrics::CostModel;

/// Configuration of the binned SAH builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BinnedConfig {
    /// Number of equal-width bins per axis, `K` (at least 2). Default 32.
    pub bins: usize,
    /// Largest leaf (at least 1): nodes with more triangles are always split. Default 8.
    pub max_leaf_size: usize,
    /// Nodes at this depth or deeper are split at the object median only (when they must be
    /// split at all). This bounds the depth of trees over adversarial inputs, where the best
    /// plane may peel off a few triangles per level, to `fallback_depth + log2(n)`; it never
    /// triggers on ordinary scenes. Default 96.
    pub fallback_depth: usize,
}

impl Default for BinnedConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl BinnedConfig {
    /// 32 bins, leaves of at most 8 triangles: the usual quality/speed trade-off.
    pub const DEFAULT: BinnedConfig = BinnedConfig {
        bins: 32,
        max_leaf_size: 8,
        fallback_depth: 96,
    };
    /// 8 bins: the fastest preset, a little worse SAH.
    pub const FAST: BinnedConfig = BinnedConfig {
        bins: 8,
        ..Self::DEFAULT
    };
    /// 128 bins: close to a full sweep in quality.
    pub const FINE: BinnedConfig = BinnedConfig {
        bins: 128,
        ..Self::DEFAULT
    };

    /// The default configuration with `bins` bins per axis.
    pub const fn with_bins(bins: usize) -> BinnedConfig {
        BinnedConfig {
            bins,
            ..Self::DEFAULT
        }
    }
}

impl Strategy for BinnedConfig {
    const NAME: &'static str = "binned";

    fn check(&self) -> Result<(), BuildError> {
        if self.bins < 2 {
            return Err(BuildError::InvalidConfig(format!(
                "binned: bins must be at least 2 (got {})",
                self.bins
            )));
        }
        if self.max_leaf_size < 1 {
            return Err(BuildError::InvalidConfig(
                "binned: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "binned SAH (Wald 2007): {} centroid bins per axis, leaves <= {}",
            self.bins, self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        Ok(build_tree(input, self, FillBackend::Simd))
    }
}

/// The tree of [`BinnedBuilder`] with `config`, its bins filled by `backend`. Both backends
/// give the bit-identical tree on every CPU (the crate's tests compare them); this entry point
/// exists so that they can be compared.
///
/// # Errors
///
/// As [`Builder::build`](crate::Builder::build): an invalid configuration or too many
/// primitives.
pub fn build_with_backend(
    input: &BuildInput,
    config: &BinnedConfig,
    backend: FillBackend,
) -> Result<Bvh, BuildError> {
    config.check()?;
    if input.is_empty() {
        return Ok(Bvh::empty());
    }
    if input.len() > (u32::MAX / 2) as usize {
        return Err(BuildError::TooManyPrimitives(input.len()));
    }
    Ok(build_tree(input, config, backend))
}

fn build_tree(input: &BuildInput, config: &BinnedConfig, backend: FillBackend) -> Bvh {
    let rule = BinnedRule::new(input, config, backend);
    let mut refs = rule.refs_of((0..input.len() as u32).collect::<Vec<_>>().as_slice());
    let nb = bounds_of(&refs);
    let root = BinTask {
        refs: &mut refs,
        nb,
        depth: 0,
    };
    topdown::build(&rule, root, false)
}

/// The binned SAH builder (Wald 2007). Parallel on rayon; the tree does not depend on the
/// number of threads.
pub type BinnedBuilder = Configured<BinnedConfig>;

/// The SAH cost `c(T)` (Eq. 1, relative to the area of the subset's bounds) of the tree that
/// [`BinnedBuilder`] with `config` would build over the primitives `prims`, computed bottom-up
/// during the build without allocating any node.
///
/// `prims` is reordered in place (it ends up in the leaf order of that tree). Scratch memory
/// (the references and the bins) is allocated once per call and reused at every node; the
/// result is the same for any number of threads. The value equals `sahara_metrics::sah` of
/// the built tree up to rounding (the two sum the same terms in different orders). An empty
/// subset costs `0`.
///
/// # Panics
///
/// If a primitive index is out of range or the configuration is invalid (see
/// [`BinnedConfig::check`]).
pub fn binned_cost_only(input: &BuildInput, prims: &mut [u32], config: &BinnedConfig) -> f64 {
    config.check().expect("invalid binned configuration");
    if prims.is_empty() {
        return 0.0;
    }
    let rule = BinnedRule::new(input, config, FillBackend::Simd);
    let mut refs = rule.refs_of(prims);
    let nb = bounds_of(&refs);
    let root = BinTask {
        refs: &mut refs,
        nb,
        depth: 0,
    };
    let c = cost_only::cost(&rule, root, &input.cost, &mut Scratch::default()).cost;
    for (p, r) in prims.iter_mut().zip(&refs) {
        *p = r.id();
    }
    c
}

/// The rule: the cheapest binned plane by Eq. 2, a leaf when small enough and no plane is
/// cheaper, an object median split where no plane separates anything (or below
/// [`BinnedConfig::fallback_depth`]).
struct BinnedRule<'a> {
    bounds: &'a [Aabb],
    cost: CostModel,
    cfg: BinnedConfig,
    backend: FillBackend,
}

/// A node still to build: its primitive references (partitioned in place), their bounds, its
/// depth.
struct BinTask<'a> {
    refs: &'a mut [PrimRef],
    nb: Bounds,
    depth: usize,
}

/// Scratch memory: the bins of three axes and the suffix sweep;
/// for small nodes, the references sorted by bin and their suffix bounds.
#[derive(Default)]
struct Scratch {
    bins: RefBins,
    right: Vec<([f32; 4], [u32; 4])>,
    sparse: SparseBins,
    /// The misplaced positions of [`partition_branchless`].
    wrong: Vec<u32>,
}

/// The bins of [`BinnedRule::best_plane_sparse`]: `3 × k`, axis-major, all empty between two
/// searches (a search empties the bins it filled, which a bit mask per axis records).
#[derive(Default)]
struct SparseBins {
    min: Vec<[f32; 4]>,
    max: Vec<[f32; 4]>,
    count: Vec<u32>,
}

impl SparseBins {
    /// Empties the bins of `masks` (`k` bins per axis).
    fn empty(&mut self, masks: &[u64; 3], k: usize) {
        for (axis, &mask) in masks.iter().enumerate() {
            let mut bits = mask;
            while bits != 0 {
                let i = axis * k + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                self.min[i] = bins::EMPTY_MIN;
                self.max[i] = bins::EMPTY_MAX;
                self.count[i] = 0;
            }
        }
    }
}

/// The bounds of a set of primitives and of their centroids.
#[derive(Clone, Copy)]
struct Bounds {
    bounds: Aabb,
    centroids: Aabb,
}

/// The best plane found by binning, with the bounds of both sides.
#[derive(Clone, Copy)]
struct Plane {
    axis: usize,
    /// Primitives in bins `< plane` go left.
    plane: usize,
    map: BinMap,
    /// Primitives going left.
    n_left: usize,
    left: Aabb,
    right: Aabb,
}

/// A plane under consideration: its score `A_l n_l + A_r n_r` (which orders the planes of one
/// node as Eq. 2 does, without a division per plane) and its tie-break.
#[derive(Clone, Copy)]
struct Rated {
    axis: usize,
    plane: usize,
    score: f64,
    imbalance: usize,
}

impl Rated {
    #[inline]
    fn better_than(&self, o: &Rated) -> bool {
        ranks_before(
            self.score,
            || (self.imbalance, self.axis, self.plane),
            o.score,
            || (o.imbalance, o.axis, o.plane),
        )
    }
}

/// Bounds of the references and of their centroids (computed at the root and for median
/// splits; other children get their bounds from the bins and their centroid bounds from the
/// partition).
fn bounds_of(refs: &[PrimRef]) -> Bounds {
    let fold = |refs: &[PrimRef]| {
        let mut b = Aabb::EMPTY;
        let mut c = Aabb::EMPTY;
        for r in refs {
            b.grow_aabb(&r.bounds());
            c.grow(r.centroid());
        }
        (b, c)
    };
    let (bounds, centroids) = if refs.len() >= PAR_NODE_THRESHOLD {
        refs.par_chunks(PAR_CHUNK).map(fold).reduce(
            || (Aabb::EMPTY, Aabb::EMPTY),
            |a, b| (a.0.union(&b.0), a.1.union(&b.1)),
        )
    } else {
        fold(refs)
    };
    Bounds { bounds, centroids }
}

impl<'a> BinnedRule<'a> {
    fn new(input: &'a BuildInput, cfg: &BinnedConfig, backend: FillBackend) -> Self {
        Self {
            bounds: input.bounds(),
            cost: input.cost,
            cfg: *cfg,
            backend,
        }
    }

    /// The references of primitives `prims`, in that order.
    fn refs_of(&self, prims: &[u32]) -> Vec<PrimRef> {
        let make = |&p: &u32| PrimRef::new(&self.bounds[p as usize], p);
        if prims.len() >= PAR_NODE_THRESHOLD {
            prims.par_iter().map(make).collect()
        } else {
            prims.iter().map(make).collect()
        }
    }

    /// The plane of least Eq. 2 cost over the three axes (ties: see [`ranks_before`]); `None`
    /// when no plane has primitives on both sides.
    fn best_plane(&self, refs: &[PrimRef], cb: &Aabb, s: &mut Scratch) -> Option<Plane> {
        let k = self.cfg.bins;
        let maps = bins::maps(cb, k);
        if maps.iter().all(Option::is_none) {
            return None;
        }
        if refs.len() == 2 {
            self.best_plane_of_two(refs, &maps)
        } else if 2 * refs.len() <= k && k <= 64 {
            self.best_plane_sparse(refs, &maps, s)
        } else {
            self.best_plane_binned(refs, &maps, s)
        }
    }

    /// [`best_plane`](Self::best_plane) by the bins.
    fn best_plane_binned(
        &self,
        refs: &[PrimRef],
        maps: &[Option<BinMap>; 3],
        s: &mut Scratch,
    ) -> Option<Plane> {
        let k = self.cfg.bins;
        s.bins.fill_par(k, maps, refs, self.backend);
        let mut best: Option<Rated> = None;
        // An axis without a map has empty bins, so it offers no plane. The planes come plane
        // by plane rather than axis by axis; the best of a strict total order is the same.
        s.bins
            .sweep_axes(&mut s.right, |axis, plane, la, lc, ra, rc| {
                let cand = Rated {
                    axis,
                    plane,
                    score: la * lc as f64 + ra as f64 * rc as f64,
                    imbalance: imbalance(lc, rc),
                };
                if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                    best = Some(cand);
                }
            });
        let Rated { axis, plane, .. } = best?;
        let (n_left, left, right) = s.bins.sides(axis, plane);
        Some(Plane {
            axis,
            plane,
            map: maps[axis].expect("a mapped axis"),
            n_left,
            left,
            right,
        })
    }

    /// [`best_plane`](Self::best_plane) for a node of two references (a third of all nodes),
    /// without bins. Bit for bit [`best_plane_sparse`](Self::best_plane_sparse) and
    /// [`best_plane_binned`](Self::best_plane_binned):
    ///
    /// * an axis offers a plane only when the two references fall into different bins, and
    ///   then exactly one (the first after the lower bin), with one reference on each side;
    /// * so every offered plane has the score `A_a + A_b` of the two boxes' half areas, in one
    ///   order or the other (`f64` addition commutes bit for bit), and the same imbalance: the
    ///   tie goes to the first such axis;
    /// * each side's bounds are one reference's box, as the bins' unions of one box are.
    fn best_plane_of_two(&self, refs: &[PrimRef], maps: &[Option<BinMap>; 3]) -> Option<Plane> {
        debug_assert_eq!(refs.len(), 2);
        let top = (self.cfg.bins - 1) as f32;
        let (lo4, scale4) = bins::map_lanes(maps);
        let i0 = bins::bin_indices(&refs[0], lo4, scale4, top);
        let i1 = bins::bin_indices(&refs[1], lo4, scale4, top);
        let axis = (0..3).find(|&a| maps[a].is_some() && i0[a] != i1[a])?;
        let (low, left, right) = if i0[axis] < i1[axis] {
            (i0[axis], &refs[0], &refs[1])
        } else {
            (i1[axis], &refs[1], &refs[0])
        };
        let aabb = |r: &PrimRef| {
            Aabb::new(
                Vec3A::new(r.min[0], r.min[1], r.min[2]),
                Vec3A::new(r.max[0], r.max[1], r.max[2]),
            )
        };
        Some(Plane {
            axis,
            plane: low as usize + 1,
            map: maps[axis].expect("a mapped axis"),
            n_left: 1,
            left: aabb(left),
            right: aabb(right),
        })
    }

    /// [`best_plane`](Self::best_plane) for nodes with fewer primitives than half the bins
    /// (and at most 64 bins): most bins are empty, so only the occupied ones are filled (a
    /// bit mask per axis says which) and swept, and only the first plane after each occupied
    /// bin is rated. Bit for bit [`best_plane_binned`](Self::best_plane_binned):
    ///
    /// * an occupied bin holds the same union in the same operand order (the first reference
    ///   stored as is equals `min(+inf, r)`, `max(-inf, r)`), and an empty bin is the neutral
    ///   element of the sweep's unions (every box of a build is finite), so skipping it changes
    ///   no bit of the sides;
    /// * the planes `a + 1 ..= b` between occupied bins `a < b` make the same partition with
    ///   the same bounds and score, and the full sweep keeps the first of them (ties need a
    ///   strictly better rank, and a later plane ranks after).
    fn best_plane_sparse(
        &self,
        refs: &[PrimRef],
        maps: &[Option<BinMap>; 3],
        s: &mut Scratch,
    ) -> Option<Plane> {
        let k = self.cfg.bins;
        debug_assert!(k <= 64);
        let sp = &mut s.sparse;
        if sp.min.len() < 3 * k {
            sp.min.resize(3 * k, bins::EMPTY_MIN);
            sp.max.resize(3 * k, bins::EMPTY_MAX);
            sp.count.resize(3 * k, 0);
        }
        let top = (k - 1) as f32;
        let (lo4, scale4) = bins::map_lanes(maps);
        let on = maps.map(|m| m.is_some());
        let mut masks = [0u64; 3];
        for r in refs {
            let mut lo = r.min;
            lo[3] = 0.0;
            let idx = bins::bin_indices(r, lo4, scale4, top);
            for axis in 0..3 {
                if !on[axis] {
                    continue;
                }
                let b = idx[axis] as usize;
                let i = axis * k + b;
                // No branch on whether the bin was empty: an empty bin is the neutral element
                // (`min(+inf, x)` is `x` bit for bit, as `minps` returns its second operand
                // unless the first is smaller), and bins are emptied again after the search.
                masks[axis] |= 1 << b;
                sp.min[i] = bins::min4(sp.min[i], lo);
                sp.max[i] = bins::max4(sp.max[i], r.max);
                sp.count[i] += 1;
            }
        }
        let mut best: Option<Rated> = None;
        let mut occupied = [0u8; 64];
        let mut right = [(0.0f32, 0u32); 64];
        for (axis, &mask) in masks.iter().enumerate() {
            if mask.count_ones() < 2 {
                continue;
            }
            let base = axis * k;
            let mut m = 0;
            let mut bits = mask;
            while bits != 0 {
                occupied[m] = bits.trailing_zeros() as u8;
                bits &= bits - 1;
                m += 1;
            }
            let bin = |j: usize| base + occupied[j] as usize;
            // Suffixes: right[j] is the union of occupied bins j.. (descending, as the sweep).
            let (mut lo, mut hi, mut rc) = (bins::EMPTY_MIN, bins::EMPTY_MAX, 0u32);
            for j in (1..m).rev() {
                lo = bins::min4(lo, sp.min[bin(j)]);
                hi = bins::max4(hi, sp.max[bin(j)]);
                rc += sp.count[bin(j)];
                right[j] = (bins::half_area4(&lo, &hi), rc);
            }
            let (mut lo, mut hi, mut lc) = (bins::EMPTY_MIN, bins::EMPTY_MAX, 0u32);
            for j in 1..m {
                lo = bins::min4(lo, sp.min[bin(j - 1)]);
                hi = bins::max4(hi, sp.max[bin(j - 1)]);
                lc += sp.count[bin(j - 1)];
                let (ra, rc) = right[j];
                let cand = Rated {
                    axis,
                    plane: occupied[j - 1] as usize + 1,
                    score: bins::half_area4(&lo, &hi) as f64 * lc as f64 + ra as f64 * rc as f64,
                    imbalance: imbalance(lc as usize, rc as usize),
                };
                if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                    best = Some(cand);
                }
            }
        }
        let Some(Rated { axis, plane, .. }) = best else {
            sp.empty(&masks, k);
            return None;
        };
        let (mut l, mut r) = (
            (bins::EMPTY_MIN, bins::EMPTY_MAX),
            (bins::EMPTY_MIN, bins::EMPTY_MAX),
        );
        let mut n_left = 0;
        let mut bits = masks[axis];
        while bits != 0 {
            let b = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let i = axis * k + b;
            let side = if b < plane {
                n_left += sp.count[i] as usize;
                &mut l
            } else {
                &mut r
            };
            side.0 = bins::min4(side.0, sp.min[i]);
            side.1 = bins::max4(side.1, sp.max[i]);
        }
        sp.empty(&masks, k);
        let aabb = |(lo, hi): ([f32; 4], [f32; 4])| {
            Aabb::new(
                Vec3A::new(lo[0], lo[1], lo[2]),
                Vec3A::new(hi[0], hi[1], hi[2]),
            )
        };
        Some(Plane {
            axis,
            plane,
            map: maps[axis].expect("a mapped axis"),
            n_left,
            left: aabb(l),
            right: aabb(r),
        })
    }

    /// Moves the references of bins `< plane` to the front (the same swaps whatever the
    /// backend and the number of threads); returns how many there are and the centroid
    /// bounds of both sides.
    fn partition(
        &self,
        refs: &mut [PrimRef],
        p: &Plane,
        wrong: &mut Vec<u32>,
    ) -> (usize, Aabb, Aabb) {
        // The parallel partition does more work (it records the misplaced positions): worth
        // it only at the few top nodes, where the other workers have nothing else to do yet.
        // Both give the same result, so the choice may depend on the thread count.
        if refs.len() >= PAR_PARTITION_THRESHOLD && rayon::current_num_threads() > 1 {
            if let Some(r) = partition_par(refs, p) {
                return r;
            }
        }
        partition_branchless(refs, p, wrong).unwrap_or_else(|| partition_serial(refs, p))
    }

    /// Object median split on the largest axis of the centroid bounds, by (centroid, index).
    fn median_split(&self, refs: &mut [PrimRef], cb: &Aabb) -> usize {
        let axis = cb.largest_axis();
        // The keys are unique (ids are), so the order does not depend on the algorithm.
        let key = |r: &PrimRef| ((float_key(r.centroid_on(axis)) as u64) << 32) | r.id() as u64;
        if refs.len() > 1 << 14 {
            refs.par_sort_unstable_by_key(key);
        } else {
            refs.sort_unstable_by_key(key);
        }
        refs.len() / 2
    }
}

/// Whether a reference goes left of plane `p` (`map.bin(x) < plane`, exactly): for a whole
/// `plane` in `1..bins`, `min(trunc(v), bins - 1) < plane` exactly when `!(v >= plane)` (NaN,
/// negative and small `v` go left, as their bin is 0).
#[inline(always)]
fn goes_left(p: &Plane, c: Vec3A) -> bool {
    let v = (c[p.axis] - p.map.min) * p.map.scale;
    // Negated on purpose: NaN goes left, as `BinMap::bin` puts it in bin 0.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let left = !(v >= p.plane as f32);
    left
}

/// The serial in-place partition (Hoare's two-pointer scheme): the `k`-th reference of the
/// front `0..mid` that goes right swaps with the `k`-th reference of the back `mid..`,
/// counted from the end, that goes left (`mid` being the number going left).
fn partition_serial(refs: &mut [PrimRef], p: &Plane) -> (usize, Aabb, Aabb) {
    let mut lc = Aabb::EMPTY;
    let mut rc = Aabb::EMPTY;
    let mut classify = |r: &PrimRef| {
        let c = r.centroid();
        let left = goes_left(p, c);
        if left {
            lc.grow(c);
        } else {
            rc.grow(c);
        }
        left
    };
    let (mut i, mut j) = (0usize, refs.len());
    loop {
        while i < j && classify(&refs[i]) {
            i += 1;
        }
        while i < j && !classify(&refs[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return (i, lc, rc);
        }
        refs.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// [`partition_serial`] without a branch per reference, with the same result (the same swaps,
/// so the same order): the references of the front `0..mid` that go right and those of the
/// back `mid..` that go left (counted from the end) are listed first, then swapped pair by
/// pair, the `k`-th of one list with the `k`-th of the other, as the two-pointer scheme pairs
/// them. Which side a reference goes to is a coin flip at most nodes, which costs the
/// two-pointer scheme a mispredicted branch every second reference. The centroid bounds are
/// unions (exact in any order but for the sign of a zero, which no bin or plane depends on).
/// `wrong` is scratch (grown to `refs.len()` once, never shrunk). `None` when the plane's count
/// of the left side is not the partition's (never, by construction; then the two-pointer
/// scheme runs).
fn partition_branchless(
    refs: &mut [PrimRef],
    p: &Plane,
    wrong: &mut Vec<u32>,
) -> Option<(usize, Aabb, Aabb)> {
    let n = refs.len();
    let mid = p.n_left;
    if mid == 0 || mid >= n {
        return None;
    }
    if wrong.len() < n {
        wrong.resize(n, 0);
    }
    // The front's misplaced positions go to `wrong[..mid]`, the back's to `wrong[mid..]`:
    // each list has room for its whole half.
    let (wf, wb) = wrong[..n].split_at_mut(mid);
    let (mut lmin, mut lmax) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let (mut rmin, mut rmax) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let mut classify = |r: &PrimRef| {
        let c = r.centroid();
        let left = goes_left(p, c);
        let m = BVec3A::splat(left);
        lmin = lmin.min(Vec3A::select(m, c, Vec3A::INFINITY));
        lmax = lmax.max(Vec3A::select(m, c, Vec3A::NEG_INFINITY));
        rmin = rmin.min(Vec3A::select(m, Vec3A::INFINITY, c));
        rmax = rmax.max(Vec3A::select(m, Vec3A::NEG_INFINITY, c));
        left
    };
    let mut nf = 0usize;
    for (i, r) in refs[..mid].iter().enumerate() {
        // Written every time, kept (the count moves on) only when the reference goes right.
        wf[nf] = i as u32;
        nf += usize::from(!classify(r));
    }
    let mut nb = 0usize;
    for (j, r) in refs[mid..].iter().enumerate().rev() {
        // `nb <= n - mid - 1 - j` here, so the slot is in bounds.
        wb[nb] = (mid + j) as u32;
        nb += usize::from(classify(r));
    }
    if nf != nb {
        return None;
    }
    for (&i, &j) in wf[..nf].iter().zip(&wb[..nb]) {
        refs.swap(i as usize, j as usize);
    }
    let lc = Aabb::new(lmin, lmax);
    let rc = Aabb::new(rmin, rmax);
    Some((mid, lc, rc))
}

/// [`partition_serial`] in parallel, with the same result: the misplaced references of the
/// front (going right) and of the back (going left) are found chunk by chunk, then swapped
/// pair by pair in the order the serial scheme pairs them. The centroid bounds are unions
/// (exact in any order but for the sign of a zero, which no bin or plane depends on). `None`
/// when the plane's count of the left side is not the partition's (never, by construction;
/// then the serial partition runs).
fn partition_par(refs: &mut [PrimRef], p: &Plane) -> Option<(usize, Aabb, Aabb)> {
    let mid = p.n_left;
    if mid == 0 || mid >= refs.len() {
        return None;
    }
    // Per chunk: the positions (in the whole slice) of the misplaced references, and the
    // centroid bounds of both sides.
    let scan = |front: bool, base: usize, chunk: &[PrimRef]| {
        let mut lc = Aabb::EMPTY;
        let mut rc = Aabb::EMPTY;
        let mut wrong = Vec::new();
        for (i, r) in chunk.iter().enumerate() {
            let c = r.centroid();
            let left = goes_left(p, c);
            if left {
                lc.grow(c);
            } else {
                rc.grow(c);
            }
            if left != front {
                wrong.push((base + i) as u32);
            }
        }
        (wrong, lc, rc)
    };
    let (front, back) = refs.split_at(mid);
    let (f, b) = rayon::join(
        || {
            front
                .par_chunks(PAR_CHUNK)
                .enumerate()
                .map(|(c, chunk)| scan(true, c * PAR_CHUNK, chunk))
                .collect::<Vec<_>>()
        },
        || {
            back.par_chunks(PAR_CHUNK)
                .enumerate()
                .map(|(c, chunk)| scan(false, mid + c * PAR_CHUNK, chunk))
                .collect::<Vec<_>>()
        },
    );
    let mut lc = Aabb::EMPTY;
    let mut rc = Aabb::EMPTY;
    for (_, l, r) in f.iter().chain(&b) {
        lc.grow_aabb(l);
        rc.grow_aabb(r);
    }
    let wrong_front: Vec<u32> = f.into_iter().flat_map(|(w, _, _)| w).collect();
    let mut wrong_back: Vec<u32> = b.into_iter().flat_map(|(w, _, _)| w).collect();
    if wrong_front.len() != wrong_back.len() {
        return None;
    }
    // The serial scheme meets the back's misplaced references from the end.
    wrong_back.reverse();
    /// The slice's base pointer, shared by the workers that swap disjoint pairs.
    #[derive(Clone, Copy)]
    struct Base(*mut PrimRef);
    // SAFETY: only used to swap pairs of distinct positions, each position in one pair.
    unsafe impl Send for Base {}
    // SAFETY: as above.
    unsafe impl Sync for Base {}
    impl Base {
        /// The pointer (a method, so that closures capture the whole `Base`).
        fn ptr(self) -> *mut PrimRef {
            self.0
        }
    }
    let base = Base(refs.as_mut_ptr());
    wrong_front
        .par_chunks(PAR_CHUNK)
        .zip(wrong_back.par_chunks(PAR_CHUNK))
        .for_each(|(a, b)| {
            let p = base.ptr();
            for (&i, &j) in a.iter().zip(b) {
                // SAFETY: `i < mid <= j < refs.len()`, and every position occurs in one pair
                // only (the lists hold distinct positions of the two halves), so no two
                // workers touch the same reference.
                unsafe { std::ptr::swap(p.add(i as usize), p.add(j as usize)) };
            }
        });
    Some((mid, lc, rc))
}

/// Nodes of at least this many references are partitioned in parallel (with more than one
/// thread).
const PAR_PARTITION_THRESHOLD: usize = 4 * PAR_NODE_THRESHOLD;

impl<'a> Rule for BinnedRule<'a> {
    type Task = BinTask<'a>;
    type Scratch = Scratch;

    fn size(&self, t: &BinTask<'a>) -> usize {
        t.refs.len()
    }

    fn split(&self, t: BinTask<'a>, scratch: &mut Scratch) -> Step<BinTask<'a>> {
        let n = t.refs.len();
        let nb = t.nb;
        let can_leaf = n <= self.cfg.max_leaf_size;
        let plane = if n == 1 || t.depth >= self.cfg.fallback_depth {
            None
        } else {
            self.best_plane(t.refs, &nb.centroids, scratch)
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
        let (mid, lb, rb) = match plane {
            Some(p) => {
                let (mid, lc, rc) = self.partition(refs, &p, &mut scratch.wrong);
                debug_assert_eq!(mid, p.n_left);
                (
                    mid,
                    Bounds {
                        bounds: p.left,
                        centroids: lc,
                    },
                    Bounds {
                        bounds: p.right,
                        centroids: rc,
                    },
                )
            }
            None => {
                let mid = self.median_split(refs, &nb.centroids);
                (mid, bounds_of(&refs[..mid]), bounds_of(&refs[mid..]))
            }
        };
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

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::rng::Pcg32;
    use sahara_geom::{Triangle, Vec3A};

    #[test]
    fn parallel_partition_equals_the_serial_one() {
        let mut rng = Pcg32::new(5, 6);
        let n = 5 * PAR_CHUNK + 123;
        let boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                // Coarse positions: many centroids on the plane's bin boundary.
                let o = Vec3A::new(rng.below(40) as f32, rng.below(7) as f32, 0.0);
                Aabb::new(o, o + Vec3A::splat(0.5 * rng.below(3) as f32))
            })
            .collect();
        let refs: Vec<PrimRef> = boxes
            .iter()
            .enumerate()
            .map(|(i, b)| PrimRef::new(b, i as u32))
            .collect();
        let cb = bounds_of(&refs).centroids;
        for (axis, plane) in [(0, 1), (0, 5), (0, 16), (0, 31), (1, 3), (1, 30)] {
            let map = BinMap::new(cb.min[axis], cb.max[axis], 32).unwrap();
            let p = plane_of(&refs, axis, plane, map);
            let mut a = refs.clone();
            let mut b = refs.clone();
            let sa = partition_serial(&mut a, &p);
            let sb = partition_par(&mut b, &p).expect("the plane's count is right");
            assert_eq!(sa, sb, "axis {axis} plane {plane}");
            assert!(a.iter().zip(&b).all(|(x, y)| x.id() == y.id()));
        }
    }

    /// The plane `plane` of `axis` under `map`, with its count of `refs` going left (the
    /// partitions' inputs; the sides' bounds are not used).
    fn plane_of(refs: &[PrimRef], axis: usize, plane: usize, map: BinMap) -> Plane {
        let mut p = Plane {
            axis,
            plane,
            map,
            n_left: 0,
            left: Aabb::EMPTY,
            right: Aabb::EMPTY,
        };
        p.n_left = refs.iter().filter(|r| goes_left(&p, r.centroid())).count();
        p
    }

    /// The branch-free partition makes the two-pointer scheme's swaps (the same order of the
    /// references) and the same centroid bounds, at every size and plane, with centroids on
    /// bin boundaries, signed zeros and references of one side only.
    #[test]
    fn branchless_partition_equals_the_serial_one() {
        let mut rng = Pcg32::new(17, 3);
        let mut wrong = Vec::new();
        let mut checked = 0;
        for case in 0..600 {
            let n = 2 + rng.below(if case % 10 == 0 { 3000 } else { 70 }) as usize;
            let coord = |rng: &mut Pcg32| match rng.below(6) {
                0 => -0.0,
                1 => 0.0,
                _ => rng.below(9) as f32 * 0.5 - 2.0,
            };
            let refs: Vec<PrimRef> = (0..n)
                .map(|i| {
                    let o = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng));
                    let e = Vec3A::splat(0.25 * rng.below(3) as f32);
                    PrimRef::new(&Aabb::new(o, o + e), i as u32)
                })
                .collect();
            let cb = bounds_of(&refs).centroids;
            let axis = rng.below(3) as usize;
            let k = [2, 8, 32][case % 3];
            let Some(map) = BinMap::new(cb.min[axis], cb.max[axis], k) else {
                continue;
            };
            let plane = 1 + rng.below(k as u32 - 1) as usize;
            let p = plane_of(&refs, axis, plane, map);
            let mut a = refs.clone();
            let mut b = refs.clone();
            let sa = partition_serial(&mut a, &p);
            match partition_branchless(&mut b, &p, &mut wrong) {
                Some(sb) => {
                    assert_eq!(sa, sb, "case {case}");
                    checked += 1;
                }
                // Only a plane with an empty side is refused; the serial scheme keeps the
                // order then.
                None => {
                    assert!(p.n_left == 0 || p.n_left == n, "case {case}");
                    b = a.clone();
                }
            }
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.id() == y.id()),
                "case {case}: other order"
            );
        }
        assert!(checked > 400, "only {checked} partitions compared");
    }

    #[test]
    fn nodes_of_two_equal_full_binning() {
        let mut rng = Pcg32::new(8, 1);
        // Coarse positions and sizes: shared bins, equal centroids on some axes, signed zeros,
        // and boxes of very different sizes.
        let coord = |rng: &mut Pcg32| [0.0, -0.0, 1.0, 2.5, 1e-30, 1e30][rng.below(6) as usize];
        let tris: Vec<Triangle> = (0..64)
            .map(|_| {
                let o = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng));
                let s = [0.0, 0.5, 3.0][rng.below(3) as usize];
                Triangle::new(o, o + Vec3A::X * s, o + Vec3A::Y * (s + 1.0))
            })
            .collect();
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        let mut found = 0;
        for bins in [2, 8, 32, 128] {
            let cfg = BinnedConfig::with_bins(bins);
            let rule = BinnedRule::new(&input, &cfg, FillBackend::Simd);
            let mut s = Scratch::default();
            for _ in 0..2000 {
                let prims = rule.refs_of(&[rng.below(64), rng.below(64)]);
                let maps = bins::maps(&bounds_of(&prims).centroids, bins);
                if maps.iter().all(Option::is_none) {
                    continue;
                }
                let fast = rule.best_plane_of_two(&prims, &maps);
                found += usize::from(fast.as_ref().is_some_and(|p| p.axis > 0));
                same_plane(fast, rule.best_plane_binned(&prims, &maps, &mut s));
            }
        }
        // Planes on the second or third axis were found too (the first axis ties them away
        // when it separates).
        assert!(found > 500, "{found}");
    }

    #[test]
    fn small_node_path_equals_full_binning() {
        let mut rng = Pcg32::new(3, 4);
        let tris: Vec<Triangle> = (0..64)
            .map(|i| {
                // Coarse positions so that several centroids share bins and planes tie.
                let z = [0.0, -0.0, 1.0][i % 3];
                let o = Vec3A::new(rng.below(6) as f32, rng.below(3) as f32, z);
                let s = 0.25 * (1 + rng.below(3)) as f32;
                Triangle::new(o, o + Vec3A::X * s, o + Vec3A::Y * s)
            })
            .collect();
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        for bins in [16, 32, 64] {
            let cfg = BinnedConfig::with_bins(bins);
            let rule = BinnedRule::new(&input, &cfg, FillBackend::Simd);
            let mut s = Scratch::default();
            for trial in 0..200 {
                let n = 2 + trial % (bins / 2 - 1);
                let prims: Vec<u32> = (0..n).map(|_| rng.below(64)).collect();
                let prims = rule.refs_of(&prims);
                let cb = bounds_of(&prims).centroids;
                let maps = bins::maps(&cb, bins);
                let a = rule.best_plane_sparse(&prims, &maps, &mut s);
                let b = rule.best_plane_binned(&prims, &maps, &mut s);
                if n == 2 {
                    same_plane(rule.best_plane_of_two(&prims, &maps), b);
                }
                same_plane(a, b);
            }
        }
    }

    /// Asserts that two searches found the same plane, bit for bit.
    fn same_plane(a: Option<Plane>, b: Option<Plane>) {
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                assert_eq!((a.axis, a.plane, a.n_left), (b.axis, b.plane, b.n_left));
                // Bit for bit (signed zeros included), not only `==`.
                let bits = |b: &Aabb| {
                    (
                        b.min.to_array().map(f32::to_bits),
                        b.max.to_array().map(f32::to_bits),
                    )
                };
                assert_eq!(bits(&a.left), bits(&b.left));
                assert_eq!(bits(&a.right), bits(&b.right));
            }
            _ => panic!("one path found a plane, the other did not"),
        }
    }
}
