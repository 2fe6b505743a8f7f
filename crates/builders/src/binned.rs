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

use crate::common::{
    half_area, imbalance, BinMap, Fragment, PAR_CHUNK, PAR_NODE_THRESHOLD, PAR_SPLIT_THRESHOLD,
};
use crate::registry::Entry;
use crate::{BuildError, BuildInput, Builder, Bvh};
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

    /// Checks the ranges of the fields.
    pub fn check(&self) -> Result<(), BuildError> {
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
}

/// The binned SAH builder (Wald 2007). Parallel on rayon; the tree does not depend on the
/// number of threads.
#[derive(Clone, Debug)]
pub struct BinnedBuilder {
    /// The configuration.
    pub config: BinnedConfig,
    name: &'static str,
}

impl BinnedBuilder {
    /// A builder with `config`, named `"binned"`.
    pub fn new(config: BinnedConfig) -> Self {
        Self::named("binned", config)
    }

    /// A builder with `config` and a registry name of your choice.
    pub fn named(name: &'static str, config: BinnedConfig) -> Self {
        Self { config, name }
    }
}

impl Default for BinnedBuilder {
    fn default() -> Self {
        Self::new(BinnedConfig::default())
    }
}

impl Builder for BinnedBuilder {
    fn name(&self) -> &str {
        self.name
    }

    fn describe(&self) -> String {
        let c = &self.config;
        format!(
            "binned SAH (Wald 2007): {} centroid bins per axis, leaves <= {}",
            c.bins, c.max_leaf_size
        )
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        self.config.check()?;
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        let ctx = Ctx::new(input, &self.config);
        let mut prims: Vec<u32> = (0..input.len() as u32).collect();
        let mut out = Fragment::default();
        let mut scratch = Scratch::new(self.config.bins);
        let nb = node_bounds(&ctx, &prims);
        build_node(&ctx, &mut prims, nb, 0, &mut scratch, Some(&mut out));
        Ok(out.into_bvh(false))
    }
}

/// The SAH cost `c(T)` (Eq. 1, relative to the area of the subset's bounds) of the tree that
/// [`BinnedBuilder`] with `config` would build over the primitives `prims`, computed bottom-up
/// during the build without allocating any node.
///
/// `prims` is reordered in place (it ends up in the leaf order of that tree). Scratch memory
/// (the bins) is allocated once per call and reused at every node; nodes with many primitives
/// are processed in parallel with `rayon::join`, and the result is the same for any number of
/// threads. The value equals `sahara_metrics::sah` of the built tree up to rounding (the two
/// sum the same terms in different orders). An empty subset costs `0`.
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
    let ctx = Ctx::new(input, config);
    let mut scratch = Scratch::new(config.bins);
    let nb = node_bounds(&ctx, prims);
    build_node(&ctx, prims, nb, 0, &mut scratch, None)
}

/// Registry entries of this module: `binned` (32 bins), `binned-8` and `binned-128`.
pub fn registry_entries() -> Vec<Entry> {
    vec![
        Entry {
            name: "binned",
            summary: "binned SAH (Wald 2007), 32 centroid bins per axis, leaves <= 8",
            spatial: false,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || Box::new(BinnedBuilder::named("binned", BinnedConfig::DEFAULT)),
        },
        Entry {
            name: "binned-8",
            summary: "binned SAH with 8 bins per axis (fastest)",
            spatial: false,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || Box::new(BinnedBuilder::named("binned-8", BinnedConfig::FAST)),
        },
        Entry {
            name: "binned-128",
            summary: "binned SAH with 128 bins per axis",
            spatial: false,
            small_inputs_only: false,
            max_practical_triangles: None,
            make: || Box::new(BinnedBuilder::named("binned-128", BinnedConfig::FINE)),
        },
    ]
}

struct Ctx<'a> {
    bounds: &'a [Aabb],
    centroids: &'a [Vec3A],
    cost: CostModel,
    cfg: &'a BinnedConfig,
}

impl<'a> Ctx<'a> {
    fn new(input: &'a BuildInput, cfg: &'a BinnedConfig) -> Self {
        Self {
            bounds: input.bounds(),
            centroids: input.centroids(),
            cost: input.cost,
            cfg,
        }
    }
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    centroids: Aabb,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    bounds: Aabb::EMPTY,
    centroids: Aabb::EMPTY,
    count: 0,
};

impl Bin {
    #[inline]
    fn merge(&mut self, other: &Bin) {
        self.bounds.grow_aabb(&other.bounds);
        self.centroids.grow_aabb(&other.centroids);
        self.count += other.count;
    }
}

/// Per-task scratch memory: three axes of bins and the suffix sweep; for small nodes, the
/// primitives sorted by bin and their suffix bounds.
struct Scratch {
    bins: Vec<Bin>,
    right_area: Vec<f64>,
    right_count: Vec<u32>,
    sorted: Vec<(u32, u32)>,
    suffix: Vec<Aabb>,
}

impl Scratch {
    fn new(k: usize) -> Self {
        Self {
            bins: vec![EMPTY_BIN; 3 * k],
            right_area: vec![0.0; k],
            right_count: vec![0; k],
            sorted: Vec::new(),
            suffix: Vec::new(),
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
    left: Bounds,
    right: Bounds,
}

/// Bounds of the primitives and of their centroids (computed once, at the root; children get
/// theirs from the bins).
fn node_bounds(ctx: &Ctx, prims: &[u32]) -> Bounds {
    let fold = |prims: &[u32]| {
        let mut b = Aabb::EMPTY;
        let mut c = Aabb::EMPTY;
        for &p in prims {
            b.grow_aabb(&ctx.bounds[p as usize]);
            c.grow(ctx.centroids[p as usize]);
        }
        (b, c)
    };
    let (bounds, centroids) = if prims.len() >= PAR_NODE_THRESHOLD {
        prims.par_chunks(PAR_CHUNK).map(fold).reduce(
            || (Aabb::EMPTY, Aabb::EMPTY),
            |a, b| (a.0.union(&b.0), a.1.union(&b.1)),
        )
    } else {
        fold(prims)
    };
    Bounds { bounds, centroids }
}

/// Fills `bins` (3 axes of `K`) for the axes that have a mapping. Exact whatever the chunking:
/// counts are integer sums, bounds are min/max.
fn fill_bins(ctx: &Ctx, prims: &[u32], maps: &[Option<BinMap>; 3], bins: &mut [Bin]) {
    let k = ctx.cfg.bins;
    let fill = |prims: &[u32], bins: &mut [Bin]| {
        for &p in prims {
            let c = ctx.centroids[p as usize];
            let b = &ctx.bounds[p as usize];
            for (axis, map) in maps.iter().enumerate() {
                if let Some(map) = map {
                    let bin = &mut bins[axis * k + map.bin(c[axis])];
                    bin.count += 1;
                    bin.bounds.grow_aabb(b);
                    bin.centroids.grow(c);
                }
            }
        }
    };
    bins.fill(EMPTY_BIN);
    if prims.len() >= PAR_NODE_THRESHOLD {
        let merged = prims
            .par_chunks(PAR_CHUNK)
            .map(|chunk| {
                let mut local = vec![EMPTY_BIN; 3 * k];
                fill(chunk, &mut local);
                local
            })
            .reduce(
                || vec![EMPTY_BIN; 3 * k],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(&b) {
                        x.merge(y);
                    }
                    a
                },
            );
        bins.copy_from_slice(&merged);
    } else {
        fill(prims, bins);
    }
}

/// The plane of least Eq. 2 cost over the three axes. Exact ties go to the more balanced
/// plane (smaller `n_l² + n_r²`), then to the lower axis, then to the lower plane. `None`
/// when no plane has primitives on both sides.
fn best_plane(ctx: &Ctx, prims: &[u32], cb: &Aabb, s: &mut Scratch) -> Option<Plane> {
    let k = ctx.cfg.bins;
    let maps = [0, 1, 2].map(|a| BinMap::new(cb.min[a], cb.max[a], k));
    if maps.iter().all(Option::is_none) {
        return None;
    }
    if 2 * prims.len() <= k {
        best_plane_small(ctx, prims, &maps, s)
    } else {
        best_plane_binned(ctx, prims, &maps, s)
    }
}

/// [`best_plane`] by the bins.
fn best_plane_binned(
    ctx: &Ctx,
    prims: &[u32],
    maps: &[Option<BinMap>; 3],
    s: &mut Scratch,
) -> Option<Plane> {
    let k = ctx.cfg.bins;
    fill_bins(ctx, prims, maps, &mut s.bins);
    // (axis, plane, map, score, balance). The score `A_l n_l + A_r n_r` orders the planes of
    // one node as Eq. 2 does, without a division per plane.
    let mut best: Option<(usize, usize, BinMap, f64, u128)> = None;
    for (axis, map) in maps.iter().enumerate() {
        let Some(map) = *map else { continue };
        let bins = &s.bins[axis * k..(axis + 1) * k];
        let mut rb = Aabb::EMPTY;
        let mut rc = 0u32;
        for i in (1..k).rev() {
            rb.grow_aabb(&bins[i].bounds);
            rc += bins[i].count;
            s.right_area[i] = half_area(&rb);
            s.right_count[i] = rc;
        }
        let mut lb = Aabb::EMPTY;
        let mut lc = 0u32;
        for i in 1..k {
            lb.grow_aabb(&bins[i - 1].bounds);
            lc += bins[i - 1].count;
            let rc = s.right_count[i];
            if lc == 0 || rc == 0 {
                continue;
            }
            let score = half_area(&lb) * lc as f64 + s.right_area[i] * rc as f64;
            let better = match best {
                None => true,
                Some((.., bs, bb)) => {
                    score < bs || (score == bs && imbalance(lc as usize, rc as usize) < bb)
                }
            };
            if better {
                let balance = imbalance(lc as usize, rc as usize);
                best = Some((axis, i, map, score, balance));
            }
        }
    }
    let (axis, plane, map, ..) = best?;
    let bins = &s.bins[axis * k..(axis + 1) * k];
    let mut left = EMPTY_BIN;
    let mut right = EMPTY_BIN;
    for b in &bins[..plane] {
        left.merge(b);
    }
    for b in &bins[plane..] {
        right.merge(b);
    }
    let side = |b: Bin| Bounds {
        bounds: b.bounds,
        centroids: b.centroids,
    };
    Some(Plane {
        axis,
        plane,
        map,
        n_left: left.count as usize,
        left: side(left),
        right: side(right),
    })
}

/// [`best_plane`] for nodes with fewer primitives than half the bins: most bins are empty,
/// so instead of sweeping `K` bins the primitives are sorted by bin and only the planes
/// between two occupied bins are rated. A plane between occupied bins `a < b` makes the same
/// partition, with the same bounds and the same score, as every plane `a + 1 ..= b` of the
/// full sweep, of which the full sweep keeps the first (`a + 1`, because ties need a strictly
/// better score or balance to win): the result is identical to the full sweep's.
fn best_plane_small(
    ctx: &Ctx,
    prims: &[u32],
    maps: &[Option<BinMap>; 3],
    s: &mut Scratch,
) -> Option<Plane> {
    let n = prims.len();
    // (axis, plane, map, score, balance)
    let mut best: Option<(usize, usize, BinMap, f64, u128)> = None;
    for (axis, map) in maps.iter().enumerate() {
        let Some(map) = *map else { continue };
        s.sorted.clear();
        s.sorted.extend(
            prims
                .iter()
                .map(|&p| (map.bin(ctx.centroids[p as usize][axis]) as u32, p)),
        );
        s.sorted.sort_unstable();
        s.suffix.clear();
        s.suffix.resize(n, Aabb::EMPTY);
        let mut rb = Aabb::EMPTY;
        for i in (1..n).rev() {
            rb.grow_aabb(&ctx.bounds[s.sorted[i].1 as usize]);
            s.suffix[i] = rb;
        }
        let mut lb = Aabb::EMPTY;
        for i in 1..n {
            lb.grow_aabb(&ctx.bounds[s.sorted[i - 1].1 as usize]);
            if s.sorted[i].0 == s.sorted[i - 1].0 {
                continue;
            }
            let score = half_area(&lb) * i as f64 + half_area(&s.suffix[i]) * (n - i) as f64;
            let balance = imbalance(i, n - i);
            let better = match best {
                None => true,
                Some((.., bs, bb)) => score < bs || (score == bs && balance < bb),
            };
            if better {
                best = Some((axis, s.sorted[i - 1].0 as usize + 1, map, score, balance));
            }
        }
    }
    let (axis, plane, map, ..) = best?;
    let mut left = EMPTY_BIN;
    let mut right = EMPTY_BIN;
    for &p in prims {
        let c = ctx.centroids[p as usize];
        let side = if map.bin(c[axis]) < plane {
            &mut left
        } else {
            &mut right
        };
        side.bounds.grow_aabb(&ctx.bounds[p as usize]);
        side.centroids.grow(c);
        side.count += 1;
    }
    let side = |b: Bin| Bounds {
        bounds: b.bounds,
        centroids: b.centroids,
    };
    Some(Plane {
        axis,
        plane,
        map,
        n_left: left.count as usize,
        left: side(left),
        right: side(right),
    })
}

/// Moves the primitives of bins `< plane` to the front; returns how many there are.
fn partition(ctx: &Ctx, prims: &mut [u32], p: &Plane) -> usize {
    let goes_left = |q: u32| p.map.bin(ctx.centroids[q as usize][p.axis]) < p.plane;
    let (mut i, mut j) = (0usize, prims.len());
    loop {
        while i < j && goes_left(prims[i]) {
            i += 1;
        }
        while i < j && !goes_left(prims[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// Object median split on the largest axis of the centroid bounds: sorts by (centroid,
/// index), a total order, so the result does not depend on the sort algorithm.
fn median_split(ctx: &Ctx, prims: &mut [u32], cb: &Aabb) -> usize {
    let axis = cb.largest_axis();
    let key = |p: u32| ctx.centroids[p as usize][axis];
    prims.sort_unstable_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    prims.len() / 2
}

/// Builds (or, with `out == None`, only costs) the subtree over `prims`, whose bounds are
/// `nb`; returns its cost `c(n)` relative to the node's area.
fn build_node(
    ctx: &Ctx,
    prims: &mut [u32],
    nb: Bounds,
    depth: usize,
    scratch: &mut Scratch,
    out: Option<&mut Fragment>,
) -> f64 {
    let n = prims.len();
    let leaf_cost = ctx.cost.leaf_cost(n);
    let area = half_area(&nb.bounds);
    let can_leaf = n <= ctx.cfg.max_leaf_size;
    let plane = if n == 1 || depth >= ctx.cfg.fallback_depth {
        None
    } else {
        best_plane(ctx, prims, &nb.centroids, scratch)
    };
    let make_leaf = match &plane {
        _ if n == 1 => true,
        Some(p) => {
            let (nl, nr) = (p.n_left, n - p.n_left);
            let cost = ctx.cost.split_cost(
                area,
                half_area(&p.left.bounds),
                nl,
                half_area(&p.right.bounds),
                nr,
            );
            can_leaf && cost >= leaf_cost
        }
        None => can_leaf,
    };
    if make_leaf {
        if let Some(out) = out {
            out.push_leaf(&nb.bounds, prims.iter().copied());
        }
        return leaf_cost;
    }
    let (mid, lb, rb) = match plane {
        Some(p) => (partition(ctx, prims, &p), p.left, p.right),
        None => {
            let mid = median_split(ctx, prims, &nb.centroids);
            let lb = node_bounds(ctx, &prims[..mid]);
            let rb = node_bounds(ctx, &prims[mid..]);
            (mid, lb, rb)
        }
    };
    debug_assert!(mid > 0 && mid < n);
    let (left, right) = prims.split_at_mut(mid);
    let parallel = n >= PAR_SPLIT_THRESHOLD;
    let d = depth + 1;
    let (c_l, c_r) = match out {
        Some(out) => {
            let me = out.push_inner(&nb.bounds);
            if parallel {
                let mut right_out = Fragment::default();
                let res = rayon::join(
                    || build_node(ctx, left, lb, d, scratch, Some(&mut *out)),
                    || {
                        let mut s = Scratch::new(ctx.cfg.bins);
                        build_node(ctx, right, rb, d, &mut s, Some(&mut right_out))
                    },
                );
                out.set_right_here(me);
                out.append(right_out);
                res
            } else {
                let l = build_node(ctx, left, lb, d, scratch, Some(&mut *out));
                out.set_right_here(me);
                (l, build_node(ctx, right, rb, d, scratch, Some(out)))
            }
        }
        None if parallel => rayon::join(
            || build_node(ctx, left, lb, d, scratch, None),
            || build_node(ctx, right, rb, d, &mut Scratch::new(ctx.cfg.bins), None),
        ),
        None => (
            build_node(ctx, left, lb, d, scratch, None),
            build_node(ctx, right, rb, d, scratch, None),
        ),
    };
    ctx.cost
        .inner_cost(area, half_area(&lb.bounds), c_l, half_area(&rb.bounds), c_r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::rng::Pcg32;
    use sahara_geom::Triangle;

    #[test]
    fn small_node_path_equals_full_binning() {
        let mut rng = Pcg32::new(3, 4);
        let tris: Vec<Triangle> = (0..64)
            .map(|i| {
                // Coarse positions so that several centroids share bins and planes tie.
                let o = Vec3A::new(rng.below(6) as f32, rng.below(3) as f32, (i % 2) as f32);
                let s = 0.25 * (1 + rng.below(3)) as f32;
                Triangle::new(o, o + Vec3A::X * s, o + Vec3A::Y * s)
            })
            .collect();
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        for bins in [16, 32, 128] {
            let cfg = BinnedConfig::with_bins(bins);
            let ctx = Ctx::new(&input, &cfg);
            let mut s = Scratch::new(bins);
            for trial in 0..200 {
                let n = 2 + trial % (bins / 2 - 1);
                let prims: Vec<u32> = (0..n).map(|_| rng.below(64)).collect();
                let cb = node_bounds(&ctx, &prims).centroids;
                let maps = [0, 1, 2].map(|a| BinMap::new(cb.min[a], cb.max[a], bins));
                let a = best_plane_small(&ctx, &prims, &maps, &mut s);
                let b = best_plane_binned(&ctx, &prims, &maps, &mut s);
                match (a, b) {
                    (None, None) => {}
                    (Some(a), Some(b)) => {
                        assert_eq!((a.axis, a.plane, a.n_left), (b.axis, b.plane, b.n_left));
                        assert_eq!(a.left.bounds, b.left.bounds);
                        assert_eq!(a.right.centroids, b.right.centroids);
                    }
                    _ => panic!("one path found a plane, the other did not"),
                }
            }
        }
    }
}
