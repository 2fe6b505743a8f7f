//! The reference pinned by the exact oracle.
//!
//! Every kernel is checked bit for bit against the reference (brute force, and the scalar
//! traversal that equals it), so a fault of the acceptance rule they share is invisible to those
//! checks. [`sahara_oracle`] decides ray/triangle intersection exactly (rational arithmetic on
//! the `f32` inputs) and shares no code with the kernels; this module judges the reference's
//! answers with it, ray by ray, and counts the classes of [`Class`]:
//!
//! * `agree`: the answer is the exact one;
//! * `edge`: the decisive hit is within 10^-4 (barycentric) of an edge, where `f32` rounding
//!   may legitimately decide either way (counted apart);
//! * `unorderable`: `f32` cannot order the candidates (exact distances of two triangles, or of a
//!   triangle and `tmin`/`tmax`, within a few ulps: stacked or coplanar geometry, origins on a
//!   surface) (counted apart);
//! * `missed`, `farther`, `false-hit`: failures.

use rayon::prelude::*;
use sahara_bvh::Bvh;
use sahara_geom::{Ray, Triangle};
use sahara_oracle::{judge_any, judge_closest_detailed, Class, Oracle, OracleRay};
use sahara_traverse::{scalar, Bvh8, Hit, NoStats};
use std::fmt;

/// The oracle over a scene's triangles.
pub fn oracle_for(tris: &[Triangle]) -> Oracle {
    let raw: Vec<[[f32; 3]; 3]> = tris
        .iter()
        .map(|t| [t.v[0].to_array(), t.v[1].to_array(), t.v[2].to_array()])
        .collect();
    Oracle::new(&raw)
}

fn oracle_ray(r: &Ray) -> OracleRay {
    OracleRay {
        origin: r.origin.to_array(),
        dir: r.direction().to_array(),
        tmin: r.tmin,
        tmax: r.tmax,
    }
}

/// The classes of a judged ray set.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Tally {
    /// Rays judged.
    pub rays: usize,
    /// Exact answers.
    pub agree: usize,
    /// Decisive hit on an edge (counted apart).
    pub edge: usize,
    /// Candidates `f32` cannot order (counted apart).
    pub unorderable: usize,
    /// Failures: a miss where the oracle finds a hit.
    pub missed: usize,
    /// Failures: a hit farther than the oracle's nearest.
    pub farther: usize,
    /// Failures: a hit on a triangle the oracle says the ray misses.
    pub false_hit: usize,
    /// Largest relative error of the reported distance among exact closest-hit answers.
    pub max_t_rel_error: f64,
    /// The first failing ray, described.
    pub first_failure: Option<String>,
}

impl Tally {
    /// Missed + farther + false hits.
    pub fn failures(&self) -> usize {
        self.missed + self.farther + self.false_hit
    }

    /// Adds another tally.
    pub fn add(&mut self, o: &Tally) {
        self.rays += o.rays;
        self.agree += o.agree;
        self.edge += o.edge;
        self.unorderable += o.unorderable;
        self.missed += o.missed;
        self.farther += o.farther;
        self.false_hit += o.false_hit;
        self.max_t_rel_error = self.max_t_rel_error.max(o.max_t_rel_error);
        if self.first_failure.is_none() {
            self.first_failure.clone_from(&o.first_failure);
        }
    }

    fn count(&mut self, class: Class, what: impl FnOnce() -> String) {
        self.rays += 1;
        match class {
            Class::Agree => self.agree += 1,
            Class::Edge => self.edge += 1,
            Class::Unorderable => self.unorderable += 1,
            Class::Missed => self.missed += 1,
            Class::Farther => self.farther += 1,
            Class::FalseHit => self.false_hit += 1,
        }
        if matches!(class, Class::Missed | Class::Farther | Class::FalseHit)
            && self.first_failure.is_none()
        {
            self.first_failure = Some(what());
        }
    }
}

impl fmt::Display for Tally {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} rays: {} agree, {} edge, {} unorderable, {} missed, {} farther, {} false hits",
            self.rays,
            self.agree,
            self.edge,
            self.unorderable,
            self.missed,
            self.farther,
            self.false_hit
        )
    }
}

fn describe(i: usize, r: &Ray) -> String {
    let o = r.origin.to_array().map(f64::from);
    let d = r.direction().to_array().map(f64::from);
    format!(
        "ray {i} [{} {} {} {} {} {} {} {}]",
        o[0], o[1], o[2], r.tmin as f64, d[0], d[1], d[2], r.tmax as f64
    )
}

/// Judges closest-hit answers (`answers[i]` for `rays[i]`).
pub fn pin_closest(oracle: &Oracle, rays: &[Ray], answers: &[Hit]) -> Tally {
    assert_eq!(rays.len(), answers.len());
    rays.par_iter()
        .zip(answers)
        .enumerate()
        .fold(Tally::default, |mut t, (i, (r, h))| {
            let reported = h.is_hit().then_some((h.prim, h.t));
            let v = judge_closest_detailed(oracle, &oracle_ray(r), reported);
            if let Some(e) = v.t_rel_error {
                t.max_t_rel_error = t.max_t_rel_error.max(e);
            }
            t.count(v.class, || {
                let want = v
                    .nearest
                    .as_ref()
                    .map(|n| {
                        format!(
                            "triangle {} at t {} (smallest barycentric {:.3e})",
                            n.prim, n.t, n.min_bary
                        )
                    })
                    .unwrap_or_else(|| "a miss".into());
                let got = reported
                    .map(|(p, t)| format!("triangle {p} at t {t}"))
                    .unwrap_or_else(|| "a miss".into());
                format!("{}: {:?}, got {got}, exact {want}", describe(i, r), v.class)
            });
            t
        })
        .reduce(Tally::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// Judges any-hit answers (`answers[i]` for `rays[i]`).
pub fn pin_any(oracle: &Oracle, rays: &[Ray], answers: &[bool]) -> Tally {
    assert_eq!(rays.len(), answers.len());
    rays.par_iter()
        .zip(answers)
        .enumerate()
        .fold(Tally::default, |mut t, (i, (r, &a))| {
            let class = judge_any(oracle, &oracle_ray(r), a);
            t.count(class, || {
                format!("{}: {class:?} (any hit reported {a})", describe(i, r))
            });
            t
        })
        .reduce(Tally::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// Traces `rays` with the reference (the scalar traversal of `bvh`, equal to brute force bit
/// for bit: closest hit, or any hit when `any`) and judges every answer with `oracle`.
pub fn pin_reference(
    oracle: &Oracle,
    bvh: &Bvh,
    tris: &[Triangle],
    rays: &[Ray],
    any: bool,
) -> Tally {
    if any {
        let answers: Vec<bool> = rays
            .par_iter()
            .map(|r| scalar::any_hit(bvh, tris, r, &mut NoStats))
            .collect();
        pin_any(oracle, rays, &answers)
    } else {
        let answers: Vec<Hit> = rays
            .par_iter()
            .map(|r| scalar::closest_hit(bvh, tris, r, &mut NoStats))
            .collect();
        pin_closest(oracle, rays, &answers)
    }
}

/// Traces `rays` with the 8-wide kernels of `wide` at its precision
/// ([`sahara_traverse::WideBvh::precision`]; closest hit, or any hit when `any`) and judges
/// every answer with `oracle`. For [`Precision::Exact`](sahara_traverse::Precision::Exact) the
/// answers are the reference's ([`pin_reference`]); for `Fast` this measures how often the
/// non-watertight test misses a real hit or reports a false one.
pub fn pin_wide(oracle: &Oracle, wide: &Bvh8, rays: &[Ray], any: bool) -> Tally {
    if any {
        let answers: Vec<bool> = rays
            .par_iter()
            .map(|r| wide.any_hit(r, &mut NoStats))
            .collect();
        pin_any(oracle, rays, &answers)
    } else {
        let answers: Vec<Hit> = rays
            .par_iter()
            .map(|r| wide.closest_hit(r, &mut NoStats))
            .collect();
        pin_closest(oracle, rays, &answers)
    }
}
