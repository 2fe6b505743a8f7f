//! Randomised cross-check: the accelerated, filtered `candidates` must equal a
//! naive loop of `exact` over every triangle, for several bands and both modes,
//! on soups near the origin, far from it, and with tiny/huge direction
//! components. Any candidate dropped by the BVH culling or the f64 filter shows
//! up as a mismatch.

use sahara_oracle::*;
use std::cmp::Ordering;

type Tri = [[f32; 3]; 3];

/// The oracle's [`SplitMix64`] with uniform `f64`s.
struct Rng(SplitMix64);
impl Rng {
    fn u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn f(&mut self) -> f64 {
        (self.u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
}

/// A soup around `offset` in a box of size `size`: random triangles, exact
/// duplicates, edge-sharing neighbours, coplanar overlaps, axis-aligned
/// dyadic triangles (exact edge hits) and degenerate ones.
fn soup(rng: &mut Rng, n: usize, offset: [f64; 3], size: f64) -> Vec<Tri> {
    let mut tris: Vec<Tri> = Vec::with_capacity(n);
    let pt = |rng: &mut Rng, c: [f64; 3], s: f64| -> [f32; 3] {
        std::array::from_fn(|a| (c[a] + rng.range(-s, s)) as f32)
    };
    while tris.len() < n {
        let k = rng.below(20);
        if k < 2 && !tris.is_empty() {
            // exact duplicate
            let t = tris[rng.below(tris.len())];
            tris.push(t);
        } else if k < 5 && !tris.is_empty() {
            // shares an edge with an earlier one
            let t = tris[rng.below(tris.len())];
            let c = t[0].map(f64::from);
            let s = (t[1][0] as f64 - c[0]).abs().max(0.1 * size / 100.0);
            tris.push([t[1], t[0], pt(rng, c, s)]);
        } else if k < 7 && !tris.is_empty() {
            // coplanar with an earlier one: affine combination of its vertices
            let t = tris[rng.below(tris.len())];
            let w = |rng: &mut Rng| -> [f32; 3] {
                let (a, b) = (rng.range(-0.5, 1.5), rng.range(-0.5, 1.5));
                std::array::from_fn(|i| {
                    let v0 = t[0][i] as f64;
                    (v0 + a * (t[1][i] as f64 - v0) + b * (t[2][i] as f64 - v0)) as f32
                })
            };
            tris.push([w(rng), w(rng), w(rng)]);
        } else if k < 9 {
            // axis-aligned dyadic triangle (exact edges, exact t)
            let c: [f64; 3] =
                std::array::from_fn(|a| offset[a] + (rng.range(0.0, size) * 4.0).round() / 4.0);
            let s = (rng.range(0.5, 8.0)).round();
            let ax = rng.below(3);
            let (u, v) = ((ax + 1) % 3, (ax + 2) % 3);
            let mut a = c;
            let mut b = c;
            let mut d = c;
            b[u] += s;
            d[v] += s;
            a[ax] = c[ax];
            tris.push([a, b, d].map(|p| p.map(|x| x as f32)));
        } else if k < 10 {
            // degenerate: collinear or repeated vertex
            let a = pt(rng, offset.map(|o| o + size / 2.0), size / 2.0);
            let b = pt(rng, offset.map(|o| o + size / 2.0), size / 2.0);
            tris.push([a, b, a]);
        } else {
            let c: [f64; 3] = std::array::from_fn(|a| offset[a] + rng.range(0.0, size));
            let s = size * rng.range(0.003, 0.1);
            tris.push([pt(rng, c, s), pt(rng, c, s), pt(rng, c, s)]);
        }
    }
    tris
}

/// Rays: random, aimed at a triangle point with barycentrics near (or exactly
/// on, or just outside) its edges, axis-parallel, and with `tmax`/`tmin` placed
/// right at the aimed hit.
fn rays(
    rng: &mut Rng,
    tris: &[Tri],
    n: usize,
    offset: [f64; 3],
    size: f64,
    dir_scale: bool,
) -> Vec<OracleRay> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let o: [f64; 3] = std::array::from_fn(|a| offset[a] + rng.range(-0.2 * size, 1.2 * size));
        let origin = o.map(|x| x as f32);
        let kind = rng.below(10);
        let mut dir: [f64; 3];
        let mut tmin = 0.0f32;
        let mut tmax = f32::INFINITY;
        if kind < 3 {
            dir = std::array::from_fn(|_| rng.range(-1.0, 1.0));
        } else if kind < 4 {
            // axis-parallel or in a coordinate plane
            dir = [0.0; 3];
            dir[rng.below(3)] = if rng.below(2) == 0 { 1.0 } else { -1.0 };
            if rng.below(2) == 0 {
                dir[rng.below(3)] = rng.range(-1.0, 1.0);
            }
        } else {
            let t = tris[rng.below(tris.len())];
            let (mut b, mut g) = (rng.f(), rng.f());
            if b + g > 1.0 {
                (b, g) = (1.0 - b, 1.0 - g);
            }
            match rng.below(4) {
                0 => b = rng.range(-3e-4, 3e-4),
                1 => g = 1.0 - b + rng.range(-3e-4, 3e-4),
                2 => {
                    b = 0.5;
                    g = 0.5;
                }
                _ => {}
            }
            let target: [f64; 3] = std::array::from_fn(|i| {
                let v0 = t[0][i] as f64;
                v0 + b * (t[1][i] as f64 - v0) + g * (t[2][i] as f64 - v0)
            });
            let target = target.map(|x| x as f32 as f64);
            dir = std::array::from_fn(|i| target[i] - origin[i] as f64);
            match rng.below(6) {
                0 => tmax = 1.0,
                1 => tmax = 1.0f32.next_down(),
                2 => tmin = 1.0,
                3 => {
                    tmin = -1.0;
                    tmax = 1.0f32.next_up().next_up();
                }
                _ => {}
            }
        }
        if dir_scale {
            // tiny/huge components, each scaled independently or all together
            let k = rng.below(3);
            for (i, c) in dir.iter_mut().enumerate() {
                let e = if k == 0 {
                    (rng.below(181) as i32) - 90
                } else if k == 1 {
                    if i == 0 {
                        0
                    } else {
                        -(rng.below(100) as i32)
                    }
                } else {
                    60
                };
                *c *= 2f64.powi(e);
            }
            if k == 2 {
                tmin = (tmin as f64 * 2f64.powi(-60)) as f32;
                tmax = (tmax as f64 * 2f64.powi(-60)) as f32;
            }
        }
        out.push(OracleRay {
            origin,
            dir: dir.map(|x| x as f32),
            tmin,
            tmax,
        });
    }
    out
}

fn sort(v: &mut [ExactHit]) {
    v.sort_by(|a, b| a.cmp_t(b).then(a.prim.cmp(&b.prim)));
}

/// The reference: `exact` on every triangle, then the candidate rules.
fn naive(all: &[ExactHit], ray: &OracleRay, band: f64, mode: Mode) -> Vec<ExactHit> {
    let (lo, hi) = window(ray);
    let mut v: Vec<ExactHit> = all
        .iter()
        .filter(|h| {
            h.cmp_min_bary_f64(-band) != Ordering::Less
                && h.cmp_t_f64(lo) != Ordering::Less
                && h.cmp_t_f64(hi) != Ordering::Greater
        })
        .cloned()
        .collect();
    sort(&mut v);
    if mode == Mode::Closest {
        if let Some(b) = v.iter().find(|h| h.is_strict()).cloned() {
            v.retain(|h| h.t_minus_le(&b, slack(b.t)));
        }
    }
    v
}

#[derive(Default, Debug)]
struct Stats {
    rays: usize,
    candidates: usize,
    strict: usize,
    band_only: usize,
    slack_only: usize,
    ties: usize,
    edge_strict: usize,
}

fn cross_check(tris: &[Tri], rays: &[OracleRay]) -> Stats {
    let oracle = Oracle::new(tris);
    let mut st = Stats::default();
    for (i, ray) in rays.iter().enumerate() {
        let all: Vec<ExactHit> = (0..tris.len() as u32)
            .filter_map(|p| oracle.exact(p, ray))
            .collect();
        for band in [0.0, EDGE_BAND, 0.02] {
            for mode in [Mode::Closest, Mode::Any] {
                let want = naive(&all, ray, band, mode);
                let got = oracle.candidates(ray, band, mode);
                let key = |v: &[ExactHit]| {
                    v.iter()
                        .map(|h| (h.prim, h.t.to_bits(), h.min_bary.to_bits(), h.in_range))
                        .collect::<Vec<_>>()
                };
                assert_eq!(
                    key(&got),
                    key(&want),
                    "ray {i} {ray:?} band {band} {mode:?}\n got {got:?}\nwant {want:?}"
                );
                if band == EDGE_BAND && mode == Mode::Any {
                    st.candidates += want.len();
                    st.strict += want.iter().filter(|h| h.is_strict()).count();
                    st.band_only += want.iter().filter(|h| h.min_bary < 0.0).count();
                    st.slack_only += want
                        .iter()
                        .filter(|h| h.min_bary >= 0.0 && !h.in_range)
                        .count();
                    st.ties += want
                        .windows(2)
                        .filter(|w| w[0].cmp_t(&w[1]) == Ordering::Equal)
                        .count();
                    st.edge_strict += want
                        .iter()
                        .filter(|h| h.is_strict() && h.min_bary < EDGE_BAND)
                        .count();
                }
            }
        }
        // nearest / occluded / judges consistent with the reference
        let strict = naive(&all, ray, 0.0, Mode::Closest)
            .into_iter()
            .find(|h| h.is_strict());
        assert_eq!(
            oracle.nearest(ray).map(|h| h.prim),
            strict.as_ref().map(|h| h.prim)
        );
        assert_eq!(oracle.occluded(ray), strict.is_some());
        match &strict {
            Some(h) => {
                assert_eq!(
                    judge_closest(&oracle, ray, Some((h.prim, h.t as f32))),
                    Class::Agree
                );
                assert_eq!(judge_any(&oracle, ray, true), Class::Agree);
                assert_ne!(judge_closest(&oracle, ray, None), Class::Agree);
                assert_ne!(judge_any(&oracle, ray, false), Class::Agree);
            }
            None => {
                assert_eq!(judge_closest(&oracle, ray, None), Class::Agree);
                assert_eq!(judge_any(&oracle, ray, false), Class::Agree);
            }
        }
        st.rays += 1;
    }
    st
}

fn check_coverage(st: &Stats) {
    // The scenes must really exercise every kind of candidate.
    assert!(st.strict > st.rays / 4, "{st:?}");
    assert!(st.band_only > 20, "{st:?}");
    assert!(st.slack_only > 5, "{st:?}");
    assert!(st.ties > 20, "{st:?}");
    assert!(st.edge_strict > 20, "{st:?}");
}

#[test]
fn near_origin() {
    let mut rng = Rng(SplitMix64(11));
    let off = [0.0, -50.0, 3.0];
    let tris = soup(&mut rng, 2500, off, 100.0);
    let rays = rays(&mut rng, &tris, 2500, off, 100.0, false);
    let st = cross_check(&tris, &rays);
    eprintln!("near_origin {st:?}");
    check_coverage(&st);
}

#[test]
fn far_from_origin() {
    let mut rng = Rng(SplitMix64(12));
    let mut band_only = 0;
    for (k, off) in [[1e4, -2e4, 3e4], [-3e5, 1e5, 7e5], [1e6, 1e6, -1e6]]
        .into_iter()
        .enumerate()
    {
        let tris = soup(&mut rng, 800, off, 100.0 * (k + 1) as f64);
        let rays = rays(&mut rng, &tris, 600, off, 100.0 * (k + 1) as f64, false);
        let st = cross_check(&tris, &rays);
        eprintln!("far {off:?} {st:?}");
        assert!(st.strict > st.rays / 4, "{st:?}");
        assert!(st.ties > 20 && st.slack_only > 5, "{st:?}");
        band_only += st.band_only;
    }
    // f32 quantisation of the aim points far out limits how many land in the band
    assert!(band_only > 10, "{band_only}");
}

#[test]
fn tiny_and_huge_directions() {
    let mut rng = Rng(SplitMix64(13));
    let off = [5.0, 5.0, 5.0];
    let tris = soup(&mut rng, 500, off, 50.0);
    let rays = rays(&mut rng, &tris, 500, off, 50.0, true);
    let st = cross_check(&tris, &rays);
    eprintln!("dirs {st:?}");
    assert!(st.strict > st.rays / 5, "{st:?}");
}

// The rough speed numbers of the README ("Speed") are measured by `cargo xtask measure oracle`.
