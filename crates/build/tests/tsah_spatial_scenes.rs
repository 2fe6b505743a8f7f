//! Measurements of the spatial temporary-subtree builder's knobs on real scenes (ignored by
//! default; run in release):
//!
//! ```text
//! cargo test --release -p sahara-build --test tsah_spatial_scenes -- --ignored --nocapture
//! ```
//!
//! Scenes come from `SAHARA_SCENES` (default `../shared/scenes`), `SCENES` selects them
//! (default `sibenik,sponza_dabrovic`), `CONFIGS` the configurations (default
//! `default,fast`; see the list below, `old-default` is the default before issue #4: exact
//! temporaries, plain top-k candidates, `min_size` 256).

use sahara_build::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_build::tsah_spatial::{TemporarySearch, TsahSpatialBuilder, TsahSpatialConfig};
use sahara_build::{BuildInput, Builder};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};
use std::path::PathBuf;
use std::time::Instant;

fn load_obj(path: &std::path::Path) -> Vec<Triangle> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut v: Vec<Vec3A> = Vec::new();
    let mut tris = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|x| x.parse().unwrap()).collect();
                v.push(Vec3A::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|t| {
                        let i: i64 = t.split('/').next().unwrap().parse().unwrap();
                        if i < 0 {
                            (v.len() as i64 + i) as usize
                        } else {
                            i as usize - 1
                        }
                    })
                    .collect();
                for k in 1..idx.len().saturating_sub(1) {
                    tris.push(Triangle::new(v[idx[0]], v[idx[k]], v[idx[k + 1]]));
                }
            }
            _ => {}
        }
    }
    tris
}

#[test]
#[ignore = "measurement on real scenes; run in release with --ignored --nocapture"]
fn measure_knobs() {
    let dir = std::env::var_os("SAHARA_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")
        });
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
        let tris = load_obj(&dir.join(format!("{scene}.obj")));
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
