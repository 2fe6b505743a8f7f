//! `cargo xtask bvh` and `cargo xtask builders`.

use crate::util::{self, Spread};
use anyhow::Result;
use sahara_builders::{BuildInput, CostModel};
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

/// The JSON record of one build (its fields are a contract: `docs/command-line.md`).
#[derive(Clone, Debug, Serialize)]
pub struct BuildReport {
    pub scene: String,
    pub triangles: usize,
    pub builder: String,
    pub config: String,
    pub threads: usize,
    pub build_ms: Spread,
    pub sah: f64,
    pub epo: Option<f64>,
    pub nodes: usize,
    pub leaves: usize,
    pub references: usize,
    pub max_leaf: usize,
    pub depth: usize,
}

/// Builds `runs` times on `threads` threads and measures the last tree.
pub fn build_and_measure(
    scene: &str,
    tris: &[sahara_geom::Triangle],
    builder_name: &str,
    threads: Option<usize>,
    runs: usize,
    with_epo: bool,
) -> Result<(BuildReport, sahara_bvh::Bvh)> {
    let builder = util::builder(builder_name)?;
    let cost = CostModel::default();
    let input = BuildInput::new(tris, cost)?;
    let (times, bvh) =
        util::with_threads(threads, || util::time_runs(runs, || builder.build(&input)))?;
    let bvh = bvh?;
    let stats = bvh.stats();
    let epo = if with_epo {
        Some(util::with_threads(threads, || {
            sahara_metrics::epo(&bvh, tris, &cost)
        })?)
    } else {
        None
    };
    let report = BuildReport {
        scene: scene.to_string(),
        triangles: tris.len(),
        builder: builder_name.to_string(),
        config: builder.describe(),
        threads: util::with_threads(threads, rayon::current_num_threads)?,
        build_ms: Spread::of(&times).map(|s| s * 1e3),
        sah: sahara_metrics::sah(&bvh, &cost),
        epo,
        nodes: stats.nodes,
        leaves: stats.leaves,
        references: stats.references,
        max_leaf: stats.max_leaf,
        depth: stats.depth,
    };
    Ok((report, bvh))
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
    let (r, bvh) = build_and_measure(
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
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
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
    }
    Ok(())
}

pub fn list_builders() -> Result<()> {
    println!("{:<18} {:<8} description / configuration", "name", "kind");
    for e in sahara_builders::registry::entries() {
        let b = (e.make)();
        let kind = if e.spatial { "spatial" } else { "object" };
        println!("{:<18} {:<8} {}", e.name, kind, e.summary);
        println!("{:<18} {:<8} {}", "", "", b.describe());
    }
    Ok(())
}
