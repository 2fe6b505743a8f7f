//! The binned builder's references: [`PrimRef`] (a primitive's box corners as four-lane
//! arrays, the id in the bits of a spare lane, partitioned in place), their bins over the three
//! axes ([`RefBins`]: SSE2 on x86-64, a scalar twin elsewhere and for tests, bit for bit the
//! same) and the bounds of a set of them ([`ref_bounds`]).

// The planted bug (`--cfg sahara_planted_bug`, issue 46) is for fuzzing builds only: cargo fuzz
// sets `--cfg fuzzing`; any other build with it fails here.
#[cfg(all(
    any(sahara_planted_bug = "kernel", sahara_planted_bug = "builder"),
    not(fuzzing)
))]
compile_error!("sahara_planted_bug plants a wrong answer: only with --cfg fuzzing (cargo fuzz)");

use rayon::prelude::*;
use sahara_geom::{Aabb, Vec3A};

use super::Bin;
use crate::split::{BinMap, PAR_CHUNK, PAR_NODE_THRESHOLD};

/// A primitive reference of the binned builder: the corners of the primitive's box as
/// four-lane arrays, 32 bytes aligned for 128-bit loads, with the primitive id in the bits of
/// the fourth lane of `min` (the fourth lane of `max` is zero). The builder partitions these
/// in place instead of chasing ids into the input's box and centroid arrays.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct PrimRef {
    /// Lower corner `x, y, z`, then the primitive id's bits.
    pub min: [f32; 4],
    /// Upper corner `x, y, z`, then `0.0`, or the bits of a spatial-split builder's cut entry
    /// plus one ([`with_cut`](Self::with_cut)).
    pub max: [f32; 4],
}

impl PrimRef {
    /// The reference of primitive `id` with box `b`.
    #[inline]
    pub fn new(b: &Aabb, id: u32) -> Self {
        Self {
            min: [b.min.x, b.min.y, b.min.z, f32::from_bits(id)],
            max: [b.max.x, b.max.y, b.max.z, 0.0],
        }
    }

    /// The primitive id.
    #[inline]
    pub fn id(&self) -> u32 {
        self.min[3].to_bits()
    }

    /// The same reference carrying `cut`, the last entry of the build's
    /// [`CutLog`](crate::split::spatial::CutLog) that cut it
    /// ([`NO_CUT`](crate::split::spatial::NO_CUT): none), kept in the fourth lane of `max`,
    /// which no search reads.
    ///
    /// # Panics
    ///
    /// In debug builds, if `cut` is neither `NO_CUT` nor below `0x7f80_0000` (so that the
    /// lane always holds a finite, non-negative `f32`).
    #[inline]
    pub fn with_cut(mut self, cut: u32) -> Self {
        let bits = cut.wrapping_add(1);
        debug_assert!(bits < 0x7f80_0000, "cut entry {cut} out of range");
        self.max[3] = f32::from_bits(bits);
        self
    }

    /// The reference's last cut entry (see [`with_cut`](Self::with_cut)).
    #[inline]
    pub fn cut(&self) -> u32 {
        self.max[3].to_bits().wrapping_sub(1)
    }

    /// The primitive's box.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            Vec3A::new(self.min[0], self.min[1], self.min[2]),
            Vec3A::new(self.max[0], self.max[1], self.max[2]),
        )
    }

    /// The centre of the box, exactly [`Aabb::centroid`] (`(min + max) * 0.5` per axis).
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of the x86-64 baseline; both loads read a 16-byte aligned
            // `[f32; 4]` of the reference. The fourth lanes (id and cut bits, often subnormal,
            // which would cost a microcode assist in the addition) are replaced by the third
            // before any arithmetic, so every lane is what `Vec3A::new(x, y, z)` holds
            // (`[x, y, z, z]`), computed by the same IEEE operations.
            unsafe {
                let xyzz = |v: __m128| _mm_shuffle_ps::<0b10_10_01_00>(v, v);
                let mn = xyzz(_mm_load_ps(self.min.as_ptr()));
                let mx = xyzz(_mm_load_ps(self.max.as_ptr()));
                Vec3A::from(_mm_mul_ps(_mm_add_ps(mn, mx), _mm_set1_ps(0.5)))
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Vec3A::new(
            (self.min[0] + self.max[0]) * 0.5,
            (self.min[1] + self.max[1]) * 0.5,
            (self.min[2] + self.max[2]) * 0.5,
        )
    }

    /// The centre of the box on one axis (as [`centroid`](Self::centroid)).
    #[inline]
    pub fn centroid_on(&self, axis: usize) -> f32 {
        (self.min[axis] + self.max[axis]) * 0.5
    }
}

/// Which implementation [`RefBins::fill`] runs. Both give bit-identical bins (and so the same
/// trees) on every CPU: the SIMD path uses only lane-wise IEEE operations (add, multiply,
/// min, max, truncation) in the order of the scalar one, and the scalar path reproduces the
/// SIMD min/max semantics exactly (`min(a, b)` is `a` only when `a < b`, which decides between
/// `-0.0` and `+0.0`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FillBackend {
    /// 128-bit SIMD (SSE2) on x86-64, the scalar code elsewhere.
    #[default]
    Simd,
    /// The scalar code everywhere (for tests that compare the two).
    Scalar,
}

/// The bins of [`PrimRef`]s over the three axes (`3 × k`, axis-major): the union of the boxes
/// (lanes `x, y, z`; the fourth is zero) and the count of each bin. No centroid bounds: the
/// binned builder computes those of its children while partitioning.
#[derive(Clone, Debug, Default)]
pub struct RefBins {
    k: usize,
    min: Vec<[f32; 4]>,
    max: Vec<[f32; 4]>,
    count: Vec<u32>,
}

/// `min` of two lanes as SSE's `minps` computes it (`a` only when `a < b`).
#[inline(always)]
pub(in crate::split) fn min_lane(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `max` of two lanes as SSE's `maxps` computes it (`a` only when `a > b`).
#[inline(always)]
pub(in crate::split) fn max_lane(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The lower corner of an empty box, as [`RefBins`] stores it.
pub(crate) const EMPTY_MIN: [f32; 4] = [f32::INFINITY, f32::INFINITY, f32::INFINITY, 0.0];
/// The upper corner of an empty box, as [`RefBins`] stores it.
pub(crate) const EMPTY_MAX: [f32; 4] =
    [f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY, 0.0];

/// Lane-wise [`min_lane`] (what `Aabb::grow_aabb` computes for the lower corner).
#[inline(always)]
pub(crate) fn min4(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_min_ps};
        // SAFETY: `[f32; 4]` and `__m128` are both 16 plain bytes; SSE2 is part of the
        // x86-64 baseline, and `minps` is `min_lane` lane by lane.
        unsafe {
            let into = |v: [f32; 4]| std::mem::transmute::<[f32; 4], __m128>(v);
            std::mem::transmute::<__m128, [f32; 4]>(_mm_min_ps(into(a), into(b)))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    std::array::from_fn(|l| min_lane(a[l], b[l]))
}

/// Lane-wise [`max_lane`] (what `Aabb::grow_aabb` computes for the upper corner).
#[inline(always)]
pub(crate) fn max4(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_max_ps};
        // SAFETY: as in `min4`; `maxps` is `max_lane` lane by lane.
        unsafe {
            let into = |v: [f32; 4]| std::mem::transmute::<[f32; 4], __m128>(v);
            std::mem::transmute::<__m128, [f32; 4]>(_mm_max_ps(into(a), into(b)))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    std::array::from_fn(|l| max_lane(a[l], b[l]))
}

/// The maps' origins and scales as four lanes (`0` for an axis without a map and for the
/// fourth lane): the constants of [`bin_indices`].
#[inline(always)]
pub(crate) fn map_lanes(maps: &[Option<BinMap>; 3]) -> ([f32; 4], [f32; 4]) {
    let mut lo = [0.0; 4];
    let mut scale = [0.0; 4];
    for (a, m) in maps.iter().enumerate() {
        if let Some(m) = m {
            lo[a] = m.min;
            scale[a] = m.scale;
        }
    }
    (lo, scale)
}

/// The bins of a reference's centroid on the three axes as [`RefBins::fill`] computes them
/// (both backends): `min(max((c - lo) * scale, 0), top)` truncated lane by lane, with
/// `c = (min + max) * 0.5` (an axis with `scale` 0 gets bin 0).
#[inline(always)]
pub(crate) fn bin_indices(r: &PrimRef, lo: [f32; 4], scale: [f32; 4], top: f32) -> [i32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the loads read a `PrimRef`'s 16-byte
        // aligned corners and two `[f32; 4]`s, the store writes a `[i32; 4]`. The operations
        // are those of `fill_sse2`, in its order.
        unsafe {
            let xyz = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
            let mn = _mm_and_ps(_mm_load_ps(r.min.as_ptr()), xyz);
            let c = _mm_mul_ps(
                _mm_add_ps(mn, _mm_load_ps(r.max.as_ptr())),
                _mm_set1_ps(0.5),
            );
            let v = _mm_mul_ps(
                _mm_sub_ps(c, _mm_loadu_ps(lo.as_ptr())),
                _mm_loadu_ps(scale.as_ptr()),
            );
            let v = _mm_min_ps(_mm_max_ps(v, _mm_setzero_ps()), _mm_set1_ps(top));
            let mut out = [0i32; 4];
            _mm_storeu_si128(out.as_mut_ptr().cast(), _mm_cvttps_epi32(v));
            out
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    std::array::from_fn(|a| {
        if a == 3 {
            return 0;
        }
        let c = (r.min[a] + r.max[a]) * 0.5;
        min_lane(max_lane((c - lo[a]) * scale[a], 0.0), top) as i32
    })
}

/// `Aabb::half_area` of the box with these corners (the same operations in the same order).
#[inline(always)]
pub(crate) fn half_area4(lo: &[f32; 4], hi: &[f32; 4]) -> f32 {
    let (x, y, z) = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    x * y + y * z + z * x
}

impl RefBins {
    /// Empty storage (it grows at the first fill).
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of bins per axis of the last fill.
    pub fn bins_per_axis(&self) -> usize {
        self.k
    }

    fn reset(&mut self, k: usize) {
        self.k = k;
        self.min.clear();
        self.min.resize(3 * k, EMPTY_MIN);
        self.max.clear();
        self.max.resize(3 * k, EMPTY_MAX);
        self.count.clear();
        self.count.resize(3 * k, 0);
    }

    /// Bin `i` (of `3 × k`) as a [`Bin`] (its centroid bounds empty).
    #[inline]
    pub fn bin(&self, i: usize) -> Bin {
        let (a, b) = (&self.min[i], &self.max[i]);
        Bin {
            bounds: Aabb::new(Vec3A::new(a[0], a[1], a[2]), Vec3A::new(b[0], b[1], b[2])),
            centroids: Aabb::EMPTY,
            count: self.count[i],
        }
    }

    /// Writes the bins of axis `axis` into `out` (`k` of them) as [`Bin`]s, for
    /// [`sweep_planes`](super::sweep_planes) and [`sides`](super::sides).
    pub fn axis_bins(&self, axis: usize, out: &mut Vec<Bin>) {
        out.clear();
        out.extend((axis * self.k..(axis + 1) * self.k).map(|i| self.bin(i)));
    }

    /// The planes `1..k` of axis `axis`, straight from the bins: the suffix (right side) right
    /// to left into `right[1..k]` (half area as `f32`, count), then `visit(plane, left_area,
    /// n_left, right_area, n_right)` left to right for every plane with items on both sides.
    ///
    /// Bit for bit [`sweep_planes`](super::sweep_planes) over [`axis_bins`](Self::axis_bins) with `S = f32` (the
    /// same unions in the same operand order, the same `f32` half areas, the left one widened
    /// to `f64`), without copying the bins out: at the many small nodes of a build, those
    /// copies cost more than the fill.
    #[inline]
    pub fn sweep_axis(
        &self,
        axis: usize,
        right: &mut [(f32, u32)],
        mut visit: impl FnMut(usize, f64, usize, f32, usize),
    ) {
        let k = self.k;
        let base = axis * k;
        let (mins, maxs, counts) = (
            &self.min[base..base + k],
            &self.max[base..base + k],
            &self.count[base..base + k],
        );
        let right = &mut right[..k];
        let mut lo = EMPTY_MIN;
        let mut hi = EMPTY_MAX;
        let mut rc = 0u32;
        for i in (1..k).rev() {
            lo = min4(lo, mins[i]);
            hi = max4(hi, maxs[i]);
            rc += counts[i];
            right[i] = (half_area4(&lo, &hi), rc);
        }
        let mut lo = EMPTY_MIN;
        let mut hi = EMPTY_MAX;
        let mut lc = 0u32;
        for i in 1..k {
            lo = min4(lo, mins[i - 1]);
            hi = max4(hi, maxs[i - 1]);
            lc += counts[i - 1];
            let (ra, rc) = right[i];
            if lc == 0 || rc == 0 {
                continue;
            }
            visit(i, half_area4(&lo, &hi) as f64, lc as usize, ra, rc as usize);
        }
    }

    /// [`sweep_axis`](Self::sweep_axis) of the three axes at once: `visit(axis, plane,
    /// left_area, n_left, right_area, n_right)` for every plane of every axis with items on
    /// both sides, plane by plane (the three axes of a plane in order), with the same values bit
    /// for bit. The three boxes of a position are grown side by side and their half areas
    /// computed in one transposed step (the operations and order of `Aabb::half_area` in every
    /// lane), which costs about what one axis costs alone. Callers that keep the best plane
    /// by a strict total order (as the binned builder does) find the same plane whatever the
    /// order of the visits. `right` is scratch.
    #[inline]
    pub fn sweep_axes(
        &self,
        right: &mut Vec<([f32; 4], [u32; 4])>,
        mut visit: impl FnMut(usize, usize, f64, usize, f32, usize),
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            use crate::split::sweep::batched::half_areas4;
            use std::arch::x86_64::*;
            let k = self.k;
            if right.len() < k {
                right.resize(k, ([0.0; 4], [0; 4]));
            }
            let (mins, maxs, counts) =
                (&self.min[..3 * k], &self.max[..3 * k], &self.count[..3 * k]);
            // SAFETY (whole block): SSE2 is part of the x86-64 baseline; every load reads a
            // `[f32; 4]` of the bins (indices `a * k + i < 3 k`), every store a `[f32; 4]`.
            unsafe {
                let load = |v: &[f32; 4]| _mm_loadu_ps(v.as_ptr());
                let empty = (load(&EMPTY_MIN), load(&EMPTY_MAX));
                let zero = _mm_setzero_ps();
                let mut lo = [empty.0; 3];
                let mut hi = [empty.1; 3];
                let mut rc = [0u32; 3];
                for i in (1..k).rev() {
                    for a in 0..3 {
                        lo[a] = _mm_min_ps(lo[a], load(&mins[a * k + i]));
                        hi[a] = _mm_max_ps(hi[a], load(&maxs[a * k + i]));
                        rc[a] += counts[a * k + i];
                    }
                    let e = [0, 1, 2].map(|a| _mm_sub_ps(hi[a], lo[a]));
                    let areas = half_areas4([e[0], e[1], e[2], zero]);
                    let slot = &mut right[i];
                    _mm_storeu_ps(slot.0.as_mut_ptr(), areas);
                    slot.1 = [rc[0], rc[1], rc[2], 0];
                }
                let mut lo = [empty.0; 3];
                let mut hi = [empty.1; 3];
                let mut lc = [0u32; 3];
                for i in 1..k {
                    for a in 0..3 {
                        lo[a] = _mm_min_ps(lo[a], load(&mins[a * k + i - 1]));
                        hi[a] = _mm_max_ps(hi[a], load(&maxs[a * k + i - 1]));
                        lc[a] += counts[a * k + i - 1];
                    }
                    let e = [0, 1, 2].map(|a| _mm_sub_ps(hi[a], lo[a]));
                    let mut la = [0.0f32; 4];
                    _mm_storeu_ps(la.as_mut_ptr(), half_areas4([e[0], e[1], e[2], zero]));
                    let (ra, rcs) = right[i];
                    for a in 0..3 {
                        if lc[a] == 0 || rcs[a] == 0 {
                            continue;
                        }
                        visit(a, i, la[a] as f64, lc[a] as usize, ra[a], rcs[a] as usize);
                    }
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut r = vec![(0.0f32, 0u32); self.k];
            let _ = right;
            for axis in 0..3 {
                self.sweep_axis(axis, &mut r, |p, la, lc, ra, rc| {
                    visit(axis, p, la, lc, ra, rc)
                });
            }
        }
    }

    /// The count and bounds of the items in bins `< plane` of axis `axis`, and the bounds of
    /// the others: bit for bit [`sides`](super::sides) over [`axis_bins`](Self::axis_bins).
    pub fn sides(&self, axis: usize, plane: usize) -> (usize, Aabb, Aabb) {
        let k = self.k;
        let base = axis * k;
        let union = |range: std::ops::Range<usize>| {
            let mut lo = EMPTY_MIN;
            let mut hi = EMPTY_MAX;
            let mut n = 0u32;
            for i in range {
                lo = min4(lo, self.min[base + i]);
                hi = max4(hi, self.max[base + i]);
                n += self.count[base + i];
            }
            let b = Aabb::new(
                Vec3A::new(lo[0], lo[1], lo[2]),
                Vec3A::new(hi[0], hi[1], hi[2]),
            );
            (n as usize, b)
        };
        let (n_left, left) = union(0..plane);
        let (_, right) = union(plane..k);
        (n_left, left, right)
    }

    /// Fills the bins with `refs` by their centroids (`k` bins per axis, the axes without a
    /// map left empty), exactly as [`fill`](super::fill) does for the same items in the same order.
    pub fn fill(
        &mut self,
        k: usize,
        maps: &[Option<BinMap>; 3],
        refs: &[PrimRef],
        backend: FillBackend,
    ) {
        self.reset(k);
        let (lo, scale) = map_lanes(maps);
        let on = maps.map(|m| m.is_some());
        match backend {
            #[cfg(target_arch = "x86_64")]
            FillBackend::Simd => {
                // SAFETY: SSE2 is part of the x86-64 baseline.
                unsafe { self.fill_sse2(lo, scale, on, refs) }
            }
            _ => self.fill_scalar(lo, scale, on, refs),
        }
    }

    /// [`fill`](Self::fill) in parallel chunks of [`PAR_CHUNK`] for at least
    /// [`PAR_NODE_THRESHOLD`] references (exact, so the chunking changes nothing).
    pub fn fill_par(
        &mut self,
        k: usize,
        maps: &[Option<BinMap>; 3],
        refs: &[PrimRef],
        backend: FillBackend,
    ) {
        if refs.len() < PAR_NODE_THRESHOLD {
            self.fill(k, maps, refs, backend);
            return;
        }
        let merged = refs
            .par_chunks(PAR_CHUNK)
            .map(|chunk| {
                let mut local = RefBins::new();
                local.fill(k, maps, chunk, backend);
                local
            })
            .reduce_with(|mut a, b| {
                a.merge(&b);
                a
            })
            .expect("a non-empty node");
        *self = merged;
    }

    /// Adds the content of `other` (same `k`) bin by bin, `self` first.
    fn merge(&mut self, other: &RefBins) {
        for i in 0..3 * self.k {
            for l in 0..3 {
                // Test-only (issue 46): `--cfg sahara_planted_bug="builder"` flips this
                // comparison (the larger lower corner wins): wrong bin boxes on the parallel
                // path only, which the fuzzers must find. Normal builds fold it away.
                self.min[i][l] = if cfg!(sahara_planted_bug = "builder") {
                    max_lane(self.min[i][l], other.min[i][l])
                } else {
                    min_lane(self.min[i][l], other.min[i][l])
                };
                self.max[i][l] = max_lane(self.max[i][l], other.max[i][l]);
            }
            self.count[i] += other.count[i];
        }
    }

    /// The bin index of each axis: `min(max((c - lo) * scale, 0), k - 1)` truncated, where
    /// `c = (min + max) * 0.5`, lane by lane.
    fn fill_scalar(&mut self, lo: [f32; 4], scale: [f32; 4], on: [bool; 3], refs: &[PrimRef]) {
        let k = self.k;
        let top = (k - 1) as f32;
        for r in refs {
            for (a, &on) in on.iter().enumerate() {
                if !on {
                    continue;
                }
                let c = (r.min[a] + r.max[a]) * 0.5;
                let v = min_lane(max_lane((c - lo[a]) * scale[a], 0.0), top);
                let i = a * k + v as usize;
                let (bmin, bmax) = (&mut self.min[i], &mut self.max[i]);
                for l in 0..3 {
                    bmin[l] = min_lane(bmin[l], r.min[l]);
                    bmax[l] = max_lane(bmax[l], r.max[l]);
                }
                self.count[i] += 1;
            }
        }
    }

    /// [`fill_scalar`](Self::fill_scalar) with 128-bit lanes.
    ///
    /// # Safety
    ///
    /// The CPU supports SSE2 (always true on x86-64).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "sse2")]
    unsafe fn fill_sse2(&mut self, lo: [f32; 4], scale: [f32; 4], on: [bool; 3], refs: &[PrimRef]) {
        use std::arch::x86_64::*;
        let k = self.k;
        let (mins, maxs, counts) = (&mut self.min, &mut self.max, &mut self.count);
        // SAFETY (whole body): every pointer read or written is that of a `[f32; 4]` or of a
        // `PrimRef` (16-byte aligned), and every bin index is below `3 k` (the lane values are
        // clamped to `[0, k - 1]` before truncation, and only mapped axes are written).
        unsafe {
            let lo = _mm_loadu_ps(lo.as_ptr());
            let scale = _mm_loadu_ps(scale.as_ptr());
            let top = _mm_set1_ps((k - 1) as f32);
            let zero = _mm_setzero_ps();
            let half = _mm_set1_ps(0.5);
            // Clears the id lane of `min`.
            let xyz = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
            let offs = [0usize, k, 2 * k];
            for r in refs {
                let mn = _mm_and_ps(_mm_load_ps(r.min.as_ptr()), xyz);
                let mx = _mm_load_ps(r.max.as_ptr());
                let c = _mm_mul_ps(_mm_add_ps(mn, mx), half);
                let v = _mm_min_ps(_mm_max_ps(_mm_mul_ps(_mm_sub_ps(c, lo), scale), zero), top);
                let mut idx = [0i32; 4];
                _mm_storeu_si128(idx.as_mut_ptr().cast(), _mm_cvttps_epi32(v));
                for a in 0..3 {
                    if on[a] {
                        let i = offs[a] + idx[a] as usize;
                        let pmin = mins.as_mut_ptr().add(i).cast::<f32>();
                        let pmax = maxs.as_mut_ptr().add(i).cast::<f32>();
                        _mm_storeu_ps(pmin, _mm_min_ps(_mm_loadu_ps(pmin), mn));
                        _mm_storeu_ps(pmax, _mm_max_ps(_mm_loadu_ps(pmax), mx));
                        *counts.get_unchecked_mut(i) += 1;
                    }
                }
            }
        }
    }
}

/// The bounds of a set of primitives and of their centroids.
#[derive(Clone, Copy, Debug)]
pub struct RefBounds {
    /// Union of the primitives' boxes.
    pub bounds: Aabb,
    /// Bounds of their centroids.
    pub centroids: Aabb,
}

/// Bounds of the references and of their centroids (computed at the root and for median
/// splits; other children get their bounds from the bins and their centroid bounds from the
/// partition).
pub fn ref_bounds(refs: &[PrimRef]) -> RefBounds {
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
    RefBounds { bounds, centroids }
}

#[cfg(test)]
mod tests {
    use super::super::{maps, sides, sweep_planes};
    use super::*;
    use sahara_geom::rng::Pcg32;

    /// [`PrimRef::centroid`] (four lanes at once) is [`Aabb::centroid`] of the reference's box
    /// bit for bit in every lane, with signed zeros, huge and tiny coordinates, and ids and cut
    /// entries whose bits are subnormal or NaN floats in the fourth lanes.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn centroid_is_the_box_centroid() {
        let mut rng = Pcg32::new(31, 7);
        let coord = |rng: &mut Pcg32| match rng.below(6) {
            0 => 0.0,
            1 => -0.0,
            2 => 1e30,
            3 => -3e-38,
            _ => rng.below(1000) as f32 * 0.125 - 60.0,
        };
        for case in 0..2000u32 {
            let a = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng));
            let b = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng));
            let bx = Aabb::new(a.min(b), a.max(b));
            let id = [case, u32::MAX / 2 + case, 0x7fc0_0000 + case][case as usize % 3];
            let mut r = PrimRef::new(&bx, id);
            if case % 2 == 1 {
                r = r.with_cut(case);
            }
            // SAFETY: on x86-64 a `Vec3A` is one `__m128`, 16 bytes of four `f32` lanes.
            let bits = |v: Vec3A| unsafe { std::mem::transmute::<Vec3A, [u32; 4]>(v) };
            assert_eq!(bits(r.centroid()), bits(bx.centroid()), "case {case}");
        }
    }

    /// The direct sweep and sides of [`RefBins`] are bit for bit those of [`sweep_planes`] and
    /// [`sides`] over copied-out [`Bin`]s, signed zeros and empty bins included.
    #[test]
    fn direct_sweep_equals_the_sweep_over_copied_bins() {
        let mut rng = Pcg32::new(11, 12);
        let coord = |rng: &mut Pcg32| match rng.below(5) {
            0 => 0.0,
            1 => -0.0,
            _ => rng.below(9) as f32 * 0.25 - 1.0,
        };
        for case in 0..300 {
            let n = 1 + rng.below(60) as usize;
            let refs: Vec<PrimRef> = (0..n)
                .map(|i| {
                    let a = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng));
                    let e = Vec3A::new(coord(&mut rng), coord(&mut rng), coord(&mut rng)).abs();
                    PrimRef::new(&Aabb::new(a, a + e), i as u32)
                })
                .collect();
            let mut cb = Aabb::EMPTY;
            for r in &refs {
                cb.grow(r.centroid());
            }
            let k = [2, 5, 8, 32][case % 4];
            let m = maps(&cb, k);
            let mut bins = RefBins::new();
            bins.fill(k, &m, &refs, FillBackend::Simd);
            let mut copied = Vec::new();
            let mut right_a = vec![(0.0f32, 0u32); k];
            let mut right_b = vec![(0.0f32, 0u32); k];
            let mut right_c = Vec::new();
            for axis in 0..3 {
                let mut direct = Vec::new();
                bins.sweep_axis(axis, &mut right_a, |p, la, lc, ra, rc| {
                    direct.push((p, la.to_bits(), lc, ra.to_bits(), rc));
                });
                bins.axis_bins(axis, &mut copied);
                let mut reference = Vec::new();
                sweep_planes(&copied, &mut right_b, |p, lb, lc, ra: &f32, rc| {
                    reference.push((p, (lb.half_area() as f64).to_bits(), lc, ra.to_bits(), rc));
                });
                assert_eq!(direct, reference, "case {case}, axis {axis}");
                let mut all = Vec::new();
                bins.sweep_axes(&mut right_c, |a, p, la, lc, ra, rc| {
                    if a == axis {
                        all.push((p, la.to_bits(), lc, ra.to_bits(), rc));
                    }
                });
                assert_eq!(all, direct, "case {case}, axis {axis}: three axes at once");
                for plane in 1..k {
                    let (l, r) = sides(&copied, plane);
                    let (nl, lb, rb) = bins.sides(axis, plane);
                    let bits = |b: &Aabb| {
                        (
                            b.min.to_array().map(f32::to_bits),
                            b.max.to_array().map(f32::to_bits),
                        )
                    };
                    assert_eq!(
                        nl, l.count as usize,
                        "case {case}, axis {axis}, plane {plane}"
                    );
                    assert_eq!(bits(&lb), bits(&l.bounds), "case {case}, plane {plane}");
                    assert_eq!(bits(&rb), bits(&r.bounds), "case {case}, plane {plane}");
                }
            }
        }
    }
}
