//! `cargo xtask trace`: speed and work per ray of one builder's tree on one ray set.

use crate::util;
use anyhow::{bail, Context, Result};
use sahara_geom::Triangle;
use sahara_trace::{
    measure, trace_set, trace_set_counted, Bvh2Tracer, RayKind, RaySet, Throughput, Tracer,
    WorkPerRay,
};
use serde::Serialize;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Catalog name or path to .obj/.obj.gz/.gltf/.glb.
    #[arg(long)]
    scene: String,
    /// The camera of the primary rays: `eye=x,y,z target=x,y,z up=x,y,z fov=deg` (up and fov
    /// optional; default: the scene's own, or a placed one, see docs/cameras.md).
    #[arg(long, value_parser = util::parse_camera)]
    camera: Option<sahara_scene::Camera>,
    /// Registered builder name.
    #[arg(long)]
    builder: String,
    /// primary, diffuse, ao, or a ray file (32-byte records, see docs/command-line.md).
    #[arg(long, default_value = "primary")]
    rays: String,
    /// Traversal layout: bvh2, bvh4 or bvh8 (or embree, the same as `--engine embree`).
    #[arg(long, default_value = "bvh2")]
    layout: String,
    /// Trace engine: sahara (the kernels of `--layout`) or embree (Intel Embree 3 over its own
    /// MEDIUM-quality BVH; needs `--features embree`, see docs/embree.md).
    #[arg(long, default_value = "sahara", value_parser = ["sahara", "embree"])]
    engine: String,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Image width (primary rays are one per pixel).
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 768)]
    height: u32,
    /// Timed passes (after one warm-up pass).
    #[arg(long, default_value_t = 5)]
    passes: usize,
    /// Seed of the secondary rays.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the hits (16-byte records) to this file.
    #[arg(long)]
    dump_hits: Option<PathBuf>,
    /// Write the rays (32-byte records) to this file.
    #[arg(long)]
    dump_rays: Option<PathBuf>,
}

/// The JSON record of one trace measurement (its fields are a contract: `docs/command-line.md`).
#[derive(Clone, Debug, Serialize)]
pub struct TraceReport {
    pub scene: String,
    pub triangles: usize,
    pub builder: String,
    pub layout: String,
    pub ray_kind: String,
    pub rays: usize,
    pub threads: usize,
    pub mrays_s: Throughput,
    pub trace_ms: sahara_trace::Timing,
    pub work: WorkPerRay,
    pub inner_per_ray: f64,
    pub leaves_per_ray: f64,
    pub triangles_per_ray: f64,
    /// Standard deviation of the leaves visited per ray (leaf count variability).
    pub lcv: f64,
    pub hits: usize,
    pub checksum: String,
}

/// Layout names the tracer accepts.
pub const LAYOUTS: &[&str] = &["bvh2", "bvh4", "bvh8"];

/// Layout names of this build: [`LAYOUTS`], plus `embree` with the `embree` feature.
pub fn layouts() -> Vec<&'static str> {
    let mut l = LAYOUTS.to_vec();
    if cfg!(feature = "embree") {
        l.push("embree");
    }
    l
}

/// A tracer of `layout` over `bvh`.
pub fn make_tracer<'a>(
    layout: &str,
    bvh: &'a sahara_bvh::Bvh,
    tris: &'a [Triangle],
) -> Result<Box<dyn Tracer + 'a>> {
    match layout {
        "bvh2" => Ok(Box::new(Bvh2Tracer::new(bvh, tris))),
        "bvh4" => Ok(Box::new(sahara_trace::WideTracer::<4>::new(bvh, tris))),
        "bvh8" => Ok(Box::new(sahara_trace::WideTracer::<8>::new(bvh, tris))),
        // Embree builds (once per triangle slice) and traces its own BVH; `bvh` is unused.
        #[cfg(feature = "embree")]
        "embree" => Ok(Box::new(crate::embree::EmbreeTracer::new(tris)?)),
        #[cfg(not(feature = "embree"))]
        "embree" => bail!(
            "built without the `embree` feature: install libembree-dev and run \
             `cargo run --release -p xtask --features embree -- trace ...` (docs/embree.md)"
        ),
        other => bail!("unknown layout '{other}' (known: {})", layouts().join(", ")),
    }
}

/// Times `set` through `tracer` (one warm-up, `passes` timed passes) and counts its work.
pub fn measure_trace(
    tracer: &dyn Tracer,
    set: &RaySet,
    threads: Option<usize>,
    passes: usize,
) -> Result<(
    sahara_trace::Timing,
    sahara_trace::CountedTrace<sahara_trace::TraceResults>,
)> {
    util::with_threads(threads, || {
        let timing = measure(passes.max(1), 1, || trace_set(tracer, set));
        let counted = trace_set_counted(tracer, set);
        (timing, counted)
    })
}

/// Assembles the report of one measurement.
#[allow(clippy::too_many_arguments)]
pub fn report(
    scene: &str,
    triangles: usize,
    builder: &str,
    layout: &str,
    set: &RaySet,
    threads: Option<usize>,
    timing: sahara_trace::Timing,
    counted: &sahara_trace::CountedTrace<sahara_trace::TraceResults>,
) -> TraceReport {
    let work = counted.per_ray();
    let leaves: Vec<u32> = counted.work.iter().map(|w| w.leaves as u32).collect();
    TraceReport {
        scene: scene.to_string(),
        triangles,
        builder: builder.to_string(),
        layout: layout.to_string(),
        ray_kind: set.kind.name().to_string(),
        rays: set.len(),
        threads: util::thread_count(threads),
        mrays_s: timing.mrays_per_s(set.len()),
        trace_ms: timing.millis(),
        work,
        inner_per_ray: work.inner,
        leaves_per_ray: work.leaves,
        triangles_per_ray: work.triangles,
        lcv: sahara_metrics::lcv(&leaves),
        hits: counted.results.hit_count(),
        checksum: format!("{:016x}", counted.results.checksum()),
    }
}

/// The ray set named by `spec` (a kind or a ray file) for a scene, generated with `tracer`.
pub fn ray_set(
    spec: &str,
    scene: &util::LoadedScene,
    tracer: &dyn Tracer,
    width: u32,
    height: u32,
    seed: u64,
) -> Result<RaySet> {
    let camera = trace_camera(&scene.camera);
    match spec.parse::<RayKind>() {
        Ok(kind) => Ok(RaySet::generate(
            kind,
            &camera,
            width,
            height,
            tracer,
            &scene.triangles,
            seed,
        )),
        Err(_) => {
            let rays = sahara_trace::read_rays(spec).with_context(|| {
                format!("'{spec}' is neither primary|diffuse|ao nor a ray file")
            })?;
            Ok(RaySet::from_rays(RayKind::Primary, rays))
        }
    }
}

/// The catalog's camera as the tracer's camera type.
pub fn trace_camera(c: &sahara_scene::Camera) -> sahara_trace::Camera {
    sahara_trace::Camera::new(c.eye, c.target, c.up, c.fov_y_degrees)
}

pub fn run(a: Args) -> Result<()> {
    let catalog = sahara_scene::Catalog::discover();
    let scene = util::load_scene_with(&catalog, &a.scene, a.camera.as_ref())?;
    if !a.json {
        eprintln!("camera ({}): {}", scene.camera_source, scene.camera);
    }
    let builder = util::builder(&a.builder)?;
    let input =
        sahara_builders::BuildInput::new(&scene.triangles, sahara_builders::CostModel::default())?;
    let bvh = util::with_threads(a.threads, || builder.build(&input))??;
    let layout = if a.engine == "embree" {
        "embree"
    } else {
        a.layout.as_str()
    };
    let tracer = make_tracer(layout, &bvh, &scene.triangles)?;
    // Secondary rays start at the primary hits of the tracer that generates them: sahara's
    // kernels (which agree ray by ray), so that Embree traces exactly the rays bvh* trace.
    let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
    let generator: &dyn Tracer = if layout == "embree" {
        &reference
    } else {
        tracer.as_ref()
    };
    let set = ray_set(&a.rays, &scene, generator, a.width, a.height, a.seed)?;
    if let Some(p) = &a.dump_rays {
        sahara_trace::write_rays(p, &set.rays)?;
    }
    let (timing, counted) = measure_trace(tracer.as_ref(), &set, a.threads, a.passes)?;
    if let Some(p) = &a.dump_hits {
        match &counted.results {
            sahara_trace::TraceResults::Closest(h) => sahara_trace::write_hits(p, h)?,
            sahara_trace::TraceResults::Any(_) => {
                bail!("--dump-hits writes closest hits; AO rays are any-hit queries")
            }
        }
    }
    let r = report(
        &scene.name,
        scene.triangles.len(),
        &a.builder,
        layout,
        &set,
        a.threads,
        timing,
        &counted,
    );
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "scene      {} ({} triangles), builder {}, layout {}",
            r.scene, r.triangles, r.builder, r.layout
        );
        println!(
            "rays       {} {} rays on {} threads",
            r.rays, r.ray_kind, r.threads
        );
        println!(
            "speed      {:.2} Mrays/s median (min {:.2}, max {:.2}) over {} passes",
            r.mrays_s.median, r.mrays_s.min, r.mrays_s.max, a.passes
        );
        println!(
            "work/ray   {:.2} inner, {:.2} leaves, {:.2} triangles (LCV {:.2})",
            r.inner_per_ray, r.leaves_per_ray, r.triangles_per_ray, r.lcv
        );
        println!("hits       {} (checksum {})", r.hits, r.checksum);
    }
    Ok(())
}
