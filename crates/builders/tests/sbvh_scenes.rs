//! Measurements on real scenes (ignored by default; run in release):
//!
//! ```text
//! cargo test --release -p sahara-builders --test sbvh_scenes -- --ignored --nocapture
//! ```
//!
//! The scenes are the files of the scene catalog (`sahara_scene::Catalog::discover`: the
//! folders of `SAHARA_SCENES`, then `../shared/scenes` next to the workspace; missing ones
//! are skipped with a message), `SCENES` selects them (comma-separated names) and `BUILDERS`
//! registry names. Each build is validated; its time (best of `REPEAT`, default 1), SAH and
//! reference count are printed.

use sahara_builders::{registry, BuildInput};
use sahara_fixtures::scenes::{env_list, scene_file_triangles};
use sahara_metrics::{sah, CostModel};
use sahara_scene::Catalog;
use std::time::Instant;

#[test]
#[ignore = "measurement on real scenes; run in release with --ignored --nocapture"]
fn measure_scenes() {
    let catalog = Catalog::discover();
    let scenes = env_list(
        "SCENES",
        "sibenik,sponza_dabrovic,san_francisco_osm,teapot_in_stadium",
    );
    let builders = env_list("BUILDERS", "binned,sweep,sbvh");
    let repeat: usize = std::env::var("REPEAT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    println!(
        "threads: {}; cost model c_t = 1.2, c_i = 1",
        rayon::current_num_threads()
    );
    println!(
        "{:<20} {:<14} {:>9} {:>10} {:>10} {:>10} {:>7}",
        "scene", "builder", "tris", "build_ms", "sah", "refs", "depth"
    );
    for scene in &scenes {
        let Some(tris) = scene_file_triangles(&catalog, scene) else {
            continue;
        };
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        for name in &builders {
            let Some(builder) = registry::by_name(name) else {
                println!("{scene:<20} {name:<14} (not registered)");
                continue;
            };
            let mut best = f64::INFINITY;
            let mut bvh = None;
            for _ in 0..repeat {
                let t = Instant::now();
                let b = builder.build(&input).unwrap();
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
                bvh = Some(b);
            }
            let bvh = bvh.unwrap();
            bvh.validate(&tris).unwrap();
            println!(
                "{:<20} {:<14} {:>9} {:>10.1} {:>10.3} {:>10} {:>7}",
                scene,
                name,
                tris.len(),
                best,
                sah(&bvh, &input.cost),
                bvh.prim_indices.len(),
                bvh.stats().depth
            );
        }
    }
}
