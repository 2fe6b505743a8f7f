//! Times closest-point queries through the façade against a brute-force scan of every
//! triangle, on two procedural scenes of about 100k triangles, and checks that both give the
//! same answers bit for bit.
//!
//! `cargo run --release -p sahara --example point_queries [points] [brute points]`
//! (defaults 10000 and 1000; the figures are in `docs/point-queries.md`).

use std::time::Instant;

use sahara::{Aabb, Accel, Quality, Triangle, Vec3A};
use sahara_fixtures::{meshes::mesh_like, rays::point_in, soups::mixed_soup};
use sahara_geom::rng::Pcg32;
use sahara_traverse::{brute, WorkCounters};

/// Query points: random points in the scene's bounds grown by half, and points near the
/// triangles (a random vertex moved by up to 1% of the scene's size).
fn points(tris: &[Triangle], n: usize) -> Vec<Vec3A> {
    let mut b = Aabb::EMPTY;
    tris.iter().for_each(|t| b.grow_aabb(&t.bounds()));
    let (c, e) = (b.centroid(), b.extent());
    let grown = Aabb::new(c - e * 0.75, c + e * 0.75);
    let mut rng = Pcg32::new(3, 7);
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                point_in(&grown, &mut rng)
            } else {
                let t = &tris[rng.below(tris.len() as u32) as usize];
                let d = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                t.v[rng.below(3) as usize] + d * e.max_element() * 0.02
            }
        })
        .collect()
}

/// The median of `runs` timings of `f`, in seconds.
fn median<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        out = Some(std::hint::black_box(f()));
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (times[runs / 2], out.unwrap())
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let n_points = args.first().copied().unwrap_or(10_000);
    let n_brute = args.get(1).copied().unwrap_or(1_000).min(n_points);
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    println!(
        "CPU: {cpu}; rayon threads: {}",
        rayon::current_num_threads()
    );
    println!(
        "| scene | triangles | quality | build ms | BVH µs/query (1 thread) | nodes, leaves, triangles per query | batch µs/query (rayon) | brute µs/query | speed-up |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let scenes = [
        ("mesh_like(224)", mesh_like(224, 1)),
        ("mixed_soup(100k)", mixed_soup(100_000, 1)),
    ];
    for (name, tris) in &scenes {
        let pts = points(tris, n_points);
        // The brute-force scan, on the first `n_brute` points (one thread).
        let (brute_s, want) = median(1, || {
            pts[..n_brute]
                .iter()
                .map(|&p| brute::closest_point(tris, p, f32::INFINITY))
                .collect::<Vec<_>>()
        });
        let brute_us = brute_s * 1e6 / n_brute as f64;
        for q in [Quality::Medium, Quality::High] {
            let t = Instant::now();
            let accel = Accel::build(tris, q).unwrap();
            let build_ms = t.elapsed().as_secs_f64() * 1e3;
            let (one_s, got) = median(3, || {
                pts.iter()
                    .map(|&p| accel.closest_point(p, f32::INFINITY))
                    .collect::<Vec<_>>()
            });
            for (g, w) in got.iter().zip(&want) {
                let (g, w) = (g.unwrap(), w.unwrap());
                assert_eq!(
                    (
                        g.prim,
                        g.distance_squared.to_bits(),
                        g.point.to_array().map(f32::to_bits)
                    ),
                    (
                        w.prim,
                        w.distance_squared.to_bits(),
                        w.point.to_array().map(f32::to_bits)
                    ),
                    "{name}: BVH and brute force differ"
                );
            }
            let (batch_s, batch) = median(3, || accel.closest_points(&pts, f32::INFINITY));
            assert_eq!(batch, got);
            let mut work = WorkCounters::default();
            for &p in &pts {
                accel.wide().closest_point(p, f32::INFINITY, &mut work);
            }
            let per = |x: u64| x as f64 / pts.len() as f64;
            let one_us = one_s * 1e6 / pts.len() as f64;
            println!(
                "| {name} | {} | {} | {build_ms:.0} | {one_us:.2} | {:.1}, {:.1}, {:.1} | {:.2} | {brute_us:.0} | {:.0}× |",
                tris.len(),
                q.name(),
                per(work.inner),
                per(work.leaves),
                per(work.triangles),
                batch_s * 1e6 / pts.len() as f64,
                brute_us / one_us,
            );
        }
    }
}
