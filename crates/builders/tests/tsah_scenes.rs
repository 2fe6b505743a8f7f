//! Measurements of the sweep, temporary-subtree and look-ahead builders on the shared scenes
//! (all `#[ignore]`: run them in release mode, for example
//! `cargo test --release -p sahara-builders --test tsah_scenes -- --ignored --nocapture measure`).
//!
//! Environment: `SAHARA_SHARED_SCENES` (a folder, the only one searched when set; else the
//! scene catalog's folders: `SAHARA_SCENES`, then `../shared/scenes`), `TSAH_SCENES`
//! (comma-separated scene names), `TSAH_BUILDERS` (comma-separated registry names),
//! `TSAH_EPO=1` to also compute the EPO metric. Scenes are loaded by `sahara_scene` (`.obj`,
//! `.obj.gz`, `.gltf`, `.glb`); missing ones are skipped with a message.

use std::path::Path;
use std::time::Instant;

use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::{registry, BuildInput, Builder, Bvh, Strategy};
use sahara_fixtures::meshes::mesh_like;
use sahara_fixtures::scenes::{env_list, scene_file_triangles};
use sahara_fixtures::soups::box_soup;
use sahara_geom::Triangle;
use sahara_metrics::{sah, CostModel};
use sahara_scene::{Catalog, Origin};

/// The scenes: the folder `SAHARA_SHARED_SCENES` alone when it is set, else the catalog's.
fn catalog() -> Catalog {
    let Some(dir) = std::env::var_os("SAHARA_SHARED_SCENES") else {
        return Catalog::discover();
    };
    let mut c = Catalog::default();
    c.add_dir(Path::new(&dir), Origin::Env);
    c
}

/// CPU time of the process so far (all threads), in milliseconds, from `/proc/self/stat`.
fn cpu_ms() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    let after = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 =
        f[11].parse::<f64>().unwrap_or(f64::NAN) + f[12].parse::<f64>().unwrap_or(f64::NAN);
    ticks * 10.0
}

struct Row {
    ms: f64,
    cpu_ms: f64,
    sah: f64,
    epo: Option<f64>,
    leaves: usize,
}

fn measure(builder: &dyn Builder, tris: &[Triangle], epo: bool) -> (Row, Bvh) {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    let c0 = cpu_ms();
    let t = Instant::now();
    let bvh = builder.build(&input).unwrap();
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let cpu_ms = cpu_ms() - c0;
    bvh.validate(tris).unwrap();
    let row = Row {
        ms,
        cpu_ms,
        sah: sah(&bvh, &input.cost),
        epo: epo.then(|| sahara_metrics::epo(&bvh, tris, &input.cost)),
        leaves: bvh.nodes.iter().filter(|n| n.is_leaf()).count(),
    };
    (row, bvh)
}

fn print_row(scene: &str, n: usize, name: &str, r: &Row, base: Option<&Row>) {
    let rel = base.map_or(String::new(), |b| {
        format!("{:+.2}%", 100.0 * (r.sah / b.sah - 1.0))
    });
    let epo = match (r.epo, base.and_then(|b| b.epo)) {
        (Some(e), Some(b)) => format!("{e:.3} ({:+.2}%)", 100.0 * (e / b - 1.0)),
        (Some(e), None) => format!("{e:.3}"),
        _ => "-".into(),
    };
    eprintln!(
        "| {scene} | {n} | {name} | {:.0} | {:.0} | {:.3} | {rel} | {epo} | {} |",
        r.ms, r.cpu_ms, r.sah, r.leaves
    );
}

/// The registered presets on the shared scenes: build time, SAH (and EPO) relative to sweep.
#[test]
#[ignore]
fn measure_presets() {
    let scenes = env_list(
        "TSAH_SCENES",
        "sibenik,sponza_dabrovic,stanford_bunny,teapot_in_stadium",
    );
    let builders = env_list(
        "TSAH_BUILDERS",
        "sweep,tsah-topk,tsah-binned,popov-d2,hybrid",
    );
    let epo = std::env::var("TSAH_EPO").is_ok();
    eprintln!(
        "| scene | triangles | builder | build ms | CPU ms | SAH | vs sweep | EPO | leaves |"
    );
    eprintln!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    let catalog = catalog();
    for scene in &scenes {
        let Some(tris) = scene_file_triangles(&catalog, scene) else {
            continue;
        };
        let mut base = None;
        for name in &builders {
            let b = registry::by_name(name).unwrap_or_else(|| panic!("no builder {name}"));
            let (row, _) = measure(b.as_ref(), &tris, epo);
            print_row(scene, tris.len(), name, &row, base.as_ref());
            if name == "sweep" {
                base = Some(row);
            }
        }
    }
}

/// The knobs of the temporary-subtree builder (k, per-axis selection, greedy threshold,
/// binned candidates and temporaries) on the shared scenes and on procedural ones
/// (`TSAH_KNOBS=wide` for more configurations, `TSAH_GREEDY_BELOW` for the threshold).
#[test]
#[ignore]
fn measure_knobs() {
    let scenes = env_list(
        "TSAH_SCENES",
        "sibenik,stanford_bunny,teapot_in_stadium,soup,mesh",
    );
    let epo = std::env::var("TSAH_EPO").is_ok();
    let g = std::env::var("TSAH_GREEDY_BELOW").map_or(8, |v| v.parse().unwrap());
    let base_cfg = TsahConfig {
        greedy_below: g,
        ..TsahConfig::TOP_K
    };
    let top = |k, per_axis| TsahConfig {
        candidates: Candidates::TopK { k, per_axis },
        ..base_cfg
    };
    let binned = |bins_per_axis, temporary| TsahConfig {
        candidates: Candidates::Binned { bins_per_axis },
        temporary,
        ..base_cfg
    };
    let mut configs: Vec<(String, TsahConfig)> = Vec::new();
    if std::env::var("TSAH_KNOBS").as_deref() == Ok("wide") {
        for k in [1, 2, 4, 8, 16] {
            configs.push((format!("top-{k}"), top(k, false)));
        }
        for gb in [0, 8, 32, 64, 256] {
            configs.push((
                format!("top-1/axis greedy<={gb}"),
                TsahConfig {
                    greedy_below: gb,
                    ..top(1, true)
                },
            ));
        }
        for (bins, tbins) in [(2, 8), (3, 8), (4, 8), (4, 16), (8, 16)] {
            configs.push((
                format!("binned {bins}, binned temps {tbins}"),
                binned(bins, Temporary::Binned { bins: tbins }),
            ));
        }
    }
    configs.push(("top-4".into(), top(4, false)));
    for k in [1, 2, 3] {
        configs.push((format!("top-{k}/axis"), top(k, true)));
    }
    for bins in [2, 3, 4] {
        configs.push((
            format!("binned {bins}, sweep temps"),
            binned(bins, Temporary::Sweep),
        ));
    }
    for (bins, tbins) in [(2, 8), (2, 16), (4, 8)] {
        configs.push((
            format!("binned {bins}, binned temps {tbins}"),
            binned(bins, Temporary::Binned { bins: tbins }),
        ));
    }
    eprintln!("| scene | triangles | config | build ms | CPU ms | SAH | vs sweep | EPO | leaves |");
    eprintln!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    let catalog = catalog();
    for scene in &scenes {
        let tris = match scene.as_str() {
            "soup" => box_soup(100_000, 5),
            "mesh" => mesh_like(200, 6),
            s => match scene_file_triangles(&catalog, s) {
                Some(t) => t,
                None => continue,
            },
        };
        let (base, _) = measure(registry::by_name("sweep").unwrap().as_ref(), &tris, epo);
        print_row(scene, tris.len(), "sweep", &base, None);
        for (name, cfg) in &configs {
            let (row, _) = measure(&TsahBuilder::new(*cfg), &tris, epo);
            print_row(scene, tris.len(), name, &row, Some(&base));
        }
    }
}

/// The 871k-triangle dragon with the sweep and top-k presets (`TSAH_BUILDERS` to change).
#[test]
#[ignore]
fn measure_dragon() {
    let Some(tris) = scene_file_triangles(&catalog(), "stanford_dragon") else {
        return;
    };
    let builders = env_list("TSAH_BUILDERS", "sweep,tsah-topk");
    let epo = std::env::var("TSAH_EPO").is_ok();
    let mut base = None;
    for name in &builders {
        let b = registry::by_name(name).unwrap();
        let (row, _) = measure(b.as_ref(), &tris, epo);
        print_row("stanford_dragon", tris.len(), name, &row, base.as_ref());
        if name == "sweep" {
            base = Some(row);
        }
    }
}

#[test]
fn scene_reader_reads_polygons() {
    // A quad and a triangle: three triangles.
    let dir = std::env::temp_dir().join(format!("tsah-scenes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("q.obj"),
        "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1/1 -2 -1\n",
    )
    .unwrap();
    std::env::set_var("SAHARA_SHARED_SCENES", &dir);
    let c = catalog();
    std::env::remove_var("SAHARA_SHARED_SCENES");
    let t = scene_file_triangles(&c, "q").unwrap();
    assert_eq!(t.len(), 3);
    // Names without a file are skipped, procedural scenes' names included.
    assert!(scene_file_triangles(&c, "r").is_none());
    assert!(scene_file_triangles(&Catalog::discover(), "soup").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Arbitrary configurations, as a JSON array of `TsahConfig` in `TSAH_CONFIGS`, for example
/// `[{"candidates":{"Binned":{"bins_per_axis":2}},"temporary":"Sweep","greedy_below":32,
/// "always_include_greedy_best":true,"max_leaf_size":8}]`.
#[test]
#[ignore]
fn measure_configs() {
    let Ok(json) = std::env::var("TSAH_CONFIGS") else {
        eprintln!("set TSAH_CONFIGS");
        return;
    };
    let configs: Vec<TsahConfig> = serde_json::from_str(&json).unwrap();
    let scenes = env_list("TSAH_SCENES", "sibenik,sponza_dabrovic");
    let epo = std::env::var("TSAH_EPO").is_ok();
    eprintln!("| scene | triangles | config | build ms | CPU ms | SAH | vs sweep | EPO | leaves |");
    eprintln!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    let catalog = catalog();
    for scene in &scenes {
        let Some(tris) = scene_file_triangles(&catalog, scene) else {
            continue;
        };
        let (base, _) = measure(registry::by_name("sweep").unwrap().as_ref(), &tris, epo);
        print_row(scene, tris.len(), "sweep", &base, None);
        for cfg in &configs {
            let (row, _) = measure(&TsahBuilder::new(*cfg), &tris, epo);
            print_row(scene, tris.len(), &cfg.describe(), &row, Some(&base));
        }
    }
}

/// Look-ahead configurations, as a JSON array of `PopovConfig` in `POPOV_CONFIGS`.
#[test]
#[ignore]
fn measure_popov_configs() {
    let Ok(json) = std::env::var("POPOV_CONFIGS") else {
        eprintln!("set POPOV_CONFIGS");
        return;
    };
    let configs: Vec<sahara_builders::popov::PopovConfig> = serde_json::from_str(&json).unwrap();
    let scenes = env_list("TSAH_SCENES", "sibenik,sponza_dabrovic");
    let epo = std::env::var("TSAH_EPO").is_ok();
    eprintln!("| scene | triangles | config | build ms | CPU ms | SAH | vs sweep | EPO | leaves |");
    eprintln!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    let catalog = catalog();
    for scene in &scenes {
        let Some(tris) = scene_file_triangles(&catalog, scene) else {
            continue;
        };
        let (base, _) = measure(registry::by_name("sweep").unwrap().as_ref(), &tris, epo);
        print_row(scene, tris.len(), "sweep", &base, None);
        for cfg in &configs {
            let b = sahara_builders::popov::PopovBuilder::new(*cfg);
            let (row, _) = measure(&b, &tris, epo);
            print_row(scene, tris.len(), &cfg.describe(), &row, Some(&base));
        }
    }
}
