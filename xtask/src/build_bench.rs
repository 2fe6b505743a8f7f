//! `cargo xtask build-bench`: build times of sahara's builders and, with the `embree` feature,
//! of Embree's builder, alternating in one time window (docs/embree.md, "Build times").
//!
//! Every round builds each scene once with every engine, in an order rotated from round to
//! round, so that slow phases of a shared machine fall on every engine alike. A sahara build
//! is timed as `Builder::build` on a prepared `BuildInput` (as `cargo xtask bvh` does), and its
//! collapse to the 8-wide layout with 4-triangle leaf packets (`WideBvh::<8>::from_bvh`) is
//! timed separately; Embree's time is `rtcCommitScene`, which builds its 8-wide tree directly,
//! so the fair comparison is against sahara's build plus collapse (both are printed).

use std::time::Instant;

use anyhow::{bail, Result};
use sahara_builders::simd::{self, BuildSimd};
use sahara_builders::{BuildInput, CostModel};
use serde::Serialize;

use crate::util::{self, Spread};

#[derive(clap::Args)]
pub struct Args {
    /// Comma-separated scene names (catalog names or paths).
    #[arg(long, value_delimiter = ',', default_value = "sponza_dabrovic,sibenik")]
    scenes: Vec<String>,
    /// Comma-separated registered builder names. `name@level` builds with the builders' SIMD
    /// capped at `level` (`baseline`, `avx2`, `avx512`; `sahara_builders::simd`), to time the
    /// backends side by side: the trees are the same.
    #[arg(long, value_delimiter = ',', default_value = "binned,sweep,sbvh")]
    builders: Vec<String>,
    /// Comma-separated Embree build qualities to time as well (`low`, `medium`, `high`);
    /// needs the `embree` feature.
    #[arg(long, value_delimiter = ',')]
    embree: Vec<String>,
    /// Rounds (each engine builds each scene once per round).
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Threads of sahara's rayon pool and of Embree's device (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print one JSON record per scene and engine instead of the table.
    #[arg(long)]
    json: bool,
}

/// One engine's figures on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub triangles: usize,
    /// A sahara builder's registry name, or `embree-medium` etc.
    pub engine: String,
    pub threads: usize,
    pub rounds: usize,
    /// Build time in ms (sahara: `Builder::build`; Embree: `rtcCommitScene`).
    pub build_ms: Spread,
    /// Collapse to bvh8 with its leaf packets, in ms (sahara only).
    pub collapse_bvh8_ms: Option<Spread>,
    /// Build plus collapse, per round, in ms (sahara only).
    pub total_ms: Option<Spread>,
    /// SAH of the binary tree (sahara only).
    pub sah: Option<f64>,
    /// Per-round ratio of this engine's time (sahara: build + collapse) to each Embree
    /// quality's, as `(quality, spread)`.
    pub ratios: Vec<(String, Spread)>,
}

/// What builds a scene in a round: one of sahara's builders (with its SIMD cap) or Embree at
/// one quality (not a tracing engine: those are `crate::engine::Engine`).
enum BuildEngine {
    /// Name as given, builder, SIMD cap.
    Sahara(String, Box<dyn sahara_builders::Builder>, BuildSimd),
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Embree(String, u8),
}

impl BuildEngine {
    fn name(&self) -> String {
        match self {
            BuildEngine::Sahara(n, ..) => n.clone(),
            BuildEngine::Embree(q, _) => format!("embree-{q}"),
        }
    }
}

#[cfg(feature = "embree")]
type Timer = crate::engine::embree::BuildTimer;
#[cfg(not(feature = "embree"))]
type Timer = ();

fn embree_timer(threads: usize, wanted: bool) -> Result<Option<Timer>> {
    if !wanted {
        return Ok(None);
    }
    #[cfg(feature = "embree")]
    {
        Ok(Some(crate::engine::embree::BuildTimer::new(threads)?))
    }
    #[cfg(not(feature = "embree"))]
    {
        let _ = threads;
        bail!(
            "built without the `embree` feature: run `cargo run --release -p xtask --features \
             embree -- build-bench ...` (docs/embree.md)"
        )
    }
}

#[cfg_attr(not(feature = "embree"), allow(unused_variables))]
fn time_embree(timer: &Option<Timer>, tris: &[sahara_geom::Triangle], quality: u8) -> Result<f64> {
    #[cfg(feature = "embree")]
    {
        timer
            .as_ref()
            .expect("a timer when Embree is timed")
            .time_build(tris, quality)
    }
    #[cfg(not(feature = "embree"))]
    {
        bail!("built without the `embree` feature")
    }
}

#[cfg(feature = "embree")]
fn quality_of(name: &str) -> Result<u8> {
    crate::engine::embree::parse_quality(name)
}

#[cfg(not(feature = "embree"))]
fn quality_of(name: &str) -> Result<u8> {
    Ok(match name {
        "low" => 0,
        "medium" => 1,
        "high" => 2,
        other => bail!("Embree build quality '{other}' is not low, medium or high"),
    })
}

/// Per-engine samples of one scene.
#[derive(Default, Clone)]
struct Samples {
    build: Vec<f64>,
    collapse: Vec<f64>,
    sah: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let mut engines: Vec<BuildEngine> = Vec::new();
    for b in &a.builders {
        let (name, level) = match b.split_once('@') {
            Some((name, level)) => {
                let Some(l) = BuildSimd::from_name(level) else {
                    bail!("unknown SIMD level {level:?} (baseline, avx2, avx512)");
                };
                if l > BuildSimd::detected() {
                    bail!(
                        "this CPU does not run {l} (best: {})",
                        BuildSimd::detected()
                    );
                }
                (name, l)
            }
            None => (b.as_str(), BuildSimd::Avx512),
        };
        engines.push(BuildEngine::Sahara(b.clone(), util::builder(name)?, level));
    }
    for q in &a.embree {
        engines.push(BuildEngine::Embree(q.to_ascii_lowercase(), quality_of(q)?));
    }
    if engines.is_empty() {
        bail!("nothing to time: give --builders and/or --embree");
    }
    // One pool for every sahara build of the run (Embree, too, keeps its threads).
    let pool = util::pool(a.threads)?;
    let threads = pool.current_num_threads();
    let timer = embree_timer(threads, !a.embree.is_empty())?;
    let rounds = a.rounds.max(1);
    let cost = CostModel::default();
    let mut rows = Vec::new();
    for scene_name in &a.scenes {
        let scene = util::load_scene(scene_name)?;
        let tris = &scene.triangles;
        let input = BuildInput::new(tris, cost)?;
        let mut samples = vec![Samples::default(); engines.len()];
        // A warm-up build of every engine (page faults, Embree's thread start-up).
        for (e, s) in engines.iter().zip(samples.iter_mut()) {
            match e {
                BuildEngine::Sahara(_, b, level) => {
                    simd::set_max(*level);
                    let bvh = pool.install(|| b.build(&input))?;
                    s.sah = Some(sahara_metrics::sah(&bvh, &cost));
                }
                BuildEngine::Embree(_, q) => {
                    time_embree(&timer, tris, *q)?;
                }
            }
        }
        for round in 0..rounds {
            for i in 0..engines.len() {
                let idx = (i + round) % engines.len();
                match &engines[idx] {
                    BuildEngine::Sahara(_, b, level) => {
                        simd::set_max(*level);
                        let (build, collapse) = pool.install(|| {
                            let t0 = Instant::now();
                            let bvh = b.build(&input);
                            let build = t0.elapsed().as_secs_f64();
                            let bvh = bvh?;
                            let t1 = Instant::now();
                            let wide = sahara_traverse::wide::WideBvh::<8>::from_bvh(&bvh, tris);
                            let collapse = t1.elapsed().as_secs_f64();
                            drop(wide);
                            anyhow::Ok((build, collapse))
                        })?;
                        samples[idx].build.push(build * 1e3);
                        samples[idx].collapse.push(collapse * 1e3);
                    }
                    BuildEngine::Embree(_, q) => {
                        let t = time_embree(&timer, tris, *q)?;
                        samples[idx].build.push(t * 1e3);
                    }
                }
            }
            eprintln!("{}: round {}/{rounds}", scene.name, round + 1);
        }
        let embree_idx: Vec<usize> = (0..engines.len())
            .filter(|&i| matches!(engines[i], BuildEngine::Embree(..)))
            .collect();
        for (i, e) in engines.iter().enumerate() {
            let s = &samples[i];
            let total: Vec<f64> = if s.collapse.is_empty() {
                s.build.clone()
            } else {
                s.build
                    .iter()
                    .zip(&s.collapse)
                    .map(|(b, c)| b + c)
                    .collect()
            };
            let ratios = embree_idx
                .iter()
                .filter(|&&j| j != i)
                .map(|&j| {
                    let r: Vec<f64> = total
                        .iter()
                        .zip(&samples[j].build)
                        .map(|(t, e)| t / e)
                        .collect();
                    (engines[j].name(), Spread::of(&r))
                })
                .collect();
            let sahara = matches!(e, BuildEngine::Sahara(..));
            rows.push(BenchRow {
                scene: scene.name.clone(),
                triangles: tris.len(),
                engine: e.name(),
                threads,
                rounds,
                build_ms: Spread::of(&s.build),
                collapse_bvh8_ms: sahara.then(|| Spread::of(&s.collapse)),
                total_ms: sahara.then(|| Spread::of(&total)),
                sah: s.sah,
                ratios,
            });
        }
    }
    if a.json {
        for r in &rows {
            println!("{}", serde_json::to_string(r)?);
        }
        return Ok(());
    }
    println!(
        "{} rounds, {threads} threads, {}; times in ms: median (min-max)",
        rounds,
        util::cpu_name()
    );
    let f = |s: &Spread| format!("{:.1} ({:.1}-{:.1})", s.median, s.min, s.max);
    println!(
        "{:<18} {:<14} {:>24} {:>22} {:>24}  ratios of build+collapse to Embree (median of rounds)",
        "scene", "engine", "build", "collapse bvh8", "build+collapse"
    );
    for r in &rows {
        let ratios: Vec<String> = r
            .ratios
            .iter()
            .map(|(n, s)| format!("{n} {:.2}x ({:.2}-{:.2})", s.median, s.min, s.max))
            .collect();
        println!(
            "{:<18} {:<14} {:>24} {:>22} {:>24}  {}",
            r.scene,
            r.engine,
            f(&r.build_ms),
            r.collapse_bvh8_ms.as_ref().map_or("-".into(), f),
            r.total_ms.as_ref().map_or("-".into(), f),
            ratios.join(", ")
        );
    }
    Ok(())
}
