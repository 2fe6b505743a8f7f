//! `cargo xtask trace`: speed and work per ray of one builder's tree on one ray set.

use crate::util;
use anyhow::{bail, Context, Result};
use sahara_geom::Triangle;
use sahara_trace::{
    measure, trace_set, trace_set_counted, Backend, Bvh2Tracer, RayKind, RaySet, Throughput,
    Tracer, WorkPerRay,
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
    /// Traversal layout: bvh2, bvh4 or bvh8 (or an engine's name, the same as `--engine`).
    #[arg(long, default_value = "bvh2")]
    layout: String,
    /// Trace engine: sahara (the kernels of `--layout`), embree (Intel Embree 3 over its own
    /// MEDIUM-quality BVH; `--features embree`, docs/embree.md), tinybvh or tinybvh-hq
    /// (tinybvh's BVH8_CPU over its Build or BuildHQ tree; `--features tinybvh`) or obvhs
    /// (obvhs's CWBVH over its medium_build tree; `--features obvhs`; docs/peers.md).
    #[arg(long, default_value = "sahara", value_parser = ENGINES)]
    engine: String,
    /// SIMD kernels of bvh4/bvh8: portable, sse2, avx2 or avx512 (default: the best this CPU
    /// runs). A backend the CPU lacks is an error. Embree gets the matching `isa=`.
    #[arg(long, value_parser = parse_backend_arg)]
    backend: Option<Backend>,
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
    /// The kernels that ran: the SIMD backend of bvh4/bvh8, `scalar` for bvh2, the ISA asked
    /// of Embree (or `default`), `avx2` for tinybvh, `default` for obvhs.
    pub backend: String,
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

/// Values of `--engine`.
pub const ENGINES: [&str; 5] = ["sahara", "embree", "tinybvh", "tinybvh-hq", "obvhs"];

/// Engines other than sahara's kernels, usable wherever a layout is: each builds and traces
/// its own tree from the triangles (the builder's tree is unused), with the cargo feature
/// that enables it.
pub const FOREIGN: [(&str, &str); 4] = [
    ("embree", "embree"),
    ("tinybvh", "tinybvh"),
    ("tinybvh-hq", "tinybvh"),
    ("obvhs", "obvhs"),
];

/// True for the names of [`FOREIGN`] engines.
pub fn is_foreign(layout: &str) -> bool {
    FOREIGN.iter().any(|(l, _)| *l == layout)
}

/// Whether this build has the cargo feature `feature`.
fn has_feature(feature: &str) -> bool {
    match feature {
        "embree" => cfg!(feature = "embree"),
        "tinybvh" => cfg!(feature = "tinybvh"),
        "obvhs" => cfg!(feature = "obvhs"),
        _ => false,
    }
}

/// Layout names of this build: [`LAYOUTS`], plus the [`FOREIGN`] engines whose feature is on.
pub fn layouts() -> Vec<&'static str> {
    let mut l = LAYOUTS.to_vec();
    l.extend(
        FOREIGN
            .iter()
            .filter(|(_, f)| has_feature(f))
            .map(|(l, _)| *l),
    );
    l
}

/// `--backend`'s parser: the name checked against this CPU ([`sahara_trace::parse_backend`]).
pub fn parse_backend_arg(name: &str) -> Result<Backend, sahara_trace::BackendError> {
    sahara_trace::parse_backend(name, Backend::is_available)
}

/// A tracer of `layout` over `bvh` with the best backend of this CPU.
pub fn make_tracer<'a>(
    layout: &str,
    bvh: &'a sahara_bvh::Bvh,
    tris: &'a [Triangle],
) -> Result<Box<dyn Tracer + 'a>> {
    make_tracer_with(layout, bvh, tris, Backend::best())
}

/// A tracer of `layout` over `bvh` whose bvh4/bvh8 kernels run `backend` (an error when this
/// CPU cannot); Embree gets the matching ISA. Foreign engines ignore `bvh`.
pub fn make_tracer_with<'a>(
    layout: &str,
    bvh: &'a sahara_bvh::Bvh,
    tris: &'a [Triangle],
    backend: Backend,
) -> Result<Box<dyn Tracer + 'a>> {
    let _ = backend; // unused by some feature combinations
    match layout {
        "bvh2" => Ok(Box::new(Bvh2Tracer::new(bvh, tris))),
        "bvh4" => Ok(Box::new(sahara_trace::WideTracer::<4>::with_backend(
            bvh, tris, backend,
        )?)),
        "bvh8" => Ok(Box::new(sahara_trace::WideTracer::<8>::with_backend(
            bvh, tris, backend,
        )?)),
        // Embree builds (once per triangle slice) and traces its own BVH; `bvh` is unused.
        #[cfg(feature = "embree")]
        "embree" => Ok(Box::new(crate::embree::EmbreeTracer::with_backend(
            tris, backend,
        )?)),
        #[cfg(feature = "tinybvh")]
        "tinybvh" => Ok(Box::new(crate::tinybvh::TinyTracer::new(
            tris,
            crate::tinybvh::Quality::Build,
        )?)),
        #[cfg(feature = "tinybvh")]
        "tinybvh-hq" => Ok(Box::new(crate::tinybvh::TinyTracer::new(
            tris,
            crate::tinybvh::Quality::BuildHq,
        )?)),
        #[cfg(feature = "obvhs")]
        "obvhs" => Ok(Box::new(crate::obvhs::ObvhsTracer::new(tris)?)),
        other => match FOREIGN.iter().find(|(l, _)| *l == other) {
            Some((_, feature)) => bail!(
                "built without the `{feature}` feature: run `cargo run --release -p xtask \
                 --features {feature} -- trace ...` (docs/embree.md, docs/peers.md)"
            ),
            None => bail!("unknown layout '{other}' (known: {})", layouts().join(", ")),
        },
    }
}

/// The `backend` field of a report of `layout` traced with sahara's `backend`.
pub fn engine_backend(layout: &str, backend: Backend) -> String {
    match layout {
        "bvh2" => "scalar".into(),
        #[cfg(feature = "embree")]
        "embree" => crate::embree::reported_isa(backend),
        "tinybvh" | "tinybvh-hq" => "avx2".into(),
        "obvhs" => "default".into(),
        _ if is_foreign(layout) => "default".into(),
        _ => backend.name().into(),
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
    backend: &str,
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
        backend: backend.to_string(),
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
    let layout = if a.engine != "sahara" {
        a.engine.as_str()
    } else {
        a.layout.as_str()
    };
    let backend = a.backend.unwrap_or_else(Backend::best);
    let tracer = make_tracer_with(layout, &bvh, &scene.triangles, backend)?;
    // Secondary rays start at the primary hits of the tracer that generates them: sahara's
    // kernels (which agree ray by ray), so that a foreign engine traces exactly the rays
    // bvh* trace.
    let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
    let generator: &dyn Tracer = if is_foreign(layout) {
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
        &engine_backend(layout, backend),
        &set,
        a.threads,
        timing,
        &counted,
    );
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "scene      {} ({} triangles), builder {}, layout {} (backend {})",
            r.scene, r.triangles, r.builder, r.layout, r.backend
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
        if is_foreign(layout) {
            let agreement = util::with_threads(a.threads, || {
                crate::peers::agreement(&reference, tracer.as_ref(), &set)
            })?;
            println!("agreement  with sahara's reference: {agreement}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backend_names_parse_and_unavailable_ones_are_typed_errors() {
        // What `--backend` accepts on this CPU.
        for b in Backend::ALL {
            assert_eq!(parse_backend_arg(b.name()).is_ok(), b.is_available(), "{b}");
        }
        // A CPU without AVX-512, simulated.
        let no_avx512 = |b: Backend| b != Backend::Avx512;
        assert!(matches!(
            sahara_trace::parse_backend("avx512", no_avx512),
            Err(sahara_trace::BackendError::Unavailable {
                wanted: Backend::Avx512,
                ..
            })
        ));
        assert!(parse_backend_arg("sse4").is_err());
    }

    #[test]
    fn clap_refuses_an_unknown_backend_and_engine() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            a: Args,
        }
        let base = ["x", "--scene", "cube", "--builder", "sweep"];
        let parse = |extra: &[&str]| {
            let v: Vec<&str> = base.iter().chain(extra).copied().collect();
            Cli::try_parse_from(v)
        };
        let ok = parse(&["--backend", "portable"])
            .map_err(|e| e.to_string())
            .unwrap();
        assert_eq!(ok.a.backend, Some(Backend::Portable));
        assert_eq!(parse(&[]).ok().and_then(|c| c.a.backend), None);
        let e = parse(&["--backend", "neon"]).err().unwrap().to_string();
        assert!(e.contains("unknown backend"), "{e}");
        assert!(parse(&["--engine", "optix"]).is_err());
    }

    #[test]
    fn layouts_and_backends_of_reports() {
        assert!(layouts().starts_with(LAYOUTS));
        for (l, _) in FOREIGN {
            assert!(is_foreign(l));
            assert_eq!(
                layouts().contains(&l),
                has_feature(FOREIGN.iter().find(|f| f.0 == l).unwrap().1)
            );
        }
        assert!(!is_foreign("bvh8"));
        assert_eq!(engine_backend("bvh2", Backend::Sse2), "scalar");
        assert_eq!(engine_backend("bvh8", Backend::Sse2), "sse2");
        assert_eq!(engine_backend("bvh4", Backend::Portable), "portable");
        assert_eq!(engine_backend("tinybvh", Backend::Sse2), "avx2");
    }

    #[test]
    fn every_available_backend_traces_a_procedural_scene_alike() {
        let scene = util::load_scene("sphere_in_box:2000").unwrap();
        let input = sahara_builders::BuildInput::new(
            &scene.triangles,
            sahara_builders::CostModel::default(),
        )
        .unwrap();
        let bvh = util::builder("sweep").unwrap().build(&input).unwrap();
        let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
        for kind in ["primary", "diffuse", "ao"] {
            let set = ray_set(kind, &scene, &reference, 48, 32, 3).unwrap();
            let want = trace_set(&reference, &set).checksum();
            for layout in ["bvh4", "bvh8"] {
                for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
                    let t = make_tracer_with(layout, &bvh, &scene.triangles, b).unwrap();
                    let (_, counted) = measure_trace(t.as_ref(), &set, Some(1), 1).unwrap();
                    let r = report(
                        &scene.name,
                        scene.triangles.len(),
                        "sweep",
                        layout,
                        &engine_backend(layout, b),
                        &set,
                        Some(1),
                        sahara_trace::Timing::from_samples(&[1e-3]),
                        &counted,
                    );
                    assert_eq!(r.checksum, format!("{want:016x}"), "{layout} {b} {kind}");
                    assert_eq!(r.backend, b.name());
                }
            }
        }
        for b in Backend::ALL.into_iter().filter(|b| !b.is_available()) {
            assert!(make_tracer_with("bvh8", &bvh, &scene.triangles, b).is_err());
        }
    }
}
