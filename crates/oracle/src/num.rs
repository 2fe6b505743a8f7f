//! Exact number plumbing: integers that are `i128` when they provably fit and
//! `BigInt` otherwise, correctly rounded conversion of `num / den * 2^exp` to
//! `f64`, and an exact dyadic-scaled rational [`Q`] for the rare comparisons
//! that the rounded values cannot settle.

use num_bigint::{BigInt, BigUint, Sign};
use num_integer::Integer;
use num_traits::{ToPrimitive, Zero};
use std::cmp::Ordering;

/// An exact integer: `S` when it came out of the provably overflow-free
/// `i128` path, `B` otherwise.
#[derive(Clone, Debug)]
pub(crate) enum Int {
    S(i128),
    B(BigInt),
}

impl Int {
    pub(crate) fn to_big(&self) -> BigInt {
        match self {
            Int::S(v) => BigInt::from(*v),
            Int::B(b) => b.clone(),
        }
    }

    pub(crate) fn is_negative(&self) -> bool {
        match self {
            Int::S(v) => *v < 0,
            Int::B(b) => b.sign() == Sign::Minus,
        }
    }

    pub(crate) fn is_zero(&self) -> bool {
        match self {
            Int::S(v) => *v == 0,
            Int::B(b) => b.is_zero(),
        }
    }
}

/// Correctly rounded (to nearest, ties to even) `num / den * 2^exp`; `den > 0`.
/// Overflow gives ±inf, underflow rounds into the subnormals / to ±0.
pub(crate) fn ratio_to_f64(num: &Int, den: &Int, exp: i64) -> f64 {
    debug_assert!(!den.is_negative() && !den.is_zero());
    if num.is_zero() {
        return 0.0;
    }
    let neg = num.is_negative();
    let (m, e, sticky) = match (num, den) {
        (Int::S(n), Int::S(d)) => quotient_bits_u128(n.unsigned_abs(), d.unsigned_abs()),
        _ => {
            let n = num.to_big().magnitude().clone();
            let d = den.to_big().magnitude().clone();
            quotient_bits_big(&n, &d)
        }
    };
    round_to_f64(neg, m, e.saturating_add(exp), sticky)
}

/// `n / d = (m + f) * 2^e` with `m` in `[2^56, 2^64)`, `0 <= f < 1`, and
/// `sticky == (f > 0)`. Needs `0 < n`, `0 < d <= 2^127`.
pub(crate) fn quotient_bits_u128(n: u128, d: u128) -> (u64, i64, bool) {
    debug_assert!(n > 0 && d > 0 && d <= 1u128 << 127);
    let mut q = n / d;
    let mut r = n % d;
    let qbits = 128 - q.leading_zeros();
    if qbits > 56 {
        let k = qbits.saturating_sub(63);
        if k == 0 {
            return (q as u64, 0, r != 0);
        }
        let dropped = q & ((1u128 << k) - 1);
        return ((q >> k) as u64, k as i64, dropped != 0 || r != 0);
    }
    let mut e: i64 = 0;
    // Long division in chunks: r < d, so r << lz(d) < 2^128.
    let lz = d.leading_zeros().max(1);
    while q < 1u128 << 56 {
        let have = 128 - q.leading_zeros();
        let k = (57 - have).min(lz);
        let rr = r << k;
        q = (q << k) | (rr / d);
        r = rr % d;
        e -= k as i64;
    }
    (q as u64, e, r != 0)
}

/// Same contract as [`quotient_bits_u128`], any sizes (`n, d > 0`).
pub(crate) fn quotient_bits_big(n: &BigUint, d: &BigUint) -> (u64, i64, bool) {
    let nb = n.bits() as i64;
    let db = d.bits() as i64;
    let s = (60 + db - nb).max(0);
    let n2 = n << (s as usize);
    let (q, r) = n2.div_rem(d);
    let qb = q.bits();
    let k = qb.saturating_sub(63);
    let sticky = !r.is_zero() || (k > 0 && q.trailing_zeros().unwrap_or(0) < k);
    let m = (q >> (k as usize)).to_u64().expect("at most 63 bits");
    (m, k as i64 - s, sticky)
}

/// Round `(m + f) * 2^e` (sign `neg`; `f` in `[0, 1)`, `sticky == (f > 0)`) to
/// the nearest f64, ties to even. When `sticky`, `m` must have at least 56
/// significant bits so that `f` lies strictly below the rounding position.
pub(crate) fn round_to_f64(neg: bool, m: u64, e: i64, sticky: bool) -> f64 {
    let sign = if neg { 1u64 << 63 } else { 0 };
    if m == 0 {
        return f64::from_bits(sign);
    }
    let lz = m.leading_zeros();
    debug_assert!(
        !sticky || lz <= 8,
        "too few quotient bits for a sticky value"
    );
    let m = (m << lz) as u128;
    let e = e - lz as i64;
    let lead = e + 63; // exponent of the leading bit
    if lead > 1023 {
        return f64::from_bits(sign | 0x7ff0_0000_0000_0000);
    }
    if lead < -1076 {
        // value < 2^-1075: below half the smallest subnormal
        return f64::from_bits(sign);
    }
    let ulp_e = (lead - 52).max(-1074);
    let shift = (ulp_e - e) as u32; // in 11..=65
    let n = m >> shift;
    let rem = m & ((1u128 << shift) - 1);
    let half = 1u128 << (shift - 1);
    let up = rem > half || (rem == half && (sticky || n & 1 == 1));
    let n = (n + up as u128) as u64;
    // n * 2^ulp_e; for normal numbers n in [2^52, 2^53] and the biased exponent
    // is ulp_e + 1075, so bits = ((ulp_e + 1074) << 52) + n covers the carry and
    // the subnormal range (ulp_e == -1074) alike.
    let bits = (((ulp_e + 1074) as u64) << 52) + n;
    if bits >= 0x7ff0_0000_0000_0000 {
        return f64::from_bits(sign | 0x7ff0_0000_0000_0000);
    }
    f64::from_bits(sign | bits)
}

/// An exact rational `num / den * 2^exp` with `den > 0`.
#[derive(Clone, Debug)]
pub(crate) struct Q {
    pub num: BigInt,
    pub den: BigInt,
    pub exp: i64,
}

impl Q {
    pub(crate) fn new(num: &Int, den: &Int, exp: i64) -> Q {
        Q {
            num: num.to_big(),
            den: den.to_big(),
            exp,
        }
    }

    /// The exact value of a finite f64.
    pub(crate) fn from_f64(x: f64) -> Q {
        debug_assert!(x.is_finite());
        let bits = x.to_bits();
        let neg = bits >> 63 != 0;
        let ef = ((bits >> 52) & 0x7ff) as i64;
        let fr = bits & ((1u64 << 52) - 1);
        let (m, e) = if ef == 0 {
            (fr, -1074)
        } else {
            (fr | 1u64 << 52, ef - 1075)
        };
        let m = BigInt::from(m);
        Q {
            num: if neg { -m } else { m },
            den: BigInt::from(1u8),
            exp: e,
        }
    }

    /// `(a, b)` = the numerators of `self` and `o` over the common denominator
    /// `self.den * o.den * 2^-min(exp)`.
    fn aligned(&self, o: &Q) -> (BigInt, BigInt, i64) {
        let m = self.exp.min(o.exp);
        let a = (&self.num * &o.den) << ((self.exp - m) as usize);
        let b = (&o.num * &self.den) << ((o.exp - m) as usize);
        (a, b, m)
    }

    pub(crate) fn cmp(&self, o: &Q) -> Ordering {
        let (a, b, _) = self.aligned(o);
        a.cmp(&b)
    }

    pub(crate) fn sub(&self, o: &Q) -> Q {
        let (a, b, m) = self.aligned(o);
        Q {
            num: a - b,
            den: &self.den * &o.den,
            exp: m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::SplitMix64 as Rng;

    #[test]
    fn small_ratios_match_ieee_division() {
        // Both operands below 2^53 are exact in f64, so IEEE division is the
        // correctly rounded reference.
        let mut r = Rng(1);
        for _ in 0..200_000 {
            let bn = 1 + r.next_u64() % 53;
            let bd = 1 + r.next_u64() % 53;
            let n = (r.next_u64() >> (64 - bn)).max(1) as i128;
            let d = (r.next_u64() >> (64 - bd)).max(1) as i128;
            let n = if r.next_u64() & 1 == 0 { n } else { -n };
            let exp = (r.next_u64() % 200) as i64 - 100;
            let want = (n as f64 / d as f64) * 2f64.powi(exp as i32);
            let got = ratio_to_f64(&Int::S(n), &Int::S(d), exp);
            assert_eq!(got.to_bits(), want.to_bits(), "{n}/{d}*2^{exp}");
            let got_big = ratio_to_f64(&Int::B(BigInt::from(n)), &Int::S(d), exp);
            assert_eq!(got_big.to_bits(), want.to_bits());
        }
    }

    #[test]
    fn u128_and_big_paths_agree() {
        let mut r = Rng(2);
        for _ in 0..100_000 {
            let bn = 1 + r.next_u64() % 127;
            let bd = 1 + r.next_u64() % 127;
            let n = ((r.next_u64() as u128) << 64 | r.next_u64() as u128) >> (128 - bn);
            let d = ((r.next_u64() as u128) << 64 | r.next_u64() as u128) >> (128 - bd);
            let (n, d) = (n.max(1), d.max(1));
            let exp = (r.next_u64() % 2400) as i64 - 1200;
            let a = ratio_to_f64(&Int::S(n as i128), &Int::S(d as i128), exp);
            let b = ratio_to_f64(&Int::B(BigInt::from(n)), &Int::B(BigInt::from(d)), exp);
            assert_eq!(a.to_bits(), b.to_bits(), "{n}/{d}*2^{exp}");
            // And the result is the nearest f64: check against the exact value.
            if a.is_finite() && a != 0.0 && a.next_up().is_finite() {
                let qa = Q::from_f64(a);
                let exact = Q::new(&Int::S(n as i128), &Int::S(d as i128), exp);
                let err = exact.sub(&qa);
                let up = Q::from_f64(a.next_up()).sub(&qa);
                let down = qa.sub(&Q::from_f64(a.next_down()));
                // |err| <= half the gap on its side
                let two = |q: &Q| Q {
                    num: q.num.clone() * 2,
                    den: q.den.clone(),
                    exp: q.exp,
                };
                let zero = Q::from_f64(0.0);
                if err.cmp(&zero) == Ordering::Greater {
                    assert_ne!(two(&err).cmp(&up), Ordering::Greater);
                } else {
                    let neg = Q {
                        num: -err.num.clone(),
                        den: err.den.clone(),
                        exp: err.exp,
                    };
                    assert_ne!(two(&neg).cmp(&down), Ordering::Greater);
                }
            }
        }
    }

    #[test]
    fn rounding_edges() {
        // exactly the smallest subnormal
        assert_eq!(
            round_to_f64(false, 1 << 60, -1074 - 60, false),
            f64::from_bits(1)
        );
        // exactly half the smallest subnormal: tie to even -> 0
        assert_eq!(round_to_f64(false, 1 << 60, -1075 - 60, false), 0.0);
        // a hair above half: rounds up
        assert_eq!(
            round_to_f64(false, 1 << 60, -1075 - 60, true),
            f64::from_bits(1)
        );
        // overflow
        assert_eq!(
            round_to_f64(true, 1 << 60, 1024 - 60, false),
            f64::NEG_INFINITY
        );
        // largest finite
        assert_eq!(
            round_to_f64(false, ((1u64 << 53) - 1) << 8, 1023 - 52 - 8, false),
            f64::MAX
        );
        // 1 + 2^-53 (tie) -> 1, with sticky -> next up
        assert_eq!(round_to_f64(false, (1 << 62) + (1 << 9), -62, false), 1.0);
        assert_eq!(
            round_to_f64(false, (1 << 62) + (1 << 9), -62, true),
            1.0f64.next_up()
        );
        // 1/3
        assert_eq!(ratio_to_f64(&Int::S(1), &Int::S(3), 0), 1.0 / 3.0);
        assert_eq!(ratio_to_f64(&Int::S(-7), &Int::S(1), 0), -7.0);
    }
}
