//! Measurements on real scenes (ignored by default; run in release):
//!
//! ```text
//! cargo test --release -p sahara-build --test sbvh_scenes -- --ignored --nocapture
//! ```
//!
//! The scenes are read from `SAHARA_SCENES` (default `../shared/scenes` next to the
//! workspace), `SCENES` selects files (comma-separated stems) and `BUILDERS` registry names.
//! Each build is validated; its time (best of `REPEAT`, default 1), SAH and reference count
//! are printed.

use sahara_build::{registry, BuildInput};
use sahara_geom::{Triangle, Vec3A};
use sahara_metrics::{sah, CostModel};
use std::path::PathBuf;
use std::time::Instant;

/// A minimal OBJ reader: `v x y z` and `f a b c ...` (fan-split, 1-based or negative
/// indices, `a/b/c` forms), everything else ignored.
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

fn scenes_dir() -> PathBuf {
    std::env::var_os("SAHARA_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"))
}

fn list(var: &str, default: &str) -> Vec<String> {
    std::env::var(var)
        .unwrap_or_else(|_| default.to_string())
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

#[test]
#[ignore = "measurement on real scenes; run in release with --ignored --nocapture"]
fn measure_scenes() {
    let dir = scenes_dir();
    let scenes = list(
        "SCENES",
        "sibenik,sponza_dabrovic,san_francisco_osm,teapot_in_stadium",
    );
    let builders = list("BUILDERS", "binned,sweep,sbvh");
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
        let path = dir.join(format!("{scene}.obj"));
        if !path.exists() {
            println!("{scene}: {} not found, skipped", path.display());
            continue;
        }
        let tris = load_obj(&path);
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
