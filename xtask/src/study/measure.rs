//! The study's measurements: the trees of a setting and its reference with their SAH, EPO
//! and build time, work per ray counted exactly, speed ratios of interleaved rounds with the
//! rerun rule, and the outside camera.

use crate::engine::Engine;
use crate::interval::{median_interval, Interval};
use crate::util;
use anyhow::{Context, Result};
use sahara_builders::{BuildInput, Builder, CostModel};
use sahara_geom::Vec3A;
use sahara_trace::{Backend, RayKind, RaySet, Tracer};
use std::time::Instant;

pub const KINDS: [RayKind; 3] = [
    RayKind::Primary,
    RayKind::Diffuse,
    RayKind::AmbientOcclusion,
];
pub const LAYOUTS: [Engine; 2] = [Engine::Bvh2, Engine::Bvh8];

/// A built tree with its measurements.
pub struct Tree {
    pub bvh: sahara_bvh::Bvh,
    pub build_s: f64,
    pub sah: f64,
    pub epo: f64,
}

pub fn build(
    b: &dyn Builder,
    tris: &[sahara_geom::Triangle],
    cost: CostModel,
    threads: Option<usize>,
) -> Result<Tree> {
    let input = BuildInput::new(tris, cost)?;
    let t0 = Instant::now();
    let bvh = util::with_threads(threads, || b.build(&input))??;
    let build_s = t0.elapsed().as_secs_f64();
    bvh.validate(tris)
        .with_context(|| format!("{} tree invalid", b.name()))?;
    let sah = sahara_metrics::sah(&bvh, &cost);
    let epo = util::with_threads(threads, || sahara_metrics::epo(&bvh, tris, &cost))?;
    Ok(Tree {
        bvh,
        build_s,
        sah,
        epo,
    })
}

/// Work per ray, `c_t inner + c_i triangles`, of each (layout, ray kind).
pub fn work(
    tree: &Tree,
    tris: &[sahara_geom::Triangle],
    sets: &[RaySet],
    cost: CostModel,
    threads: Option<usize>,
) -> Result<Vec<f64>> {
    let mut out = Vec::new();
    for layout in LAYOUTS {
        let tracer = layout.tracer(&tree.bvh, tris, Backend::best())?;
        for set in sets {
            let c = util::with_threads(threads, || {
                sahara_trace::trace_set_counted(tracer.as_ref(), set)
            })?;
            let w = c.per_ray();
            out.push(cost.traversal as f64 * w.inner + cost.intersection as f64 * w.triangles);
        }
    }
    Ok(out)
}

/// The most timed rounds one speed cell may take while its interval is still undecided.
pub const MAX_SPEED_ROUNDS: usize = 60;

/// A speed cell is settled when its 95% interval excludes 1, or is narrower than this (as a
/// fraction of the estimate), or when [`MAX_SPEED_ROUNDS`] were spent.
pub const SETTLED_WIDTH: f64 = 0.02;

/// Whether a speed cell needs more rounds: its interval contains 1, is at least
/// [`SETTLED_WIDTH`] wide, and fewer than [`MAX_SPEED_ROUNDS`] rounds were taken.
pub fn needs_more_rounds(iv: &Interval, rounds: usize) -> bool {
    iv.contains_one()
        && (iv.high - iv.low) >= SETTLED_WIDTH * iv.estimate
        && rounds < MAX_SPEED_ROUNDS
}

/// One speed cell: the median of per-round ratios with its 95% interval, and the rounds taken.
#[derive(Clone, Copy, Debug)]
pub struct SpeedCell {
    pub interval: Interval,
    pub rounds: usize,
}

impl SpeedCell {
    /// The cell of a tree identical to its reference: exactly 1, no rounds timed.
    pub const IDENTICAL: SpeedCell = SpeedCell {
        interval: Interval {
            estimate: 1.0,
            low: 1.0,
            high: 1.0,
        },
        rounds: 0,
    };
}

/// Speed of `tree` against `reference` per (layout, ray kind): the median of the per-round
/// ratios reference time / tree time (> 1 is faster) of interleaved rounds, with its
/// bootstrap interval. Each cell starts with `rounds` rounds and takes `rounds` more while
/// [`needs_more_rounds`] says it is undecided (the rerun rule of `docs/study.md`).
pub fn speed(
    tree: &Tree,
    reference: &Tree,
    tris: &[sahara_geom::Triangle],
    sets: &[RaySet],
    rounds: usize,
    threads: Option<usize>,
) -> Result<Vec<SpeedCell>> {
    let mut out = Vec::new();
    for layout in LAYOUTS {
        let a = layout.tracer(&tree.bvh, tris, Backend::best())?;
        let r = layout.tracer(&reference.bvh, tris, Backend::best())?;
        for set in sets {
            let cell = util::with_threads(threads, || {
                let time = |t: &dyn Tracer| {
                    let t0 = Instant::now();
                    std::hint::black_box(sahara_trace::trace_set(t, set));
                    t0.elapsed().as_secs_f64()
                };
                time(a.as_ref());
                time(r.as_ref());
                let mut v: Vec<f64> = Vec::new();
                loop {
                    for _ in 0..rounds.max(1) {
                        // Alternate the order so neither tree always runs second.
                        let ratio = if v.len().is_multiple_of(2) {
                            let ta = time(a.as_ref());
                            time(r.as_ref()) / ta
                        } else {
                            let tr = time(r.as_ref());
                            tr / time(a.as_ref())
                        };
                        v.push(ratio);
                    }
                    let iv = median_interval(&v).unwrap_or(Interval {
                        estimate: f64::NAN,
                        low: f64::NAN,
                        high: f64::NAN,
                    });
                    if !needs_more_rounds(&iv, v.len()) {
                        return SpeedCell {
                            interval: iv,
                            rounds: v.len(),
                        };
                    }
                }
            })?;
            out.push(cell);
        }
    }
    Ok(out)
}

/// An orbit camera outside the scene's bounds, from above and to the side of the catalog
/// camera's view direction, framing the whole scene.
pub fn outside_camera(
    tris: &[sahara_geom::Triangle],
    c: &sahara_scene::Camera,
) -> sahara_trace::Camera {
    let mut b = sahara_geom::Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    let centre = b.centroid();
    let diag = b.extent().length().max(1e-6);
    let up = c.up.normalize_or_zero();
    let up = if up == Vec3A::ZERO { Vec3A::Y } else { up };
    let mut view = (c.target - c.eye).normalize_or_zero();
    view -= up * view.dot(up);
    let side = if view.length() < 1e-3 {
        up.any_orthonormal_vector()
    } else {
        -view.normalize()
    };
    let dir = (side * 0.8 + up * 0.6).normalize();
    let eye = centre + dir * diag * 1.05;
    sahara_trace::Camera::new(eye, centre, up, 55.0)
}

pub fn inside(tris: &[sahara_geom::Triangle], p: Vec3A) -> bool {
    let mut b = sahara_geom::Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    b.contains_point(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undecided_speed_cells_get_more_rounds() {
        let iv = |estimate, low, high| Interval {
            estimate,
            low,
            high,
        };
        // Contains 1 and is wide: rerun.
        assert!(needs_more_rounds(&iv(1.01, 0.97, 1.05), 5));
        // Excludes 1: settled.
        assert!(!needs_more_rounds(&iv(1.04, 1.01, 1.07), 5));
        // Contains 1 but narrower than 2%: a tie, settled.
        assert!(!needs_more_rounds(&iv(1.0, 0.995, 1.01), 5));
        // Out of rounds: settled whatever the interval.
        assert!(!needs_more_rounds(&iv(1.01, 0.9, 1.1), MAX_SPEED_ROUNDS));
    }
}
