//! `cargo xtask trace`: speed and work per ray of one builder's tree on one ray set.

use crate::engine::{self, Engine};
use crate::util;
use anyhow::{bail, Result};
use sahara_trace::{Backend, Bvh2Tracer, Tracer};
use sahara_traverse::Precision;
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
    layout: Engine,
    /// Trace engine: sahara (the kernels of `--layout`), embree (Intel Embree 3 over its own
    /// MEDIUM-quality BVH; `--features embree`, docs/embree.md), tinybvh or tinybvh-hq
    /// (tinybvh's BVH8_CPU over its Build or BuildHQ tree; `--features tinybvh`) or obvhs
    /// (obvhs's CWBVH over its medium_build tree; `--features obvhs`; docs/peers.md).
    #[arg(long, default_value = "sahara", value_parser = engine_values())]
    engine: String,
    /// SIMD kernels of bvh4/bvh8: portable, sse2, avx2 or avx512 (default: the best this CPU
    /// runs). A backend the CPU lacks is an error. Embree gets the matching `isa=`.
    #[arg(long, value_parser = engine::parse_backend_arg)]
    backend: Option<Backend>,
    /// Triangle test of bvh4/bvh8: exact (watertight, the default) or fast (Möller–Trumbore;
    /// docs/precision.md). The ray set is made by the exact kernels either way.
    #[arg(long, default_value = "exact")]
    precision: Precision,
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

/// Values of `--engine`: `sahara` (the kernels of `--layout`), then the foreign engines.
fn engine_values() -> Vec<&'static str> {
    std::iter::once("sahara")
        .chain(
            Engine::ALL
                .into_iter()
                .filter(|e| e.is_foreign())
                .map(Engine::name),
        )
        .collect()
}

/// Builds the tree, traces the ray set with the engine and prints the report.
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
        a.engine.parse::<Engine>().map_err(anyhow::Error::msg)?
    } else {
        a.layout
    };
    let backend = a.backend.unwrap_or_else(Backend::best);
    let tracer = layout.tracer_at(&bvh, &scene.triangles, backend, a.precision)?;
    // Secondary rays start at the primary hits of the tracer that generates them: sahara's
    // exact kernels (which agree ray by ray), so that a foreign engine and the fast precision
    // trace exactly the rays the exact bvh* trace.
    let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
    let generator: &dyn Tracer = if layout.is_foreign() || a.precision != Precision::Exact {
        &reference
    } else {
        tracer.as_ref()
    };
    let set = engine::ray_set(&a.rays, &scene, generator, a.width, a.height, a.seed)?;
    if let Some(p) = &a.dump_rays {
        sahara_trace::write_rays(p, &set.rays)?;
    }
    let (timing, counted) = engine::measure_trace(tracer.as_ref(), &set, a.threads, a.passes)?;
    if let Some(p) = &a.dump_hits {
        match &counted.results {
            sahara_trace::TraceResults::Closest(h) => sahara_trace::write_hits(p, h)?,
            sahara_trace::TraceResults::Any(_) => {
                bail!("--dump-hits writes closest hits; AO rays are any-hit queries")
            }
        }
    }
    let r = engine::report(
        &scene.name,
        scene.triangles.len(),
        &a.builder,
        layout,
        &layout.backend_name(backend),
        a.precision,
        &set,
        a.threads,
        timing,
        &counted,
    );
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "scene      {} ({} triangles), builder {}, layout {} (backend {}, precision {})",
            r.scene, r.triangles, r.builder, r.layout, r.backend, r.precision
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
        if layout.is_foreign() {
            let agreement = util::with_threads(a.threads, || {
                engine::peers::agreement(&reference, tracer.as_ref(), &set)
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
}
