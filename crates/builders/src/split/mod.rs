//! The split search: the one place where candidate splits of a node are enumerated and
//! ordered. Every builder, every temporary subtree and every estimate uses it.
//!
//! * [`sweep`]: the full sweep over centroid-sorted orders (all `n - 1` positions of each
//!   axis);
//! * [`orders`]: the sorted orders themselves and their stable partitions ([`orders::Marks`]:
//!   a flag per primitive);
//! * [`binned`]: equal-width centroid bins (one fill, one plane sweep);
//! * [`spatial`]: spatial-split binning with reference clipping (SBVH), its cheap box estimate,
//!   and the application of a spatial split (clipping, reference unsplitting);
//!
//! and here the pieces they share: [`BinMap`] (equal-width bins on one axis), [`float_key`]
//! (sortable keys of floats), [`imbalance`] and [`ranks_before`] (the tie-break every search
//! uses) and [`offer`] (keep the `k` best candidates).
//!
//! The searches enumerate candidates and report their geometry (the bounds, areas and counts
//! of both sides) to a visitor; what a candidate is worth (Eq. 2, a temporary subtree, a
//! look-ahead) is the caller's business. This is what lets the paper's builders rate the same
//! candidates as the greedy builders by another cost without a second copy of the search.
//!
//! # Tie-breaks
//!
//! Every search orders the candidates of a node by a value (a cost or an area-count score),
//! then, on an exact tie, by [`imbalance`] (the more balanced split first), then by axis, then
//! by position ([`ranks_before`]). It is a total order on the candidates of one node, so the
//! choice never depends on evaluation order, chunking or thread count.

pub mod binned;
pub mod object;
pub mod orders;
pub mod spatial;
pub mod sweep;

use sahara_geom::Aabb;

// Under Miri the parallel thresholds and chunks below are a few dozen references, so that the
// inputs Miri can afford (hundreds of triangles) take the parallel paths: the same code, only
// where it starts differs, and the trees are the same (`tests/miri.rs` checks them against
// fingerprints recorded outside Miri; docs/robustness.md lists every such difference).

/// Nodes with at least this many primitives bin and bound in parallel (in chunks of
/// [`PAR_CHUNK`]). 64 under Miri.
pub const PAR_NODE_THRESHOLD: usize = if cfg!(miri) { 64 } else { 32 * 1024 };

/// Chunk size of parallel reductions over primitives. Fixed, so that chunking never depends
/// on the number of threads (and the reductions are exact anyway: integer sums, min and max).
/// 16 under Miri.
pub const PAR_CHUNK: usize = if cfg!(miri) { 16 } else { 8 * 1024 };

/// Nodes with at least this many references search their three axes in parallel. 64 under
/// Miri.
pub const PAR_AXES_THRESHOLD: usize = if cfg!(miri) { 64 } else { 8 * 1024 };

/// Half the surface area of a box in `f64` (the SAH only ever uses ratios of areas).
#[inline]
pub fn half_area(b: &Aabb) -> f64 {
    b.half_area() as f64
}

/// Equal-width bins over `[min, min + bins / scale]` on one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinMap {
    /// Lower end of bin 0.
    pub min: f32,
    /// Bins per unit length.
    pub scale: f32,
    /// Number of bins (at least 2).
    pub bins: usize,
}

impl BinMap {
    /// The mapping of `bins` bins over `[min, max]`, or `None` when there are fewer than two
    /// bins or the interval is empty, flat or so thin that its bin scale is not a finite
    /// number.
    pub fn new(min: f32, max: f32, bins: usize) -> Option<Self> {
        let extent = max - min;
        // NaN-safe: a NaN extent or scale fails these tests.
        let scale = bins as f32 / extent;
        if bins >= 2 && extent > 0.0 && scale.is_finite() && scale > 0.0 {
            Some(Self { min, scale, bins })
        } else {
            None
        }
    }

    /// The bin of coordinate `x` (clamped to `0..bins`; monotone in `x`).
    #[inline]
    pub fn bin(&self, x: f32) -> usize {
        // `as usize` saturates (negative and NaN give 0).
        (((x - self.min) * self.scale) as usize).min(self.bins - 1)
    }

    /// The position of plane `i` (the boundary between bins `i - 1` and `i`).
    #[inline]
    pub fn plane(&self, i: usize) -> f32 {
        self.min + i as f32 / self.scale
    }
}

/// An unsigned key with the order of `f32::total_cmp` (`-0.0 < +0.0`).
#[inline]
pub fn float_key(x: f32) -> u32 {
    let b = x.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The items `0..n` sorted by `(key(i), i)` in the order of `f32::total_cmp` then index, as
/// `u64` words whose low half is the item (`word as u32`). The words are unique, so the result
/// does not depend on the sorting algorithm (`keys` is reused as the buffer).
///
/// Inputs of at least [`RADIX_MIN`] items are sorted by an LSD radix sort (11-bit digits):
/// three passes over the float keys when the items come in increasing id order (the sweep's
/// presort and every caller that keys by position), else a pass per varying digit of the
/// whole word. Smaller inputs use the comparison sort. Either gives the one sorted order of
/// unique words.
pub fn sort_by_key(keys: &mut Vec<u64>, n: usize, key: impl Fn(usize) -> (f32, u32)) {
    keys.clear();
    let mut ids_increasing = true;
    let mut last: Option<u32> = None;
    keys.extend((0..n).map(|i| {
        let (k, id) = key(i);
        ids_increasing &= last.is_none_or(|l| l < id);
        last = Some(id);
        ((float_key(k) as u64) << 32) | id as u64
    }));
    if keys.len() >= RADIX_MIN {
        radix_sort_words(keys, ids_increasing);
    } else {
        keys.sort_unstable();
    }
}

/// Inputs of at least this many items are radix-sorted by [`sort_by_key`].
pub const RADIX_MIN: usize = if cfg!(miri) { 64 } else { 1024 };

/// Sorts unique words ascending with an LSD radix sort of 11-bit digits, skipping every digit
/// that all words share. With `low_increasing` (the low halves are strictly increasing in the
/// current order) only the high half is sorted: the passes are stable, so words with equal
/// high halves keep their increasing low halves.
fn radix_sort_words(keys: &mut Vec<u64>, low_increasing: bool) {
    const BITS: u32 = 11;
    const RADIX: usize = 1 << BITS;
    let first = if low_increasing { 32 } else { 0 };
    let digits: Vec<u32> = (first..64).step_by(BITS as usize).collect();
    // One counting pass for every digit.
    let mut counts = vec![[0u32; RADIX]; digits.len()];
    for &w in keys.iter() {
        for (c, &shift) in counts.iter_mut().zip(&digits) {
            c[((w >> shift) as usize) & (RADIX - 1)] += 1;
        }
    }
    let n = keys.len() as u32;
    let mut buf = vec![0u64; keys.len()];
    for (c, &shift) in counts.iter_mut().zip(&digits) {
        if c.contains(&n) {
            continue; // every word has the same digit here
        }
        let mut sum = 0u32;
        for slot in c.iter_mut() {
            let here = *slot;
            *slot = sum;
            sum += here;
        }
        for &w in keys.iter() {
            let d = ((w >> shift) as usize) & (RADIX - 1);
            buf[c[d] as usize] = w;
            c[d] += 1;
        }
        std::mem::swap(keys, &mut buf);
    }
}

/// How unbalanced a split into `n_left` and `n_right` items is (`|n_left - n_right|`). Among
/// the candidates of one node (a fixed `n_left + n_right`) it orders like `n_l² + n_r²`.
#[inline]
pub fn imbalance(n_left: usize, n_right: usize) -> usize {
    n_left.abs_diff(n_right)
}

/// The order every split search uses: `a` (value, then `(imbalance, axis, position)`) ranks
/// strictly before `b`. Values compare by `f64::total_cmp`; the tie-breaks are only computed
/// on an exact tie of the values.
#[inline]
pub fn ranks_before(
    a: f64,
    a_tie: impl FnOnce() -> (usize, usize, usize),
    b: f64,
    b_tie: impl FnOnce() -> (usize, usize, usize),
) -> bool {
    // Fast paths, equivalent to `total_cmp` for these operands (it differs from `<` only on
    // NaN and on -0.0 == +0.0, which fall through).
    if a < b {
        return true;
    }
    if a > b {
        return false;
    }
    match a.total_cmp(&b) {
        std::cmp::Ordering::Less => true,
        std::cmp::Ordering::Greater => false,
        std::cmp::Ordering::Equal => a_tie() < b_tie(),
    }
}

/// Keeps the `k` best items of a stream in `list`, sorted best first, by a strict "ranks
/// before" order (an item equal to the worst kept one is not taken).
#[inline]
pub fn offer<T>(list: &mut Vec<T>, k: usize, item: T, better: impl Fn(&T, &T) -> bool) {
    if k == 0 {
        return;
    }
    if list.len() == k {
        if !better(&item, &list[k - 1]) {
            return;
        }
        list.pop();
    }
    let pos = list
        .iter()
        .position(|x| better(&item, x))
        .unwrap_or(list.len());
    list.insert(pos, item);
}

/// What a sweep keeps of the suffix (right side) of each position: only its area, or its
/// whole box.
pub trait Suffix: Copy + Send + Sync {
    /// The suffix of an empty side.
    const EMPTY: Self;
    /// The suffix of a side with these bounds.
    fn of(bounds: &Aabb) -> Self;
    /// Half the surface area of the side, in `f64`.
    fn area(&self) -> f64;
}

impl Suffix for f32 {
    const EMPTY: Self = 0.0;
    #[inline]
    fn of(bounds: &Aabb) -> Self {
        bounds.half_area()
    }
    #[inline]
    fn area(&self) -> f64 {
        *self as f64
    }
}

impl Suffix for Aabb {
    const EMPTY: Self = Aabb::EMPTY;
    #[inline]
    fn of(bounds: &Aabb) -> Self {
        *bounds
    }
    #[inline]
    fn area(&self) -> f64 {
        half_area(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_keys_are_ordered() {
        let xs = [-3.5f32, -1.0, -0.0, 0.0, 1e-30, 2.0, 1e30];
        for w in xs.windows(2) {
            assert!(float_key(w[0]) < float_key(w[1]), "{w:?}");
        }
    }

    #[test]
    fn bins_are_monotone_and_clamped() {
        let m = BinMap::new(-1.0, 3.0, 8).unwrap();
        assert_eq!(m.bin(-1.0), 0);
        assert_eq!(m.bin(3.0), 7);
        assert_eq!(m.bin(-5.0), 0);
        assert_eq!(m.bin(1e9), 7);
        assert_eq!(m.plane(4), 1.0);
        assert!(BinMap::new(1.0, 1.0, 8).is_none());
        assert!(BinMap::new(0.0, 1.0, 1).is_none());
    }

    #[test]
    fn top_k() {
        let mut v = Vec::new();
        for x in [5, 3, 9, 1, 4, 1] {
            offer(&mut v, 3, x, |a, b| a < b);
        }
        assert_eq!(v, vec![1, 1, 3]);
    }

    #[test]
    fn ties_go_to_balance_then_axis_then_position() {
        let r = |a, at, b, bt| ranks_before(a, || at, b, || bt);
        assert!(r(1.0, (5, 2, 9), 2.0, (0, 0, 0)));
        assert!(r(1.0, (0, 2, 9), 1.0, (1, 0, 0)));
        assert!(r(1.0, (1, 0, 9), 1.0, (1, 1, 0)));
        assert!(!r(1.0, (1, 1, 3), 1.0, (1, 1, 3)));
    }

    #[test]
    fn radix_sort_equals_the_comparison_sort() {
        let mut rng = sahara_geom::rng::Pcg32::new(7, 1);
        for n in [RADIX_MIN, RADIX_MIN + 1, 5000, 70_000] {
            // Few distinct values (many ties), signed zeros, infinities.
            let xs: Vec<f32> = (0..n)
                .map(|i| match i % 7 {
                    0 => -0.0,
                    1 => 0.0,
                    2 => f32::INFINITY,
                    3 => -f32::INFINITY,
                    _ => ((rng.next_u32() % 50) as f32 - 25.0) * 0.5,
                })
                .collect();
            let perm: Vec<u32> = {
                let mut p: Vec<u32> = (0..n as u32).map(|i| i * 3 + 1).collect();
                for i in (1..n).rev() {
                    p.swap(i, rng.next_u32() as usize % (i + 1));
                }
                p
            };
            for increasing in [true, false] {
                let id = |i: usize| if increasing { i as u32 * 3 } else { perm[i] };
                let mut keys = Vec::new();
                sort_by_key(&mut keys, n, |i| (xs[i], id(i)));
                let mut want: Vec<u64> = (0..n)
                    .map(|i| ((float_key(xs[i]) as u64) << 32) | id(i) as u64)
                    .collect();
                want.sort_unstable();
                assert_eq!(keys, want, "n = {n}, ids increasing: {increasing}");
            }
        }
    }

    #[test]
    fn keys_sort_like_total_cmp_then_id() {
        let xs = [2.0f32, -0.0, 0.0, -1.0, 2.0];
        let mut keys = Vec::new();
        sort_by_key(&mut keys, xs.len(), |i| (xs[i], i as u32));
        let order: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
        assert_eq!(order, vec![3, 1, 2, 0, 4]);
    }
}
