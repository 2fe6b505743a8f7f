//! `cargo xtask oracle`: the reference kernels pinned by the exact oracle on every scene.
//!
//! For every scene file of the catalog (or those named) and every floor-and-wall level of
//! `sahara_hardcases::floors` (scales 1 to 10^4, at the origin and far from it), the scalar
//! reference traversal (which equals brute force bit for bit) answers the scene's primary,
//! diffuse and AO rays (at least 10^5 of each by default), and `sahara-oracle`, exact and
//! independent of the kernels, judges every answer. Prints one row per scene and ray type with
//! the classes of `sahara_hardcases::pinning::Tally`; fails when any ray is a failure (missed,
//! farther or false hit). `docs/robustness.md` explains the classes.

use std::time::Instant;

use anyhow::Result;
use sahara_geom::Triangle;
use sahara_hardcases::floors::{levels, FlatRayKind};
use sahara_hardcases::pinning::{oracle_for, pin_reference, Tally};
use sahara_scene::{Catalog, Origin};
use sahara_trace::{Bvh2Tracer, RayKind, RaySet};
use serde::Serialize;

/// Options of `cargo xtask oracle`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene names (comma-separated; default: every scene file of the catalog).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Image width of the primary rays (secondary rays spawn from their hits).
    #[arg(long, default_value_t = 384)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 288)]
    height: u32,
    /// Rays of each kind per floor-and-wall level.
    #[arg(long, default_value_t = 25_000)]
    flat_rays: usize,
    /// Skip the floor-and-wall levels.
    #[arg(long)]
    no_flat: bool,
    /// Skip the catalog's scene files.
    #[arg(long)]
    no_files: bool,
    /// Also write the rows as JSON to this file.
    #[arg(long)]
    json: Option<std::path::PathBuf>,
}

/// One row of the report.
#[derive(Serialize)]
struct Row {
    scene: String,
    triangles: usize,
    ray_kind: String,
    #[serde(flatten)]
    tally: Tally,
}

/// Prints a judged ray set and keeps its row.
fn record(rows: &mut Vec<Row>, scene: &str, triangles: usize, kind: &str, tally: Tally) {
    eprintln!("oracle: {scene} {kind}: {tally}");
    rows.push(Row {
        scene: scene.into(),
        triangles,
        ray_kind: kind.into(),
        tally,
    });
}

fn sweep(tris: &[Triangle]) -> Result<sahara_bvh::Bvh> {
    let input = sahara_builders::BuildInput::new(tris, sahara_builders::CostModel::default())?;
    Ok(crate::util::builder("sweep")?.build(&input)?)
}

pub fn run(a: Args) -> Result<()> {
    let start = Instant::now();
    let mut rows = Vec::new();
    if !a.no_files {
        let catalog = Catalog::discover();
        let names: Vec<String> = if a.scenes.is_empty() {
            catalog
                .distinct_files()
                .into_iter()
                .filter(|e| e.origin != Origin::Procedural)
                .map(|e| e.name.clone())
                .collect()
        } else {
            a.scenes.clone()
        };
        if names.is_empty() {
            eprintln!("oracle: no scene files found (../shared/scenes or SAHARA_SCENES); skipped");
        }
        for name in names {
            let scene = crate::util::load_scene_from(&catalog, &name)?;
            let tris = &scene.triangles;
            let oracle = oracle_for(tris);
            let bvh = sweep(tris)?;
            let tracer = Bvh2Tracer::new(&bvh, tris);
            let camera = crate::engine::trace_camera(&scene.camera);
            for kind in [
                RayKind::Primary,
                RayKind::Diffuse,
                RayKind::AmbientOcclusion,
            ] {
                let set = RaySet::generate(kind, &camera, a.width, a.height, &tracer, tris, 1);
                let t = pin_reference(&oracle, &bvh, tris, &set.rays, kind.uses_any_hit());
                record(&mut rows, &name, tris.len(), kind.name(), t);
            }
        }
    }
    if !a.no_flat {
        for l in levels() {
            let tris = l.triangles();
            let oracle = oracle_for(&tris);
            let bvh = sweep(&tris)?;
            let name = format!("floors-{}", l.name);
            for kind in FlatRayKind::ALL {
                let set = l.rays(&tris, a.flat_rays, 100 + l.seed, kind);
                let t = pin_reference(&oracle, &bvh, &tris, &set, kind.uses_any_hit());
                record(&mut rows, &name, tris.len(), kind.name(), t);
            }
        }
    }
    println!(
        "| scene | triangles | rays | judged | agree | edge | unorderable | missed | farther | false hit | max t error (exact answers) |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut total = Tally::default();
    for r in &rows {
        let t = &r.tally;
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1e} |",
            r.scene,
            r.triangles,
            r.ray_kind,
            t.rays,
            t.agree,
            t.edge,
            t.unorderable,
            t.missed,
            t.farther,
            t.false_hit,
            t.max_t_rel_error
        );
        total.add(t);
    }
    println!("\ntotal: {total} ({:.0} s)", start.elapsed().as_secs_f64());
    if let Some(f) = &total.first_failure {
        println!("first failure: {f}");
    }
    if let Some(path) = &a.json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
    }
    anyhow::ensure!(
        total.failures() == 0,
        "{} rays where the reference disagrees with the exact oracle",
        total.failures()
    );
    Ok(())
}
