//! `cargo xtask reinsert-rays`: reinsertion whose objective is the ray-weighted cost of a
//! training ray set (issue 16, item 5), against `sweep` and `sweep+reinsert`, measured on
//! other rays (docs/builders-frontier.md, "Beyond SAH").
//!
//! The builders never see rays: the training rays become a `sahara_metrics::SegmentSet`
//! here, and the reinsertion only gets a node weight `w(box)` (a closure) to lower
//! `Σ_inner w(box)`: `sahara_builders::reinsert::optimize_for`.

use crate::util;
use anyhow::{Context, Result};
use sahara_builders::reinsert::{self, ReinsertConfig};
use sahara_builders::{BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Ray};
use sahara_metrics::SegmentSet;
use sahara_trace::{trace_closest, trace_set_counted, Bvh2Tracer, RayKind, RaySet, Tracer};
use serde::Serialize;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Catalog names, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sponza_dabrovic,sibenik,teapot_stadium:60000"
    )]
    scenes: Vec<String>,
    /// Width of the test image (one primary ray per pixel; diffuse rays from its hits).
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Height of the test image.
    #[arg(long, default_value_t = 768)]
    height: u32,
    /// Seed of the test diffuse rays (the training diffuse rays use `seed + 1`).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Training rays of each type (primary from a jittered camera, diffuse from their hits).
    #[arg(long, default_value_t = 16384)]
    train: usize,
    /// Share of the SAH (surface-area ratio) in the node weight, in [0, 1]; the rest is the
    /// training rays' visit fraction (primary and diffuse, half each).
    #[arg(long, default_value_t = 0.2)]
    sah_mix: f64,
    /// Reinsertion budget of the ray-driven pass: batch,decay,iterations,min_gain
    /// (default: the thorough budget).
    #[arg(long)]
    budget: Option<String>,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON object per tree on stdout.
    #[arg(long)]
    json: bool,
}

/// One tree's record.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub scene: String,
    pub triangles: usize,
    pub tree: String,
    pub sah: f64,
    /// `Σ_inner w(box)` of the training objective, relative to the sweep tree's.
    pub train_objective_vs_sweep: f64,
    /// Seconds of the reinsertion pass (0 for sweep).
    pub reinsert_seconds: f64,
    /// Work per ray, `c_t · inner + c_i · triangles`, on the test primary rays (bvh2).
    pub primary_work: f64,
    /// The same on the test diffuse rays.
    pub diffuse_work: f64,
    /// The same on the training primary rays (the rays the objective saw).
    pub train_primary_work: f64,
    /// The same on the training diffuse rays.
    pub train_diffuse_work: f64,
    /// Work per ray of the bvh8 layout on the test primary rays.
    pub primary_work_bvh8: f64,
    /// The same on the test diffuse rays.
    pub diffuse_work_bvh8: f64,
}

fn parse_budget(s: &str) -> Result<ReinsertConfig> {
    let f: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .context("--budget: numbers batch,decay,iterations,min_gain")?;
    anyhow::ensure!(f.len() == 4, "--budget: batch,decay,iterations,min_gain");
    Ok(ReinsertConfig {
        batch_fraction: f[0],
        decay: f[1],
        max_iterations: f[2] as usize,
        min_gain: f[3],
        max_search_nodes: 0,
    })
}

/// Each ray of `rays` cut at its closest hit through `tracer`, every `step`-th ray only.
fn cut_at_hits(tracer: &dyn Tracer, rays: &[Ray], count: usize) -> Vec<Ray> {
    let step = (rays.len() / count.max(1)).max(1);
    let picked: Vec<Ray> = rays.iter().step_by(step).copied().collect();
    let hits = trace_closest(tracer, &picked);
    picked
        .into_iter()
        .zip(hits)
        .map(|(mut r, h)| {
            if h.is_hit() {
                r.tmax = h.t;
            }
            r
        })
        .collect()
}

/// Work per ray `c_t · inner + c_i · triangles` of `set` through `tracer`.
fn work(tracer: &dyn Tracer, set: &RaySet, cost: &CostModel) -> f64 {
    let c = trace_set_counted(tracer, set);
    let w = c.per_ray();
    cost.traversal as f64 * w.inner + cost.intersection as f64 * w.triangles
}

pub fn run(a: Args) -> Result<()> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&a.sah_mix),
        "--sah-mix must be in [0, 1]"
    );
    let budget = match &a.budget {
        Some(s) => parse_budget(s)?,
        None => ReinsertConfig::THOROUGH,
    };
    let catalog = sahara_scene::Catalog::discover();
    let mut rows = Vec::new();
    for name in &a.scenes {
        let scene = util::load_scene_from(&catalog, name)?;
        let tris = &scene.triangles;
        let cost = CostModel::default();
        let input = BuildInput::new(tris, cost)?;
        let sweep_builder = util::builder("sweep")?;
        let sweep = util::with_threads(a.threads, || sweep_builder.build(&input))??;
        let root = sweep.nodes[0].bounds();
        // Test rays: the scene's camera at the test resolution, diffuse with `seed`.
        let reference = Bvh2Tracer::new(&sweep, tris);
        let camera = scene.camera;
        let (test_p, test_d, train_p, train_d, train_sets) = util::with_threads(a.threads, || {
            let test_p = RaySet::primary(&camera, a.width, a.height);
            let hits = trace_closest(&reference, &test_p.rays);
            let test_d = RaySet::spawn(&test_p, &hits, RayKind::Diffuse, tris, a.seed);
            // Training rays: a jittered camera (the eye moved by 1 % of the scene's diagonal
            // across the view, another resolution), diffuse rays with another seed.
            let diag = (root.max - root.min).length();
            let c = &scene.camera;
            let frame = c.basis();
            let jitter = (frame.right * 0.8 + frame.up * 0.6) * (0.01 * diag);
            let train_cam = sahara_trace::Camera::new(
                c.eye + jitter,
                c.target + jitter * 0.5,
                c.up,
                c.fov_y_degrees,
            );
            let aspect = a.width as f64 / a.height as f64;
            let th = ((a.train as f64 / aspect).sqrt().ceil() as u32).max(1) + 1;
            let tw = ((th as f64 * aspect).round() as u32).max(1) + 1;
            let train_p = RaySet::primary(&train_cam, tw, th);
            let hits = trace_closest(&reference, &train_p.rays);
            let train_d = RaySet::spawn(
                &train_p,
                &hits,
                RayKind::Diffuse,
                tris,
                a.seed.wrapping_add(1),
            );
            let sp = SegmentSet::new(&cut_at_hits(&reference, &train_p.rays, a.train), &root);
            let sd = SegmentSet::new(&cut_at_hits(&reference, &train_d.rays, a.train), &root);
            (test_p, test_d, train_p, train_d, (sp, sd))
        })?;
        let (sp, sd) = &train_sets;
        let root_area = root.half_area().max(f32::MIN_POSITIVE) as f64;
        let mix = a.sah_mix;
        let weight = move |b: &Aabb| -> f64 {
            let rays = 0.5 * (sp.fraction(b) + sd.fraction(b));
            (1.0 - mix) * rays + mix * b.half_area() as f64 / root_area
        };
        let base_objective = reinsert::objective(&sweep, &weight);
        let mut trees: Vec<(String, Bvh, f64)> = vec![("sweep".into(), sweep.clone(), 0.0)];
        let t0 = Instant::now();
        let sah_tree = util::with_threads(a.threads, || {
            reinsert::optimize(&sweep, &cost, &ReinsertConfig::THOROUGH)
        })??;
        trees.push((
            "sweep+reinsert".into(),
            sah_tree,
            t0.elapsed().as_secs_f64(),
        ));
        let t0 = Instant::now();
        let (ray_tree, stats) = util::with_threads(a.threads, || {
            reinsert::optimize_for(&sweep, &weight, &budget)
        })??;
        let secs = t0.elapsed().as_secs_f64();
        if !a.json {
            eprintln!(
                "{name}: ray-driven pass: {} iterations, {} searches, {} moves, objective {:.6} -> {:.6} in {secs:.2} s",
                stats.iterations, stats.searches, stats.moves, stats.sah_before, stats.sah_after
            );
        }
        trees.push(("sweep+reinsert-rays".into(), ray_tree, secs));
        for (tree, bvh, secs) in &trees {
            bvh.validate(tris)
                .with_context(|| format!("{name}: {tree} is not valid"))?;
            let row = util::with_threads(a.threads, || {
                let b2 = Bvh2Tracer::new(bvh, tris);
                let b8 = sahara_trace::WideTracer::<8>::new(bvh, tris);
                Row {
                    scene: scene.name.clone(),
                    triangles: tris.len(),
                    tree: tree.clone(),
                    sah: sahara_metrics::sah(bvh, &cost),
                    train_objective_vs_sweep: reinsert::objective(bvh, &weight) / base_objective,
                    reinsert_seconds: *secs,
                    primary_work: work(&b2, &test_p, &cost),
                    diffuse_work: work(&b2, &test_d, &cost),
                    train_primary_work: work(&b2, &train_p, &cost),
                    train_diffuse_work: work(&b2, &train_d, &cost),
                    primary_work_bvh8: work(&b8, &test_p, &cost),
                    diffuse_work_bvh8: work(&b8, &test_d, &cost),
                }
            })?;
            if a.json {
                println!("{}", serde_json::to_string(&row)?);
            }
            rows.push(row);
        }
    }
    if !a.json {
        println!(
            "| scene | tree | SAH | train objective | reinsert s | primary work | diffuse work | \
             train primary | train diffuse | bvh8 primary | bvh8 diffuse |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|");
        for r in &rows {
            let base = rows
                .iter()
                .find(|x| x.scene == r.scene && x.tree == "sweep")
                .expect("sweep row");
            let rel = |v: f64, b: f64| format!("{v:.2} ({:+.1} %)", 100.0 * (v / b - 1.0));
            println!(
                "| {} | {} | {:.3} | {:.4} | {:.2} | {} | {} | {} | {} | {} | {} |",
                r.scene,
                r.tree,
                r.sah,
                r.train_objective_vs_sweep,
                r.reinsert_seconds,
                rel(r.primary_work, base.primary_work),
                rel(r.diffuse_work, base.diffuse_work),
                rel(r.train_primary_work, base.train_primary_work),
                rel(r.train_diffuse_work, base.train_diffuse_work),
                rel(r.primary_work_bvh8, base.primary_work_bvh8),
                rel(r.diffuse_work_bvh8, base.diffuse_work_bvh8),
            );
        }
    }
    Ok(())
}
