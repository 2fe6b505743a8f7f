//! The spatial binning of triangle references ([`super::fill_scalar`]) many slabs at a time:
//! eight with AVX2, sixteen with AVX-512.
//!
//! Most of an SBVH build is spent here, and most of the binning's work is in references that
//! span many bins: a large triangle in a small node crosses dozens of the 128 planes. The
//! scalar [`SlabClipper::bin_into`] handles one slab per step on three useful lanes of four.
//! These backends lay the bins out as structure of arrays (one array per box coordinate) and
//! handle one slab per lane:
//!
//! 1. the crossing boxes of the block's upper planes (the lower planes' crossings are the
//!    previous block's upper ones, shifted in by one lane, so each plane is crossed once and
//!    nothing goes through memory: reloading just-stored crossings at an offset of one lane
//!    stalls store forwarding and cost more than the arithmetic);
//! 2. each slab's piece from its two crossings, the vertices inside it, the reference's box and
//!    the slab itself, grown into the bins.
//!
//! Every lane runs the scalar code's operations on the same operands in the same order
//! (`min`/`max` keep their operand order, so signed zeros and NaNs come out the same; no fused
//! multiply-adds), and each bin still grows reference after reference in input order. So the
//! bins are equal **bit for bit** to the scalar path's on every backend, and the tree does not
//! depend on the CPU (tested by `simd_binning_equals_the_scalar_binning`). Selects whose mask
//! is uniform over a block are skipped (same lanes out): a variable blend costs two or three
//! micro-ops on Intel cores.
//!
//! The kernel is written once, generic over [`Lanes`]; each backend is a `#[target_feature]`
//! entry point that instantiates it.

use std::arch::x86_64::*;

use sahara_geom::{Axis, Triangle, Vec3A};

use super::{count_span, BinMap, SlabClipper, SpatialBin};
use crate::simd::BuildSimd;
use crate::split::binned::refs::{max_lane, min_lane};
use crate::split::object::Ref;

/// The most lanes of any backend.
const MAX_W: usize = 16;

/// How many values [`fill`] needs after the `nb + 1` planes (any values).
pub(super) const PLANE_PADDING: usize = MAX_W;

/// Reusable buffers of [`fill`]: the bins as structure of arrays (`min x, min y, min z, max x,
/// max y, max z`).
#[derive(Default)]
pub(super) struct SoaScratch {
    bins: [Vec<f32>; 6],
}

/// The vector operations the kernel needs, with the semantics of the SSE instructions the
/// scalar path uses (`min(a, b) = a < b ? a : b`, ordered quiet comparisons). Every method is
/// `unsafe`: the caller's function must enable the backend's target features.
trait Lanes {
    /// A vector of `W` floats.
    type V: Copy;
    /// A lane mask.
    type M: Copy;
    const W: usize;
    unsafe fn splat(x: f32) -> Self::V;
    unsafe fn load(p: *const f32) -> Self::V;
    unsafe fn store(p: *mut f32, v: Self::V);
    unsafe fn add(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn sub(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn mul(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn min(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn max(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn lt(a: Self::V, b: Self::V) -> Self::M;
    unsafe fn gt(a: Self::V, b: Self::V) -> Self::M;
    unsafe fn ge(a: Self::V, b: Self::V) -> Self::M;
    unsafe fn le(a: Self::V, b: Self::V) -> Self::M;
    unsafe fn and(a: Self::M, b: Self::M) -> Self::M;
    unsafe fn or(a: Self::M, b: Self::M) -> Self::M;
    /// One bit per lane, lane 0 lowest.
    unsafe fn bits(m: Self::M) -> u32;
    /// `t` in the lanes of `m`, `f` elsewhere.
    unsafe fn select(m: Self::M, t: Self::V, f: Self::V) -> Self::V;
    /// `select(m, min(a, b), a)`.
    #[inline(always)]
    unsafe fn min_where(m: Self::M, a: Self::V, b: Self::V) -> Self::V {
        unsafe { Self::select(m, Self::min(a, b), a) }
    }
    /// `select(m, max(a, b), a)`.
    #[inline(always)]
    unsafe fn max_where(m: Self::M, a: Self::V, b: Self::V) -> Self::V {
        unsafe { Self::select(m, Self::max(a, b), a) }
    }
    /// Lane `l` takes `cur`'s lane `l - 1`; lane 0 takes `prev`'s last lane.
    unsafe fn shift_in(prev: Self::V, cur: Self::V) -> Self::V;
    /// The lanes `l` with `base + l < end`.
    unsafe fn below(base: usize, end: usize) -> Self::M;
    /// The lanes of the bits of `bits`.
    unsafe fn from_bits(bits: u32) -> Self::M;
}

/// The lane operations that are one intrinsic each, for vector type `$v` and mask type `$m`:
/// `$cmp` is the comparison intrinsic (its predicate a const parameter), then the others.
macro_rules! one_intrinsic_ops {
    ($v:ty, $m:ty, $cmp:ident, $splat:ident, $load:ident, $store:ident,
     [$($op:ident = $f:ident),*]) => {
        #[inline(always)]
        unsafe fn splat(x: f32) -> $v {
            unsafe { $splat(x) }
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> $v {
            unsafe { $load(p) }
        }
        #[inline(always)]
        unsafe fn store(p: *mut f32, v: $v) {
            unsafe { $store(p, v) }
        }
        $(
            #[inline(always)]
            unsafe fn $op(a: $v, b: $v) -> $v {
                unsafe { $f(a, b) }
            }
        )*
        one_intrinsic_ops!(@cmp $v, $m, $cmp, lt = _CMP_LT_OQ, gt = _CMP_GT_OQ,
            ge = _CMP_GE_OQ, le = _CMP_LE_OQ);
    };
    (@cmp $v:ty, $m:ty, $cmp:ident, $($op:ident = $pred:ident),*) => {
        $(
            #[inline(always)]
            unsafe fn $op(a: $v, b: $v) -> $m {
                unsafe { $cmp::<$pred>(a, b) }
            }
        )*
    };
}

/// Eight lanes (AVX2).
struct Avx2;

impl Lanes for Avx2 {
    type V = __m256;
    type M = __m256;
    const W: usize = 8;
    one_intrinsic_ops!(
        __m256,
        __m256,
        _mm256_cmp_ps,
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        [
            add = _mm256_add_ps,
            sub = _mm256_sub_ps,
            mul = _mm256_mul_ps,
            min = _mm256_min_ps,
            max = _mm256_max_ps
        ]
    );
    #[inline(always)]
    unsafe fn and(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_and_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn or(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_or_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn bits(m: __m256) -> u32 {
        unsafe { _mm256_movemask_ps(m) as u32 }
    }
    #[inline(always)]
    unsafe fn select(m: __m256, t: __m256, f: __m256) -> __m256 {
        unsafe { _mm256_blendv_ps(f, t, m) }
    }
    #[inline(always)]
    unsafe fn shift_in(prev: __m256, cur: __m256) -> __m256 {
        unsafe {
            let rotate = _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6);
            _mm256_blend_ps::<1>(
                _mm256_permutevar8x32_ps(cur, rotate),
                _mm256_permutevar8x32_ps(prev, rotate),
            )
        }
    }
    #[inline(always)]
    unsafe fn below(base: usize, end: usize) -> __m256 {
        unsafe {
            let idx = _mm256_add_epi32(
                _mm256_set1_epi32(base as i32),
                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
            );
            _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(end as i32), idx))
        }
    }
    #[inline(always)]
    unsafe fn from_bits(bits: u32) -> __m256 {
        unsafe {
            let lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let m = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(m, lane))
        }
    }
}

/// Sixteen lanes (AVX-512F), with mask registers: conditional minima and maxima are one
/// masked instruction each.
struct Avx512;

impl Lanes for Avx512 {
    type V = __m512;
    type M = __mmask16;
    const W: usize = 16;
    one_intrinsic_ops!(
        __m512,
        __mmask16,
        _mm512_cmp_ps_mask,
        _mm512_set1_ps,
        _mm512_loadu_ps,
        _mm512_storeu_ps,
        [
            add = _mm512_add_ps,
            sub = _mm512_sub_ps,
            mul = _mm512_mul_ps,
            min = _mm512_min_ps,
            max = _mm512_max_ps
        ]
    );
    #[inline(always)]
    unsafe fn and(a: __mmask16, b: __mmask16) -> __mmask16 {
        a & b
    }
    #[inline(always)]
    unsafe fn or(a: __mmask16, b: __mmask16) -> __mmask16 {
        a | b
    }
    #[inline(always)]
    unsafe fn bits(m: __mmask16) -> u32 {
        m as u32
    }
    #[inline(always)]
    unsafe fn select(m: __mmask16, t: __m512, f: __m512) -> __m512 {
        unsafe { _mm512_mask_blend_ps(m, f, t) }
    }
    #[inline(always)]
    unsafe fn min_where(m: __mmask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_min_ps(a, m, a, b) }
    }
    #[inline(always)]
    unsafe fn max_where(m: __mmask16, a: __m512, b: __m512) -> __m512 {
        unsafe { _mm512_mask_max_ps(a, m, a, b) }
    }
    #[inline(always)]
    unsafe fn shift_in(prev: __m512, cur: __m512) -> __m512 {
        // Indices 0..16 pick from `cur`, 16..32 from `prev`: lane 0 takes `prev[15]`.
        unsafe {
            let idx = _mm512_setr_epi32(31, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14);
            _mm512_permutex2var_ps(cur, idx, prev)
        }
    }
    #[inline(always)]
    unsafe fn below(base: usize, end: usize) -> __mmask16 {
        let n = end.saturating_sub(base).min(16);
        ((1u32 << n) - 1) as __mmask16
    }
    #[inline(always)]
    unsafe fn from_bits(bits: u32) -> __mmask16 {
        bits as __mmask16
    }
}

/// What the binning of one axis reads: the triangles, the node's references, the axis, its
/// bins and their planes (`map`'s `nb + 1` plane positions followed by at least
/// [`PLANE_PADDING`] values).
#[derive(Clone, Copy)]
pub(super) struct AxisJob<'a> {
    pub tris: &'a [Triangle],
    pub refs: &'a [Ref],
    pub axis: Axis,
    pub map: &'a BinMap,
    pub planes: &'a [f32],
}

/// Bins every triangle reference of the job into `bins` (all [`SpatialBin::EMPTY`] on entry)
/// with backend `simd`, exactly as [`super::fill_scalar`] does.
///
/// # Panics
///
/// If this CPU does not run `simd` (see [`BuildSimd::detected`]), if `simd` is
/// [`BuildSimd::Baseline`], or if the planes lack their padding.
pub(super) fn fill(simd: BuildSimd, job: AxisJob, bins: &mut [SpatialBin], sc: &mut SoaScratch) {
    assert!(
        simd <= BuildSimd::detected(),
        "{simd:?} does not run on this CPU"
    );
    assert!(
        job.planes.len() >= bins.len() + 1 + PLANE_PADDING,
        "planes without padding"
    );
    // SAFETY: the CPU runs the backend (asserted), and the planes are padded.
    unsafe {
        match simd {
            BuildSimd::Avx512 => fill_avx512(job, bins, sc),
            BuildSimd::Avx2 => fill_avx2(job, bins, sc),
            BuildSimd::Baseline => panic!("the baseline binning is `fill_scalar`"),
        }
    }
}

#[target_feature(enable = "avx2")]
unsafe fn fill_avx2(job: AxisJob, bins: &mut [SpatialBin], sc: &mut SoaScratch) {
    // SAFETY: the caller checked the CPU and the padding.
    unsafe { fill_with::<Avx2>(job, bins, sc) }
}

#[target_feature(enable = "avx512f")]
unsafe fn fill_avx512(job: AxisJob, bins: &mut [SpatialBin], sc: &mut SoaScratch) {
    // SAFETY: the caller checked the CPU and the padding.
    unsafe { fill_with::<Avx512>(job, bins, sc) }
}

/// [`fill`] with the lanes `L` (inlined into a backend's entry point).
#[inline(always)]
unsafe fn fill_with<L: Lanes>(job: AxisJob, bins: &mut [SpatialBin], sc: &mut SoaScratch) {
    let AxisJob {
        tris,
        refs,
        axis,
        map,
        planes,
    } = job;
    let nb = bins.len();
    for (c, v) in sc.bins.iter_mut().enumerate() {
        let empty = if c < 3 {
            f32::INFINITY
        } else {
            f32::NEG_INFINITY
        };
        v.clear();
        // Padding: a block of slabs may read past the last bin (it never writes there).
        v.resize(nb + MAX_W, empty);
    }
    for r in refs {
        let (first, last) = count_span(map, r, axis, bins);
        if first == last {
            for c in 0..3 {
                let lo = &mut sc.bins[c][first];
                *lo = min_lane(*lo, r.bounds.min[c]);
                let hi = &mut sc.bins[c + 3][first];
                *hi = max_lane(*hi, r.bounds.max[c]);
            }
            continue;
        }
        let clip = SlabClipper::new(&tris[r.prim as usize], axis, &r.bounds);
        // SAFETY: as for this function.
        unsafe { slabs::<L>(&clip, planes, first, last, sc) };
    }
    for (b, bin) in bins.iter_mut().enumerate() {
        let s = &sc.bins;
        bin.bounds.min = Vec3A::new(s[0][b], s[1][b], s[2][b]);
        bin.bounds.max = Vec3A::new(s[3][b], s[4][b], s[5][b]);
    }
}

/// Grows bins `first..=last` (at least two) by the pieces of one reference, `L::W` at a time.
#[inline(always)]
unsafe fn slabs<L: Lanes>(
    clip: &SlabClipper,
    planes: &[f32],
    first: usize,
    last: usize,
    sc: &mut SoaScratch,
) {
    let a = clip.axis;
    let v = &clip.v;
    let m = last - first + 1;
    let w = L::W;
    let all = (1u32 << w) - 1;
    debug_assert!(first + m + w <= planes.len());
    // SAFETY (all lane operations): the caller enabled the backend; every load and store is
    // within the arrays' lengths as noted at each.
    unsafe {
        let splat = |x: f32| L::splat(x);
        let (v0a, v1a, v2a) = (splat(v[0][a]), splat(v[1][a]), splat(v[2][a]));
        let vc = |k: usize, c: usize| splat(v[k][c]);
        let dc = |k: usize, c: usize| splat(clip.dir[k][c]);
        let inf = splat(f32::INFINITY);
        let ninf = splat(f32::NEG_INFINITY);
        // No `array::map` and no closures handed to other functions in this kernel: they
        // would be compiled without the backend's target features and could not inline its
        // intrinsics (each would become a call).
        let (mut bmin, mut bmax) = ([inf; 3], [ninf; 3]);
        for c in 0..3 {
            bmin[c] = splat(clip.bounds.min[c]);
            bmax[c] = splat(clip.bounds.max[c]);
        }
        // The crossing box at each upper plane (`SlabClipper::bin_into`'s `crossing`).
        let crossing = |p: L::V| -> ([L::V; 3], [L::V; 3]) {
            let t0 = L::sub(p, v0a);
            let below_v1 = L::lt(p, v1a);
            let inside = L::and(L::gt(p, v0a), L::lt(p, v2a));
            let all_inside = L::bits(inside) == all;
            let mut lo = [inf; 3];
            let mut hi = [ninf; 3];
            for c in 0..3 {
                let long = L::add(vc(0, c), L::mul(dc(0, c), t0));
                let s0 = || L::add(vc(0, c), L::mul(dc(1, c), t0));
                let s1 = || L::add(vc(1, c), L::mul(dc(2, c), L::sub(p, v1a)));
                let short = match L::bits(below_v1) {
                    b if b == all => s0(),
                    0 => s1(),
                    _ => L::select(below_v1, s0(), s1()),
                };
                let (l, h) = (L::min(long, short), L::max(long, short));
                if all_inside {
                    (lo[c], hi[c]) = (l, h);
                } else {
                    lo[c] = L::select(inside, l, inf);
                    hi[c] = L::select(inside, h, ninf);
                }
            }
            (lo, hi)
        };
        // The previous block's upper crossings (before the first bin: none, the empty box,
        // which is also the crossing at `-inf`).
        let mut prev = ([inf; 3], [ninf; 3]);
        let mut i = 0;
        while i < m {
            // Lane `l` is bin `first + i + l` (index `i + l` of the reference's bins); its
            // slab is `planes[first + i + l] ..= planes[first + i + l + 1]`, unbounded below
            // for index 0 and above for index `m - 1`. In bounds: `first + i + 1 + w <=
            // first + m + w <= nb + MAX_W < planes.len()` (asserted by `fill`).
            let mut lo_pos = L::load(planes.as_ptr().add(first + i));
            if i == 0 {
                lo_pos = L::select(L::from_bits(1), ninf, lo_pos);
            }
            let mut hi_pos = L::load(planes.as_ptr().add(first + i + 1));
            let full = i + w <= m;
            if i + w >= m {
                hi_pos = L::select(L::from_bits(1 << (m - 1 - i)), inf, hi_pos);
            }
            let upper = crossing(hi_pos);
            // `lower.union(&upper)`, the lower crossings shifted in from the previous block.
            let (mut pmin, mut pmax) = ([inf; 3], [ninf; 3]);
            for c in 0..3 {
                let lower_min = L::shift_in(prev.0[c], upper.0[c]);
                let lower_max = L::shift_in(prev.1[c], upper.1[c]);
                pmin[c] = L::min(lower_min, upper.0[c]);
                pmax[c] = L::max(lower_max, upper.1[c]);
            }
            prev = upper;
            // The vertices inside the slab, in order (a vertex is in one or two slabs of the
            // reference, so most blocks have none).
            for vk in v {
                let va = splat(vk[a]);
                let inside = L::and(L::ge(va, lo_pos), L::le(va, hi_pos));
                if L::bits(inside) == 0 {
                    continue;
                }
                for c in 0..3 {
                    let p = splat(vk[c]);
                    pmin[c] = L::min_where(inside, pmin[c], p);
                    pmax[c] = L::max_where(inside, pmax[c], p);
                }
            }
            // `.intersection(self.bounds).intersection(&slab)`, then the emptiness test.
            let mut empty = L::from_bits(0);
            for c in 0..3 {
                pmin[c] = L::max(pmin[c], bmin[c]);
                pmax[c] = L::min(pmax[c], bmax[c]);
                let (slab_lo, slab_hi) = if c == a {
                    (lo_pos, hi_pos)
                } else {
                    (bmin[c], bmax[c])
                };
                pmin[c] = L::max(pmin[c], slab_lo);
                pmax[c] = L::min(pmax[c], slab_hi);
                empty = L::or(empty, L::gt(pmin[c], pmax[c]));
            }
            if L::bits(empty) != 0 {
                for c in 0..3 {
                    pmin[c] = L::select(empty, inf, pmin[c]);
                    pmax[c] = L::select(empty, ninf, pmax[c]);
                }
            }
            // Lanes past the last bin leave their bins untouched.
            let b = first + i;
            let valid = L::below(i, m);
            for (c, (lo, hi)) in pmin.into_iter().zip(pmax).enumerate() {
                // In bounds: `b + w <= last + MAX_W <= nb - 1 + MAX_W`, the padded length.
                let pl = sc.bins[c].as_mut_ptr().add(b);
                let ph = sc.bins[c + 3].as_mut_ptr().add(b);
                let (old_lo, old_hi) = (L::load(pl), L::load(ph));
                let (new_lo, new_hi) = if full {
                    (L::min(old_lo, lo), L::max(old_hi, hi))
                } else {
                    (
                        L::min_where(valid, old_lo, lo),
                        L::max_where(valid, old_hi, hi),
                    )
                };
                L::store(pl, new_lo);
                L::store(ph, new_hi);
            }
            i += w;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::lcg;
    use super::*;
    use sahara_geom::Aabb;

    /// Random triangles (`grid`: coordinates from `{-1, -1/2, -0, +0, 1/2, 1}`, so that vertices
    /// lie on planes and equal coordinates differ in the sign of zero only).
    fn triangles(s: &mut u64, grid: bool, case: usize) -> Vec<Triangle> {
        let mut out = Vec::new();
        for t in 0..40 {
            let mut q = || {
                let x = lcg(s);
                if grid {
                    [-1.0, -0.5, -0.0, 0.0, 0.5, 1.0][((x + 2.0) * 1.49) as usize % 6]
                } else {
                    x
                }
            };
            let mut p = || Vec3A::new(q(), q(), q());
            let mut tri = Triangle::new(p(), p(), p());
            match (case + t) % 6 {
                0 => tri.v[1].x = tri.v[0].x,
                1 => tri.v[2] = tri.v[0],
                2 if grid => {
                    // Two vertices a denormal apart on every axis, one of them on the plane 0:
                    // the edge's slope overflows and its crossing there is `inf * 0 = NaN`.
                    tri.v[1] = Vec3A::splat(0.0);
                    tri.v[2] = Vec3A::new(1e-45, 1e-45, 1e-45) + Vec3A::new(0.0, 0.0, 0.5);
                    tri.v[0] = Vec3A::new(-0.5, 0.5, -0.5);
                }
                3 => {
                    // An edge almost parallel to the planes: its slope overflows.
                    tri.v[1] = tri.v[0] + Vec3A::new(1e-39, 3.0, -3.0);
                    tri.v[1].y = 1e30;
                }
                _ => {}
            }
            out.push(tri);
        }
        out
    }

    /// Every SIMD backend this CPU runs fills the same bins, bit for bit, as the scalar loop:
    /// random
    /// triangles with references cut to part of their box, vertices on planes, edges parallel
    /// to the axis, flat and needle triangles, coordinates that differ in the sign of zero
    /// only, and nearly flat edges whose slopes overflow (infinite and NaN crossings).
    #[test]
    fn simd_binning_equals_the_scalar_binning() {
        let backends: Vec<BuildSimd> = BuildSimd::ALL[1..]
            .iter()
            .copied()
            .filter(|&b| b <= BuildSimd::detected())
            .collect();
        if backends.is_empty() {
            eprintln!("skipped: this CPU runs no SIMD backend of the binning");
            return;
        }
        let mut s = 11u64;
        let mut sc = SoaScratch::default();
        let mut checked = 0;
        for case in 0..600 {
            let grid = case % 2 == 1;
            let tris = triangles(&mut s, grid, case);
            let refs: Vec<Ref> = tris
                .iter()
                .enumerate()
                .map(|(t, tri)| {
                    let full = tri.bounds();
                    let bounds = if t % 3 == 0 && !grid {
                        Aabb::new(full.min + (full.max - full.min) * 0.3, full.max)
                    } else {
                        full
                    };
                    Ref::new(bounds, t as u32)
                })
                .collect();
            for nb in [2usize, 4, 7, 16, 17, 32, 128] {
                for axis in 0..3 {
                    let (lo, hi) = if grid {
                        (-1.0, 1.0)
                    } else {
                        let lo = refs.iter().map(|r| r.bounds.min[axis]);
                        let hi = refs.iter().map(|r| r.bounds.max[axis]);
                        (lo.fold(f32::MAX, f32::min), hi.fold(f32::MIN, f32::max))
                    };
                    let Some(map) = BinMap::new(lo, hi, nb) else {
                        continue;
                    };
                    let mut planes: Vec<f32> = (0..=nb).map(|i| map.plane(i)).collect();
                    planes.resize(nb + 1 + PLANE_PADDING, f32::NAN);
                    let mut want = vec![SpatialBin::EMPTY; nb];
                    let clipper = super::super::Clipper::Triangles(&tris);
                    super::super::fill_scalar(&clipper, &refs, axis, &map, &planes, &mut want);
                    for &simd in &backends {
                        let mut got = vec![SpatialBin::EMPTY; nb];
                        let job = AxisJob {
                            tris: &tris,
                            refs: &refs,
                            axis,
                            map: &map,
                            planes: &planes,
                        };
                        fill(simd, job, &mut got, &mut sc);
                        for (w, g) in want.iter().zip(&got) {
                            let bits = |b: &Aabb| {
                                [b.min.to_array(), b.max.to_array()].map(|v| v.map(f32::to_bits))
                            };
                            let at = format!("{simd} case {case} nb {nb} axis {axis}");
                            assert_eq!(bits(&w.bounds), bits(&g.bounds), "{at}");
                            assert_eq!((w.enter, w.exit), (g.enter, g.exit));
                        }
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked >= 8000 * backends.len(), "{checked}");
    }
}
