//! The collapse of one registry builder's binary tree into the 8-wide layout, timed alone on
//! one shared scene (not a test): the benchmark behind the collapse figures of issue 20.
//!
//! ```text
//! cargo run --release -p sahara-traverse --example collapse_bench -- \
//!     --scene sponza_dabrovic [--builder binned] [--layout bvh8|bvh4] [--runs 20] [--threads 1]
//! ```
//!
//! It builds the tree once, then collapses it `--runs` times on a rayon pool of `--threads`
//! threads and prints the median, the range and the wide tree's fingerprint (equal
//! fingerprints: equal layouts, bit for bit).

use sahara_traverse::{Bvh4, Bvh8, WideBvh};
use std::time::Instant;

/// The time since `t` (in ms) when `w` is done, and `w`'s fingerprint.
fn timed<const W: usize>(t: Instant, w: WideBvh<W>) -> (f64, u64) {
    let ms = t.elapsed().as_secs_f64() * 1e3;
    (ms, w.fingerprint())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let get = |k: &str| {
        args.iter()
            .position(|a| a == k)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let scene = get("--scene").expect("--scene NAME");
    let builder = get("--builder").unwrap_or_else(|| "binned".into());
    let layout = get("--layout").unwrap_or_else(|| "bvh8".into());
    let runs: usize = get("--runs").map_or(20, |s| s.parse().expect("--runs N"));
    let threads: usize = get("--threads").map_or(1, |s| s.parse().expect("--threads N"));
    let scene = sahara_scene::Catalog::discover().load(&scene).unwrap();
    let tris = scene.triangles();
    let input =
        sahara_builders::BuildInput::new(&tris, sahara_metrics::CostModel::default()).unwrap();
    let bvh = sahara_builders::registry::by_name(&builder)
        .unwrap_or_else(|| panic!("unknown builder {builder}"))
        .build(&input)
        .unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut times = Vec::with_capacity(runs);
    let mut hash = 0u64;
    pool.install(|| {
        for _ in 0..runs {
            let t = Instant::now();
            // The fingerprint is taken after the clock stops.
            let (ms, fingerprint) = match layout.as_str() {
                "bvh8" => timed(t, Bvh8::from_bvh(&bvh, &tris)),
                "bvh4" => timed(t, Bvh4::from_bvh(&bvh, &tris)),
                l => panic!("unknown layout {l}"),
            };
            times.push(ms);
            hash = fingerprint;
        }
    });
    times.sort_by(f64::total_cmp);
    println!(
        "{builder} collapse {layout}: {:.2} ms median ({:.2}-{:.2}), {threads} thread(s), layout {hash:016x}",
        times[runs / 2],
        times[0],
        times[runs - 1]
    );
}
