//! SBVH: SAH construction with spatial splits (Stich, Friedrich and Dietrich 2009, "Spatial
//! splits in bounding volume hierarchies").
//!
//! The builder works on *references*: a triangle index with a box that bounds the part of the
//! triangle the reference stands for (at first the triangle's own box). At every node it finds
//!
//! * the best **object split** by Eq. 2 over the reference centroids: a full sweep over the
//!   references sorted per axis (the original algorithm; [`ObjectSplitMethod::Binned`] bins
//!   the centroids instead);
//! * when the two sides of that object split overlap by more than `alpha` times the area of
//!   the root, the best **spatial split**: per axis, equal-width bins over the node's box; each
//!   reference is clipped against the planes it straddles (the real triangle is clipped, and
//!   the pieces intersected with the reference's box) and counted as entering its first bin and
//!   leaving its last one; a sweep over the bins gives Eq. 2 with the duplicated references;
//!
//! and applies the cheapest of leaf, object split and spatial split. When a spatial split is
//! applied, every straddling reference is cut exactly at the plane (its pieces' boxes are the
//! bounds of the triangle clipped to each half of its box) unless *reference unsplitting*
//! finds it cheaper to send the whole reference to one side.
//!
//! Duplication is bounded by a budget of extra references (relative to the number of
//! triangles), shared out between the two children of every split in proportion to their
//! reference counts, so the tree does not depend on the order in which parallel subtrees are
//! built. Node bounds are the union of the node's reference boxes, so every node contains its
//! children exactly, and every leaf box touches each triangle it references.
//!
//! ```
//! use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! // Long thin diagonal triangles: object splits cannot separate them, spatial splits can.
//! let tris: Vec<Triangle> = (0..64)
//!     .map(|i| {
//!         let o = Vec3A::new(0.0, i as f32 * 0.1, 0.0);
//!         Triangle::new(o, o + Vec3A::new(50.0, 50.0, 0.0), o + Vec3A::new(50.0, 50.05, 0.1))
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = SbvhBuilder::new(SbvhConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! assert!(bvh.spatial_splits);
//! assert!(bvh.prim_indices.len() > tris.len()); // some triangles were split
//! ```

use crate::common::{
    float_key, half_area, imbalance, offer, share_budget, BinMap, Fragment, PAR_CHUNK,
    PAR_NODE_THRESHOLD, PAR_SPLIT_THRESHOLD,
};
use crate::registry::Entry;
use crate::{BuildError, BuildInput, Builder, Bvh};
use rayon::prelude::*;
use sahara_geom::clip::clipped_bounds;
use sahara_geom::{Aabb, Axis, Triangle, Vec3A};
use sahara_metrics::CostModel;

/// How SBVH finds object splits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ObjectSplitMethod {
    /// Full sweep: at every node the references are sorted by centroid on each axis and all
    /// `n - 1` positions are rated (Stich et al.'s original). `O(n log n)` per node.
    Sweep,
    /// Equal-width bins over the reference centroids (as in [`crate::binned`]); falls back to
    /// the sweep where no plane separates the centroids. `O(n)` per node.
    Binned {
        /// Bins per axis (at least 2).
        bins: usize,
    },
}

/// Configuration of the SBVH builder.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SbvhConfig {
    /// Equal-width bins per axis for the spatial split search. Default 128. Values below 2
    /// disable spatial splits (the builder then is a plain sweep SAH builder).
    pub spatial_bins: usize,
    /// Spatial splits are searched only where the two sides of the best object split overlap
    /// by more than `alpha` times the surface area of the root. Default `1e-5`.
    pub alpha: f32,
    /// No spatial split is searched at this depth or deeper. Default 48.
    pub max_spatial_depth: usize,
    /// Extra references allowed, relative to the number of triangles: `1.0` allows up to
    /// twice as many references as triangles. Default `1.0`.
    pub duplication_budget: f32,
    /// Largest leaf (at least 1): nodes with more references are always split. Default 8.
    pub max_leaf_size: usize,
    /// How object splits are found. Default [`ObjectSplitMethod::Sweep`].
    pub object_split: ObjectSplitMethod,
    /// Reference unsplitting when a spatial split is applied. Default `true`.
    pub unsplitting: bool,
    /// Nodes at this depth or deeper are split at the object median only (when they must be
    /// split), bounding the depth on adversarial input. Default 96.
    pub fallback_depth: usize,
}

impl Default for SbvhConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SbvhConfig {
    /// Stich et al.'s parameters: 128 spatial bins, `alpha = 1e-5`, full sweep object splits,
    /// spatial splits down to depth 48, up to 2× references, leaves of at most 8.
    pub const DEFAULT: SbvhConfig = SbvhConfig {
        spatial_bins: 128,
        alpha: 1e-5,
        max_spatial_depth: 48,
        duplication_budget: 1.0,
        max_leaf_size: 8,
        object_split: ObjectSplitMethod::Sweep,
        unsplitting: true,
        fallback_depth: 96,
    };
    /// A faster preset: object splits by 32 centroid bins, 32 spatial bins.
    pub const FAST: SbvhConfig = SbvhConfig {
        spatial_bins: 32,
        object_split: ObjectSplitMethod::Binned { bins: 32 },
        ..Self::DEFAULT
    };

    /// Checks the ranges of the fields.
    pub fn check(&self) -> Result<(), BuildError> {
        let bad = |m: &str| Err(BuildError::InvalidConfig(format!("sbvh: {m}")));
        if self.max_leaf_size < 1 {
            return bad("max_leaf_size must be at least 1");
        }
        if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            return bad("alpha must be finite and non-negative");
        }
        if !(self.duplication_budget.is_finite() && self.duplication_budget >= 0.0) {
            return bad("duplication_budget must be finite and non-negative");
        }
        if let ObjectSplitMethod::Binned { bins } = self.object_split {
            if bins < 2 {
                return bad("object split bins must be at least 2");
            }
        }
        Ok(())
    }

    /// The number of extra references allowed for `n` triangles.
    pub fn budget_for(&self, n: usize) -> usize {
        let b = self.duplication_budget as f64 * n as f64;
        if b >= usize::MAX as f64 {
            usize::MAX
        } else {
            b as usize
        }
    }
}

/// The SBVH builder. Parallel on rayon; the tree does not depend on the number of threads.
#[derive(Clone, Debug)]
pub struct SbvhBuilder {
    /// The configuration.
    pub config: SbvhConfig,
    name: &'static str,
}

impl SbvhBuilder {
    /// A builder with `config`, named `"sbvh"`.
    pub fn new(config: SbvhConfig) -> Self {
        Self::named("sbvh", config)
    }

    /// A builder with `config` and a registry name of your choice.
    pub fn named(name: &'static str, config: SbvhConfig) -> Self {
        Self { config, name }
    }
}

impl Default for SbvhBuilder {
    fn default() -> Self {
        Self::new(SbvhConfig::default())
    }
}

impl Builder for SbvhBuilder {
    fn name(&self) -> &str {
        self.name
    }

    fn describe(&self) -> String {
        describe_config(&self.config)
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.check()?;
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        let refs = initial_refs(input, None);
        let ctx = Ctx::new(input, self.config, &refs);
        let mut out = Fragment::default();
        build_rec(
            &ctx,
            refs,
            0,
            self.config.budget_for(input.len()),
            Some(&mut out),
        );
        Ok(out.into_bvh(true))
    }
}

/// A one-line description of an SBVH configuration.
pub(crate) fn describe_config(c: &SbvhConfig) -> String {
    let object = match c.object_split {
        ObjectSplitMethod::Sweep => "full-sweep object splits".to_string(),
        ObjectSplitMethod::Binned { bins } => format!("{bins}-bin object splits"),
    };
    format!(
        "SBVH (Stich et al. 2009): {object}, {} spatial bins, alpha {:e}, spatial depth < {}, \
         budget {}x extra refs, unsplitting {}, leaves <= {}",
        c.spatial_bins,
        c.alpha,
        c.max_spatial_depth,
        c.duplication_budget,
        if c.unsplitting { "on" } else { "off" },
        c.max_leaf_size
    )
}

/// The SAH cost `c(T)` (Eq. 1, relative to the area of the subset's bounds) of the tree that
/// [`SbvhBuilder`] with `config` would build over the triangles `prims`, computed bottom-up
/// without allocating tree nodes (references are still clipped and duplicated while the
/// cost is computed, then dropped). The duplication budget is relative to `prims.len()` and
/// the `alpha` threshold to the area of the subset's bounds. An empty subset costs `0`.
///
/// # Panics
///
/// If a primitive index is out of range or the configuration is invalid.
pub fn sbvh_cost_only(input: &BuildInput, prims: &[u32], config: &SbvhConfig) -> f64 {
    config.check().expect("invalid SBVH configuration");
    if prims.is_empty() {
        return 0.0;
    }
    let refs = initial_refs(input, Some(prims));
    let ctx = Ctx::new(input, *config, &refs);
    build_rec(&ctx, refs, 0, config.budget_for(prims.len()), None).0
}

/// Registry entries of this module: `sbvh`.
pub fn registry_entries() -> Vec<Entry> {
    vec![Entry {
        name: "sbvh",
        summary: "SBVH (Stich et al. 2009): full-sweep object splits + 128-bin spatial splits",
        spatial: true,
        small_inputs_only: false,
        max_practical_triangles: None,
        make: || Box::new(SbvhBuilder::new(SbvhConfig::DEFAULT)),
    }]
}

// ---------------------------------------------------------------------------------------------
// The machinery, shared with the spatial temporary-subtree builder (`tsah_spatial`).

/// Nodes with at least this many references search their three axes in parallel.
const PAR_AXES_THRESHOLD: usize = 8 * 1024;

/// A triangle reference: the triangle and the box of the part of it this reference covers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ref {
    pub bounds: Aabb,
    pub prim: u32,
}

/// The references of all triangles (or of a subset) with their full boxes.
pub(crate) fn initial_refs(input: &BuildInput, prims: Option<&[u32]>) -> Vec<Ref> {
    let b = input.bounds();
    match prims {
        Some(p) => p
            .iter()
            .map(|&prim| Ref {
                bounds: b[prim as usize],
                prim,
            })
            .collect(),
        None => b
            .iter()
            .enumerate()
            .map(|(i, &bounds)| Ref {
                bounds,
                prim: i as u32,
            })
            .collect(),
    }
}

/// Everything a node decision needs besides the node's references.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub tris: &'a [Triangle],
    pub cost: CostModel,
    pub cfg: SbvhConfig,
    /// Half area of the root (of the whole build, also for temporary subtrees).
    pub root_area: f64,
}

impl<'a> Ctx<'a> {
    pub fn new(input: &'a BuildInput, cfg: SbvhConfig, root_refs: &[Ref]) -> Self {
        Self {
            tris: input.triangles(),
            cost: input.cost,
            cfg,
            root_area: half_area(&refs_bounds(root_refs)),
        }
    }

    /// The same context with another configuration.
    pub fn with_config(&self, cfg: SbvhConfig) -> Self {
        Self { cfg, ..*self }
    }
}

/// Union of the reference boxes.
pub(crate) fn refs_bounds(refs: &[Ref]) -> Aabb {
    let fold = |refs: &[Ref]| refs.iter().fold(Aabb::EMPTY, |b, r| b.union(&r.bounds));
    if refs.len() >= PAR_NODE_THRESHOLD {
        refs.par_chunks(PAR_CHUNK)
            .map(fold)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    } else {
        fold(refs)
    }
}

#[inline]
fn centroid(r: &Ref, axis: Axis) -> f32 {
    (r.bounds.min[axis] + r.bounds.max[axis]) * 0.5
}

/// How an object split candidate partitions the references.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ObjectPartition {
    /// The first `count` references of the order sorted along `axis` go left.
    Sorted { axis: Axis, count: usize },
    /// References whose centroid falls in a bin below `plane` go left.
    Binned {
        axis: Axis,
        plane: usize,
        map: BinMap,
    },
}

/// A rated object split.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ObjectCand {
    pub part: ObjectPartition,
    /// `A_l n_l + A_r n_r`: orders the candidates of one node as Eq. 2 does.
    pub score: f64,
    /// Eq. 2.
    pub cost: f64,
    pub left: Aabb,
    pub right: Aabb,
    pub n_left: usize,
    pub n_right: usize,
}

impl ObjectCand {
    fn key(&self) -> (usize, usize) {
        match self.part {
            ObjectPartition::Sorted { axis, count } => (axis, count),
            ObjectPartition::Binned { axis, plane, .. } => (axis, plane),
        }
    }

    /// The candidate order: score (as Eq. 2), then balance, then axis, then position.
    pub fn better(&self, other: &ObjectCand) -> bool {
        self.score
            .total_cmp(&other.score)
            .then(imbalance(self.n_left, self.n_right).cmp(&imbalance(other.n_left, other.n_right)))
            .then(self.key().cmp(&other.key()))
            .is_lt()
    }

    /// Surface area of the overlap of the two sides (zero when they are disjoint).
    pub fn overlap(&self) -> f64 {
        let i = self.left.intersection(&self.right);
        if i.is_empty() {
            0.0
        } else {
            half_area(&i)
        }
    }
}

/// The result of an object split search: the best candidates (best first) and, for the
/// sweep, the sorted orders they refer to.
pub(crate) struct ObjectSearch {
    pub orders: [Vec<u32>; 3],
    pub cands: Vec<ObjectCand>,
}

/// The `k` best object splits of a node with at least two references (never empty).
pub(crate) fn object_search(ctx: &Ctx, refs: &[Ref], area: f64, k: usize) -> ObjectSearch {
    debug_assert!(refs.len() >= 2 && k >= 1);
    if let ObjectSplitMethod::Binned { bins } = ctx.cfg.object_split {
        let cands = binned_object_search(ctx, refs, area, k, bins);
        if !cands.is_empty() {
            return ObjectSearch {
                orders: Default::default(),
                cands,
            };
        }
    }
    let per_axis: Vec<(Vec<u32>, Vec<ObjectCand>)> = if refs.len() >= PAR_AXES_THRESHOLD {
        (0..3)
            .into_par_iter()
            .map(|axis| sweep_axis(ctx, refs, axis, area, k))
            .collect()
    } else {
        (0..3)
            .map(|axis| sweep_axis(ctx, refs, axis, area, k))
            .collect()
    };
    let mut cands = Vec::with_capacity(k);
    let mut orders: [Vec<u32>; 3] = Default::default();
    for (axis, (order, c)) in per_axis.into_iter().enumerate() {
        for cand in c {
            offer(&mut cands, k, cand, ObjectCand::better);
        }
        orders[axis] = order;
    }
    ObjectSearch { orders, cands }
}

fn sweep_axis(
    ctx: &Ctx,
    refs: &[Ref],
    axis: Axis,
    area: f64,
    k: usize,
) -> (Vec<u32>, Vec<ObjectCand>) {
    let n = refs.len();
    // Ties in the centroid go to the earlier reference: the key is unique and total.
    let mut keys: Vec<u64> = refs
        .iter()
        .enumerate()
        .map(|(i, r)| ((float_key(centroid(r, axis)) as u64) << 32) | i as u64)
        .collect();
    keys.sort_unstable();
    let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
    drop(keys);
    let mut suffix = vec![Aabb::EMPTY; n];
    let mut acc = Aabb::EMPTY;
    for i in (1..n).rev() {
        acc.grow_aabb(&refs[order[i] as usize].bounds);
        suffix[i] = acc;
    }
    let mut cands: Vec<ObjectCand> = Vec::with_capacity(k);
    let mut left = Aabb::EMPTY;
    for i in 1..n {
        left.grow_aabb(&refs[order[i - 1] as usize].bounds);
        let (al, ar) = (half_area(&left), half_area(&suffix[i]));
        let score = al * i as f64 + ar * (n - i) as f64;
        if cands.len() == k && score > cands[k - 1].score {
            continue;
        }
        let cand = ObjectCand {
            part: ObjectPartition::Sorted { axis, count: i },
            score,
            cost: ctx.cost.split_cost(area, al, i, ar, n - i),
            left,
            right: suffix[i],
            n_left: i,
            n_right: n - i,
        };
        offer(&mut cands, k, cand, ObjectCand::better);
    }
    (order, cands)
}

#[derive(Clone, Copy)]
struct CountBin {
    bounds: Aabb,
    count: u32,
}

fn binned_object_search(
    ctx: &Ctx,
    refs: &[Ref],
    area: f64,
    k: usize,
    bins: usize,
) -> Vec<ObjectCand> {
    let mut cb = Aabb::EMPTY;
    for r in refs {
        cb.grow(r.bounds.centroid());
    }
    let mut cands: Vec<ObjectCand> = Vec::with_capacity(k);
    let empty = CountBin {
        bounds: Aabb::EMPTY,
        count: 0,
    };
    let mut b = vec![empty; bins];
    let mut right = vec![(Aabb::EMPTY, 0u32); bins];
    for axis in 0..3 {
        let Some(map) = BinMap::new(cb.min[axis], cb.max[axis], bins) else {
            continue;
        };
        b.fill(empty);
        for r in refs {
            let bin = &mut b[map.bin(centroid(r, axis))];
            bin.count += 1;
            bin.bounds.grow_aabb(&r.bounds);
        }
        let mut acc = (Aabb::EMPTY, 0u32);
        for i in (1..bins).rev() {
            acc.0.grow_aabb(&b[i].bounds);
            acc.1 += b[i].count;
            right[i] = acc;
        }
        let mut lb = Aabb::EMPTY;
        let mut lc = 0u32;
        for i in 1..bins {
            lb.grow_aabb(&b[i - 1].bounds);
            lc += b[i - 1].count;
            let (rb, rc) = right[i];
            if lc == 0 || rc == 0 {
                continue;
            }
            let (al, ar) = (half_area(&lb), half_area(&rb));
            let (nl, nr) = (lc as usize, rc as usize);
            let score = al * nl as f64 + ar * nr as f64;
            if cands.len() == k && score > cands[k - 1].score {
                continue;
            }
            let cand = ObjectCand {
                part: ObjectPartition::Binned {
                    axis,
                    plane: i,
                    map,
                },
                score,
                cost: ctx.cost.split_cost(area, al, nl, ar, nr),
                left: lb,
                right: rb,
                n_left: lc as usize,
                n_right: rc as usize,
            };
            offer(&mut cands, k, cand, ObjectCand::better);
        }
    }
    cands
}

/// The two sides of an object split, each in a deterministic order.
pub(crate) fn apply_object(
    refs: &[Ref],
    search: &ObjectSearch,
    cand: &ObjectCand,
) -> (Vec<Ref>, Vec<Ref>) {
    match cand.part {
        ObjectPartition::Sorted { axis, count } => {
            let order = &search.orders[axis];
            let left = order[..count].iter().map(|&i| refs[i as usize]).collect();
            let right = order[count..].iter().map(|&i| refs[i as usize]).collect();
            (left, right)
        }
        ObjectPartition::Binned { axis, plane, map } => {
            let mut left = Vec::with_capacity(cand.n_left);
            let mut right = Vec::with_capacity(cand.n_right);
            for r in refs {
                if map.bin(centroid(r, axis)) < plane {
                    left.push(*r);
                } else {
                    right.push(*r);
                }
            }
            (left, right)
        }
    }
}

/// The object median split on the largest axis of the centroid bounds (by centroid, then
/// position), used below [`SbvhConfig::fallback_depth`].
pub(crate) fn median_split(refs: &[Ref]) -> (Vec<Ref>, Vec<Ref>) {
    let mut cb = Aabb::EMPTY;
    for r in refs {
        cb.grow(r.bounds.centroid());
    }
    let axis = cb.largest_axis();
    let mut keys: Vec<u64> = refs
        .iter()
        .enumerate()
        .map(|(i, r)| ((float_key(centroid(r, axis)) as u64) << 32) | i as u64)
        .collect();
    keys.sort_unstable();
    let mid = refs.len() / 2;
    let left = keys[..mid]
        .iter()
        .map(|&k| refs[k as u32 as usize])
        .collect();
    let right = keys[mid..]
        .iter()
        .map(|&k| refs[k as u32 as usize])
        .collect();
    (left, right)
}

/// A rated spatial split.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SpatialCand {
    pub axis: Axis,
    /// References entirely in bins `< plane` go left, entirely in bins `>= plane` go right.
    pub plane: usize,
    pub map: BinMap,
    /// The plane's coordinate.
    pub pos: f32,
    /// `A_l n_l + A_r n_r` (with duplicated references).
    pub score: f64,
    /// Eq. 2 with duplicated references.
    pub cost: f64,
    pub n_left: usize,
    pub n_right: usize,
}

impl SpatialCand {
    /// The candidate order: score (as Eq. 2), then axis, then plane.
    pub fn better(&self, other: &SpatialCand) -> bool {
        self.score
            .total_cmp(&other.score)
            .then((self.axis, self.plane).cmp(&(other.axis, other.plane)))
            .is_lt()
    }
}

/// True when the SBVH rule searches spatial splits at this node, given its best object split.
pub(crate) fn spatial_allowed(
    ctx: &Ctx,
    best_object: &ObjectCand,
    depth: usize,
    budget: usize,
) -> bool {
    ctx.cfg.spatial_bins >= 2
        && depth < ctx.cfg.max_spatial_depth
        && budget > 0
        && best_object.overlap() > ctx.cfg.alpha as f64 * ctx.root_area
}

/// The `k` best spatial splits of a node whose duplication fits in `budget`.
pub(crate) fn spatial_search(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    k: usize,
    budget: usize,
) -> Vec<SpatialCand> {
    let per_axis: Vec<Vec<SpatialCand>> = if refs.len() >= PAR_AXES_THRESHOLD {
        (0..3)
            .into_par_iter()
            .map(|axis| spatial_axis(ctx, refs, bounds, axis, area, k, budget))
            .collect()
    } else {
        (0..3)
            .map(|axis| spatial_axis(ctx, refs, bounds, axis, area, k, budget))
            .collect()
    };
    let mut cands = Vec::with_capacity(k);
    for c in per_axis.into_iter().flatten() {
        offer(&mut cands, k, c, SpatialCand::better);
    }
    cands
}

#[derive(Clone, Copy)]
struct SpatialBin {
    bounds: Aabb,
    enter: u32,
    exit: u32,
}

fn spatial_axis(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    axis: Axis,
    area: f64,
    k: usize,
    budget: usize,
) -> Vec<SpatialCand> {
    let nb = ctx.cfg.spatial_bins;
    let Some(map) = BinMap::new(bounds.min[axis], bounds.max[axis], nb) else {
        return Vec::new();
    };
    let mut bins = vec![
        SpatialBin {
            bounds: Aabb::EMPTY,
            enter: 0,
            exit: 0,
        };
        nb
    ];
    for r in refs {
        let first = map.bin(r.bounds.min[axis]);
        let last = map.bin(r.bounds.max[axis]);
        bins[first].enter += 1;
        bins[last].exit += 1;
        if first == last {
            bins[first].bounds.grow_aabb(&r.bounds);
            continue;
        }
        let tri = &ctx.tris[r.prim as usize];
        let pieces = SlabClipper::new(tri, axis, &r.bounds);
        pieces.bin(&map, first, last, |b, piece| {
            bins[b].bounds.grow_aabb(piece)
        });
    }
    let n = refs.len();
    let mut right = vec![(0.0f64, 0u32); nb];
    let mut acc = Aabb::EMPTY;
    let mut rc = 0u32;
    for i in (1..nb).rev() {
        acc.grow_aabb(&bins[i].bounds);
        rc += bins[i].exit;
        right[i] = (half_area(&acc), rc);
    }
    let mut cands: Vec<SpatialCand> = Vec::with_capacity(k);
    let mut lb = Aabb::EMPTY;
    let mut lc = 0u32;
    for i in 1..nb {
        lb.grow_aabb(&bins[i - 1].bounds);
        lc += bins[i - 1].enter;
        let (ra, rc) = right[i];
        let (nl, nr) = (lc as usize, rc as usize);
        if nl == 0 || nr == 0 || (nl + nr).saturating_sub(n) > budget {
            continue;
        }
        let la = half_area(&lb);
        let score = la * nl as f64 + ra * nr as f64;
        if cands.len() == k && score > cands[k - 1].score {
            continue;
        }
        let cand = SpatialCand {
            axis,
            plane: i,
            map,
            pos: map.plane(i),
            score,
            cost: ctx.cost.split_cost(area, la, nl, ra, nr),
            n_left: nl,
            n_right: nr,
        };
        offer(&mut cands, k, cand, SpatialCand::better);
    }
    cands
}

/// Clips a triangle reference into the consecutive slabs of a spatial binning.
///
/// Equivalent to cutting the reference with [`sahara_geom::clip::split_triangle_bounds`] at
/// every plane it straddles, from left to right, but each plane's crossing points (where the
/// triangle's edges pierce it) are computed once and shared by the two bins that plane
/// bounds, in `f32`. The box of a bin's piece is the bounds of the triangle's vertices inside
/// the slab and of the crossing points on its two planes, intersected with the reference's box
/// and the slab: the bounds of the real triangle clipped to the slab, up to rounding. Binning
/// only estimates costs; the split that is finally applied clips exactly ([`clip_halves`]).
struct SlabClipper<'a> {
    axis: Axis,
    bounds: &'a Aabb,
    /// The vertices sorted by their coordinate on `axis`.
    v: [Vec3A; 3],
    /// Per unit of `axis`, the direction of the edges v0→v2, v0→v1 and v1→v2.
    dir: [Vec3A; 3],
}

impl<'a> SlabClipper<'a> {
    fn new(tri: &Triangle, axis: Axis, bounds: &'a Aabb) -> Self {
        let mut v = tri.v;
        if v[0][axis] > v[1][axis] {
            v.swap(0, 1);
        }
        if v[1][axis] > v[2][axis] {
            v.swap(1, 2);
        }
        if v[0][axis] > v[1][axis] {
            v.swap(0, 1);
        }
        let d = |p: Vec3A, q: Vec3A| {
            let da = q[axis] - p[axis];
            if da > 0.0 {
                (q - p) / da
            } else {
                Vec3A::ZERO
            }
        };
        let dir = [d(v[0], v[2]), d(v[0], v[1]), d(v[1], v[2])];
        Self {
            axis,
            bounds,
            v,
            dir,
        }
    }

    /// Bounds of the points where the triangle's edges cross the plane `x[axis] = pos`.
    #[inline]
    fn crossing(&self, pos: f32) -> Aabb {
        let a = self.axis;
        let v = &self.v;
        if !(pos > v[0][a] && pos < v[2][a]) {
            return Aabb::EMPTY;
        }
        // The points' coordinate on `axis` is `pos` up to rounding; the caller clamps it.
        let long = v[0] + self.dir[0] * (pos - v[0][a]);
        let short = if pos < v[1][a] {
            v[0] + self.dir[1] * (pos - v[0][a])
        } else {
            v[1] + self.dir[2] * (pos - v[1][a])
        };
        Aabb::new(long.min(short), long.max(short))
    }

    /// Calls `f(bin, piece_bounds)` for every bin `first..=last` the reference spans.
    #[inline]
    fn bin(&self, map: &BinMap, first: usize, last: usize, mut f: impl FnMut(usize, &Aabb)) {
        let a = self.axis;
        // Lane masks instead of writes to one lane: those go through memory and stall.
        let mask = Vec3A::new(0.0, 1.0, 2.0).cmpeq(Vec3A::splat(a as f32));
        let mut lower_pos = f32::NEG_INFINITY;
        let mut lower = Aabb::EMPTY;
        for b in first..=last {
            let (upper_pos, upper) = if b == last {
                (f32::INFINITY, Aabb::EMPTY)
            } else {
                let p = map.plane(b + 1);
                (p, self.crossing(p))
            };
            let mut piece = lower.union(&upper);
            for p in &self.v {
                if p[a] >= lower_pos && p[a] <= upper_pos {
                    piece.grow(*p);
                }
            }
            let slab = Aabb::new(
                Vec3A::select(mask, Vec3A::splat(lower_pos), self.bounds.min),
                Vec3A::select(mask, Vec3A::splat(upper_pos), self.bounds.max),
            );
            let piece = piece.intersection(self.bounds).intersection(&slab);
            if !piece.is_empty() {
                f(b, &piece);
            }
            lower_pos = upper_pos;
            lower = upper;
        }
    }
}

/// Bounds of the parts of `tri` inside the two halves of `cur` cut at `pos` on `axis`.
///
/// The triangle is clipped to each half box, so a non-empty half touches the triangle. The
/// clipped polygon's vertices are rounded to `f32`, which may move them off the triangle by
/// half a unit in the last place: on a triangle that is almost flat along an axis this is
/// enough for the rounded box to miss the real triangle. Each piece's box is therefore grown
/// by about two units in the last place and then intersected with its half box again, so that
/// it stays inside the reference's box and on its side of the plane.
fn clip_halves(tri: &Triangle, axis: Axis, pos: f32, cur: &Aabb) -> (Aabb, Aabb) {
    let mut lbox = *cur;
    lbox.max[axis] = lbox.max[axis].min(pos);
    let mut rbox = *cur;
    rbox.min[axis] = rbox.min[axis].max(pos);
    let piece = |half: &Aabb| {
        let b = clipped_bounds(tri, half);
        if b.is_empty() {
            return b;
        }
        let slack = |v: Vec3A| v.abs() * (2.0 * f32::EPSILON) + Vec3A::splat(f32::MIN_POSITIVE);
        Aabb::new(b.min - slack(b.min), b.max + slack(b.max)).intersection(half)
    };
    (piece(&lbox), piece(&rbox))
}

/// The two sides of a spatial split (with reference unsplitting if configured), or `None`
/// when one side would be empty. No triangle is lost: a reference is dropped from a side only
/// when its part there is empty, and then it goes whole to the other side.
pub(crate) fn apply_spatial(
    ctx: &Ctx,
    refs: &[Ref],
    cand: &SpatialCand,
) -> Option<(Vec<Ref>, Vec<Ref>)> {
    let (axis, pos, map) = (cand.axis, cand.pos, cand.map);
    let mut left = Vec::with_capacity(cand.n_left);
    let mut right = Vec::with_capacity(cand.n_right);
    let mut lb = Aabb::EMPTY;
    let mut rb = Aabb::EMPTY;
    let mut straddling = Vec::new();
    for r in refs {
        let first = map.bin(r.bounds.min[axis]);
        let last = map.bin(r.bounds.max[axis]);
        if last < cand.plane {
            left.push(*r);
            lb.grow_aabb(&r.bounds);
        } else if first >= cand.plane {
            right.push(*r);
            rb.grow_aabb(&r.bounds);
        } else {
            straddling.push(*r);
        }
    }
    for s in straddling {
        let tri = &ctx.tris[s.prim as usize];
        let (pl, pr) = clip_halves(tri, axis, pos, &s.bounds);
        let piece = |bounds| Ref {
            bounds,
            prim: s.prim,
        };
        let side = match (pl.is_empty(), pr.is_empty()) {
            // Rounding left nothing on either side: keep the reference whole.
            (true, true) => {
                if s.bounds.centroid()[axis] < pos {
                    Side::WholeLeft
                } else {
                    Side::WholeRight
                }
            }
            (false, true) => {
                left.push(piece(pl));
                lb.grow_aabb(&pl);
                continue;
            }
            (true, false) => {
                right.push(piece(pr));
                rb.grow_aabb(&pr);
                continue;
            }
            (false, false) if ctx.cfg.unsplitting => {
                let (nl, nr) = (left.len() as f64, right.len() as f64);
                let c_split =
                    half_area(&lb.union(&pl)) * (nl + 1.0) + half_area(&rb.union(&pr)) * (nr + 1.0);
                let c_left = half_area(&lb.union(&s.bounds)) * (nl + 1.0) + half_area(&rb) * nr;
                let c_right = half_area(&lb) * nl + half_area(&rb.union(&s.bounds)) * (nr + 1.0);
                if c_left < c_split && c_left <= c_right {
                    Side::WholeLeft
                } else if c_right < c_split {
                    Side::WholeRight
                } else {
                    Side::Split
                }
            }
            (false, false) => Side::Split,
        };
        match side {
            Side::WholeLeft => {
                left.push(s);
                lb.grow_aabb(&s.bounds);
            }
            Side::WholeRight => {
                right.push(s);
                rb.grow_aabb(&s.bounds);
            }
            Side::Split => {
                left.push(piece(pl));
                lb.grow_aabb(&pl);
                right.push(piece(pr));
                rb.grow_aabb(&pr);
            }
        }
    }
    if left.is_empty() || right.is_empty() {
        None
    } else {
        Some((left, right))
    }
}

enum Side {
    WholeLeft,
    WholeRight,
    Split,
}

/// What the SBVH rule does with a node.
pub(crate) enum Decision {
    Leaf,
    Split(Vec<Ref>, Vec<Ref>),
}

/// The SBVH rule: the cheapest of leaf, best object split and best spatial split.
pub(crate) fn decide(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
) -> Decision {
    decide_with(
        ctx,
        refs,
        bounds,
        area,
        depth,
        budget,
        |refs, area| object_search(ctx, refs, area, 1),
        |refs, bounds, area, budget| {
            spatial_search(ctx, refs, bounds, area, 1, budget)
                .first()
                .copied()
        },
    )
}

/// The SBVH rule with the given searches (`object(refs, area)`: the best object split first
/// in its candidates; `spatial(refs, bounds, area, budget)`: the best spatial split, if any),
/// which lets cost-only temporaries use cheaper searches under the same rule (see
/// `tsah_spatial`). `ctx` gives the configuration, the cost model and the clipping.
#[allow(clippy::too_many_arguments)]
pub(crate) fn decide_with(
    ctx: &Ctx,
    refs: &[Ref],
    bounds: &Aabb,
    area: f64,
    depth: usize,
    budget: usize,
    object: impl FnOnce(&[Ref], f64) -> ObjectSearch,
    spatial: impl FnOnce(&[Ref], &Aabb, f64, usize) -> Option<SpatialCand>,
) -> Decision {
    let n = refs.len();
    if n == 1 {
        return Decision::Leaf;
    }
    let can_leaf = n <= ctx.cfg.max_leaf_size;
    if depth >= ctx.cfg.fallback_depth {
        if can_leaf {
            return Decision::Leaf;
        }
        let (l, r) = median_split(refs);
        return Decision::Split(l, r);
    }
    let search = object(refs, area);
    let best_object = search.cands[0];
    let spatial = if spatial_allowed(ctx, &best_object, depth, budget) {
        spatial(refs, bounds, area, budget).filter(|s| s.cost < best_object.cost)
    } else {
        None
    };
    let best = spatial.map_or(best_object.cost, |s| s.cost);
    if can_leaf && ctx.cost.leaf_cost(n) <= best {
        return Decision::Leaf;
    }
    if let Some(s) = spatial {
        if let Some((l, r)) = apply_spatial(ctx, refs, &s) {
            return Decision::Split(l, r);
        }
    }
    let (l, r) = apply_object(refs, &search, &best_object);
    Decision::Split(l, r)
}

/// Pushes a leaf over `refs`.
pub(crate) fn emit_leaf(out: Option<&mut Fragment>, bounds: &Aabb, refs: &[Ref]) {
    if let Some(out) = out {
        out.push_leaf(bounds, refs.iter().map(|r| r.prim));
    }
}

/// The duplication budgets of two children with `n_left` and `n_right` references made from
/// a parent with `n_parent` references and budget `budget`: what the split did not use, shared
/// in proportion to the children's reference counts.
pub(crate) fn child_budgets(
    n_parent: usize,
    n_left: usize,
    n_right: usize,
    budget: usize,
) -> (usize, usize) {
    let dups = (n_left + n_right).saturating_sub(n_parent);
    share_budget(budget.saturating_sub(dups), n_left, n_right)
}

/// Recurses into two children (in parallel above a threshold), with the duplication budget
/// left after the split shared between them; returns `((c_l, a_l), (c_r, a_r))`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn recurse_children<F>(
    n_parent: usize,
    bounds: &Aabb,
    left: Vec<Ref>,
    right: Vec<Ref>,
    depth: usize,
    budget: usize,
    out: Option<&mut Fragment>,
    f: &F,
) -> ((f64, f64), (f64, f64))
where
    F: Fn(Vec<Ref>, usize, usize, Option<&mut Fragment>) -> (f64, f64) + Sync,
{
    let (bl, br) = child_budgets(n_parent, left.len(), right.len(), budget);
    let parallel = left.len() + right.len() >= PAR_SPLIT_THRESHOLD;
    let d = depth + 1;
    match out {
        Some(out) => {
            let me = out.push_inner(bounds);
            if parallel {
                let mut right_out = Fragment::default();
                let res = rayon::join(
                    || f(left, d, bl, Some(&mut *out)),
                    || f(right, d, br, Some(&mut right_out)),
                );
                out.set_right_here(me);
                out.append(right_out);
                res
            } else {
                let l = f(left, d, bl, Some(&mut *out));
                out.set_right_here(me);
                (l, f(right, d, br, Some(out)))
            }
        }
        None if parallel => rayon::join(|| f(left, d, bl, None), || f(right, d, br, None)),
        None => (f(left, d, bl, None), f(right, d, br, None)),
    }
}

/// Builds (or, with `out == None`, only costs) the SBVH subtree over `refs`; returns its cost
/// `c(n)` and its half area.
pub(crate) fn build_rec(
    ctx: &Ctx,
    refs: Vec<Ref>,
    depth: usize,
    budget: usize,
    out: Option<&mut Fragment>,
) -> (f64, f64) {
    let n = refs.len();
    let bounds = refs_bounds(&refs);
    let area = half_area(&bounds);
    match decide(ctx, &refs, &bounds, area, depth, budget) {
        Decision::Leaf => {
            emit_leaf(out, &bounds, &refs);
            (ctx.cost.leaf_cost(n), area)
        }
        Decision::Split(left, right) => {
            drop(refs);
            let ((c_l, a_l), (c_r, a_r)) = recurse_children(
                n,
                &bounds,
                left,
                right,
                depth,
                budget,
                out,
                &|refs, d, b, out| build_rec(ctx, refs, d, b, out),
            );
            (ctx.cost.inner_cost(area, a_l, c_l, a_r, c_r), area)
        }
    }
}
