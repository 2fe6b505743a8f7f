//! The binned builder's plane search (Wald 2007): `k` equal-width bins over a node's centroid
//! bounds on each axis, the plane of least Eq. 2 cost over the three axes ([`best_plane`]),
//! ranked by its score `A_l n_l + A_r n_r` (the order of Eq. 2 without a division per plane)
//! with the tie-break of every search ([`ranks_before`]). Nodes of two references and nodes of
//! at most twice as many references as bins take shortcuts that find the same plane, bit for bit.

use sahara_geom::{Aabb, Vec3A};

use super::refs::{FillBackend, PrimRef, RefBins};
use crate::split::{imbalance, ranks_before, BinMap};

/// Reusable buffers of [`best_plane`]: the bins of three axes and the suffix sweep; for small
/// nodes, the bins of the occupied bins only.
#[derive(Debug, Default)]
pub struct PlaneScratch {
    bins: RefBins,
    right: Vec<([f32; 4], [u32; 4])>,
    sparse: SparseBins,
}

/// One bin of [`SparseBins`]: the union of its references' boxes (lanes `x, y, z`; the
/// fourth is zero) and their count.
#[derive(Clone, Copy, Debug)]
struct Slot {
    min: [f32; 4],
    max: [f32; 4],
    count: u32,
}

impl Slot {
    const EMPTY: Slot = Slot {
        min: super::refs::EMPTY_MIN,
        max: super::refs::EMPTY_MAX,
        count: 0,
    };
}

/// The bins of [`best_plane_sparse`]: 64 per axis (the most bins it takes), all empty between
/// two searches (a search empties the bins it filled, which a bit mask per axis records).
/// Fixed arrays, indexed by `bin & 63` (every bin is below 64): no bounds check on the
/// search's hottest accesses.
#[derive(Debug)]
struct SparseBins {
    bins: Box<[[Slot; 64]; 3]>,
}

impl Default for SparseBins {
    fn default() -> Self {
        Self {
            bins: Box::new([[Slot::EMPTY; 64]; 3]),
        }
    }
}

impl SparseBins {
    /// Bin `b` of axis `axis`.
    #[inline(always)]
    fn at(&mut self, axis: usize, b: usize) -> &mut Slot {
        &mut self.bins[axis % 3][b & 63]
    }

    /// Empties the bins of `masks`.
    fn empty(&mut self, masks: &[u64; 3]) {
        for (axis, &mask) in masks.iter().enumerate() {
            let mut bits = mask;
            while bits != 0 {
                *self.at(axis, bits.trailing_zeros() as usize) = Slot::EMPTY;
                bits &= bits - 1;
            }
        }
    }
}

/// The best plane found by binning, with the bounds of both sides.
#[derive(Clone, Copy, Debug)]
pub struct Plane {
    /// The axis.
    pub axis: usize,
    /// Primitives in bins `< plane` go left.
    pub plane: usize,
    /// The bins of the axis.
    pub map: BinMap,
    /// Primitives going left.
    pub n_left: usize,
    /// Bounds of the left side.
    pub left: Aabb,
    /// Bounds of the right side.
    pub right: Aabb,
}

/// A plane under consideration: its score `A_l n_l + A_r n_r` (which orders the planes of one
/// node as Eq. 2 does, without a division per plane) and its tie-break.
#[derive(Clone, Copy)]
struct RatedPlane {
    axis: usize,
    plane: usize,
    score: f64,
    imbalance: usize,
}

impl RatedPlane {
    #[inline]
    fn better_than(&self, o: &RatedPlane) -> bool {
        ranks_before(
            self.score,
            || (self.imbalance, self.axis, self.plane),
            o.score,
            || (o.imbalance, o.axis, o.plane),
        )
    }
}

/// The plane of least Eq. 2 cost over the three axes (ties: see [`ranks_before`]); `None`
/// when no plane has primitives on both sides.
pub fn best_plane(
    refs: &[PrimRef],
    cb: &Aabb,
    k: usize,
    backend: FillBackend,
    s: &mut PlaneScratch,
) -> Option<Plane> {
    let maps = super::maps(cb, k);
    if maps.iter().all(Option::is_none) {
        return None;
    }
    if refs.len() == 2 {
        best_plane_of_two(refs, &maps, k)
    } else if refs.len() <= 2 * k && k <= 64 {
        best_plane_sparse(refs, &maps, k, s)
    } else {
        best_plane_binned(refs, &maps, k, backend, s)
    }
}

/// [`best_plane`] by the bins.
fn best_plane_binned(
    refs: &[PrimRef],
    maps: &[Option<BinMap>; 3],
    k: usize,
    backend: FillBackend,
    s: &mut PlaneScratch,
) -> Option<Plane> {
    s.bins.fill_par(k, maps, refs, backend);
    let mut best: Option<RatedPlane> = None;
    // An axis without a map has empty bins, so it offers no plane. The planes come plane
    // by plane rather than axis by axis; the best of a strict total order is the same.
    s.bins
        .sweep_axes(&mut s.right, |axis, plane, la, lc, ra, rc| {
            let cand = RatedPlane {
                axis,
                plane,
                score: la * lc as f64 + ra as f64 * rc as f64,
                imbalance: imbalance(lc, rc),
            };
            if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                best = Some(cand);
            }
        });
    let RatedPlane { axis, plane, .. } = best?;
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

/// [`best_plane`] for a node of two references (a third of all nodes),
/// without bins. Bit for bit [`best_plane_sparse`] and
/// [`best_plane_binned`]:
///
/// * an axis offers a plane only when the two references fall into different bins, and
///   then exactly one (the first after the lower bin), with one reference on each side;
/// * so every offered plane has the score `A_a + A_b` of the two boxes' half areas, in one
///   order or the other (`f64` addition commutes bit for bit), and the same imbalance: the
///   tie goes to the first such axis;
/// * each side's bounds are one reference's box, as the bins' unions of one box are.
fn best_plane_of_two(refs: &[PrimRef], maps: &[Option<BinMap>; 3], k: usize) -> Option<Plane> {
    debug_assert_eq!(refs.len(), 2);
    let top = (k - 1) as f32;
    let (lo4, scale4) = super::refs::map_lanes(maps);
    let i0 = super::refs::bin_indices(&refs[0], lo4, scale4, top);
    let i1 = super::refs::bin_indices(&refs[1], lo4, scale4, top);
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

/// [`best_plane`] for nodes of at most twice as many primitives as bins (and at most 64
/// bins): many bins are empty, so only the occupied ones are filled (a bit mask per axis says
/// which) and swept, and only the first plane after each occupied bin is rated. Bit for bit
/// [`best_plane_binned`]:
///
/// * an occupied bin holds the same union in the same operand order (the first reference
///   stored as is equals `min(+inf, r)`, `max(-inf, r)`), and an empty bin is the neutral
///   element of the sweep's unions (every box of a build is finite), so skipping it changes
///   no bit of the sides;
/// * the planes `a + 1 ..= b` between occupied bins `a < b` make the same partition with
///   the same bounds and score, and the full sweep keeps the first of them (ties need a
///   strictly better rank, and a later plane ranks after).
fn best_plane_sparse(
    refs: &[PrimRef],
    maps: &[Option<BinMap>; 3],
    k: usize,
    s: &mut PlaneScratch,
) -> Option<Plane> {
    debug_assert!(k <= 64);
    let sp = &mut s.sparse;
    let top = (k - 1) as f32;
    let (lo4, scale4) = super::refs::map_lanes(maps);
    let on = maps.map(|m| m.is_some());
    let mut masks = [0u64; 3];
    for r in refs {
        let mut lo = r.min;
        lo[3] = 0.0;
        let idx = super::refs::bin_indices(r, lo4, scale4, top);
        for axis in 0..3 {
            if !on[axis] {
                continue;
            }
            let b = idx[axis] as usize;
            // No branch on whether the bin was empty: an empty bin is the neutral element
            // (`min(+inf, x)` is `x` bit for bit, as `minps` returns its second operand
            // unless the first is smaller), and bins are emptied again after the search.
            masks[axis] |= 1 << b;
            let bin = sp.at(axis, b);
            bin.min = super::refs::min4(bin.min, lo);
            bin.max = super::refs::max4(bin.max, r.max);
            bin.count += 1;
        }
    }
    let mut best: Option<RatedPlane> = None;
    let mut occupied = [0u8; 64];
    let mut right = [(0.0f32, 0u32); 64];
    for (axis, &mask) in masks.iter().enumerate() {
        if mask.count_ones() < 2 {
            continue;
        }
        let mut m = 0;
        let mut bits = mask;
        while bits != 0 {
            occupied[m & 63] = bits.trailing_zeros() as u8;
            bits &= bits - 1;
            m += 1;
        }
        let bins = &sp.bins[axis];
        let bin = |j: usize| &bins[occupied[j & 63] as usize & 63];
        // Suffixes: right[j] is the union of occupied bins j.. (descending, as the sweep).
        let (mut lo, mut hi, mut rc) = (super::refs::EMPTY_MIN, super::refs::EMPTY_MAX, 0u32);
        for j in (1..m).rev() {
            let b = bin(j);
            lo = super::refs::min4(lo, b.min);
            hi = super::refs::max4(hi, b.max);
            rc += b.count;
            right[j & 63] = (super::refs::half_area4(&lo, &hi), rc);
        }
        let (mut lo, mut hi, mut lc) = (super::refs::EMPTY_MIN, super::refs::EMPTY_MAX, 0u32);
        for j in 1..m {
            let b = bin(j - 1);
            lo = super::refs::min4(lo, b.min);
            hi = super::refs::max4(hi, b.max);
            lc += b.count;
            let (ra, rc) = right[j & 63];
            let cand = RatedPlane {
                axis,
                plane: occupied[(j - 1) & 63] as usize + 1,
                score: super::refs::half_area4(&lo, &hi) as f64 * lc as f64 + ra as f64 * rc as f64,
                imbalance: imbalance(lc as usize, rc as usize),
            };
            if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                best = Some(cand);
            }
        }
    }
    let Some(RatedPlane { axis, plane, .. }) = best else {
        sp.empty(&masks);
        return None;
    };
    let (mut l, mut r) = (
        (super::refs::EMPTY_MIN, super::refs::EMPTY_MAX),
        (super::refs::EMPTY_MIN, super::refs::EMPTY_MAX),
    );
    let mut n_left = 0;
    let mut bits = masks[axis];
    while bits != 0 {
        let b = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let bin = *sp.at(axis, b);
        let side = if b < plane {
            n_left += bin.count as usize;
            &mut l
        } else {
            &mut r
        };
        side.0 = super::refs::min4(side.0, bin.min);
        side.1 = super::refs::max4(side.1, bin.max);
    }
    sp.empty(&masks);
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

#[cfg(test)]
mod tests {
    use super::super::refs::ref_bounds;
    use super::*;
    use sahara_geom::rng::Pcg32;
    use sahara_geom::Triangle;

    /// The references of primitives `prims` of `tris`, in that order.
    fn refs_of(tris: &[Triangle], prims: &[u32]) -> Vec<PrimRef> {
        prims
            .iter()
            .map(|&p| PrimRef::new(&tris[p as usize].bounds(), p))
            .collect()
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
        let mut found = 0;
        for bins in [2, 8, 32, 128] {
            let mut s = PlaneScratch::default();
            for _ in 0..2000 {
                let prims = refs_of(&tris, &[rng.below(64), rng.below(64)]);
                let maps = super::super::maps(&ref_bounds(&prims).centroids, bins);
                if maps.iter().all(Option::is_none) {
                    continue;
                }
                let fast = best_plane_of_two(&prims, &maps, bins);
                found += usize::from(fast.as_ref().is_some_and(|p| p.axis > 0));
                let full = best_plane_binned(&prims, &maps, bins, FillBackend::Simd, &mut s);
                same_plane(fast, full);
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
        for bins in [16, 32, 64] {
            let mut s = PlaneScratch::default();
            for trial in 0..200 {
                let n = 2 + trial % (2 * bins - 1);
                let prims: Vec<u32> = (0..n).map(|_| rng.below(64)).collect();
                let prims = refs_of(&tris, &prims);
                let cb = ref_bounds(&prims).centroids;
                let maps = super::super::maps(&cb, bins);
                let a = best_plane_sparse(&prims, &maps, bins, &mut s);
                let b = best_plane_binned(&prims, &maps, bins, FillBackend::Simd, &mut s);
                if n == 2 {
                    same_plane(best_plane_of_two(&prims, &maps, bins), b);
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
