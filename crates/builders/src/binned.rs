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

use crate::registry::Entry;
use crate::split::binned::{self as bins, Bin};
use crate::split::{
    half_area, imbalance, ranks_before, sort_by_key, BinMap, Suffix, PAR_CHUNK, PAR_NODE_THRESHOLD,
};
use crate::topdown::{self, Step, TopDown};
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};
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
        let rule = BinnedRule::new(input, self);
        let mut prims: Vec<u32> = (0..input.len() as u32).collect();
        let nb = rule.bounds_of(&prims);
        let root = BinTask {
            prims: &mut prims,
            nb,
            depth: 0,
        };
        Ok(topdown::build(&rule, root, false))
    }
}

/// The binned SAH builder (Wald 2007). Parallel on rayon; the tree does not depend on the
/// number of threads.
pub type BinnedBuilder = Configured<BinnedConfig>;

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
    let rule = BinnedRule::new(input, config);
    let nb = rule.bounds_of(prims);
    let root = BinTask {
        prims,
        nb,
        depth: 0,
    };
    topdown::cost(&rule, root, &input.cost, &mut Scratch::default()).cost
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

/// The rule: the cheapest binned plane by Eq. 2, a leaf when small enough and no plane is
/// cheaper, an object median split where no plane separates anything (or below
/// [`BinnedConfig::fallback_depth`]).
struct BinnedRule<'a> {
    bounds: &'a [Aabb],
    centroids: &'a [Vec3A],
    cost: CostModel,
    cfg: BinnedConfig,
}

/// A node still to build: its primitives (partitioned in place), their bounds, its depth.
struct BinTask<'a> {
    prims: &'a mut [u32],
    nb: Bounds,
    depth: usize,
}

/// Scratch memory: three axes of bins and the suffix sweep; for small nodes, the primitives
/// sorted by bin and their suffix bounds.
#[derive(Default)]
struct Scratch {
    bins: Vec<Bin>,
    right: Vec<(f32, u32)>,
    pairs: Vec<(u32, u32)>,
    keys: Vec<u64>,
    suffix: Vec<Aabb>,
}

/// The bounds of a set of primitives and of their centroids.
#[derive(Clone, Copy)]
struct Bounds {
    bounds: Aabb,
    centroids: Aabb,
}

impl From<Bin> for Bounds {
    fn from(b: Bin) -> Self {
        Bounds {
            bounds: b.bounds,
            centroids: b.centroids,
        }
    }
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

impl<'a> BinnedRule<'a> {
    fn new(input: &'a BuildInput, cfg: &BinnedConfig) -> Self {
        Self {
            bounds: input.bounds(),
            centroids: input.centroids(),
            cost: input.cost,
            cfg: *cfg,
        }
    }

    /// Bounds of the primitives and of their centroids (computed at the root and for median
    /// splits; other children get theirs from the bins).
    fn bounds_of(&self, prims: &[u32]) -> Bounds {
        let fold = |prims: &[u32]| {
            let mut b = Aabb::EMPTY;
            let mut c = Aabb::EMPTY;
            for &p in prims {
                b.grow_aabb(&self.bounds[p as usize]);
                c.grow(self.centroids[p as usize]);
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

    /// The plane of least Eq. 2 cost over the three axes (ties: see [`ranks_before`]); `None`
    /// when no plane has primitives on both sides.
    fn best_plane(&self, prims: &[u32], cb: &Aabb, s: &mut Scratch) -> Option<Plane> {
        let k = self.cfg.bins;
        let maps = bins::maps(cb, k);
        if maps.iter().all(Option::is_none) {
            return None;
        }
        if 2 * prims.len() <= k {
            self.best_plane_small(prims, &maps, s)
        } else {
            self.best_plane_binned(prims, &maps, s)
        }
    }

    /// [`best_plane`](Self::best_plane) by the bins.
    fn best_plane_binned(
        &self,
        prims: &[u32],
        maps: &[Option<BinMap>; 3],
        s: &mut Scratch,
    ) -> Option<Plane> {
        let k = self.cfg.bins;
        s.bins.resize(3 * k, Bin::EMPTY);
        s.right.resize(k, (0.0, 0));
        bins::fill_par(&mut s.bins, k, maps, prims, self.bounds, self.centroids);
        let mut best: Option<Rated> = None;
        for (axis, map) in maps.iter().enumerate() {
            if map.is_none() {
                continue;
            }
            let axis_bins = &s.bins[axis * k..(axis + 1) * k];
            bins::sweep_planes(axis_bins, &mut s.right, |plane, lb, lc, ra: &f32, rc| {
                let cand = Rated {
                    axis,
                    plane,
                    score: half_area(lb) * lc as f64 + ra.area() * rc as f64,
                    imbalance: imbalance(lc, rc),
                };
                if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                    best = Some(cand);
                }
            });
        }
        let Rated { axis, plane, .. } = best?;
        let (left, right) = bins::sides(&s.bins[axis * k..(axis + 1) * k], plane);
        Some(Plane {
            axis,
            plane,
            map: maps[axis].expect("a mapped axis"),
            n_left: left.count as usize,
            left: left.into(),
            right: right.into(),
        })
    }

    /// [`best_plane`](Self::best_plane) for nodes with fewer primitives than half the bins:
    /// most bins are empty, so instead of sweeping `K` bins the primitives are sorted by bin
    /// and only the planes between two occupied bins are rated. A plane between occupied bins
    /// `a < b` makes the same partition, with the same bounds and the same score, as every
    /// plane `a + 1 ..= b` of the full sweep, of which the full sweep keeps the first
    /// (`a + 1`, because ties need a strictly better rank to win): the result is identical
    /// to the full sweep's.
    fn best_plane_small(
        &self,
        prims: &[u32],
        maps: &[Option<BinMap>; 3],
        s: &mut Scratch,
    ) -> Option<Plane> {
        let n = prims.len();
        let mut best: Option<(Rated, BinMap)> = None;
        for (axis, map) in maps.iter().enumerate() {
            let Some(map) = *map else { continue };
            s.pairs.clear();
            s.pairs.extend(
                prims
                    .iter()
                    .map(|&p| (map.bin(self.centroids[p as usize][axis]) as u32, p)),
            );
            s.pairs.sort_unstable();
            let bin_of = |i: usize| s.pairs[i].0 as usize;
            let prim_of = |i: usize| s.pairs[i].1 as usize;
            s.suffix.clear();
            s.suffix.resize(n, Aabb::EMPTY);
            let mut rb = Aabb::EMPTY;
            for i in (1..n).rev() {
                rb.grow_aabb(&self.bounds[prim_of(i)]);
                s.suffix[i] = rb;
            }
            let mut lb = Aabb::EMPTY;
            for i in 1..n {
                lb.grow_aabb(&self.bounds[prim_of(i - 1)]);
                if bin_of(i) == bin_of(i - 1) {
                    continue;
                }
                let cand = Rated {
                    axis,
                    plane: bin_of(i - 1) + 1,
                    score: half_area(&lb) * i as f64 + half_area(&s.suffix[i]) * (n - i) as f64,
                    imbalance: imbalance(i, n - i),
                };
                if best.as_ref().is_none_or(|(b, _)| cand.better_than(b)) {
                    best = Some((cand, map));
                }
            }
        }
        let (Rated { axis, plane, .. }, map) = best?;
        let mut left = Bin::EMPTY;
        let mut right = Bin::EMPTY;
        for &p in prims {
            let c = self.centroids[p as usize];
            let side = if map.bin(c[axis]) < plane {
                &mut left
            } else {
                &mut right
            };
            side.add(&self.bounds[p as usize], c);
        }
        Some(Plane {
            axis,
            plane,
            map,
            n_left: left.count as usize,
            left: left.into(),
            right: right.into(),
        })
    }

    /// Moves the primitives of bins `< plane` to the front; returns how many there are.
    fn partition(&self, prims: &mut [u32], p: &Plane) -> usize {
        let goes_left = |q: u32| p.map.bin(self.centroids[q as usize][p.axis]) < p.plane;
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

    /// Object median split on the largest axis of the centroid bounds, by (centroid, index).
    fn median_split(&self, prims: &mut [u32], cb: &Aabb, s: &mut Scratch) -> usize {
        let axis = cb.largest_axis();
        sort_by_key(&mut s.keys, prims.len(), |i| {
            (self.centroids[prims[i] as usize][axis], prims[i])
        });
        for (p, &k) in prims.iter_mut().zip(&s.keys) {
            *p = k as u32;
        }
        prims.len() / 2
    }
}

impl<'a> TopDown for BinnedRule<'a> {
    type Task = BinTask<'a>;
    type Scratch = Scratch;

    fn size(&self, t: &BinTask<'a>) -> usize {
        t.prims.len()
    }

    fn split(&self, t: BinTask<'a>, scratch: &mut Scratch) -> Step<BinTask<'a>> {
        let n = t.prims.len();
        let nb = t.nb;
        let can_leaf = n <= self.cfg.max_leaf_size;
        let plane = if n == 1 || t.depth >= self.cfg.fallback_depth {
            None
        } else {
            self.best_plane(t.prims, &nb.centroids, scratch)
        };
        let make_leaf = match &plane {
            _ if n == 1 => true,
            Some(p) => {
                let (nl, nr) = (p.n_left, n - p.n_left);
                let cost = self.cost.split_cost(
                    half_area(&nb.bounds),
                    half_area(&p.left.bounds),
                    nl,
                    half_area(&p.right.bounds),
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
        let prims = t.prims;
        let (mid, lb, rb) = match plane {
            Some(p) => (self.partition(prims, &p), p.left, p.right),
            None => {
                let mid = self.median_split(prims, &nb.centroids, scratch);
                let lb = self.bounds_of(&prims[..mid]);
                let rb = self.bounds_of(&prims[mid..]);
                (mid, lb, rb)
            }
        };
        debug_assert!(mid > 0 && mid < n);
        let (left, right) = prims.split_at_mut(mid);
        let depth = t.depth + 1;
        Step::Split {
            bounds: nb.bounds,
            left: BinTask {
                prims: left,
                nb: lb,
                depth,
            },
            right: BinTask {
                prims: right,
                nb: rb,
                depth,
            },
        }
    }

    fn leaf_refs(&self, t: &BinTask<'a>, out: &mut Vec<u32>) {
        out.extend_from_slice(t.prims);
    }

    fn parallel_threshold(&self) -> usize {
        2048
    }
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
            let rule = BinnedRule::new(&input, &cfg);
            let mut s = Scratch::default();
            for trial in 0..200 {
                let n = 2 + trial % (bins / 2 - 1);
                let prims: Vec<u32> = (0..n).map(|_| rng.below(64)).collect();
                let cb = rule.bounds_of(&prims).centroids;
                let maps = bins::maps(&cb, bins);
                let a = rule.best_plane_small(&prims, &maps, &mut s);
                let b = rule.best_plane_binned(&prims, &maps, &mut s);
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
