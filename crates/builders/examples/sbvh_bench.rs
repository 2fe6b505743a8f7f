//! Builds one scene with one registered builder and prints the build time, SAH, tree size and
//! fingerprint: `cargo run --release -p sahara-builders --example sbvh_bench -- SCENE [BUILDER]
//! [RUNS]`. A quick loop for build-speed work (the real figures come from `cargo xtask bvh`).

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_scene::Catalog;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = args.get(1).map_or("sponza_dabrovic", String::as_str);
    let builder = args.get(2).map_or("sbvh", String::as_str);
    let runs: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let tris = Catalog::discover().load(scene).expect("scene").triangles();
    let input = BuildInput::new(&tris, CostModel::default()).expect("input");
    let b = registry::by_name(builder).expect("builder");
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        let t0 = std::time::Instant::now();
        let bvh = b.build(&input).expect("build");
        times.push(t0.elapsed().as_secs_f64() * 1e3);
        last = Some(bvh);
    }
    let bvh = last.unwrap();
    times.sort_by(f64::total_cmp);
    println!(
        "{scene} {builder}: median {:.1} ms (min {:.1}, max {:.1}) SAH {:.6} nodes {} refs {} fp {:016x}",
        times[times.len() / 2],
        times[0],
        times[times.len() - 1],
        sahara_metrics::sah(&bvh, &input.cost),
        bvh.nodes.len(),
        bvh.prim_indices.len(),
        bvh.fingerprint()
    );
}
