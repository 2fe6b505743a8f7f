//! Measures the reinsertion optimiser's knobs on one scene: for a base builder and a list of
//! budgets, the SAH before and after, the moves, the iterations and the time.
//!
//! `cargo run --release -p sahara-builders --example reinsert_knobs -- SCENE BASE [BATCH,DECAY,ITERS,MIN_GAIN[,SEARCH_LIMIT] ...]`
//! (SCENE: a catalog name, procedural or shared; BASE: a registered builder).

use std::time::Instant;

use sahara_builders::reinsert::{optimize_with_stats, ReinsertConfig};
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_scene::Catalog;

/// CPU seconds (user + system) of this process so far, from `/proc/self/stat` (Linux; 0
/// elsewhere), so that the budgets can be compared on a loaded machine.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which ends with the last ')'): utime is the 12th, stime
    // the 13th, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|x| x.parse().ok())
        .collect();
    f.iter().sum::<f64>() / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_name = args.first().map_or("sphere_in_box", String::as_str);
    let base = args.get(1).map_or("sweep", String::as_str);
    let scene = Catalog::discover().load(scene_name).expect("scene");
    let tris = scene.triangles();
    let input = BuildInput::new(&tris, CostModel::default()).expect("input");
    let t0 = Instant::now();
    let bvh = registry::by_name(base)
        .expect("builder")
        .build(&input)
        .expect("build");
    let build = t0.elapsed().as_secs_f64();
    println!(
        "{scene_name}: {} triangles, {base} in {build:.3} s, {} nodes, SAH {:.4}",
        tris.len(),
        bvh.nodes.len(),
        sahara_metrics::sah(&bvh, &input.cost)
    );
    let configs: Vec<ReinsertConfig> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|s| {
                let f: Vec<f64> = s.split(',').map(|x| x.parse().expect("number")).collect();
                ReinsertConfig {
                    batch_fraction: f[0],
                    decay: f[1],
                    max_iterations: f[2] as usize,
                    min_gain: f[3],
                    max_search_nodes: f.get(4).map_or(0, |&v| v as usize),
                }
            })
            .collect()
    } else {
        vec![ReinsertConfig::THOROUGH, ReinsertConfig::LIGHT]
    };
    println!(
        "batch\tdecay\titers\tmin_gain\tran\tsearches\tmoves\tsah_after\tdrop_%\tsecs\tcpu_secs"
    );
    for c in configs {
        let (t0, c0) = (Instant::now(), cpu_seconds());
        let (out, s) = optimize_with_stats(&bvh, &input.cost, &c).expect("optimize");
        let secs = t0.elapsed().as_secs_f64();
        let cpu = cpu_seconds() - c0;
        out.validate(&tris).expect("valid");
        println!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.4}\t{:.2}\t{secs:.3}\t{cpu:.2}",
            c.batch_fraction,
            c.decay,
            c.max_iterations,
            c.min_gain,
            s.iterations,
            s.searches,
            s.moves,
            s.sah_after,
            100.0 * (1.0 - s.sah_after / s.sah_before)
        );
    }
}
