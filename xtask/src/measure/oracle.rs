//! `measure oracle`: rough speed figures of the exact oracle (`crates/oracle/README.md`,
//! "Speed"), one thread: its BVH build on a large and a smaller random soup, `candidates` and
//! the judgements per ray on the smaller soup, and one exact test on the `i128` and `BigInt`
//! paths.

use super::{Out, Row};
use anyhow::{Context, Result};
use sahara_geom::rng::Pcg32;
use sahara_oracle::{judge_any, judge_closest_detailed, Mode, Oracle, OracleRay, EDGE_BAND};
use serde::Serialize;
use std::time::Instant;

/// `measure oracle`.
#[derive(clap::Args, Clone, Debug)]
pub struct OracleArgs {
    /// Triangles of the soup whose build alone is timed.
    #[arg(long, default_value_t = 900_000)]
    pub big: usize,
    /// Triangles of the soup the queries run on.
    #[arg(long, default_value_t = 100_000)]
    pub small: usize,
    /// Rays (random origins in the soup's box, random directions, every other one ending at
    /// distance 10).
    #[arg(long, default_value_t = 20_000)]
    pub rays: usize,
    /// Calls of each exact test.
    #[arg(long, default_value_t = 100_000)]
    pub calls: usize,
    /// Print one JSON record on standard output instead of the lines.
    #[arg(long)]
    pub json: bool,
}

/// The record of `measure oracle` (times per ray and per call in microseconds).
#[derive(Clone, Debug, Serialize)]
pub struct OracleReport {
    pub big: usize,
    pub small: usize,
    pub build_big_s: f64,
    pub build_small_s: f64,
    pub rays: usize,
    pub candidates_closest_us: f64,
    pub candidates_closest: usize,
    pub candidates_any_us: f64,
    pub candidates_any: usize,
    pub judge_closest_us: f64,
    pub judge_closest_hits: usize,
    pub judge_any_us: f64,
    pub exact_i128_us: f64,
    pub exact_bigint_us: f64,
}

impl Row for OracleReport {
    fn line(&self) -> String {
        [
            format!("build {}: {:.2} s", self.big, self.build_big_s),
            format!("build {}: {:.3} s", self.small, self.build_small_s),
            format!(
                "candidates Closest: {:.2} us/ray ({} candidates)",
                self.candidates_closest_us, self.candidates_closest
            ),
            format!(
                "candidates Any: {:.2} us/ray ({} candidates)",
                self.candidates_any_us, self.candidates_any
            ),
            format!(
                "judge_closest: {:.2} us/ray ({} rays hit)",
                self.judge_closest_us, self.judge_closest_hits
            ),
            format!("judge_any(true): {:.2} us/ray", self.judge_any_us),
            format!("exact (i128): {:.3} us/call", self.exact_i128_us),
            format!("exact (BigInt): {:.3} us/call", self.exact_bigint_us),
        ]
        .join("\n")
    }
}

/// `n` random triangles: centres uniform in `[0, 100)³`, vertices within a random half-size of
/// 0.3 to 3 of the centre on each axis.
fn soup(rng: &mut Pcg32, n: usize) -> Vec<[[f32; 3]; 3]> {
    (0..n)
        .map(|_| {
            let c: [f32; 3] = std::array::from_fn(|_| rng.range_f32(0.0, 100.0));
            let s = rng.range_f32(0.3, 3.0);
            std::array::from_fn(|_| std::array::from_fn(|a| c[a] + rng.range_f32(-s, s)))
        })
        .collect()
}

/// Microseconds per item of `items` items done in `f`.
fn per_item_us<T>(items: usize, f: impl FnOnce() -> T) -> (f64, T) {
    let t0 = Instant::now();
    let r = f();
    (t0.elapsed().as_secs_f64() / items.max(1) as f64 * 1e6, r)
}

pub fn oracle(a: &OracleArgs) -> Result<OracleReport> {
    let mut rng = Pcg32::new(99, 0);
    let big = soup(&mut rng, a.big);
    let (build_big_s, o) = per_item_us(1, || Oracle::new(&big));
    drop(o);
    drop(big);
    let tris = soup(&mut rng, a.small);
    let (build_small_s, o) = per_item_us(1, || Oracle::new(&tris));
    let rays: Vec<OracleRay> = (0..a.rays)
        .map(|i| OracleRay {
            origin: std::array::from_fn(|_| rng.range_f32(0.0, 100.0)),
            dir: std::array::from_fn(|_| rng.range_f32(-1.0, 1.0)),
            tmin: 0.0,
            tmax: if i % 2 == 0 { f32::INFINITY } else { 10.0 },
        })
        .collect();
    let candidates = |mode| {
        per_item_us(a.rays, || {
            rays.iter()
                .map(|r| o.candidates(r, EDGE_BAND, mode).len())
                .sum::<usize>()
        })
    };
    let (candidates_closest_us, candidates_closest) = candidates(Mode::Closest);
    let (candidates_any_us, candidates_any) = candidates(Mode::Any);
    let (judge_closest_us, judge_closest_hits) = per_item_us(a.rays, || {
        rays.iter()
            .filter(|r| judge_closest_detailed(&o, r, None).nearest.is_some())
            .count()
    });
    let (judge_any_us, _) = per_item_us(a.rays, || {
        for r in &rays {
            std::hint::black_box(judge_any(&o, r, true));
        }
    });
    // One exact test: the i128 path, and the BigInt path (a coordinate with a tiny ulp).
    let exact = |first: f32| -> Result<f64> {
        let o = Oracle::new(&[[
            [first, 20.25, 30.0],
            [60.125, 21.0, 30.5],
            [11.0, 70.0, 29.75],
        ]]);
        let ray = OracleRay {
            origin: [20.3, 30.7, 80.1],
            dir: [0.11, -0.05, -1.0],
            tmin: 0.0,
            tmax: f32::INFINITY,
        };
        let (us, acc) = per_item_us(a.calls, || {
            (0..a.calls)
                .map(|_| o.exact(0, std::hint::black_box(&ray)).map(|h| h.t))
                .sum::<Option<f64>>()
        });
        acc.context("the exact test's ray misses its triangle")?;
        Ok(us)
    };
    let report = OracleReport {
        big: a.big,
        small: a.small,
        build_big_s: build_big_s / 1e6,
        build_small_s: build_small_s / 1e6,
        rays: a.rays,
        candidates_closest_us,
        candidates_closest,
        candidates_any_us,
        candidates_any,
        judge_closest_us,
        judge_closest_hits,
        judge_any_us,
        exact_i128_us: exact(10.5)?,
        exact_bigint_us: exact(1e-9)?,
    };
    Out { json: a.json }.row(&report)?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::super::tests::parse;
    use super::super::What;
    use super::*;

    #[test]
    fn oracle_runs_on_small_soups() {
        let What::Oracle(a) = parse(&["oracle"]).unwrap() else {
            panic!()
        };
        assert_eq!(
            (a.big, a.small, a.rays, a.calls),
            (900_000, 100_000, 20_000, 100_000)
        );
        let What::Oracle(a) = parse(&[
            "oracle", "--big", "3000", "--small", "2000", "--rays", "300", "--calls", "50",
        ])
        .unwrap() else {
            panic!()
        };
        let r = oracle(&a).unwrap();
        assert_eq!((r.big, r.small, r.rays), (3000, 2000, 300));
        // Rays from inside a dense soup hit, and any-hit queries see every candidate.
        assert!(r.judge_closest_hits > 0, "{r:?}");
        assert!(r.candidates_any >= r.candidates_closest, "{r:?}");
        assert!(r.exact_i128_us > 0.0 && r.exact_bigint_us > 0.0);
        assert_eq!(r.line().lines().count(), 8);
    }
}
