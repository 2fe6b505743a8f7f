//! The f64 pre-filter in front of the exact test.
//!
//! It may only say "provably not a candidate"; anything else goes exact.
//!
//! # The error bound
//!
//! Inputs are f32, so their f64 images are exact. The filter evaluates, in f64,
//! `ê1 = fl(v1 - v0)`, `ê2 = fl(v2 - v0)`, `ŝ = fl(o - v0)` and then the
//! Möller–Trumbore polynomials `det = e1·(d×e2)`, `β·det = s·(d×e2)`,
//! `γ·det = d·(s×e1)`, `t·det = e2·(s×e1)` and `α·det = det - β·det - γ·det`.
//!
//! Standard forward-error analysis (Higham, *Accuracy and Stability of Numerical
//! Algorithms*, §3): with unit roundoff `u = 2^-53`, every operation is
//! `fl(a ∘ b) = (a ∘ b)(1 + δ)`, `|δ| <= u`. Expanding the evaluation tree, each
//! monomial of the exact polynomial (in the exact inputs and exact differences)
//! picks up at most `n` factors `(1 + δ)`, where `n` is the longest chain of
//! roundings from a leaf to the root: 6 for `det`, `β·det`, `γ·det`, `t·det`
//! (difference 1, product 1, cross-product subtraction 1, product 1, two sums 2)
//! and 8 for `α·det`. Hence
//!
//! ```text
//! |computed - exact| <= γ_n · X(|e|),   γ_n = n u / (1 - n u),
//! ```
//!
//! where `X` is the same expression with every input replaced by its absolute
//! value and every subtraction by an addition. The filter evaluates `X` in f64
//! on `|ê|` (`|e| <= |ê| / (1 - u)`, degree 3; `X` itself is computed with at most
//! 8 roundings, all of positive terms, so `X(|e|) <= X̂ (1 - u)^-11`). Altogether the
//! error is below `8.1 u X̂`; the filter uses
//!
//! ```text
//! E = K · u · X̂,   K = 32,
//! ```
//!
//! leaving a factor 4 to spare, which also covers the roundings of the
//! comparisons themselves (each bound below is further widened by a relative
//! 2^-40). No underflow can spoil the relative-error model: every nonzero
//! product of up to three f32-derived values has magnitude >= 2^-447 and at most
//! ~(2^129)^3 << 2^1023, and sums round relative to their result (subnormal sums are
//! exact).
//!
//! A triangle is rejected only when `|det̂| > E_det` (so the sign of `det` is
//! known) and then either some barycentric is provably `< -band` (its upper
//! bound, taken over the numerator interval `[x̂ - E_x, x̂ + E_x]` and the
//! denominator interval `[|det̂| - E_det, |det̂| + E_det]`, is below `-band`), or
//! `t` provably lies outside `[lo, hi]`.

const U: f64 = 1.0 / (1u64 << 53) as f64;
const K: f64 = 32.0;
/// Relative widening of the ratio bounds (covers the ≤ 3 roundings in them).
const RATIO_REL: f64 = 1.0 / (1u64 << 40) as f64;

/// Upper bound of `x' / d'` over all `x' <= x`, `d' in [d - e, d + e]`, with
/// `d > e >= 0`.
#[inline]
fn upper_ratio(x: f64, d: f64, e: f64) -> f64 {
    let r = if x >= 0.0 { x / (d - e) } else { x / (d + e) };
    r + r.abs() * RATIO_REL
}

/// Lower bound of `x' / d'` over all `x' >= x`, `d' in [d - e, d + e]`.
#[inline]
fn lower_ratio(x: f64, d: f64, e: f64) -> f64 {
    -upper_ratio(-x, d, e)
}

#[inline]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
fn cross_abs(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] + a[2] * b[1],
        a[2] * b[0] + a[0] * b[2],
        a[0] * b[1] + a[1] * b[0],
    ]
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn abs3(a: [f64; 3]) -> [f64; 3] {
    a.map(f64::abs)
}

/// `true` only if the triangle provably has no exact line intersection with
/// `min_bary >= -band` and `t` in `[lo, hi]`. Inputs finite (`o`, `d` are the
/// exact f64 images of the ray's f32 values); `lo <= hi`, either may be infinite.
#[inline]
pub(crate) fn rejects(
    tri: &[[f32; 3]; 3],
    o: [f64; 3],
    d: [f64; 3],
    band: f64,
    lo: f64,
    hi: f64,
) -> bool {
    let v0 = tri[0].map(f64::from);
    let v1 = tri[1].map(f64::from);
    let v2 = tri[2].map(f64::from);
    let e1 = [v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]];
    let e2 = [v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]];
    let s = [o[0] - v0[0], o[1] - v0[1], o[2] - v0[2]];
    let (ae1, ae2, as_, ad) = (abs3(e1), abs3(e2), abs3(s), abs3(d));

    let p = cross(d, e2);
    let pa = cross_abs(ad, ae2);
    let det = dot(e1, p);
    let det_a = dot(ae1, pa);
    let err_det = K * U * det_a;
    let dabs = det.abs();
    if dabs <= err_det {
        return false; // sign of det not certain
    }
    let sg = if det > 0.0 { 1.0 } else { -1.0 };

    let b = dot(s, p);
    let b_a = dot(as_, pa);
    let q = cross(s, e1);
    let qa = cross_abs(as_, ae1);
    let g = dot(d, q);
    let g_a = dot(ad, qa);
    let a = det - b - g;
    let a_a = det_a + b_a + g_a;

    for (x, xa) in [(b, b_a), (g, g_a), (a, a_a)] {
        if upper_ratio(sg * x + K * U * xa, dabs, err_det) < -band {
            return true;
        }
    }

    let tn = dot(e2, q);
    let t_a = dot(ae2, qa);
    let et = K * U * t_a;
    if upper_ratio(sg * tn + et, dabs, err_det) < lo {
        return true;
    }
    if lower_ratio(sg * tn - et, dabs, err_det) > hi {
        return true;
    }
    false
}
