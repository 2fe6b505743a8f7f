//! Measurements of the spatial temporary-subtree builder's knobs on real scenes (ignored by
//! default; run in release):
//!
//! ```text
//! cargo test --release -p sahara-builders --test tsah_spatial_scenes -- --ignored --nocapture
//! ```
//!
//! Scenes are the files of the scene catalog (`sahara_scene::Catalog::discover`: the folders
//! of `SAHARA_SCENES`, then `../shared/scenes`; missing ones are skipped with a message),
//! `SCENES` selects them (default `sibenik,sponza_dabrovic`), `CONFIGS` the configurations
//! (default `default,fast`; see the list below, `old-default` is the default before
//! issue #4: exact temporaries, plain top-k candidates, `min_size` 256).

use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_builders::tsah_spatial::{TemporarySearch, TsahSpatialBuilder, TsahSpatialConfig};
use sahara_builders::{BuildInput, Builder};
use sahara_fixtures::scenes::scene_file_triangles;
use sahara_metrics::{sah, CostModel};
use sahara_scene::Catalog;
use std::time::Instant;

#[test]
#[ignore = "measurement on real scenes; run in release with --ignored --nocapture"]
fn measure_knobs() {
    let catalog = Catalog::discover();
    let scenes = std::env::var("SCENES").unwrap_or_else(|_| "sibenik,sponza_dabrovic".into());
    let which = std::env::var("CONFIGS").unwrap_or_else(|_| "default,fast".into());
    let mut configs: Vec<(&str, TsahSpatialConfig)> = vec![
        ("default", TsahSpatialConfig::DEFAULT),
        ("exact", TsahSpatialConfig::EXACT),
        ("fast", TsahSpatialConfig::FAST),
        (
            "top-k",
            TsahSpatialConfig {
                object_separation: 0.0,
                spatial_separation: 0,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "k2+2",
            TsahSpatialConfig {
                object_candidates: 2,
                spatial_candidates: 2,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "k6+6",
            TsahSpatialConfig {
                object_candidates: 6,
                spatial_candidates: 6,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "min256",
            TsahSpatialConfig {
                min_size: 256,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "refine1",
            TsahSpatialConfig {
                temporary_search: TemporarySearch::Estimated {
                    bins_per_ref: 1,
                    min_bins: 4,
                    refine: 1,
                },
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "fast-temps",
            TsahSpatialConfig {
                temporary: SbvhConfig::FAST,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "old-default",
            TsahSpatialConfig {
                object_separation: 0.0,
                spatial_separation: 0,
                min_size: 256,
                ..TsahSpatialConfig::EXACT
            },
        ),
    ];
    configs.retain(|(n, _)| which.split(',').any(|w| w == *n));
    println!("threads: {}", rayon::current_num_threads());
    for scene in scenes.split(',') {
        let Some(tris) = scene_file_triangles(&catalog, scene) else {
            continue;
        };
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        let t = Instant::now();
        let reference = SbvhBuilder::new(SbvhConfig::DEFAULT).build(&input).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let s0 = sah(&reference, &input.cost);
        println!(
            "{scene:<18} {:<12} {ms:>10.0} ms  sah {s0:.3}  refs {}",
            "sbvh",
            reference.prim_indices.len()
        );
        for (name, config) in &configs {
            let t = Instant::now();
            let bvh = TsahSpatialBuilder::new(*config).build(&input).unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            bvh.validate(&tris).unwrap();
            let s = sah(&bvh, &input.cost);
            println!(
                "{scene:<18} {name:<12} {ms:>10.0} ms  sah {s:.3} ({:+.2}% vs sbvh)  refs {}",
                100.0 * (s / s0 - 1.0),
                bvh.prim_indices.len()
            );
        }
    }
}
