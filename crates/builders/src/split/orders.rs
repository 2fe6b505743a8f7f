//! The centroid-sorted orders of a node and their stable partitions: what keeps the orders
//! of the full sweep ([`super::sweep`]) sorted through a split without sorting again.
//!
//! [`sorted_orders`] sorts a set of primitives by centroid on each axis; [`split_orders`]
//! (into new arrays) and [`partition_in_place`] split a node's three orders by a candidate of
//! one of them, each side keeping the order of every axis, with a flag per primitive
//! ([`Marks`]).

use std::sync::atomic::{AtomicBool, Ordering};

use sahara_geom::Vec3A;

use super::{sort_by_key, PAR_AXES_THRESHOLD};

/// The three sorted orders of a subset of primitives: `ids` sorted by centroid along x, y and
/// z, each by the total order of `f32::total_cmp` with ties broken by the primitive id. Runs
/// the three sorts in parallel.
pub fn sorted_orders(centroids: &[Vec3A], ids: &[u32]) -> [Vec<u32>; 3] {
    let sort_axis = |axis: usize| {
        let mut keys = Vec::new();
        sort_by_key(&mut keys, ids.len(), |i| {
            (centroids[ids[i] as usize][axis], ids[i])
        });
        keys.into_iter().map(|k| k as u32).collect::<Vec<u32>>()
    };
    let (x, (y, z)) = rayon::join(
        || sort_axis(0),
        || rayon::join(|| sort_axis(1), || sort_axis(2)),
    );
    [x, y, z]
}

/// One flag per primitive id, shareable between threads that work on disjoint sets of ids
/// (relaxed atomics, which cost nothing on common hardware).
///
/// [`split_orders`] and [`partition_in_place`] set flags while they partition
/// and clear them again before returning, so a `Marks` with every flag clear can be reused for
/// any number of calls, and concurrent calls on disjoint id sets may share one.
pub struct Marks {
    flags: Vec<AtomicBool>,
}

impl Marks {
    /// `len` clear flags, for ids `0..len`.
    pub fn new(len: usize) -> Self {
        Self {
            flags: (0..len).map(|_| AtomicBool::new(false)).collect(),
        }
    }

    /// Makes room for ids `0..len` (new flags are clear; never shrinks).
    pub fn reserve_ids(&mut self, len: usize) {
        if self.flags.len() < len {
            self.flags.resize_with(len, || AtomicBool::new(false));
        }
    }

    /// Number of flags.
    pub fn len(&self) -> usize {
        self.flags.len()
    }

    /// True when there is no flag.
    pub fn is_empty(&self) -> bool {
        self.flags.is_empty()
    }

    /// Sets flag `id` to `value`.
    #[inline]
    pub fn set(&self, id: u32, value: bool) {
        self.flags[id as usize].store(value, Ordering::Relaxed);
    }

    /// Flag `id`.
    #[inline]
    pub fn get(&self, id: u32) -> bool {
        self.flags[id as usize].load(Ordering::Relaxed)
    }

    /// Sets the flags of `ids` to `value`.
    #[inline]
    pub(crate) fn set_all(&self, ids: &[u32], value: bool) {
        for &id in ids {
            self.set(id, value);
        }
    }
}

impl Default for Marks {
    /// No flags (see [`Marks::reserve_ids`]).
    fn default() -> Self {
        Self::new(0)
    }
}

impl std::fmt::Debug for Marks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Marks").field("len", &self.len()).finish()
    }
}

/// Splits the sorted orders of a node by a candidate into new arrays: the first `pos` ids of
/// `orders[axis]` go left, the rest right; `left[a]` and `right[a]` receive the ids of each
/// side in the order of `orders[a]` (a stable partition, so they stay sorted). `left` slices
/// must hold `pos` ids and `right` slices `n - pos`. `marks` must cover every id and have the
/// ids' flags clear; they are clear again on return.
///
/// # Panics
/// If the slice lengths do not match, or `pos` is not in `1..n`.
pub fn split_orders(
    orders: [&[u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    left: [&mut [u32]; 3],
    right: [&mut [u32]; 3],
) {
    split_orders_into::<0>(orders, axis, pos, marks, left, right);
}

/// [`split_orders`] into buffers one id longer than the sides (`left[k].len() == pos + 1`,
/// `right[k].len() == n - pos + 1`; the last id of each is scratch), without a branch per id:
/// on the orders not split, whether an id goes left is not predictable, so each id is written
/// at both cursors and only its side's cursor advances (the other write is overwritten later,
/// or lands in the spare last slot). The split order itself is copied.
pub(crate) fn split_orders_padded(
    orders: [&[u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    left: [&mut [u32]; 3],
    right: [&mut [u32]; 3],
) {
    split_orders_into::<1>(orders, axis, pos, marks, left, right);
}

/// [`split_orders`] (`PAD == 0`, exact buffers, a branch per id) or
/// [`split_orders_padded`] (`PAD == 1`).
fn split_orders_into<const PAD: usize>(
    orders: [&[u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    left: [&mut [u32]; 3],
    right: [&mut [u32]; 3],
) {
    let n = orders[axis].len();
    assert!(pos > 0 && pos < n, "split position {pos} outside 1..{n}");
    marks.set_all(&orders[axis][..pos], true);
    for (k, ((order, l), r)) in orders.iter().zip(left).zip(right).enumerate() {
        assert_eq!(order.len(), n);
        assert_eq!(l.len(), pos + PAD);
        assert_eq!(r.len(), n - pos + PAD);
        let (mut li, mut ri) = (0, 0);
        if PAD == 0 {
            for &id in order.iter() {
                if marks.get(id) {
                    l[li] = id;
                    li += 1;
                } else {
                    r[ri] = id;
                    ri += 1;
                }
            }
        } else if k == axis {
            l[..pos].copy_from_slice(&order[..pos]);
            r[..n - pos].copy_from_slice(&order[pos..]);
            li = pos;
        } else {
            for &id in order.iter() {
                let m = marks.get(id) as usize;
                // `li <= pos` and `ri <= n - pos` before every write (each counts the ids of
                // its side seen so far), inside the padded buffers.
                l[li] = id;
                r[ri] = id;
                li += m;
                ri += 1 - m;
            }
        }
        assert_eq!(li, pos, "orders do not hold the same ids");
    }
    marks.set_all(&orders[axis][..pos], false);
}

/// Stable partition of a node's orders in place by a split: the first `pos` ids of
/// `orders[axis]` stay in front on every axis, in their order. `tmp.len() >= n`.
pub fn partition_in_place(
    orders: &mut [&mut [u32]; 3],
    axis: usize,
    pos: usize,
    marks: &Marks,
    tmp: &mut [u32],
) {
    marks.set_all(&orders[axis][..pos], true);
    // The marked ids to the front, the others (through `tmp`) behind them, in order. Without
    // a branch on the flag (it is unpredictable on the orders not split): each id is written
    // to both places and only the cursor of its side advances. A write to `order[l]` never
    // overtakes the read (`l <= j`), and what an unmarked id leaves at `order[l]` is
    // overwritten later (by a marked id, or by the copy of `tmp` when `l == pos`). `tmp` needs
    // room for `n` ids: a marked id is written at `tmp[r]` with `r <= n - pos`.
    let part = |order: &mut [u32], tmp: &mut [u32]| {
        let n = order.len();
        let tmp = &mut tmp[..n];
        let (mut l, mut r) = (0, 0);
        for j in 0..n {
            let id = order[j];
            let m = marks.get(id) as usize;
            // SAFETY: `l + r == j < n` before the writes (each step advances one of them), and
            // both slices hold `n` ids.
            unsafe {
                *order.get_unchecked_mut(l) = id;
                *tmp.get_unchecked_mut(r) = id;
            }
            l += m;
            r += 1 - m;
        }
        debug_assert_eq!(l, pos);
        order[pos..].copy_from_slice(&tmp[..r]);
    };
    let [o0, o1, o2] = orders;
    let (a, b): (&mut [u32], &mut [u32]) = match axis {
        0 => (&mut **o1, &mut **o2),
        1 => (&mut **o0, &mut **o2),
        _ => (&mut **o0, &mut **o1),
    };
    if a.len() >= PAR_AXES_THRESHOLD && rayon::current_num_threads() > 1 {
        // Both orders at once (the marks are only read), the second through its own buffer.
        let mut tmp2 = vec![0u32; b.len()];
        rayon::join(|| part(a, tmp), || part(b, &mut tmp2));
    } else {
        part(a, tmp);
        part(b, tmp);
    }
    marks.set_all(&orders[axis][..pos], false);
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::rng::Pcg32;

    /// Three random orders of the ids `0..n` (`n >= 2`), the split axis and a random split
    /// position in `1..n`.
    fn random_split(rng: &mut Pcg32, n: usize, axis: usize) -> (Vec<Vec<u32>>, usize, usize) {
        let mut base: Vec<Vec<u32>> = (0..3).map(|_| (0..n as u32).collect()).collect();
        for o in base.iter_mut() {
            for i in (1..n).rev() {
                o.swap(i, rng.next_u32() as usize % (i + 1));
            }
        }
        let pos = 1 + rng.next_u32() as usize % (n - 1);
        (base, axis, pos)
    }

    /// The three orders of `v` as mutable slices.
    fn slices(v: &mut [Vec<u32>]) -> [&mut [u32]; 3] {
        let [a, b, c] = v else { unreachable!() };
        [a, b, c]
    }

    /// The in-place stable partition equals a plain filter of each order.
    #[test]
    fn padded_split_equals_split_orders() {
        let mut rng = Pcg32::new(13, 4);
        for case in 0..200 {
            let n = 2 + (rng.next_u32() % 300) as usize;
            let (base, axis, pos) = random_split(&mut rng, n, case % 3);
            let orders = [&base[0][..], &base[1][..], &base[2][..]];
            let marks = Marks::new(n);
            let mut want_l = vec![vec![0u32; pos]; 3];
            let mut want_r = vec![vec![0u32; n - pos]; 3];
            split_orders(
                orders,
                axis,
                pos,
                &marks,
                slices(&mut want_l),
                slices(&mut want_r),
            );
            let mut got_l = vec![vec![0u32; pos + 1]; 3];
            let mut got_r = vec![vec![0u32; n - pos + 1]; 3];
            let (l, r) = (slices(&mut got_l), slices(&mut got_r));
            split_orders_padded(orders, axis, pos, &marks, l, r);
            for k in 0..3 {
                assert_eq!(got_l[k][..pos], want_l[k][..], "case {case}, left {k}");
                assert_eq!(got_r[k][..n - pos], want_r[k][..], "case {case}, right {k}");
            }
            assert!((0..n as u32).all(|id| !marks.get(id)), "marks left set");
        }
    }

    #[test]
    fn partition_in_place_is_a_stable_partition() {
        let mut rng = Pcg32::new(11, 2);
        for case in 0..200 {
            let n = if case == 0 {
                PAR_AXES_THRESHOLD + 7
            } else {
                2 + (rng.next_u32() % 300) as usize
            };
            let (mut base, axis, pos) = random_split(&mut rng, n, case % 3);
            let left: Vec<u32> = base[axis][..pos].to_vec();
            let want: Vec<Vec<u32>> = base
                .iter()
                .map(|o| {
                    let (mut l, r): (Vec<u32>, Vec<u32>) =
                        o.iter().partition(|id| left.contains(id));
                    l.extend(r);
                    l
                })
                .collect();
            let marks = Marks::new(n);
            let mut tmp = vec![0u32; n];
            let mut orders = slices(&mut base);
            partition_in_place(&mut orders, axis, pos, &marks, &mut tmp);
            assert_eq!(base, want, "case {case}, n = {n}, axis {axis}, pos {pos}");
            assert!((0..n as u32).all(|id| !marks.get(id)), "marks left set");
        }
    }
}
