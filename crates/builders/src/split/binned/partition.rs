//! The binned builder's partitions: its references moved in place to the sides of a plane
//! found by [`super::plane::best_plane`] ([`partition`]: a two-pointer scheme, its branch-free
//! twin and a parallel one for the top nodes, all making the same swaps), and its object median
//! split ([`median_split`]) where no plane separates anything.

use rayon::prelude::*;
use sahara_geom::{Aabb, Vec3A};

use super::plane::Plane;
use super::refs::{ref_bounds, PrimRef, RefBounds};
use crate::split::{float_key, PAR_CHUNK, PAR_NODE_THRESHOLD};

/// Nodes of at least this many references are partitioned in parallel (with more than one
/// thread).
const PAR_PARTITION_THRESHOLD: usize = 4 * PAR_NODE_THRESHOLD;

/// Moves the references of bins `< plane` to the front (the same swaps whatever the
/// backend and the number of threads); returns how many there are and the centroid
/// bounds of both sides. `wrong` is scratch, reused between calls.
pub fn partition(refs: &mut [PrimRef], p: &Plane, wrong: &mut Vec<u32>) -> (usize, Aabb, Aabb) {
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

/// Above this many references the median split sorts in parallel (the keys are unique, so the
/// order is the same). 64 under Miri.
const PAR_SORT_THRESHOLD: usize = if cfg!(miri) { 64 } else { 1 << 14 };

/// Object median split on the largest axis of the centroid bounds `cb`, by (centroid, index,
/// box): sorts the references and returns the size of the left half.
pub fn median_split(refs: &mut [PrimRef], cb: &Aabb) -> usize {
    let axis = cb.largest_axis();
    // The keys are unique (ids are, and the pieces of one primitive that spatial splits make
    // have different boxes), so the order does not depend on the algorithm.
    let key = |r: &PrimRef| {
        let b = r.bounds();
        (
            ((float_key(r.centroid_on(axis)) as u64) << 32) | r.id() as u64,
            [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z].map(f32::to_bits),
        )
    };
    if refs.len() > PAR_SORT_THRESHOLD {
        refs.par_sort_unstable_by_key(key);
    } else {
        refs.sort_unstable_by_key(key);
    }
    refs.len() / 2
}

/// The object split of a node's references `refs` (bounds `nb`) in place: by plane `p` when
/// there is one ([`partition`]; the sides' bounds from the plane's bins, their centroid bounds
/// from the partition), else at the object median ([`median_split`]). Returns the size of the
/// left side and both sides' bounds.
pub fn split_refs(
    refs: &mut [PrimRef],
    p: Option<&Plane>,
    nb: &RefBounds,
    wrong: &mut Vec<u32>,
) -> (usize, RefBounds, RefBounds) {
    match p {
        Some(p) => {
            let (mid, lc, rc) = partition(refs, p, wrong);
            debug_assert_eq!(mid, p.n_left);
            let side = |bounds, centroids| RefBounds { bounds, centroids };
            (mid, side(p.left, lc), side(p.right, rc))
        }
        None => {
            let mid = median_split(refs, &nb.centroids);
            (mid, ref_bounds(&refs[..mid]), ref_bounds(&refs[mid..]))
        }
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

/// [`goes_left`] of a reference, reading its centroid on the plane's axis only (the same
/// operations as `goes_left(p, r.centroid())`, without forming the other two lanes).
#[derive(Clone, Copy)]
struct Classifier {
    min: f32,
    scale: f32,
    plane: f32,
    axis: usize,
}

impl Classifier {
    fn new(p: &Plane) -> Self {
        Self {
            min: p.map.min,
            scale: p.map.scale,
            plane: p.plane as f32,
            axis: p.axis,
        }
    }

    /// Whether reference `r` goes left, exactly [`goes_left`] of its centroid.
    #[inline(always)]
    fn left(&self, r: &PrimRef) -> bool {
        // `& 3` keeps the index in the lanes without a bounds check (the axis is below 3).
        let a = self.axis & 3;
        let c = (r.min[a] + r.max[a]) * 0.5;
        let v = (c - self.min) * self.scale;
        // Negated on purpose: NaN goes left, as in `goes_left`.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let left = !(v >= self.plane);
        left
    }
}

/// The bounds of the references' centroids (a union: exact in any order but for the sign of
/// a zero).
#[inline]
fn centroid_bounds(refs: &[PrimRef]) -> Aabb {
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for r in refs {
        let c = r.centroid();
        lo = lo.min(c);
        hi = hi.max(c);
    }
    Aabb::new(lo, hi)
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
    let plane = Classifier::new(p);
    let classify = |r: &PrimRef| plane.left(r);
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
    // The centroid bounds of both sides in a second pass over the partitioned references
    // (cached at all but the top nodes): two lanes of `min` and `max` per reference instead
    // of a masked union of both sides in the classifying pass.
    Some((
        mid,
        centroid_bounds(&refs[..mid]),
        centroid_bounds(&refs[mid..]),
    ))
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

#[cfg(test)]
mod tests {
    use super::super::refs::ref_bounds;
    use super::*;
    use crate::split::BinMap;
    use sahara_geom::rng::Pcg32;

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
        let cb = ref_bounds(&refs).centroids;
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
            let cb = ref_bounds(&refs).centroids;
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
}
