//! Single-thread primary-ray throughput of the scalar binary kernel and the wide kernels on the
//! Stanford bunny (a benchmark, not a test: run it with
//! `cargo test --release -p sahara-traverse --test wide_bench -- --ignored --nocapture`).
//!
//! The scene is read from `$SAHARA_SCENES/stanford_bunny.obj` (default `../shared/scenes` beside
//! the workspace),
//! the binary tree is a binned SAH build (see `wide_common::sah_bvh`, leaves of at most
//! `$SAHARA_BENCH_LEAF` = 4 triangles) or, with `SAHARA_BENCH_BUILDER=<name>`, the
//! `sahara-builders` registry's builder of that name (for example `sweep`); the camera is the
//! "framed" one of `docs/baselines.md`:
//! eye = centre + normalize(0, 0.1, 1) · 1.2 · |diagonal|, looking at the centre, 45° vertical
//! field of view, 1024 × 768 rays through pixel centres.

mod wide_common;

use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
use sahara_traverse::{scalar, simd_backend, Backend, Bvh4, Bvh8, Hit, NoStats, WorkCounters};
use std::time::Instant;

fn primary_rays(b: &Aabb, width: u32, height: u32) -> Vec<Ray> {
    let centre = b.centroid();
    let diag = (b.max - b.min).length();
    let eye = centre + Vec3A::new(0.0, 0.1, 1.0).normalize() * 1.2 * diag;
    let forward = (centre - eye).normalize();
    let right = forward.cross(Vec3A::Y).normalize();
    let up = right.cross(forward);
    let tan_half = (45.0f32.to_radians() * 0.5).tan();
    let aspect = width as f32 / height as f32;
    let mut rays = Vec::with_capacity((width * height) as usize);
    for py in 0..height {
        for px in 0..width {
            let sx = (2.0 * (px as f32 + 0.5) / width as f32 - 1.0) * tan_half * aspect;
            let sy = (1.0 - 2.0 * (py as f32 + 0.5) / height as f32) * tan_half;
            let d = (forward + right * sx + up * sy).normalize();
            rays.push(Ray::new(eye, d, 0.0, f32::INFINITY));
        }
    }
    rays
}

/// Median of 5 timed runs after one warm-up run, in Mrays/s, and a checksum of the hits.
fn measure(rays: &[Ray], mut trace: impl FnMut(&Ray) -> Hit) -> (f64, u64) {
    let run = |trace: &mut dyn FnMut(&Ray) -> Hit| {
        let mut sum = 0u64;
        let t0 = Instant::now();
        for r in rays {
            let h = trace(r);
            sum = sum.wrapping_add(h.prim as u64 ^ h.t.to_bits() as u64);
        }
        (t0.elapsed().as_secs_f64(), sum)
    };
    let (_, check) = run(&mut trace);
    let mut times: Vec<f64> = (0..5).map(|_| run(&mut trace).0).collect();
    times.sort_by(f64::total_cmp);
    (rays.len() as f64 / times[2] / 1e6, check)
}

fn counters(rays: &[Ray], mut trace: impl FnMut(&Ray, &mut WorkCounters)) -> (f64, f64, f64) {
    let mut c = WorkCounters::default();
    for r in rays {
        trace(r, &mut c);
    }
    let n = rays.len() as f64;
    (
        c.inner as f64 / n,
        c.leaves as f64 / n,
        c.triangles as f64 / n,
    )
}

fn bench_scene(tris: &[Triangle], bvh: &Bvh, rays: &[Ray]) {
    let t0 = Instant::now();
    let w4 = Bvh4::from_bvh(bvh, tris);
    let w8 = Bvh8::from_bvh(bvh, tris);
    let collapse_ms = t0.elapsed().as_secs_f64() * 1e3 / 2.0;
    eprintln!(
        "binary: {} nodes; bvh4: {} nodes, {} packets ({:.2} refs/packet); bvh8: {} nodes, {} packets; collapse {:.1} ms per tree",
        bvh.nodes.len(),
        w4.node_count(),
        w4.packet_count(),
        w4.reference_count() as f64 / w4.packet_count() as f64,
        w8.node_count(),
        w8.packet_count(),
        collapse_ms
    );
    let (m2, c2) = measure(rays, |r| scalar::closest_hit(bvh, tris, r, &mut NoStats));
    let mut rows = vec![("bvh2 scalar".to_string(), m2, c2)];
    for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
        let (m4, c4) = measure(rays, |r| w4.closest_hit_with(b, r, &mut NoStats));
        let (m8, c8) = measure(rays, |r| w8.closest_hit_with(b, r, &mut NoStats));
        rows.push((format!("bvh4 {b}"), m4, c4));
        rows.push((format!("bvh8 {b}"), m8, c8));
    }
    let s2 = counters(rays, |r, c| {
        scalar::closest_hit(bvh, tris, r, c);
    });
    let s4 = counters(rays, |r, c| {
        w4.closest_hit(r, c);
    });
    let s8 = counters(rays, |r, c| {
        w8.closest_hit(r, c);
    });
    let (a2, _) = measure(rays, |r| {
        let h = scalar::any_hit(bvh, tris, r, &mut NoStats);
        Hit {
            prim: h as u32,
            ..Hit::MISS
        }
    });
    let (a8, _) = measure(rays, |r| {
        let h = w8.any_hit(r, &mut NoStats);
        Hit {
            prim: h as u32,
            ..Hit::MISS
        }
    });
    eprintln!("simd backend: {}", simd_backend());
    eprintln!("{:<16} {:>8} {:>8}", "kernel", "Mrays/s", "vs bvh2");
    for (name, m, c) in &rows {
        assert_eq!(*c, c2, "{name} disagrees with the scalar kernel");
        eprintln!("{name:<16} {m:>8.2} {:>7.2}x", m / m2);
    }
    eprintln!(
        "any-hit: bvh2 scalar {a2:.2} Mrays/s, bvh8 {a8:.2} Mrays/s ({:.2}x)",
        a8 / a2
    );
    for (name, s) in [("bvh2", s2), ("bvh4", s4), ("bvh8", s8)] {
        eprintln!(
            "{name}: {:.1} inner nodes, {:.1} leaves, {:.1} triangles per ray",
            s.0, s.1, s.2
        );
    }
}

/// SAH cost of a binary tree (traversal and intersection costs 1, relative to the root area).
fn sah_cost(bvh: &Bvh) -> f64 {
    let root = bvh.nodes[0].bounds().half_area() as f64;
    bvh.nodes
        .iter()
        .map(|n| {
            let a = n.bounds().half_area() as f64 / root;
            if n.is_leaf() {
                a * n.count as f64
            } else {
                a
            }
        })
        .sum()
}

#[test]
#[ignore = "benchmark: run with --ignored --nocapture"]
fn bunny_primary_rays() {
    let dir = std::env::var("SAHARA_SCENES")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/scenes").into());
    let leaf: usize = std::env::var("SAHARA_BENCH_LEAF").map_or(4, |s| s.parse().unwrap());
    let tris = wide_common::load_obj(&format!("{dir}/stanford_bunny.obj"));
    let b = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let t0 = Instant::now();
    let (bvh, builder) = match std::env::var("SAHARA_BENCH_BUILDER") {
        Ok(name) => {
            let input =
                sahara_builders::BuildInput::new(&tris, sahara_builders::CostModel::default())
                    .unwrap();
            let b = sahara_builders::registry::by_name(&name)
                .unwrap_or_else(|| panic!("no builder {name:?} in the registry"));
            (b.build(&input).unwrap(), b.describe())
        }
        Err(_) => (
            wide_common::sah_bvh(&tris, leaf),
            format!("test-local binned SAH, leaves <= {leaf}"),
        ),
    };
    eprintln!(
        "bunny: {} triangles, {builder}: {:.0} ms, SAH {:.1}",
        tris.len(),
        t0.elapsed().as_secs_f64() * 1e3,
        sah_cost(&bvh)
    );
    bvh.validate(&tris).unwrap();
    let rays = primary_rays(&b, 1024, 768);
    let hits = rays
        .iter()
        .filter(|r| scalar::closest_hit(&bvh, &tris, r, &mut NoStats).is_hit())
        .count();
    eprintln!(
        "bounds {:?}; {:.1}% of the primary rays hit",
        b,
        100.0 * hits as f64 / rays.len() as f64
    );
    bench_scene(&tris, &bvh, &rays);
}

/// Reads a ray file of `cargo xtask trace --dump-rays` (32-byte little-endian records:
/// origin, tmin, direction, tmax).
fn read_rays(path: &str) -> Vec<Ray> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert_eq!(bytes.len() % 32, 0, "{path}: not a ray file");
    bytes
        .chunks_exact(32)
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

/// Single-thread throughput of the binary kernel and the wide kernels on a shared scene and a
/// ray file, timed in interleaved rounds (a benchmark, not a test).
///
/// `SAHARA_BENCH_SCENE` (catalog name), `SAHARA_BENCH_RAYS` (a file written by
/// `cargo xtask trace --dump-rays`, for example the diffuse rays of the scene),
/// `SAHARA_BENCH_BUILDER` (registry name, default `sweep`), `SAHARA_BENCH_ROUNDS`
/// (default 5; each round times every kernel once, median of 5 passes, in a rotating order)
/// and `SAHARA_BENCH_KERNELS` (a comma-separated subset of `bvh2,bvh4,bvh8`, default all: to
/// compare builds of the kernels in interleaved processes, time `bvh8` alone).
/// Prints the work per ray and, per kernel, the median Mrays/s with its range and the median
/// of the per-round ratios to bvh8.
#[test]
#[ignore = "benchmark: run with --ignored --nocapture"]
fn scene_ray_file() {
    let Ok(scene) = std::env::var("SAHARA_BENCH_SCENE") else {
        eprintln!("SAHARA_BENCH_SCENE not set");
        return;
    };
    let builder = std::env::var("SAHARA_BENCH_BUILDER").unwrap_or_else(|_| "sweep".into());
    let rays = read_rays(&std::env::var("SAHARA_BENCH_RAYS").expect("SAHARA_BENCH_RAYS"));
    let rounds: usize = std::env::var("SAHARA_BENCH_ROUNDS").map_or(5, |s| s.parse().unwrap());
    let scene = sahara_scene::Catalog::discover().load(&scene).unwrap();
    let tris = scene.triangles();
    let input =
        sahara_builders::BuildInput::new(&tris, sahara_builders::CostModel::default()).unwrap();
    let bvh = sahara_builders::registry::by_name(&builder)
        .unwrap_or_else(|| panic!("no builder {builder:?} in the registry"))
        .build(&input)
        .unwrap();
    let t0 = Instant::now();
    let w8 = Bvh8::from_bvh(&bvh, &tris);
    let collapse_ms = t0.elapsed().as_secs_f64() * 1e3;
    let w4 = Bvh4::from_bvh(&bvh, &tris);
    eprintln!(
        "{} ({} triangles, {builder}): {} rays; bvh8: {} nodes, {} packets ({:.2} refs/packet), collapse {collapse_ms:.0} ms",
        scene.name,
        tris.len(),
        rays.len(),
        w8.node_count(),
        w8.packet_count(),
        w8.reference_count() as f64 / w8.packet_count() as f64,
    );
    let work = [
        counters(&rays, |r, c| {
            scalar::closest_hit(&bvh, &tris, r, c);
        }),
        counters(&rays, |r, c| {
            w4.closest_hit(r, c);
        }),
        counters(&rays, |r, c| {
            w8.closest_hit(r, c);
        }),
    ];
    let names = ["bvh2 scalar", "bvh4", "bvh8"];
    let wanted = std::env::var("SAHARA_BENCH_KERNELS").unwrap_or_else(|_| "bvh2,bvh4,bvh8".into());
    let timed: Vec<usize> = ["bvh2", "bvh4", "bvh8"]
        .iter()
        .enumerate()
        .filter(|(_, k)| wanted.split(',').any(|w| w.trim() == **k))
        .map(|(i, _)| i)
        .collect();
    let mut speed: [Vec<f64>; 3] = Default::default();
    let mut checks: [Option<u64>; 3] = [None; 3];
    for round in 0..rounds {
        for j in 0..timed.len() {
            let i = timed[(j + round) % timed.len()];
            let (m, check) = match i {
                0 => measure(&rays, |r| scalar::closest_hit(&bvh, &tris, r, &mut NoStats)),
                1 => measure(&rays, |r| w4.closest_hit(r, &mut NoStats)),
                _ => measure(&rays, |r| w8.closest_hit(r, &mut NoStats)),
            };
            speed[i].push(m);
            checks[i] = Some(check);
        }
    }
    let mut sums = checks.iter().flatten();
    let first = sums.next();
    assert!(sums.all(|c| Some(c) == first), "the kernels disagree");
    let med = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    eprintln!(
        "{:<12} {:>8} {:>15} {:>9}   work per ray (inner, leaves, triangles)",
        "kernel", "Mrays/s", "range", "vs bvh8"
    );
    for &i in &timed {
        let s = &speed[i];
        let ratios: Vec<f64> = s.iter().zip(&speed[2]).map(|(a, b)| a / b).collect();
        let (lo, hi) = s.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
        eprintln!(
            "{:<12} {:>8.2} {:>7.2}-{:<7.2} {:>8.3}x   {:.2}, {:.2}, {:.2}",
            names[i],
            med(s),
            lo,
            hi,
            med(&ratios),
            work[i].0,
            work[i].1,
            work[i].2
        );
    }
}
