//! Equal-width centroid bins (Wald 2007): the bin fill and the plane sweep that the binned
//! temporaries of the paper's builder and SBVH's binned object search use, and the binned
//! builder's searches and partitions.
//!
//! A node's items are counted into `K` bins per axis by the centroid of their box
//! ([`fill`], or [`fill_par`] for large nodes); each bin keeps the count, the union of the
//! boxes and the union of the centroids. [`sweep_planes`] then visits the `K - 1` planes of an
//! axis with the geometry of both sides; planes with an empty side are skipped. Bins are exact
//! (integer counts, min and max), so the result never depends on the order of the items or on
//! chunking.
//!
//! * [`refs`]: the binned builder's 32-byte references ([`PrimRef`]) and their bins
//!   ([`RefBins`], SIMD with a bit-identical scalar twin);
//! * [`plane`]: the binned builder's plane search over its references ([`plane::best_plane`]);
//! * [`partition`]: the binned builder's in-place partitions of its references (serial,
//!   branch-free, parallel: the same swaps) and its object median split;
//! * [`boxes`]: the cheapest plane of plain boxes by Eq. 2 and their partition (the cost-only
//!   binned temporaries of the paper's builder).

use rayon::prelude::*;
use sahara_geom::{Aabb, Vec3A};

use super::{BinMap, Suffix, PAR_CHUNK, PAR_NODE_THRESHOLD};

pub mod boxes;
pub mod partition;
pub mod plane;
pub mod refs;

pub use refs::{FillBackend, PrimRef, RefBins};

/// One bin: how many items it holds, the union of their boxes and of their centroids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bin {
    /// Union of the items' boxes.
    pub bounds: Aabb,
    /// Union of the items' centroids.
    pub centroids: Aabb,
    /// Number of items.
    pub count: u32,
}

impl Bin {
    /// A bin with nothing in it.
    pub const EMPTY: Bin = Bin {
        bounds: Aabb::EMPTY,
        centroids: Aabb::EMPTY,
        count: 0,
    };

    /// Adds an item.
    #[inline]
    pub fn add(&mut self, bounds: &Aabb, centroid: Vec3A) {
        self.count += 1;
        self.bounds.grow_aabb(bounds);
        self.centroids.grow(centroid);
    }

    /// Adds the content of another bin.
    #[inline]
    pub fn merge(&mut self, other: &Bin) {
        self.bounds.grow_aabb(&other.bounds);
        self.centroids.grow_aabb(&other.centroids);
        self.count += other.count;
    }
}

/// The bin maps of a node's three axes over its centroid bounds (`None` for a flat axis).
#[inline]
pub fn maps(centroids: &Aabb, bins: usize) -> [Option<BinMap>; 3] {
    std::array::from_fn(|a| BinMap::new(centroids.min[a], centroids.max[a], bins))
}

/// Fills `bins` (`3 × k`: axis-major) with the items `(box, centroid)`, on the axes that have
/// a map (the others are left empty). With `CENTROIDS == false` the bins' centroid bounds are
/// left empty (a third of the work of a fill, for callers that do not need them).
#[inline]
pub fn fill<'a, const CENTROIDS: bool>(
    bins: &mut [Bin],
    k: usize,
    maps: &[Option<BinMap>; 3],
    items: impl IntoIterator<Item = (&'a Aabb, Vec3A)>,
) {
    let bins = &mut bins[..3 * k];
    bins.fill(Bin::EMPTY);
    // The three bin indices at once: clamping in floating point before truncating gives
    // exactly `BinMap::bin` (the operand of a mapped axis is never negative).
    let lo = Vec3A::from_array(std::array::from_fn(|a| maps[a].map_or(0.0, |m| m.min)));
    let scale = Vec3A::from_array(std::array::from_fn(|a| maps[a].map_or(0.0, |m| m.scale)));
    let top = Vec3A::splat((k - 1) as f32);
    let on = maps.map(|m| m.is_some());
    for (b, c) in items {
        let v = ((c - lo) * scale).min(top);
        let [bx, by, bz] = v.to_array();
        for (on, i) in on
            .into_iter()
            .zip([bx as usize, k + by as usize, 2 * k + bz as usize])
        {
            if on {
                let bin = &mut bins[i];
                bin.count += 1;
                bin.bounds.grow_aabb(b);
                if CENTROIDS {
                    bin.centroids.grow(c);
                }
            }
        }
    }
}

/// [`fill`] over primitive ids, in parallel chunks of [`PAR_CHUNK`] for nodes of at least
/// [`PAR_NODE_THRESHOLD`] primitives (exact, so the chunking changes nothing).
pub fn fill_par(
    bins: &mut [Bin],
    k: usize,
    maps: &[Option<BinMap>; 3],
    ids: &[u32],
    bounds: &[Aabb],
    centroids: &[Vec3A],
) {
    let item = |&p: &u32| (&bounds[p as usize], centroids[p as usize]);
    if ids.len() < PAR_NODE_THRESHOLD {
        fill::<true>(bins, k, maps, ids.iter().map(item));
        return;
    }
    let merged = ids
        .par_chunks(PAR_CHUNK)
        .map(|chunk| {
            let mut local = vec![Bin::EMPTY; 3 * k];
            fill::<true>(&mut local, k, maps, chunk.iter().map(item));
            local
        })
        .reduce(
            || vec![Bin::EMPTY; 3 * k],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    x.merge(y);
                }
                a
            },
        );
    bins[..3 * k].copy_from_slice(&merged);
}

/// Visits the planes `1..k` of one axis's `k` bins: the suffix (right side) right to left into
/// `right[1..k]`, then `visit(plane, left_bounds, n_left, right, n_right)` left to right for
/// every plane with items on both sides.
#[inline]
pub fn sweep_planes<S: Suffix>(
    bins: &[Bin],
    right: &mut [(S, u32)],
    mut visit: impl FnMut(usize, &Aabb, usize, &S, usize),
) {
    let k = bins.len();
    let mut acc = Aabb::EMPTY;
    let mut rc = 0u32;
    for i in (1..k).rev() {
        acc.grow_aabb(&bins[i].bounds);
        rc += bins[i].count;
        right[i] = (S::of(&acc), rc);
    }
    let mut lb = Aabb::EMPTY;
    let mut lc = 0u32;
    for i in 1..k {
        lb.grow_aabb(&bins[i - 1].bounds);
        lc += bins[i - 1].count;
        let (r, rc) = &right[i];
        if lc == 0 || *rc == 0 {
            continue;
        }
        visit(i, &lb, lc as usize, r, *rc as usize);
    }
}

/// The merged content of the bins below `plane` and of the others.
pub fn sides(bins: &[Bin], plane: usize) -> (Bin, Bin) {
    let mut left = Bin::EMPTY;
    let mut right = Bin::EMPTY;
    for b in &bins[..plane] {
        left.merge(b);
    }
    for b in &bins[plane..] {
        right.merge(b);
    }
    (left, right)
}
