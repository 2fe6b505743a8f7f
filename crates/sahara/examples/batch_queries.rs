//! Times the façade's batch queries, `Accel::closest_hits` and `Accel::any_hits`, on a
//! procedural scene generated here (no scene file), for A/B comparisons between commits.
//!
//! ```text
//! cargo run --release -p sahara --example batch_queries [ROUNDS]
//! ```
//!
//! Builds one `Accel` at `Quality::Medium` over about 200 000 triangles (a tessellated
//! sphere in a box of random small triangles), then traces two ray sets ROUNDS times
//! (default 7), the queries alternating: 262 144 camera rays (`closest_hits`), the same rays
//! through the 8-wide kernel alone on one thread (`kernel_closest`: `Accel::wide().closest_hit`,
//! no façade hit record), and 262 144 random shadow segments (`any_hits`). Prints one line per
//! query, `query median min max`, in nanoseconds per ray over the rounds, and a checksum of the answers (the same on every
//! commit whose answers are the same). The batch queries run on the current rayon pool
//! (`RAYON_NUM_THREADS` picks its size). The file uses only the API that every version of the
//! façade since 2026-12-02 has, so that the same file times an older commit.
//! `docs/facade.md` ("Batch queries before and after issue 45") has the figures.

use std::time::Instant;

use sahara::sahara_traverse::NoStats;
use sahara::{Accel, Hit, Quality, Ray, Triangle, Vec3A};

/// A small deterministic generator (xorshift64*), so that every commit traces the same rays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (x >> 40) as f32 / (1u64 << 24) as f32
    }

    fn point(&mut self, lo: f32, hi: f32) -> Vec3A {
        let s = hi - lo;
        Vec3A::new(
            lo + s * self.next(),
            lo + s * self.next(),
            lo + s * self.next(),
        )
    }
}

/// A sphere of radius 3 (about 80 000 triangles) and 120 000 small random triangles in the
/// box [-10, 10]^3.
fn scene() -> Vec<Triangle> {
    let mut tris = Vec::new();
    let (rings, segments) = (200usize, 200usize);
    let at = |i: usize, j: usize| {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = std::f32::consts::TAU * j as f32 / segments as f32;
        3.0 * Vec3A::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    };
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            tris.push(Triangle::new(a, b, c));
            tris.push(Triangle::new(a, c, d));
        }
    }
    let mut rng = Rng(0x5eed_0f5a_4a7a);
    for _ in 0..120_000 {
        let o = rng.point(-10.0, 10.0);
        let (e1, e2) = (rng.point(-0.3, 0.3), rng.point(-0.3, 0.3));
        tris.push(Triangle::new(o, o + e1, o + e2));
    }
    tris
}

/// Camera rays from z = -30 through a 512 × 512 grid over the scene.
fn camera_rays() -> Vec<Ray> {
    let n = 512;
    let eye = Vec3A::new(0.0, 0.0, -30.0);
    (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32 / n as f32, (k / n) as f32 / n as f32);
            let target = Vec3A::new(-10.0 + 20.0 * x, -10.0 + 20.0 * y, 0.0);
            Ray::new(eye, target - eye, 0.0, f32::INFINITY)
        })
        .collect()
}

/// Shadow segments between random points of the box (t in [0, 1]).
fn shadow_rays() -> Vec<Ray> {
    let mut rng = Rng(0xa11_5ad0);
    (0..512 * 512)
        .map(|_| {
            let (a, b) = (rng.point(-10.0, 10.0), rng.point(-10.0, 10.0));
            Ray::new(a, b - a, 1e-4, 1.0)
        })
        .collect()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(7);
    let accel = Accel::build(&scene(), Quality::Medium).expect("the scene is finite");
    let (camera, shadow) = (camera_rays(), shadow_rays());
    let (mut closest, mut any, mut kernel) = (Vec::new(), Vec::new(), Vec::new());
    let mut checksum = 0u64;
    for _ in 0..rounds.max(1) {
        let start = Instant::now();
        let hits = accel.closest_hits(&camera);
        closest.push(start.elapsed().as_secs_f64() * 1e9 / camera.len() as f64);
        // The kernel alone, one ray after the other on this thread: what the façade's batch
        // adds on top of it (with RAYON_NUM_THREADS=1).
        let start = Instant::now();
        let bare: Vec<Hit> = camera
            .iter()
            .map(|r| accel.wide().closest_hit(r, &mut NoStats))
            .collect();
        kernel.push(start.elapsed().as_secs_f64() * 1e9 / camera.len() as f64);
        assert_eq!(
            bare.iter().filter(|h| h.is_hit()).count(),
            hits.iter().flatten().count()
        );
        let start = Instant::now();
        let occluded = accel.any_hits(&shadow);
        any.push(start.elapsed().as_secs_f64() * 1e9 / shadow.len() as f64);
        checksum = hits
            .iter()
            .flatten()
            .fold(0u64, |s, h| {
                s.wrapping_mul(31).wrapping_add(h.t.to_bits() as u64)
            })
            .wrapping_add(occluded.iter().filter(|&&o| o).count() as u64);
    }
    for (name, times) in [
        ("closest_hits", &mut closest),
        ("any_hits", &mut any),
        ("kernel_closest", &mut kernel),
    ] {
        let (lo, hi) = (
            times.iter().copied().fold(f64::INFINITY, f64::min),
            times.iter().copied().fold(0.0, f64::max),
        );
        println!("{name} {:.1} {lo:.1} {hi:.1}", median(times));
    }
    println!("checksum {checksum:016x} triangles {}", accel.len());
}
