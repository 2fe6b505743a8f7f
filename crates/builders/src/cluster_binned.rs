//! Binned SAH over Morton clusters: the quick build for per-frame rebuilds.
//!
//! The triangles are sorted once along the Morton curve of their centroids (30-bit codes, one
//! parallel sort), and the sorted array is cut into *clusters* by radix splits: a range whose
//! triangles all share a code prefix is halved at the next bit where they differ, until it
//! holds at most [`ClusterBinnedConfig::cluster_size`] triangles. A cluster is a cell of the
//! Morton grid (or a few neighbouring cells), so its box is compact.
//!
//! The top of the tree is then built by the binned SAH rule ([`crate::binned`]) over the
//! clusters' boxes, one reference per cluster, so its upper levels bin and partition a
//! `cluster_size`-th of the references a binned build over triangles would; a node holding a
//! single cluster goes on with the same rule over that cluster's triangles, down to leaves of
//! at most [`ClusterBinnedConfig::max_leaf_size`]. Clusters are never leaves themselves: the
//! SAH decides where the leaves are, inside the clusters.
//!
//! The tree depends on the triangles and the configuration only (the sort's keys are unique,
//! and the binned rule is deterministic), whatever the number of threads.
//!
//! ```
//! use sahara_builders::cluster_binned::{ClusterBinnedBuilder, ClusterBinnedConfig};
//! use sahara_builders::{BuildInput, Builder};
//! use sahara_geom::{Triangle, Vec3A};
//! use sahara_metrics::CostModel;
//!
//! let tris: Vec<Triangle> = (0..500)
//!     .map(|i| {
//!         let o = Vec3A::new((i % 13) as f32, (i / 13) as f32, (i % 5) as f32);
//!         Triangle::new(o, o + Vec3A::X * 0.5, o + Vec3A::Y * 0.5)
//!     })
//!     .collect();
//! let input = BuildInput::new(&tris, CostModel::default()).unwrap();
//! let bvh = ClusterBinnedBuilder::new(ClusterBinnedConfig::default()).build(&input).unwrap();
//! bvh.validate(&tris).unwrap();
//! ```

use std::sync::Mutex;

use rayon::prelude::*;
use sahara_geom::{Aabb, Vec3A};

use crate::rules::binned::{BinTask, BinnedRule, Scratch};
use crate::split::binned::partition::split_refs;
use crate::split::binned::plane::best_plane;
use crate::split::binned::refs::{ref_bounds, RefBounds};
use crate::split::binned::{FillBackend, PrimRef};
use crate::split::PAR_NODE_THRESHOLD;
use crate::topdown::{self, Rule, Step};
use crate::{BuildError, BuildInput, Bvh, Configured, Strategy};

/// Configuration of the Morton-cluster binned builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ClusterBinnedConfig {
    /// Equal-width centroid bins per axis, for clusters and triangles alike (at least 2).
    /// Default 8.
    pub bins: usize,
    /// Most triangles in one cluster (at least 1). Default 32.
    pub cluster_size: usize,
    /// Largest leaf (at least 1). Default 8.
    pub max_leaf_size: usize,
    /// Nodes of at most this many triangles are leaves without a plane search (at most
    /// `max_leaf_size`; 0: none). Default 4, one packet of the 8-wide layout.
    pub always_leaf: usize,
}

impl Default for ClusterBinnedConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ClusterBinnedConfig {
    /// 8 bins, clusters of at most 32 triangles, leaves of at most 8, always of up to 4.
    pub const DEFAULT: ClusterBinnedConfig = ClusterBinnedConfig {
        bins: 8,
        cluster_size: 32,
        max_leaf_size: 8,
        always_leaf: 4,
    };
}

impl Strategy for ClusterBinnedConfig {
    const NAME: &'static str = "cluster-binned";

    fn check(&self) -> Result<(), BuildError> {
        if self.always_leaf > self.max_leaf_size {
            return Err(BuildError::InvalidConfig(
                "cluster-binned: always_leaf must be at most max_leaf_size".into(),
            ));
        }
        if self.cluster_size < 1 {
            return Err(BuildError::InvalidConfig(
                "cluster-binned: cluster_size must be at least 1".into(),
            ));
        }
        if self.bins < 2 {
            return Err(BuildError::InvalidConfig(format!(
                "cluster-binned: bins must be at least 2 (got {})",
                self.bins
            )));
        }
        if self.max_leaf_size < 1 {
            return Err(BuildError::InvalidConfig(
                "cluster-binned: max_leaf_size must be at least 1".into(),
            ));
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!(
            "binned SAH over Morton clusters of <= {} triangles, then over their triangles: \
             {} centroid bins per axis, leaves <= {}",
            self.cluster_size, self.bins, self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        Ok(build_tree(input, self))
    }
}

/// The binned SAH builder over Morton clusters. Parallel on rayon; the tree does not depend on
/// the number of threads.
pub type ClusterBinnedBuilder = Configured<ClusterBinnedConfig>;

/// Depth below which the rule splits triangles at the object median only (as
/// [`BinnedConfig::fallback_depth`](crate::binned::BinnedConfig::fallback_depth), counted from
/// the cluster's node).
const FALLBACK_DEPTH: usize = 96;

/// Bits per axis of the Morton codes.
const BITS: u32 = 10;

/// Spreads the low 10 bits of `v` to every third bit.
#[inline]
fn spread(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    x = (x | (x << 2)) & 0x0924_9249;
    x
}

/// The 30-bit Morton code of `c` in the grid of `2^10` cells per axis over `lo + [0, 1/scale]`.
#[inline]
fn morton(c: Vec3A, lo: Vec3A, scale: Vec3A) -> u32 {
    let top = ((1u32 << BITS) - 1) as f32;
    let q = ((c - lo) * scale).clamp(Vec3A::ZERO, Vec3A::splat(top));
    spread(q.x as u32) << 2 | spread(q.y as u32) << 1 | spread(q.z as u32)
}

/// The triangles sorted by `(code, index)`: keys `code << 32 | index`, unique.
fn sorted_keys(centroids: &[Vec3A]) -> Vec<u64> {
    let fold = |cs: &[Vec3A]| {
        cs.iter().fold(Aabb::EMPTY, |mut b, &c| {
            b.grow(c);
            b
        })
    };
    let cb = if centroids.len() >= PAR_NODE_THRESHOLD {
        centroids
            .par_chunks(8192)
            .map(fold)
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    } else {
        fold(centroids)
    };
    let extent = cb.max - cb.min;
    let cells = (1u32 << BITS) as f32;
    let scale = Vec3A::from_array(std::array::from_fn(|a| {
        if extent[a] > 0.0 {
            cells / extent[a]
        } else {
            0.0
        }
    }));
    let key = |(i, &c): (usize, &Vec3A)| (u64::from(morton(c, cb.min, scale)) << 32) | i as u64;
    let mut keys: Vec<u64> = if centroids.len() >= PAR_NODE_THRESHOLD {
        centroids.par_iter().enumerate().map(key).collect()
    } else {
        centroids.iter().enumerate().map(key).collect()
    };
    if keys.len() >= PAR_NODE_THRESHOLD {
        keys.par_sort_unstable();
    } else {
        keys.sort_unstable();
    }
    keys
}

/// Cuts the sorted keys into clusters of at most `size` by radix splits (the first bit, from
/// the top, where a range's codes differ); ranges of equal codes are cut into runs of `size`.
/// Returns the clusters' end offsets, in order.
fn clusters(keys: &[u64], size: usize) -> Vec<u32> {
    let mut ends = Vec::with_capacity(keys.len() / size.max(1) * 2 + 1);
    // (start, end, bit to split at next); popped in order: right pushed first.
    let mut stack = vec![(0usize, keys.len(), 3 * BITS as i32 - 1)];
    while let Some((lo, hi, mut bit)) = stack.pop() {
        if hi - lo <= size {
            ends.push(hi as u32);
            continue;
        }
        let mut cut = None;
        while bit >= 0 {
            let m = 1u64 << (32 + bit);
            let at = lo + keys[lo..hi].partition_point(|&k| k & m == 0);
            bit -= 1;
            if at > lo && at < hi {
                cut = Some(at);
                break;
            }
        }
        match cut {
            Some(at) => {
                stack.push((at, hi, bit));
                stack.push((lo, at, bit));
            }
            None => {
                // Equal codes: runs of `size` in index order.
                let mut s = lo;
                while s < hi {
                    s = (s + size).min(hi);
                    ends.push(s as u32);
                }
            }
        }
    }
    ends
}

fn build_tree(input: &BuildInput, cfg: &ClusterBinnedConfig) -> Bvh {
    let bounds = input.bounds();
    let keys = sorted_keys(input.centroids());
    let ends = clusters(&keys, cfg.cluster_size);
    let make = |&k: &u64| {
        let id = k as u32;
        PrimRef::new(&bounds[id as usize], id)
    };
    let mut tris: Vec<PrimRef> = if keys.len() >= PAR_NODE_THRESHOLD {
        keys.par_iter().map(make).collect()
    } else {
        keys.iter().map(make).collect()
    };
    drop(keys);
    // The clusters' triangle slices, to be taken by the node that holds the cluster alone.
    let mut slices: Vec<Option<&mut [PrimRef]>> = Vec::with_capacity(ends.len());
    let mut rest: &mut [PrimRef] = &mut tris;
    let mut start = 0u32;
    for &end in &ends {
        let (head, tail) = rest.split_at_mut((end - start) as usize);
        slices.push(Some(head));
        rest = tail;
        start = end;
    }
    let cluster_ref = |(c, s): (usize, &Option<&mut [PrimRef]>)| {
        let s = s.as_deref().expect("every cluster is there");
        let b = s.iter().fold(Aabb::EMPTY, |b, r| b.union(&r.bounds()));
        PrimRef::new(&b, c as u32)
    };
    let mut crefs: Vec<PrimRef> = if slices.len() >= PAR_NODE_THRESHOLD / 8 {
        slices.par_iter().enumerate().map(cluster_ref).collect()
    } else {
        slices.iter().enumerate().map(cluster_ref).collect()
    };
    let counts: Vec<u32> = slices
        .iter()
        .map(|s| s.as_deref().map_or(0, <[PrimRef]>::len) as u32)
        .collect();
    let rule = ClusterRule {
        always_leaf: cfg.always_leaf,
        inner: BinnedRule::new(
            input,
            cfg.bins,
            cfg.max_leaf_size,
            FALLBACK_DEPTH,
            FillBackend::Simd,
        ),
        bins: cfg.bins,
        counts: &counts,
        slices: Mutex::new(slices),
    };
    let nb = ref_bounds(&crefs);
    let root = Task::Clusters {
        n: input.len(),
        refs: &mut crefs,
        nb,
    };
    topdown::build(&rule, root, false)
}

/// The rule: binned SAH splits of the clusters while a node holds more than one (never a leaf),
/// then the binned rule over the triangles of the one cluster left.
struct ClusterRule<'a> {
    always_leaf: usize,
    inner: BinnedRule<'a>,
    bins: usize,
    counts: &'a [u32],
    slices: Mutex<Vec<Option<&'a mut [PrimRef]>>>,
}

/// A node still to build: clusters (with their number of triangles), or triangles.
enum Task<'a> {
    Clusters {
        n: usize,
        refs: &'a mut [PrimRef],
        nb: RefBounds,
    },
    Prims(BinTask<'a>),
}

impl<'a> ClusterRule<'a> {
    fn triangles(&self, refs: &[PrimRef]) -> usize {
        refs.iter()
            .map(|r| self.counts[r.id() as usize] as usize)
            .sum()
    }

    /// The binned rule's step over triangles, or a leaf without a search for a small node.
    fn prims(&self, p: BinTask<'a>, scratch: &mut Scratch) -> Step<Task<'a>> {
        if p.refs.len() <= self.always_leaf {
            return Step::Leaf {
                bounds: p.nb.bounds,
                task: Task::Prims(p),
            };
        }
        self.inner.split(p, scratch).map(Task::Prims)
    }
}

impl<'a> Rule for ClusterRule<'a> {
    type Task = Task<'a>;
    type Scratch = Scratch;

    fn size(&self, t: &Task<'a>) -> usize {
        match t {
            Task::Clusters { n, .. } => *n,
            Task::Prims(p) => p.refs.len(),
        }
    }

    fn split(&self, t: Task<'a>, scratch: &mut Scratch) -> Step<Task<'a>> {
        let (refs, nb) = match t {
            Task::Prims(p) => return self.prims(p, scratch),
            Task::Clusters { refs, nb, .. } => (refs, nb),
        };
        if refs.len() == 1 {
            let prims = self.slices.lock().expect("slices")[refs[0].id() as usize]
                .take()
                .expect("a cluster is taken once");
            let nb = ref_bounds(prims);
            let task = BinTask {
                refs: prims,
                nb,
                depth: 0,
            };
            return self.prims(task, scratch);
        }
        let plane = best_plane(
            refs,
            &nb.centroids,
            self.bins,
            FillBackend::Simd,
            &mut scratch.plane,
        );
        let (mid, lb, rb) = split_refs(refs, plane.as_ref(), &nb, &mut scratch.wrong);
        debug_assert!(mid > 0 && mid < refs.len());
        let (left, right) = refs.split_at_mut(mid);
        let (nl, nr) = (self.triangles(left), self.triangles(right));
        Step::Split {
            bounds: nb.bounds,
            left: Task::Clusters {
                n: nl,
                refs: left,
                nb: lb,
            },
            right: Task::Clusters {
                n: nr,
                refs: right,
                nb: rb,
            },
        }
    }

    fn leaf_refs(&self, t: &Task<'a>, out: &mut Vec<u32>) {
        match t {
            Task::Prims(p) => self.inner.leaf_refs(p, out),
            Task::Clusters { .. } => unreachable!("clusters are never leaves"),
        }
    }

    fn parallel_threshold(&self) -> usize {
        self.inner.parallel_threshold()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_cover_the_keys_in_order_and_respect_the_size() {
        let keys: Vec<u64> = (0..1000u64)
            .map(|i| ((i * 7919 % 512) << 32) | i)
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        for size in [1, 3, 16, 2000] {
            let ends = clusters(&keys, size);
            assert_eq!(*ends.last().unwrap() as usize, keys.len());
            let mut start = 0;
            for &e in &ends {
                assert!(e > start && (e - start) as usize <= size);
                start = e;
            }
        }
    }

    #[test]
    fn morton_codes_interleave_x_highest() {
        let one = Vec3A::ONE;
        assert_eq!(morton(Vec3A::new(1.0, 0.0, 0.0), Vec3A::ZERO, one), 0b100);
        assert_eq!(morton(Vec3A::new(0.0, 1.0, 0.0), Vec3A::ZERO, one), 0b010);
        assert_eq!(morton(Vec3A::new(0.0, 0.0, 1.0), Vec3A::ZERO, one), 0b001);
        assert_eq!(
            morton(Vec3A::splat(1023.0), Vec3A::ZERO, one),
            (1 << 30) - 1
        );
    }
}
