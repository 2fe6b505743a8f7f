//! Bad-ray batch timing: how much slower a batch of bad rays traces than a batch of valid
//! ones, per kernel. Measured (in `cargo xtask hardcases`), never asserted: the bound
//! is a slowdown of at most 2×.

use std::hint::black_box;
use std::time::Instant;

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::{rng::Pcg32, Ray, Vec3A};
use sahara_scene::{Procedural, DEFAULT_SEED};
use sahara_traverse::{scalar, Bvh, NoStats, WideBvh};

use crate::{rays::unit, Kernel};

/// The time of one batch with one kernel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BatchTiming {
    /// The kernel.
    pub kernel: String,
    /// The batch (`valid`, `origin NaN`, ...).
    pub batch: String,
    /// Rays in the batch.
    pub rays: usize,
    /// Best time over the repeats, seconds (one thread, closest hit).
    pub seconds: f64,
    /// Nanoseconds per ray.
    pub ns_per_ray: f64,
    /// `seconds` over the `valid` batch's seconds with the same kernel.
    pub ratio: f64,
}

/// The batches: a valid batch (rays from the camera inside `sphere_in_box`, in random
/// directions) and the same rays made bad in one way each.
pub fn batches(n: usize) -> Vec<(&'static str, Vec<Ray>)> {
    let scene = Procedural::SphereInBox.scene(20_000, DEFAULT_SEED);
    let eye = scene.camera.eye;
    let mut rng = Pcg32::new(3, 9);
    let valid: Vec<Ray> = (0..n)
        .map(|_| Ray::new(eye, unit(&mut rng), 0.0, f32::INFINITY))
        .collect();
    let map = |f: &dyn Fn(&Ray) -> Ray| valid.iter().map(f).collect::<Vec<_>>();
    vec![
        ("valid", valid.clone()),
        (
            "origin NaN",
            map(&|r| Ray::new(Vec3A::NAN, r.direction(), r.tmin, r.tmax)),
        ),
        (
            "direction NaN",
            map(&|r| {
                Ray::new(
                    r.origin,
                    Vec3A::new(f32::NAN, r.direction().y, r.direction().z),
                    r.tmin,
                    r.tmax,
                )
            }),
        ),
        (
            "direction inf",
            map(&|r| {
                Ray::new(
                    r.origin,
                    Vec3A::new(r.direction().x, f32::INFINITY, r.direction().z),
                    r.tmin,
                    r.tmax,
                )
            }),
        ),
        (
            "direction zero",
            map(&|r| Ray::new(r.origin, Vec3A::ZERO, r.tmin, r.tmax)),
        ),
        (
            "tmin > tmax",
            map(&|r| Ray::new(r.origin, r.direction(), 2.0, 1.0)),
        ),
        (
            "tmax NaN",
            map(&|r| Ray::new(r.origin, r.direction(), r.tmin, f32::NAN)),
        ),
        (
            "half invalid (interleaved)",
            valid
                .iter()
                .enumerate()
                .map(|(i, r)| {
                    if i % 2 == 0 {
                        *r
                    } else {
                        Ray::new(Vec3A::NAN, r.direction(), r.tmin, r.tmax)
                    }
                })
                .collect(),
        ),
        (
            "direction denormal (invalid: a miss)",
            map(&|r| Ray::new(r.origin, r.direction() * 1e-40, r.tmin, r.tmax)),
        ),
        (
            "direction 1e-30 (valid)",
            map(&|r| Ray::new(r.origin, r.direction() * 1e-30, r.tmin, r.tmax)),
        ),
        (
            "direction -0 components (valid)",
            map(&|r| {
                Ray::new(
                    r.origin,
                    Vec3A::new(r.direction().x, -0.0, -0.0),
                    r.tmin,
                    r.tmax,
                )
            }),
        ),
    ]
}

fn best_of<F: FnMut() -> u64>(repeats: usize, mut f: F) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        black_box(f());
        best = best.min(start.elapsed().as_secs_f64());
    }
    best
}

fn time_batch(
    kernel: Kernel,
    bvh: &Bvh,
    tris: &[sahara_geom::Triangle],
    w4: &WideBvh<4>,
    w8: &WideBvh<8>,
    rays: &[Ray],
    repeats: usize,
) -> f64 {
    best_of(repeats, || {
        let mut acc = 0u64;
        for r in rays {
            let h = match kernel {
                Kernel::Bvh2 => scalar::closest_hit(bvh, tris, black_box(r), &mut NoStats),
                Kernel::Bvh4(b) => w4.closest_hit_with(b, black_box(r), &mut NoStats),
                Kernel::Bvh8(b) => w8.closest_hit_with(b, black_box(r), &mut NoStats),
            };
            acc = acc.wrapping_add(u64::from(h.prim));
        }
        acc
    })
}

/// Times every batch of [`batches`] with every kernel (closest hit, one thread, best of
/// `repeats`) on a `builder` tree of `sphere_in_box` (20 000 triangles).
pub fn bad_ray_timing(
    kernels: &[Kernel],
    builder: &str,
    n_rays: usize,
    repeats: usize,
) -> Vec<BatchTiming> {
    let scene = Procedural::SphereInBox.scene(20_000, DEFAULT_SEED);
    let tris = scene.triangles();
    let input = BuildInput::new(&tris, CostModel::default()).expect("finite scene");
    let bvh = registry::by_name(builder)
        .unwrap_or_else(|| registry::by_name("binned").expect("binned is registered"))
        .build(&input)
        .expect("sphere_in_box builds");
    let w4 = WideBvh::<4>::from_bvh(&bvh, &tris);
    let w8 = WideBvh::<8>::from_bvh(&bvh, &tris);
    let batches = batches(n_rays);
    let mut out = Vec::new();
    for &k in kernels {
        let mut valid_secs = f64::NAN;
        for (name, rays) in &batches {
            let secs = time_batch(k, &bvh, &tris, &w4, &w8, rays, repeats);
            if *name == "valid" {
                valid_secs = secs;
            }
            out.push(BatchTiming {
                kernel: k.name(),
                batch: name.to_string(),
                rays: rays.len(),
                seconds: secs,
                ns_per_ray: secs * 1e9 / rays.len().max(1) as f64,
                ratio: secs / valid_secs,
            });
        }
    }
    out
}

/// Batch × kernel table of the ratios (batch time over valid-batch time), with the valid
/// batch's nanoseconds per ray on the first line.
pub fn timing_table(t: &[BatchTiming]) -> String {
    let mut kernels: Vec<&str> = Vec::new();
    let mut batches: Vec<&str> = Vec::new();
    for x in t {
        if !kernels.contains(&x.kernel.as_str()) {
            kernels.push(&x.kernel);
        }
        if !batches.contains(&x.batch.as_str()) {
            batches.push(&x.batch);
        }
    }
    let w0 = batches.iter().map(|b| b.len()).max().unwrap_or(5).max(22);
    let wk = kernels.iter().map(|k| k.len()).max().unwrap_or(4).max(8);
    let mut s = format!("{:<w0$}", "batch (ratio to valid)");
    for k in &kernels {
        s.push_str(&format!("  {k:>wk$}"));
    }
    s.push('\n');
    for b in &batches {
        s.push_str(&format!("{b:<w0$}"));
        for k in &kernels {
            let x = t.iter().find(|x| x.kernel == *k && x.batch == *b);
            let text = match x {
                Some(x) if *b == "valid" => format!("{:.0} ns/ray", x.ns_per_ray),
                Some(x) => format!("{:.2}x", x.ratio),
                None => "-".to_string(),
            };
            s.push_str(&format!("  {text:>wk$}"));
        }
        s.push('\n');
    }
    s
}
