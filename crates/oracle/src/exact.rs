//! Exact Möller–Trumbore on the raw f32 inputs.
//!
//! Every finite f32 is `m * 2^e` with an integer `m`. The twelve position
//! coordinates (origin and the three vertices) are scaled by one common power of
//! two `2^Sp` into integers, the three direction components by another, `2^Sd`.
//! With `e1 = v1 - v0`, `e2 = v2 - v0`, `s = o - v0`, `p = d × e2`,
//! `q = s × e1`, the integer quantities
//!
//! ```text
//! det = e1·p     β·det = s·p     γ·det = d·q     t·det = e2·q
//! ```
//!
//! are exact, and (all scaled by the same `2^(2Sp+Sd)` except `t·det`, scaled by
//! `2^(3Sp)`) `β`, `γ`, `α = 1 - β - γ` come out scale-free while
//! `t = (e2·q) / det * 2^(Sd - Sp)`.
//!
//! Overflow-free `i128` path: with `|position integer| < 2^P` every difference is
//! below `2^A`, `A = P + 1`; with `|direction integer| < 2^B`:
//! `|p_i| < 2^(A+B+1)`, `|det|, |β·det|, |γ·det| < 2^(2A+B+3)`,
//! `|α·det| < 2^(2A+B+5)`, `|q_i| < 2^(2A+1)`, `|t·det| < 2^(3A+3)`.
//! So `2A+B+5 <= 127` and `3A+3 <= 127` keep everything inside `i128`;
//! otherwise the same code runs on `BigInt`.

use crate::num::Int;
use num_bigint::BigInt;
use num_traits::{Signed, Zero};

/// `x = m * 2^e` with `m` odd, or `(0, 0)` for ±0. `x` must be finite.
fn split(x: f32) -> (i64, i32) {
    let bits = x.to_bits();
    let neg = bits >> 31 != 0;
    let ef = ((bits >> 23) & 0xff) as i32;
    let fr = (bits & 0x7f_ffff) as i64;
    let (mut m, mut e) = if ef == 0 {
        (fr, -149)
    } else {
        (fr | 1 << 23, ef - 150)
    };
    if m == 0 {
        return (0, 0);
    }
    let tz = m.trailing_zeros();
    m >>= tz;
    e += tz as i32;
    (if neg { -m } else { m }, e)
}

/// A set of f32 values brought to integers `m * 2^(e - emin)`; `bits` is such
/// that every integer is below `2^bits` in magnitude (0 when all are zero).
struct Scaled<const N: usize> {
    parts: [(i64, i32); N],
    emin: i32,
    bits: u32,
}

impl<const N: usize> Scaled<N> {
    fn new(xs: &[f32; N]) -> Self {
        let parts = xs.map(split);
        let mut emin = i32::MAX;
        let mut top = i32::MIN;
        for &(m, e) in &parts {
            if m != 0 {
                emin = emin.min(e);
                top = top.max(e + (64 - m.unsigned_abs().leading_zeros()) as i32);
            }
        }
        if emin == i32::MAX {
            return Scaled {
                parts,
                emin: 0,
                bits: 0,
            };
        }
        Scaled {
            parts,
            emin,
            bits: (top - emin) as u32,
        }
    }

    fn to_i128(&self) -> [i128; N] {
        self.parts.map(|(m, e)| {
            if m == 0 {
                0
            } else {
                (m as i128) << (e - self.emin)
            }
        })
    }

    fn to_big(&self) -> [BigInt; N] {
        self.parts.map(|(m, e)| {
            if m == 0 {
                BigInt::zero()
            } else {
                BigInt::from(m) << ((e - self.emin) as usize)
            }
        })
    }
}

/// Ring operations shared by the `i128` and `BigInt` paths.
trait Ring: Sized + Ord {
    fn add(&self, o: &Self) -> Self;
    fn sub(&self, o: &Self) -> Self;
    fn mul(&self, o: &Self) -> Self;
    fn neg(&self) -> Self;
    fn sign(&self) -> i32;
    fn into_int(self) -> Int;
}

impl Ring for i128 {
    #[inline]
    fn add(&self, o: &Self) -> Self {
        self + o
    }
    #[inline]
    fn sub(&self, o: &Self) -> Self {
        self - o
    }
    #[inline]
    fn mul(&self, o: &Self) -> Self {
        self * o
    }
    #[inline]
    fn neg(&self) -> Self {
        -self
    }
    #[inline]
    fn sign(&self) -> i32 {
        self.signum() as i32
    }
    fn into_int(self) -> Int {
        Int::S(self)
    }
}

impl Ring for BigInt {
    fn add(&self, o: &Self) -> Self {
        self + o
    }
    fn sub(&self, o: &Self) -> Self {
        self - o
    }
    fn mul(&self, o: &Self) -> Self {
        self * o
    }
    fn neg(&self) -> Self {
        -self
    }
    fn sign(&self) -> i32 {
        if self.is_zero() {
            0
        } else if self.is_negative() {
            -1
        } else {
            1
        }
    }
    fn into_int(self) -> Int {
        Int::B(self)
    }
}

fn sub3<T: Ring>(a: &[T], b: &[T]) -> [T; 3] {
    [a[0].sub(&b[0]), a[1].sub(&b[1]), a[2].sub(&b[2])]
}

fn cross<T: Ring>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [
        a[1].mul(&b[2]).sub(&a[2].mul(&b[1])),
        a[2].mul(&b[0]).sub(&a[0].mul(&b[2])),
        a[0].mul(&b[1]).sub(&a[1].mul(&b[0])),
    ]
}

fn dot<T: Ring>(a: &[T; 3], b: &[T; 3]) -> T {
    a[0].mul(&b[0]).add(&a[1].mul(&b[1])).add(&a[2].mul(&b[2]))
}

/// The exact outcome of one ray/triangle pair with `det != 0`:
/// `min_bary = mnum / den`, `t = tnum / den * 2^texp`, `den > 0`.
#[derive(Clone, Debug)]
pub(crate) struct Core {
    pub den: Int,
    pub mnum: Int,
    pub tnum: Int,
    pub texp: i64,
}

/// `pos` = origin then v0, v1, v2 (12 coordinates, integers); `d` = direction.
fn mt<T: Ring>(pos: &[T; 12], d: &[T; 3], texp: i64) -> Option<Core> {
    let o = &pos[0..3];
    let v0 = &pos[3..6];
    let e1 = sub3(&pos[6..9], v0);
    let e2 = sub3(&pos[9..12], v0);
    let s = sub3(o, v0);
    let p = cross(d, &e2);
    let det = dot(&e1, &p);
    let sd = det.sign();
    if sd == 0 {
        return None;
    }
    let b = dot(&s, &p);
    let q = cross(&s, &e1);
    let g = dot(d, &q);
    let tn = dot(&e2, &q);
    let (det, b, g, tn) = if sd < 0 {
        (det.neg(), b.neg(), g.neg(), tn.neg())
    } else {
        (det, b, g, tn)
    };
    let a = det.sub(&b).sub(&g);
    // smallest of the three numerators (common positive denominator det)
    let mut m = a;
    for x in [b, g] {
        if x < m {
            m = x;
        }
    }
    Some(Core {
        den: det.into_int(),
        mnum: m.into_int(),
        tnum: tn.into_int(),
        texp,
    })
}

/// Exact Möller–Trumbore for finite inputs. `None` iff `det == 0` exactly
/// (zero direction, ray parallel to the plane, or a degenerate triangle).
pub(crate) fn core(o: &[f32; 3], d: &[f32; 3], v: &[[f32; 3]; 3]) -> Option<Core> {
    let pos = [
        o[0], o[1], o[2], v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1],
        v[2][2],
    ];
    let sp = Scaled::new(&pos);
    let sd = Scaled::new(d);
    if sd.bits == 0 {
        return None;
    }
    // t = (e2·q)/det * 2^(Sd - Sp) with Sp = -emin_pos, Sd = -emin_dir
    let texp = sp.emin as i64 - sd.emin as i64;
    let a = sp.bits + 1;
    if 2 * a + sd.bits + 5 <= 127 && 3 * a + 3 <= 127 {
        mt(&sp.to_i128(), &sd.to_i128(), texp)
    } else {
        mt(&sp.to_big(), &sd.to_big(), texp)
    }
}

/// Exactly `(v1 - v0) × (v2 - v0) == 0`: the triangle has zero area and
/// `det == 0` for every ray. Inputs finite. (`|cross| < 2^(2A+1)`, so `i128` is
/// safe for `2A + 1 <= 127`.)
pub(crate) fn degenerate(v: &[[f32; 3]; 3]) -> bool {
    let pos = [
        v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2],
    ];
    let sp = Scaled::new(&pos);
    let a = sp.bits + 1;
    fn is_zero<T: Ring>(p: &[T; 9]) -> bool {
        let e1 = sub3(&p[3..6], &p[0..3]);
        let e2 = sub3(&p[6..9], &p[0..3]);
        cross(&e1, &e2).iter().all(|c| c.sign() == 0)
    }
    if 2 * a < 127 {
        is_zero(&sp.to_i128())
    } else {
        is_zero(&sp.to_big())
    }
}

/// For a pair with `det == 0`: whether the ray's line lies in the plane of the
/// (non-degenerate) triangle and meets the closed triangle there — a grazing
/// configuration with no single intersection point. Exact (`BigInt`; only the
/// judge calls it). Inputs finite.
pub(crate) fn grazes(o: &[f32; 3], d: &[f32; 3], v: &[[f32; 3]; 3]) -> bool {
    let pos = [
        o[0], o[1], o[2], v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1],
        v[2][2],
    ];
    let p = Scaled::new(&pos).to_big();
    let sd = Scaled::new(d);
    if sd.bits == 0 {
        return false;
    }
    let dd = sd.to_big();
    let e1 = sub3(&p[6..9], &p[3..6]);
    let e2 = sub3(&p[9..12], &p[3..6]);
    let n = cross(&e1, &e2);
    let s = sub3(&p[0..3], &p[3..6]);
    if n.iter().all(|c| Ring::sign(c) == 0)
        || Ring::sign(&dot(&s, &n)) != 0
        || Ring::sign(&dot(&dd, &n)) != 0
    {
        return false; // degenerate, parallel off the plane, or not parallel
    }
    // Project along the dominant normal axis k (non-degenerate for in-plane
    // geometry): the line meets the closed triangle iff the vertices are not all
    // strictly on one side of it.
    let k = (0..3)
        .max_by_key(|&i| n[i].magnitude().clone())
        .unwrap_or(0);
    let side = |i: usize| {
        let w = sub3(&p[3 + 3 * i..6 + 3 * i], &p[0..3]);
        Ring::sign(&cross(&dd, &w)[k])
    };
    let sides = [side(0), side(1), side(2)];
    !(sides.iter().all(|&x| x > 0) || sides.iter().all(|&x| x < 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_roundtrips() {
        for x in [
            1.0f32,
            -3.5,
            1e-45,
            -1e-40,
            f32::MAX,
            f32::MIN_POSITIVE,
            0.1,
            1088.7494,
            0.0,
            -0.0,
        ] {
            let (m, e) = split(x);
            assert_eq!((m as f64) * 2f64.powi(e), x as f64, "{x}");
            assert!(m == 0 || m % 2 != 0);
        }
    }

    #[test]
    fn i128_and_big_paths_agree() {
        let o = [0.25f32, 0.5, 3.0];
        let d = [0.125f32, -0.0625, -1.0];
        let v = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let pos = [
            o[0], o[1], o[2], v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0],
            v[2][1], v[2][2],
        ];
        let sp = Scaled::new(&pos);
        let sd = Scaled::new(&d);
        let texp = sp.emin as i64 - sd.emin as i64;
        let a = mt(&sp.to_i128(), &sd.to_i128(), texp).unwrap();
        let b = mt(&sp.to_big(), &sd.to_big(), texp).unwrap();
        assert_eq!(a.den.to_big(), b.den.to_big());
        assert_eq!(a.mnum.to_big(), b.mnum.to_big());
        assert_eq!(a.tnum.to_big(), b.tnum.to_big());
        // t = 3 exactly
        let t = crate::num::ratio_to_f64(&a.tnum, &a.den, a.texp);
        assert_eq!(t, 3.0);
    }

    #[test]
    fn degeneracy_is_exact() {
        assert!(degenerate(&[
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 1.0],
            [2.0, 2.0, 2.0]
        ]));
        assert!(degenerate(&[
            [1e30, 0.0, 0.0],
            [1e30, 0.0, 0.0],
            [1e-30, 5.0, 2.0]
        ]));
        assert!(!degenerate(&[
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 1.0],
            [2.0, 2.0, 2.0000002]
        ]));
        assert!(!degenerate(&[
            [1e30, 0.0, 0.0],
            [1e-30, 1e-30, 0.0],
            [0.0, 1e-30, 0.0]
        ]));
    }
}
