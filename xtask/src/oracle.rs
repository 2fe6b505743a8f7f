//! `cargo xtask oracle`: the reference kernels pinned by the exact oracle on every scene.
//!
//! For every scene file of the catalog (or those named) and every floor-and-wall level of
//! `sahara_hardcases::floors` (scales 1 to 10^4, at the origin and far from it), the scalar
//! reference traversal (which equals brute force bit for bit) answers the scene's primary,
//! diffuse and AO rays (at least 10^5 of each by default), and `sahara-oracle`, exact and
//! independent of the kernels, judges every answer. Prints one row per scene and ray type with
//! the classes of `sahara_hardcases::pinning::Tally`; fails when any ray is a failure (missed,
//! farther or false hit). `docs/robustness.md` explains the classes.
//!
//! `--precision fast` judges the 8-wide kernels at `Precision::Fast` instead (Möller–Trumbore,
//! not watertight): it measures the failures per million rays and does not fail
//! (`docs/precision.md`).

use std::time::Instant;

use anyhow::Result;
use sahara_geom::Triangle;
use sahara_hardcases::floors::{levels, FlatRayKind};
use sahara_hardcases::pinning::{oracle_for, pin_reference, pin_wide, Tally};
use sahara_scene::{Catalog, Origin};
use sahara_trace::{Bvh2Tracer, RayKind, RaySet};
use sahara_traverse::{Bvh8, Precision};
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
    /// With `--precision fast`, skip the hard cases (`sahara_hardcases::cases`, CI level: closed
    /// meshes with rays from inside, rays through edges and vertices, extreme geometry), whose
    /// rays the fast test is judged on too, with the rays that must hit counted apart.
    #[arg(long)]
    no_hardcases: bool,
    /// Also write the rows as JSON to this file.
    #[arg(long)]
    json: Option<std::path::PathBuf>,
    /// `exact`: the scalar reference, which must have no failure; `fast`: the 8-wide kernels at
    /// `Precision::Fast`, whose failures are measured (per million rays), not refused.
    #[arg(long, default_value = "exact")]
    precision: Precision,
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

/// The answers of the reference (`Exact`) or of the 8-wide kernels at `Fast`, judged.
fn judge(
    oracle: &sahara_oracle::Oracle,
    bvh: &sahara_bvh::Bvh,
    tris: &[Triangle],
    rays: &[sahara_geom::Ray],
    any: bool,
    precision: Precision,
) -> Tally {
    match precision {
        Precision::Exact => pin_reference(oracle, bvh, tris, rays, any),
        Precision::Fast => pin_wide(
            oracle,
            &Bvh8::from_bvh(bvh, tris).with_precision(precision),
            rays,
            any,
        ),
    }
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
            let camera = scene.camera;
            for kind in [
                RayKind::Primary,
                RayKind::Diffuse,
                RayKind::AmbientOcclusion,
            ] {
                let set = RaySet::generate(kind, &camera, a.width, a.height, &tracer, tris, 1);
                let t = judge(
                    &oracle,
                    &bvh,
                    tris,
                    &set.rays,
                    kind.uses_any_hit(),
                    a.precision,
                );
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
                let t = judge(&oracle, &bvh, &tris, &set, kind.uses_any_hit(), a.precision);
                record(&mut rows, &name, tris.len(), kind.name(), t);
            }
        }
    }
    if a.precision == Precision::Fast && !a.no_hardcases {
        hard_cases(&mut rows)?;
    }
    println!("precision: {}", a.precision);
    println!(
        "| scene | triangles | rays | judged | agree | edge | unorderable | missed | farther | false hit | failures per million | max t error (exact answers) |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut total = Tally::default();
    for r in &rows {
        let t = &r.tally;
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} | {:.1e} |",
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
            per_million(t),
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
    if a.precision == Precision::Fast {
        println!(
            "fast precision: {:.1} failures per million rays (not refused)",
            per_million(&total)
        );
        return Ok(());
    }
    anyhow::ensure!(
        total.failures() == 0,
        "{} rays where the reference disagrees with the exact oracle",
        total.failures()
    );
    Ok(())
}

/// Failures (missed, farther, false hits) per million judged rays.
fn per_million(t: &Tally) -> f64 {
    t.failures() as f64 * 1e6 / t.rays.max(1) as f64
}

/// The hard cases of the CI level with finite triangles and rays, judged at `Precision::Fast`
/// (the exact reference passes them in the test suite); a ray of a closed mesh that must hit
/// and does not is a `missed` answer, which the oracle counts like any other.
fn hard_cases(rows: &mut Vec<Row>) -> Result<()> {
    for case in sahara_hardcases::cases(sahara_hardcases::Level::Fast) {
        if case.expect_non_finite.is_some() || case.rays.is_empty() {
            continue;
        }
        let tris = case.triangles.as_slice();
        let oracle = oracle_for(tris);
        let bvh = sweep(tris)?;
        for any in [false, true] {
            let t = judge(&oracle, &bvh, tris, &case.rays, any, Precision::Fast);
            let kind = if any { "any" } else { "closest" };
            record(rows, &case.name, tris.len(), kind, t);
        }
    }
    Ok(())
}
