//! `cargo xtask bvh`: build a tree, report its build time, shape and memory.

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

/// The memory figures of `bvh --json` (field `memory`): exact heap bytes from the xtask's
/// counting allocator ([`crate::alloc_count`]) and the sizes of the traversal layouts.
#[derive(Clone, Debug, Serialize)]
pub struct MemoryReport {
    /// Heap bytes the `BuildInput` (primitive boxes and centroids) allocated.
    pub input_bytes: usize,
    /// The most heap bytes the build held at once above what was live when it started (its
    /// working memory and the tree it returns), the largest over the timed builds.
    pub peak_build_bytes: usize,
    /// `peak_build_bytes` per triangle.
    pub peak_build_bytes_per_triangle: f64,
    /// Bytes per triangle of the binary tree (32-byte nodes and 4-byte references).
    pub bvh2_bytes_per_triangle: f64,
    /// Bytes per triangle of the 4-wide layout (nodes and 4-triangle leaf packets).
    pub bvh4_bytes_per_triangle: f64,
    /// Bytes per triangle of the 8-wide layout (nodes and 4-triangle leaf packets).
    pub bvh8_bytes_per_triangle: f64,
}

/// The record of `bvh --json`: the build's fields and, under `memory`, its memory figures.
#[derive(Clone, Debug, Serialize)]
pub struct BvhJson {
    #[serde(flatten)]
    pub build: BuildReport,
    pub memory: MemoryReport,
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
    let (r, bvh, _, _) = build_measure_memory(scene, tris, builder_name, threads, runs, with_epo)?;
    Ok((r, bvh))
}

/// [`build_and_measure`], also returning the input's heap bytes and the build's peak heap
/// bytes (see [`MemoryReport`]).
pub fn build_measure_memory(
    scene: &str,
    tris: &[sahara_geom::Triangle],
    builder_name: &str,
    threads: Option<usize>,
    runs: usize,
    with_epo: bool,
) -> Result<(BuildReport, sahara_bvh::Bvh, usize, usize)> {
    let builder = util::builder(builder_name)?;
    let cost = CostModel::default();
    let before_input = crate::alloc_count::reset_peak();
    let input = BuildInput::new(tris, cost)?;
    let input_bytes = crate::alloc_count::live().saturating_sub(before_input);
    let mut peak = 0usize;
    let (times, bvh) = util::with_threads(threads, || {
        util::time_runs(runs, || {
            let base = crate::alloc_count::reset_peak();
            let r = builder.build(&input);
            peak = peak.max(crate::alloc_count::peak().saturating_sub(base));
            r
        })
    })?;
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
    Ok((report, bvh, input_bytes, peak))
}

/// The memory figures of a build (see [`MemoryReport`]).
pub fn memory_report(
    bvh: &sahara_bvh::Bvh,
    tris: &[sahara_geom::Triangle],
    input_bytes: usize,
    peak_build_bytes: usize,
) -> MemoryReport {
    let per = |bytes: usize| bytes as f64 / tris.len().max(1) as f64;
    let bvh2 = bvh.nodes.len() * std::mem::size_of::<sahara_bvh::Node>()
        + bvh.prim_indices.len() * std::mem::size_of::<u32>();
    let bvh4 = sahara_traverse::wide::WideBvh::<4>::from_bvh(bvh, tris).memory_bytes();
    let bvh8 = sahara_traverse::wide::WideBvh::<8>::from_bvh(bvh, tris).memory_bytes();
    MemoryReport {
        input_bytes,
        peak_build_bytes,
        peak_build_bytes_per_triangle: per(peak_build_bytes),
        bvh2_bytes_per_triangle: per(bvh2),
        bvh4_bytes_per_triangle: per(bvh4),
        bvh8_bytes_per_triangle: per(bvh8),
    }
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
    let (r, bvh, input_bytes, peak) = build_measure_memory(
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
    let mem = memory_report(&bvh, &scene.triangles, input_bytes, peak);
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
