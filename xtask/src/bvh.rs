//! `cargo xtask bvh`: build a tree, report its build time, shape and memory.

use crate::tree::{self, BuildReport, MemoryReport};
use crate::util;
use anyhow::Result;
use serde::Serialize;

#[derive(clap::Args)]
pub struct Args {
    /// Catalog name or path to .obj/.obj.gz/.gltf/.glb.
    #[arg(long)]
    scene: String,
    /// Registered builder name (`cargo xtask builders`).
    #[arg(long)]
    builder: String,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Number of timed builds (at least 5 are recommended).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Skip the EPO metric (it costs a few seconds on million-triangle scenes).
    #[arg(long)]
    no_epo: bool,
    /// Also write the tree to this file (sahara BVH format).
    #[arg(long)]
    save: Option<std::path::PathBuf>,
    /// Build even when the scene is larger than the builder's practical limit (the registry's
    /// `max_practical_triangles`, e.g. `tsah-exhaustive`: hours on a 66k-triangle scene).
    #[arg(long)]
    force: bool,
}

/// The record of `bvh --json`: the build's fields and, under `memory`, its memory figures.
#[derive(Clone, Debug, Serialize)]
pub struct BvhJson {
    #[serde(flatten)]
    pub build: BuildReport,
    pub memory: MemoryReport,
}

pub fn run(a: Args) -> Result<()> {
    let scene = util::load_scene(&a.scene)?;
    let limit = sahara_builders::registry::entries()
        .into_iter()
        .find(|e| e.name == a.builder)
        .and_then(|e| e.max_practical_triangles);
    if let Some(limit) = limit.filter(|&m| scene.triangles.len() > m && !a.force) {
        anyhow::bail!(
            "{} is practical up to {limit} triangles and {} has {}: the build would take far too \
             long (see `cargo xtask builders`); pass --force to build anyway",
            a.builder,
            scene.name,
            scene.triangles.len()
        );
    }
    let (r, bvh, input_bytes, peak) = tree::build_and_measure(
        &scene.name,
        &scene.triangles,
        &a.builder,
        a.threads,
        a.runs,
        !a.no_epo,
    )?;
    bvh.validate(&scene.triangles)?;
    if let Some(path) = &a.save {
        bvh.save_to_path(path)?;
    }
    let mem = tree::memory_report(&bvh, &scene.triangles, input_bytes, peak);
    if a.json {
        let j = BvhJson {
            build: r,
            memory: mem,
        };
        println!("{}", serde_json::to_string(&j)?);
    } else {
        println!("scene      {} ({} triangles)", r.scene, r.triangles);
        println!("builder    {} [{}]", r.builder, r.config);
        println!(
            "build      {:.2} ms median (min {:.2}, max {:.2}) over {} runs on {} threads",
            r.build_ms.median, r.build_ms.min, r.build_ms.max, a.runs, r.threads
        );
        println!("SAH        {:.4}", r.sah);
        if let Some(e) = r.epo {
            println!("EPO        {e:.4}");
        }
        println!(
            "nodes      {} ({} leaves), {} references, max leaf {}, depth {}",
            r.nodes, r.leaves, r.references, r.max_leaf, r.depth
        );
        let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
        println!(
            "memory     input {:.1} MiB, build peak {:.1} MiB ({:.1} B/triangle); layouts bvh2 \
             {:.1}, bvh4 {:.1}, bvh8 {:.1} B/triangle",
            mib(mem.input_bytes),
            mib(mem.peak_build_bytes),
            mem.peak_build_bytes_per_triangle,
            mem.bvh2_bytes_per_triangle,
            mem.bvh4_bytes_per_triangle,
            mem.bvh8_bytes_per_triangle
        );
    }
    Ok(())
}
