//! An independent, exact oracle for ray/triangle closest-hit and any-hit queries.
//!
//! The oracle shares no code with sahara's geometry or kernels and takes raw f32
//! arrays. Every decision it makes — the sign of a barycentric coordinate,
//! `det == 0`, `t` against `tmin`/`tmax`, `t(p) == t(q)` — is exact: Möller–Trumbore
//! is evaluated on the f32 inputs in (big-)integer arithmetic (see the `exact`
//! module), and only the *reported* `t` and `min_bary` are rounded to f64.
//! In front of the exact test sit an f64 BVH of the oracle's own and an f64
//! filter, both provably conservative: they only discard what cannot be a
//! candidate.
//!
//! ```
//! use sahara_oracle::{judge_closest, Class, Oracle, OracleRay};
//! let oracle = Oracle::new(&[[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
//! let ray = OracleRay { origin: [0.25, 0.25, 1.0], dir: [0.0, 0.0, -1.0], tmin: 0.0, tmax: f32::INFINITY };
//! let hit = oracle.exact(0, &ray).unwrap();
//! assert_eq!((hit.t, hit.min_bary, hit.in_range), (1.0, 0.25, true));
//! assert_eq!(judge_closest(&oracle, &ray, Some((0, 1.0))), Class::Agree);
//! assert_eq!(judge_closest(&oracle, &ray, None), Class::Missed);
//! ```

#![warn(missing_docs)]

mod bvh;
mod exact;
mod filter;
mod num;

use num::{ratio_to_f64, Q};
use std::cmp::Ordering;

/// SplitMix64 (Steele et al. 2014), a small deterministic generator seeded by its state:
/// the oracle's randomised tests draw from it, and so does the xtask's bootstrap.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n` > 0; the modulo bias is below 2^-40 for counts below 2^24).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Tolerance, in f32 ulps, under which two `t` values (or a `t` and a range end)
/// count as not orderable by f32 arithmetic.
pub const ULPS: f64 = 4.0;

/// Barycentric band: a decisive hit with smallest barycentric below this, or a
/// reported non-hit with smallest barycentric in `[-EDGE_BAND, 0)`, is an edge case.
pub const EDGE_BAND: f64 = 1e-4;

/// A ray: `origin + t * dir`, `t` in `[tmin, tmax]` (`tmax` may be `+inf`,
/// `tmin` may be negative or `-inf`). All f32 as given.
///
/// A ray with a non-finite origin or direction component, or a NaN `tmin` or
/// `tmax`, hits nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleRay {
    /// Ray origin.
    pub origin: [f32; 3],
    /// Ray direction (need not be normalised; `t` is in units of `dir`).
    pub dir: [f32; 3],
    /// Smallest accepted `t` (inclusive).
    pub tmin: f32,
    /// Largest accepted `t` (inclusive).
    pub tmax: f32,
}

impl OracleRay {
    /// Finite origin and direction, non-NaN `tmin`/`tmax`.
    pub fn is_valid(&self) -> bool {
        self.origin.iter().chain(&self.dir).all(|x| x.is_finite())
            && !self.tmin.is_nan()
            && !self.tmax.is_nan()
    }
}

/// Exact status of one triangle for one ray (with `det != 0`).
///
/// `t` and `min_bary` are the exact values rounded to the nearest f64. Rounding
/// is monotone, so comparisons of these fields against f64 values are exact
/// except on equality; the `cmp_*` methods settle that case exactly. The sign
/// of `min_bary` is always exact, and `min_bary == 0.0` iff the exact value is 0.
#[derive(Clone, Debug)]
pub struct ExactHit {
    /// Triangle index (position in the slice given to [`Oracle::new`]).
    pub prim: u32,
    /// Exact `t` of the intersection with the ray's line, rounded to nearest f64.
    pub t: f64,
    /// Smallest of the three exact barycentric coordinates (which sum to 1),
    /// rounded to f64; negative = the line passes outside the triangle.
    pub min_bary: f64,
    /// Exactly `tmin <= t <= tmax`.
    pub in_range: bool,
    core: exact::Core,
}

impl ExactHit {
    /// A strict hit: exact `min_bary >= 0` and `tmin <= t <= tmax`.
    pub fn is_strict(&self) -> bool {
        self.min_bary >= 0.0 && self.in_range
    }

    fn t_q(&self) -> Q {
        Q::new(&self.core.tnum, &self.core.den, self.core.texp)
    }

    fn bary_q(&self) -> Q {
        Q::new(&self.core.mnum, &self.core.den, 0)
    }

    /// Exact comparison of `t` with an f64 value (`x` may be infinite; panics on NaN).
    pub fn cmp_t_f64(&self, x: f64) -> Ordering {
        assert!(!x.is_nan(), "cmp_t_f64 against NaN");
        if x.is_infinite() {
            return if x > 0.0 {
                Ordering::Less
            } else {
                Ordering::Greater
            };
        }
        match self.t.partial_cmp(&x).expect("t is never NaN") {
            Ordering::Equal => self.t_q().cmp(&Q::from_f64(x)),
            o => o,
        }
    }

    /// Exact comparison of `min_bary` with an f64 value (panics on NaN).
    pub fn cmp_min_bary_f64(&self, x: f64) -> Ordering {
        assert!(!x.is_nan(), "cmp_min_bary_f64 against NaN");
        if x.is_infinite() {
            return if x > 0.0 {
                Ordering::Less
            } else {
                Ordering::Greater
            };
        }
        match self
            .min_bary
            .partial_cmp(&x)
            .expect("min_bary is never NaN")
        {
            Ordering::Equal => self.bary_q().cmp(&Q::from_f64(x)),
            o => o,
        }
    }

    /// Exact comparison of the two exact `t` values.
    pub fn cmp_t(&self, other: &ExactHit) -> Ordering {
        match self.t.partial_cmp(&other.t).expect("t is never NaN") {
            Ordering::Equal => self.t_q().cmp(&other.t_q()),
            o => o,
        }
    }

    /// Exactly `t(self) - t(other) <= s` (`s` finite, non-NaN).
    pub fn t_minus_le(&self, other: &ExactHit, s: f64) -> bool {
        assert!(s.is_finite(), "t_minus_le with a non-finite bound");
        if self.t.is_finite() && other.t.is_finite() {
            // |t - self.t| <= u|self.t| (round to nearest), likewise other;
            // the subtraction adds u|df|. Margin: 4u(...) > 2x all of that.
            let df = self.t - other.t;
            let m = 4.0 * f64::EPSILON * (self.t.abs() + other.t.abs() + df.abs());
            if df + m < s {
                return true;
            }
            if df - m > s {
                return false;
            }
        }
        self.t_q().sub(&other.t_q()).cmp(&Q::from_f64(s)) != Ordering::Greater
    }

    /// Exactly `|t(self) - t(other)| <= slack(max(|t|))`: f32 cannot order the two.
    pub fn t_near(&self, other: &ExactHit) -> bool {
        let s = slack(self.t.abs().max(other.t.abs()));
        s.is_finite() && self.t_minus_le(other, s) && other.t_minus_le(self, s)
    }
}

/// Which hits [`Oracle::candidates`] keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Only candidates up to the nearest strict hit's `t` plus its slack.
    Closest,
    /// All candidates along the ray.
    Any,
}

/// The spacing of f32 numbers at `|x|`: `2^(floor(log2|x|) - 23)`, at least the
/// smallest subnormal `2^-149`; `+inf` for infinite `x`. For an exact `t` it is
/// taken at the f64-rounded value.
pub fn ulp_f32(x: f64) -> f64 {
    let a = x.abs();
    if a.is_nan() {
        return f64::NAN;
    }
    if a.is_infinite() {
        return f64::INFINITY;
    }
    if a < f32::MIN_POSITIVE as f64 {
        return 2f64.powi(-149);
    }
    let e = ((a.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    f64::from_bits(((e - 23 + 1023) as u64) << 52)
}

/// `slack(x) = ULPS * ulp_f32(x)`; `slack(±inf) = 0`.
pub fn slack(x: f64) -> f64 {
    if x.is_infinite() {
        0.0
    } else {
        ULPS * ulp_f32(x)
    }
}

/// The widened window `[tmin - slack(tmin), tmax + slack(tmax)]` of a ray; both
/// ends exact in f64.
pub fn window(ray: &OracleRay) -> (f64, f64) {
    let (a, b) = (ray.tmin as f64, ray.tmax as f64);
    (a - slack(a), b + slack(b))
}

/// The exact oracle. Owns a copy of the triangles and an f64 BVH of its own.
/// `Sync`: share it across threads (e.g. rayon over rays).
pub struct Oracle {
    /// By prim.
    tris: Vec<[[f32; 3]; 3]>,
    nodes: Vec<bvh::Node>,
    /// Leaf order: prim and its vertices.
    order: Vec<u32>,
    ord_tris: Vec<[[f32; 3]; 3]>,
}

fn tri_finite(t: &[[f32; 3]; 3]) -> bool {
    t.iter().flatten().all(|x| x.is_finite())
}

/// Exact test of a triangle against a ray (both assumed valid/finite).
fn exact_hit(prim: u32, tri: &[[f32; 3]; 3], ray: &OracleRay) -> Option<ExactHit> {
    let core = exact::core(&ray.origin, &ray.dir, tri)?;
    let t = ratio_to_f64(&core.tnum, &core.den, core.texp);
    let min_bary = ratio_to_f64(&core.mnum, &core.den, 0);
    let mut h = ExactHit {
        prim,
        t,
        min_bary,
        in_range: false,
        core,
    };
    h.in_range = h.cmp_t_f64(ray.tmin as f64) != Ordering::Less
        && h.cmp_t_f64(ray.tmax as f64) != Ordering::Greater;
    Some(h)
}

impl Oracle {
    /// Build the oracle over `tris` (3 vertices each). Triangles with a
    /// non-finite coordinate or exactly zero area never hit anything and are
    /// left out of the BVH. Panics if there are more than `u32::MAX` triangles.
    pub fn new(tris: &[[[f32; 3]; 3]]) -> Oracle {
        assert!(tris.len() <= u32::MAX as usize, "too many triangles");
        let prims: Vec<u32> = (0..tris.len() as u32)
            .filter(|&p| {
                let t = &tris[p as usize];
                tri_finite(t) && !exact::degenerate(t)
            })
            .collect();
        let (nodes, order) = bvh::build(tris, prims);
        let ord_tris = order.iter().map(|&p| tris[p as usize]).collect();
        Oracle {
            tris: tris.to_vec(),
            nodes,
            order,
            ord_tris,
        }
    }

    /// Number of triangles given to [`Oracle::new`].
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// No triangles at all.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Triangle `prim` as given.
    pub fn triangle(&self, prim: u32) -> Option<[[f32; 3]; 3]> {
        self.tris.get(prim as usize).copied()
    }

    /// Exact test of one triangle: `None` when `det == 0` exactly (ray parallel
    /// to the plane, zero direction, or degenerate triangle), when a coordinate
    /// is non-finite (or `tmin`/`tmax` is NaN), or when `prim` is out of range.
    pub fn exact(&self, prim: u32, ray: &OracleRay) -> Option<ExactHit> {
        let tri = self.tris.get(prim as usize)?;
        if !ray.is_valid() || !tri_finite(tri) {
            return None;
        }
        exact_hit(prim, tri, ray)
    }

    /// Every triangle whose exact intersection with the ray's *line* has
    /// `min_bary >= -band` and `t` within `[tmin - slack(tmin), tmax + slack(tmax)]`
    /// ("candidates"); in [`Mode::Closest`] only those with
    /// `t <= t* + slack(t*)`, `t*` the nearest strict hit's `t` (all candidates
    /// when there is no strict hit). Sorted by (exact `t`, prim).
    ///
    /// Panics if `band` is NaN.
    pub fn candidates(&self, ray: &OracleRay, band: f64, mode: Mode) -> Vec<ExactHit> {
        self.search(ray, band, mode, |_| false)
    }

    /// The nearest strict hit (ties: lowest prim), if any.
    pub fn nearest(&self, ray: &OracleRay) -> Option<ExactHit> {
        // band 0 keeps the search tight; strict hits have min_bary >= 0 anyway
        self.candidates(ray, 0.0, Mode::Closest)
            .into_iter()
            .find(ExactHit::is_strict)
    }

    /// Whether any strict hit exists (stops at the first one found).
    pub fn occluded(&self, ray: &OracleRay) -> bool {
        self.search(ray, 0.0, Mode::Any, ExactHit::is_strict)
            .iter()
            .any(ExactHit::is_strict)
    }

    /// The traversal behind [`Oracle::candidates`]. When `stop` returns true for
    /// a candidate, the search ends at once and returns what it has (sorted).
    fn search(
        &self,
        ray: &OracleRay,
        band: f64,
        mode: Mode,
        mut stop: impl FnMut(&ExactHit) -> bool,
    ) -> Vec<ExactHit> {
        assert!(!band.is_nan(), "band is NaN");
        let mut out: Vec<ExactHit> = Vec::new();
        if !ray.is_valid() || self.nodes.is_empty() {
            return out;
        }
        let (lo, hi) = window(ray);
        if lo > hi {
            return out;
        }
        let o = ray.origin.map(f64::from);
        let d = ray.dir.map(f64::from);
        let sr = bvh::SlabRay {
            o,
            d,
            inv: d.map(|x| if x != 0.0 { 1.0 / x } else { 0.0 }),
            wband: if band > 0.0 {
                2.0 * band * (1.0 + 1e-6)
            } else {
                0.0
            },
        };
        let closest = mode == Mode::Closest;
        let mut best: Option<ExactHit> = None;
        // f64 upper bound (widened) of the closest-mode limit t* + slack(t*)
        let mut bound = hi;
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        if let Some(tn) = bvh::slab(&self.nodes[0], &sr, lo, bound) {
            stack.push((0, tn));
        }
        while let Some((ni, tn)) = stack.pop() {
            if tn > bound {
                continue;
            }
            let n = &self.nodes[ni as usize];
            if n.count == 0 {
                let (l, r) = (n.first, n.first + 1);
                let hl = bvh::slab(&self.nodes[l as usize], &sr, lo, bound);
                let hr = bvh::slab(&self.nodes[r as usize], &sr, lo, bound);
                match (hl, hr) {
                    (Some(a), Some(b)) => {
                        // nearer child on top
                        if a <= b {
                            stack.push((r, b));
                            stack.push((l, a));
                        } else {
                            stack.push((l, a));
                            stack.push((r, b));
                        }
                    }
                    (Some(a), None) => stack.push((l, a)),
                    (None, Some(b)) => stack.push((r, b)),
                    (None, None) => {}
                }
                continue;
            }
            let range = n.first as usize..(n.first + n.count) as usize;
            for (tri, &prim) in self.ord_tris[range.clone()].iter().zip(&self.order[range]) {
                if filter::rejects(tri, o, d, band, lo, bound) {
                    continue;
                }
                let Some(h) = exact_hit(prim, tri, ray) else {
                    continue;
                };
                if h.cmp_min_bary_f64(-band) == Ordering::Less
                    || h.cmp_t_f64(lo) == Ordering::Less
                    || h.cmp_t_f64(hi) == Ordering::Greater
                {
                    continue;
                }
                if closest {
                    if let Some(b) = &best {
                        if !h.t_minus_le(b, slack(b.t)) {
                            continue;
                        }
                    }
                    if h.is_strict() && best.as_ref().is_none_or(|b| h.cmp_t(b) == Ordering::Less) {
                        let bt = h.t;
                        let bf = bt + slack(bt);
                        // exact limit <= t̂(1+u) + slack(t̂) (+ rounding of bf)
                        bound = bound.min((bf + (bt.abs() + bf.abs()) * 2f64.powi(-50)).next_up());
                        best = Some(h.clone());
                    }
                }
                let done = stop(&h);
                out.push(h);
                if done {
                    sort_hits(&mut out);
                    return out;
                }
            }
        }
        if let Some(b) = &best {
            let s = slack(b.t);
            out.retain(|h| h.t_minus_le(b, s));
        }
        sort_hits(&mut out);
        out
    }
}

/// The README's example, compiled as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

fn sort_hits(v: &mut [ExactHit]) {
    v.sort_by(|a, b| a.cmp_t(b).then(a.prim.cmp(&b.prim)));
}

/// The classes a checked ray falls in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Class {
    /// The answer is right.
    Agree,
    /// The decisive geometry is within [`EDGE_BAND`] of a triangle edge; counted
    /// apart, not a failure.
    Edge,
    /// f32 cannot order the decisive candidates (near-equal `t`, or `t` within
    /// slack of `tmin`/`tmax`); counted apart, not a failure.
    Unorderable,
    /// Reported a miss where a hit exists.
    Missed,
    /// Reported a hit on a triangle that is not the nearest.
    Farther,
    /// Reported a hit where the reported triangle is not hit.
    FalseHit,
}

/// Detailed closest-hit verdict.
#[derive(Clone, Debug)]
pub struct ClosestVerdict {
    /// The class.
    pub class: Class,
    /// For [`Class::Agree`] with a reported hit: `|t_reported - t_exact| / |t_exact|`
    /// (`|t_reported|` when `t_exact == 0`).
    pub t_rel_error: Option<f64>,
    /// The oracle's nearest strict hit (ties: lowest prim).
    pub nearest: Option<ExactHit>,
    /// Exact status of the reported triangle, when a hit was reported and the
    /// triangle has `det != 0`.
    pub reported: Option<ExactHit>,
}

/// `t` within slack of `tmin` or `tmax` (exact), for a hit with `t` in range.
fn near_range_end(h: &ExactHit, ray: &OracleRay) -> bool {
    let (a, b) = (ray.tmin as f64, ray.tmax as f64);
    (a.is_finite() && h.cmp_t_f64(a + slack(a)) != Ordering::Greater)
        || (b.is_finite() && h.cmp_t_f64(b - slack(b)) != Ordering::Less)
}

/// Smallest barycentric below [`EDGE_BAND`] (exact).
fn is_edge(h: &ExactHit) -> bool {
    h.cmp_min_bary_f64(EDGE_BAND) == Ordering::Less
}

/// Judge a closest-hit answer: `reported = Some((prim, t))` or `None` (miss).
pub fn judge_closest(oracle: &Oracle, ray: &OracleRay, reported: Option<(u32, f32)>) -> Class {
    judge_closest_detailed(oracle, ray, reported).class
}

/// [`judge_closest`] with the oracle's view and the `t` error of agreeing answers.
///
/// Rules: a reported miss is `Agree` without a strict hit, `Missed` when any
/// robust strict hit exists (away from edges and from `tmin`/`tmax`), else `Edge`
/// / `Unorderable` as [`judge_any`] judges a `false` answer. A reported `p` that is not a strict hit is
/// `Edge` if its line intersection lies in the band (`min_bary` in
/// `[-EDGE_BAND, 0)`, `t` in the widened window), `Unorderable` if it is inside the
/// triangle with `t` within slack outside `[tmin, tmax]`, else `FalseHit`
/// (a triangle with `det == 0` exactly is `Edge` when the ray's line lies in its
/// plane and meets it — no single intersection point exists — and `FalseHit`
/// when the triangle has zero area or the line runs parallel off its plane or
/// misses it). A strict `p` is `Agree` when it is
/// the nearest strict hit; otherwise, against the nearest `q`: `Unorderable` when
/// `t(p)`, `t(q)` are within `ULPS` f32 ulps, else `Edge` if `q` is an edge hit,
/// else `Unorderable` if `t(q)` is within slack of `tmin`/`tmax`, else `Farther`.
pub fn judge_closest_detailed(
    oracle: &Oracle,
    ray: &OracleRay,
    reported: Option<(u32, f32)>,
) -> ClosestVerdict {
    let nearest = oracle
        .candidates(ray, EDGE_BAND, Mode::Closest)
        .into_iter()
        .find(ExactHit::is_strict);
    let mut v = ClosestVerdict {
        class: Class::Agree,
        t_rel_error: None,
        nearest,
        reported: None,
    };
    let Some((p, t_rep)) = reported else {
        // A miss is wrong when any robust hit exists, not only when the nearest hit is
        // robust (an edge hit in front of a robust one does not excuse missing both): the
        // any-hit judgement of a `false` answer.
        v.class = match &v.nearest {
            None => Class::Agree,
            Some(_) => judge_any(oracle, ray, false),
        };
        return v;
    };
    let Some(e) = oracle.exact(p, ray) else {
        let grazing = ray.is_valid()
            && oracle
                .triangle(p)
                .is_some_and(|t| tri_finite(&t) && exact::grazes(&ray.origin, &ray.dir, &t));
        v.class = if grazing {
            Class::Edge
        } else {
            Class::FalseHit
        };
        return v;
    };
    v.reported = Some(e.clone());
    if !e.is_strict() {
        let (lo, hi) = window(ray);
        let in_window = e.cmp_t_f64(lo) != Ordering::Less && e.cmp_t_f64(hi) != Ordering::Greater;
        v.class = if !in_window {
            Class::FalseHit
        } else if e.min_bary < 0.0 {
            if e.cmp_min_bary_f64(-EDGE_BAND) != Ordering::Less {
                Class::Edge
            } else {
                Class::FalseHit
            }
        } else {
            Class::Unorderable // inside, t within slack outside [tmin, tmax]
        };
        return v;
    }
    let q = v.nearest.clone().unwrap_or_else(|| e.clone());
    v.class = if q.prim == p {
        let err = (t_rep as f64 - e.t).abs();
        v.t_rel_error = Some(if e.t != 0.0 { err / e.t.abs() } else { err });
        Class::Agree
    } else if e.t_near(&q) || e.cmp_t(&q) == Ordering::Equal {
        Class::Unorderable
    } else if is_edge(&q) {
        Class::Edge
    } else if near_range_end(&q, ray) {
        Class::Unorderable
    } else {
        Class::Farther
    };
    v
}

/// Judge an any-hit (occlusion) answer.
///
/// Reported `false`: `Agree` without a strict hit; `Missed` if a robust strict
/// hit exists (`min_bary >= EDGE_BAND`, `t` not within slack of `tmin`/`tmax`);
/// otherwise `Edge` if some strict hit is an edge hit, else `Unorderable`.
/// Reported `true`: `Agree` if a strict hit exists; else `Edge` if a band
/// candidate exists (`min_bary` in `[-EDGE_BAND, 0)`, `t` in the widened
/// window), else `Unorderable` if a slack candidate exists (inside, `t` within
/// slack outside `[tmin, tmax]`), else `FalseHit`.
pub fn judge_any(oracle: &Oracle, ray: &OracleRay, reported: bool) -> Class {
    if reported {
        let c = oracle.search(ray, EDGE_BAND, Mode::Any, ExactHit::is_strict);
        if c.iter().any(ExactHit::is_strict) {
            Class::Agree
        } else if c.iter().any(|h| h.min_bary < 0.0) {
            Class::Edge
        } else if !c.is_empty() {
            Class::Unorderable
        } else {
            Class::FalseHit
        }
    } else {
        let robust = |h: &ExactHit| h.is_strict() && !is_edge(h) && !near_range_end(h, ray);
        let c = oracle.search(ray, 0.0, Mode::Any, robust);
        if c.iter().any(robust) {
            Class::Missed
        } else if !c.iter().any(ExactHit::is_strict) {
            Class::Agree
        } else if c.iter().any(|h| h.is_strict() && is_edge(h)) {
            Class::Edge
        } else {
            Class::Unorderable
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulp_and_slack() {
        assert_eq!(ulp_f32(1.0), 2f64.powi(-23));
        assert_eq!(ulp_f32(1.5), 2f64.powi(-23));
        assert_eq!(ulp_f32(-2.0), 2f64.powi(-22));
        assert_eq!(ulp_f32(0.0), 2f64.powi(-149));
        assert_eq!(ulp_f32(1e-42), 2f64.powi(-149));
        assert_eq!(ulp_f32(f32::MIN_POSITIVE as f64), 2f64.powi(-149));
        assert_eq!(ulp_f32(1e30), (1e30f32.next_up() - 1e30f32) as f64);
        assert_eq!(slack(f64::INFINITY), 0.0);
        assert_eq!(slack(1.0), 4.0 * 2f64.powi(-23));
        // window ends are exact and equal to 4 f32 steps
        let (lo, hi) = window(&OracleRay {
            origin: [0.0; 3],
            dir: [1.0, 0.0, 0.0],
            tmin: 3.0,
            tmax: 7.0,
        });
        let mut a = 3.0f32;
        let mut b = 7.0f32;
        for _ in 0..4 {
            a = a.next_down();
            b = b.next_up();
        }
        assert_eq!((lo, hi), (a as f64, b as f64));
    }

    #[test]
    fn oracle_is_sync() {
        fn is_sync<T: Sync + Send>() {}
        is_sync::<Oracle>();
    }
}
