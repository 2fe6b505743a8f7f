//! One wide kernel on one shared scene and one ray file, one thread: the benchmark behind
//! `docs/results/2026-12-02-kernels/` (not a test).
//!
//! ```text
//! cargo run --release -p sahara-traverse --example kernel_bench -- \
//!     --scene sponza_dabrovic --rays sponza.diffuse.rays \
//!     [--builder sweep] [--layout bvh8|bvh4] [--backend avx512|avx2|sse2|portable] \
//!     [--any] [--passes 5] [--limit N] [--precision exact|fast]
//! ```
//!
//! `--precision fast` times the kernels with the Möller–Trumbore triangle test of
//! `Precision::Fast` instead of the exact one (their answers differ on edges).
//!
//! The ray file is one written by `cargo xtask trace --dump-rays` (32-byte little-endian
//! records: origin, tmin, direction, tmax). The tree is the registry's builder (default
//! `sweep`) collapsed to the layout. After one warm-up pass it times `--passes` passes and
//! prints one line: the median Mrays/s, the range, the work per ray and a checksum of the hits
//! (equal checksums: equal hits). `--passes 0` traces the rays once, untimed (for
//! `valgrind --tool=callgrind --toggle-collect='*trace_all*'`).

use sahara_geom::{Ray, Vec3A};
use sahara_traverse::{
    Backend, Bvh4, Bvh8, Hit, NoStats, Precision, TraversalStats, WideBvh, WorkCounters,
};
use std::time::Instant;

fn read_rays(path: &str, limit: usize) -> Vec<Ray> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert_eq!(bytes.len() % 32, 0, "{path}: not a ray file");
    bytes
        .chunks_exact(32)
        .take(limit)
        .map(|b| {
            let f = |i: usize| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
            Ray::new(
                Vec3A::new(f(0), f(1), f(2)),
                Vec3A::new(f(4), f(5), f(6)),
                f(3),
                f(7),
            )
        })
        .collect()
}

/// Closest hit with backend `b` (the tree's precision is set by `--precision`).
#[inline(always)]
fn closest<const W: usize, S: TraversalStats>(
    w: &WideBvh<W>,
    b: Backend,
    r: &Ray,
    s: &mut S,
) -> Hit {
    w.closest_hit_with(b, r, s)
}

/// Any hit, as [`closest`].
#[inline(always)]
fn any_hit<const W: usize, S: TraversalStats>(
    w: &WideBvh<W>,
    b: Backend,
    r: &Ray,
    s: &mut S,
) -> bool {
    w.any_hit_with(b, r, s)
}

/// Traces every ray once; returns a checksum of the answers.
#[inline(never)]
fn trace_all<const W: usize>(w: &WideBvh<W>, b: Backend, rays: &[Ray], any: bool) -> u64 {
    let mut sum = 0u64;
    if any {
        for r in rays {
            sum = sum
                .wrapping_mul(3)
                .wrapping_add(any_hit(w, b, r, &mut NoStats) as u64);
        }
    } else {
        for r in rays {
            let h = closest(w, b, r, &mut NoStats);
            sum = sum
                .wrapping_mul(0x100_0000_01b3)
                .wrapping_add(h.prim as u64 ^ ((h.t.to_bits() as u64) << 32))
                .wrapping_add(h.u.to_bits() as u64 ^ ((h.v.to_bits() as u64) << 21));
        }
    }
    sum
}

fn run<const W: usize>(w: &WideBvh<W>, b: Backend, rays: &[Ray], any: bool, passes: usize) {
    let check = trace_all(w, b, rays, any);
    if passes == 0 {
        println!("checksum {check:016x}");
        return;
    }
    let mut c = WorkCounters::default();
    for r in rays {
        if any {
            any_hit(w, b, r, &mut c);
        } else {
            closest(w, b, r, &mut c);
        }
    }
    let mut speed: Vec<f64> = (0..passes)
        .map(|_| {
            let t0 = Instant::now();
            let s = trace_all(w, b, rays, any);
            let dt = t0.elapsed().as_secs_f64();
            assert_eq!(s, check, "answers changed between passes");
            rays.len() as f64 / dt / 1e6
        })
        .collect();
    speed.sort_by(f64::total_cmp);
    let n = rays.len() as f64;
    println!(
        "mrays {:.4} min {:.4} max {:.4} inner {:.3} leaves {:.3} tris {:.3} checksum {check:016x}",
        speed[speed.len() / 2],
        speed[0],
        speed[speed.len() - 1],
        c.inner as f64 / n,
        c.leaves as f64 / n,
        c.triangles as f64 / n,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .map(|i| args.get(i + 1).cloned().unwrap_or_default())
    };
    let scene = get("--scene").expect("--scene NAME");
    let rays_path = get("--rays").expect("--rays FILE");
    let builder = get("--builder").unwrap_or_else(|| "sweep".into());
    let layout = get("--layout").unwrap_or_else(|| "bvh8".into());
    let passes: usize = get("--passes").map_or(5, |s| s.parse().unwrap());
    let limit: usize = get("--limit").map_or(usize::MAX, |s| s.parse().unwrap());
    let any = args.iter().any(|a| a == "--any");
    let precision: Precision = get("--precision").map_or(Precision::Exact, |s| s.parse().unwrap());
    let backend = get("--backend").map_or(Backend::best(), |s| {
        *Backend::ALL
            .iter()
            .find(|b| b.name() == s)
            .unwrap_or_else(|| panic!("unknown backend {s}"))
    });
    assert!(backend.is_available(), "{backend} is not available here");
    let rays = read_rays(&rays_path, limit);
    let scene = sahara_scene::Catalog::discover().load(&scene).unwrap();
    let tris = scene.triangles();
    let input =
        sahara_builders::BuildInput::new(&tris, sahara_builders::CostModel::default()).unwrap();
    let bvh = sahara_builders::registry::by_name(&builder)
        .unwrap_or_else(|| panic!("no builder {builder:?}"))
        .build(&input)
        .unwrap();
    match layout.as_str() {
        "bvh4" => run(
            &Bvh4::from_bvh(&bvh, &tris).with_precision(precision),
            backend,
            &rays,
            any,
            passes,
        ),
        "bvh8" => run(
            &Bvh8::from_bvh(&bvh, &tris).with_precision(precision),
            backend,
            &rays,
            any,
            passes,
        ),
        l => panic!("unknown layout {l}"),
    }
}
