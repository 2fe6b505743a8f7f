//! How far another engine's answers agree with sahara's reference on the same rays.
//!
//! sahara's kernels are exact (every layout and backend returns the brute-force hit bit for
//! bit); Embree, tinybvh and obvhs are not watertight and break ties between coincident
//! triangles their own way, so their hits are compared, not asserted equal: [`agreement`]
//! counts the rays where one engine hits and the other misses, and the rays whose hit
//! distances differ by more than [`T_TOLERANCE`] (relative). `cargo xtask trace` prints it for
//! the foreign engines; the features' tests bound it.

use sahara_trace::{trace_set, RaySet, TraceResults, Tracer};
use std::fmt;

/// Hit distances closer than this (relative to the larger, at least 1e-30 absolute) count
/// as the same.
pub const T_TOLERANCE: f32 = 1e-4;

/// The comparison of two engines' answers on one ray set ([`agreement`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Agreement {
    /// Rays compared.
    pub rays: usize,
    /// Rays that hit (or are occluded) in one engine and not in the other.
    pub hit_miss: usize,
    /// Rays that hit in both at distances further apart than [`T_TOLERANCE`].
    pub distance: usize,
    /// Rays that hit another triangle at the same distance (coincident triangles, ties).
    pub other_triangle: usize,
}

impl Agreement {
    /// Rays whose answers differ: hit/miss or distance.
    pub fn mismatches(&self) -> usize {
        self.hit_miss + self.distance
    }

    /// [`Agreement::mismatches`] per ray (0 for an empty set).
    pub fn rate(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.mismatches() as f64 / self.rays as f64
        }
    }
}

impl fmt::Display for Agreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} of {} rays differ ({:.4}%): {} hit/miss, {} distance; {} others hit another \
             triangle at the same distance",
            self.mismatches(),
            self.rays,
            100.0 * self.rate(),
            self.hit_miss,
            self.distance,
            self.other_triangle
        )
    }
}

/// Compares `engine` with `reference` on `set` (closest hits, or occlusion for AO rays).
pub fn agreement(reference: &dyn Tracer, engine: &dyn Tracer, set: &RaySet) -> Agreement {
    compare(&trace_set(reference, set), &trace_set(engine, set))
}

/// [`agreement`] of two sets of results of the same rays.
pub fn compare(reference: &TraceResults, engine: &TraceResults) -> Agreement {
    let mut a = Agreement::default();
    match (reference, engine) {
        (TraceResults::Closest(r), TraceResults::Closest(e)) => {
            a.rays = r.len().min(e.len());
            for (x, y) in r.iter().zip(e) {
                match (x.is_hit(), y.is_hit()) {
                    (true, true) => {
                        let scale = x.t.abs().max(y.t.abs()).max(1e-30);
                        if (x.t - y.t).abs() > T_TOLERANCE * scale {
                            a.distance += 1;
                        } else if x.prim != y.prim {
                            a.other_triangle += 1;
                        }
                    }
                    (false, false) => {}
                    _ => a.hit_miss += 1,
                }
            }
        }
        (TraceResults::Any(r), TraceResults::Any(e)) => {
            a.rays = r.len().min(e.len());
            a.hit_miss = r.iter().zip(e).filter(|(x, y)| x != y).count();
        }
        _ => {
            a.rays = reference.len().max(engine.len());
            a.hit_miss = a.rays;
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_trace::Hit;

    #[test]
    fn counts_each_kind_of_difference() {
        let h = |t: f32, prim: u32| Hit {
            t,
            prim,
            u: 0.0,
            v: 0.0,
        };
        let r = TraceResults::Closest(vec![h(1.0, 0), h(2.0, 1), Hit::MISS, h(3.0, 2), h(4.0, 3)]);
        let e = TraceResults::Closest(vec![
            h(1.00001, 0),
            Hit::MISS,
            h(5.0, 9),
            h(3.0, 7),
            h(4.1, 3),
        ]);
        let a = compare(&r, &e);
        assert_eq!(
            a,
            Agreement {
                rays: 5,
                hit_miss: 2,
                distance: 1,
                other_triangle: 1
            }
        );
        assert_eq!(a.mismatches(), 3);
        assert!((a.rate() - 0.6).abs() < 1e-12);
        assert!(a.to_string().starts_with("3 of 5 rays differ"));
        let any = compare(
            &TraceResults::Any(vec![true, false, true]),
            &TraceResults::Any(vec![true, true, true]),
        );
        assert_eq!((any.rays, any.hit_miss), (3, 1));
        assert_eq!(compare(&r, &r).mismatches(), 0);
        assert_eq!(Agreement::default().rate(), 0.0);
        // Two exact tracers agree on every ray.
        let tris = [sahara_geom::Triangle::new(
            sahara_geom::Vec3A::new(-1.0, -1.0, 2.0),
            sahara_geom::Vec3A::new(1.0, -1.0, 2.0),
            sahara_geom::Vec3A::new(0.0, 1.0, 2.0),
        )];
        let cam = sahara_trace::Camera::new(
            sahara_geom::Vec3A::ZERO,
            sahara_geom::Vec3A::Z,
            sahara_geom::Vec3A::Y,
            60.0,
        );
        let set = RaySet::primary(&cam, 16, 12);
        let b = sahara_trace::BruteTracer::new(&tris);
        let a = agreement(&b, &b, &set);
        assert_eq!((a.rays, a.mismatches()), (192, 0));
    }
}
