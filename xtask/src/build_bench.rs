//! `cargo xtask build-bench`: build times of sahara's builders and, with the `embree` feature,
//! of Embree's builder, alternating in one time window (docs/embree.md, "Build times").
//!
//! Every round builds each scene once with every engine, in an order rotated from round to
//! round, so that slow phases of a shared machine fall on every engine alike. A sahara build
//! is timed as `Builder::build` on a prepared `BuildInput` (as `cargo xtask bvh` does), and its
//! collapse to the 8-wide layout with 4-triangle leaf packets (`WideBvh::<8>::from_bvh`) is
//! timed separately; Embree's time is `rtcCommitScene`, which builds its 8-wide tree directly,
//! so the fair comparison is against sahara's build plus collapse (both are printed).
//!
//! After the timed rounds of a scene, one untimed build per engine measures its memory in
//! bytes per triangle (`docs/builders-classic.md`, "Build memory"): sahara's from the xtask's
//! counting allocator ([`crate::alloc_count`], always on, timed builds included: two relaxed
//! atomics per allocation), Embree's from its device's memory monitor callback, which is set
//! for the memory build only. The fields of [`BenchRow`] say what each figure counts.

use std::time::Instant;

use anyhow::{bail, Result};
use sahara_builders::simd::{self, BuildSimd};
use sahara_builders::{BuildInput, CostModel};
use serde::Serialize;

use crate::alloc_count;
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
    /// The build's peak memory in bytes per triangle, the figure comparable between the
    /// engines (from one untimed build after the timed rounds): sahara: the most heap bytes
    /// live at once from before `BuildInput::new` to the end of the collapse to bvh8, above
    /// what was live before (the input, the binary tree and the bvh8 with every temporary;
    /// `input_bytes_per_triangle` plus `peak_build_bvh8_bytes_per_triangle`); Embree: the most
    /// bytes its memory monitor saw live during `rtcCommitScene`, above its vertex and index
    /// buffers (its primitive references, the temporaries of its build and its tree). Neither
    /// counts the loaded scene's triangles nor Embree's copy of them in its buffers.
    pub peak_bytes_per_triangle: f64,
    /// Bytes per triangle of the finished traversal structure: sahara: the bvh8's nodes and
    /// leaf packets (`WideBvh::memory_bytes`); Embree: what its monitor saw live after
    /// `rtcCommitScene` above the buffers (nodes and leaves).
    pub structure_bytes_per_triangle: f64,
    /// Heap bytes per triangle of the `BuildInput` (primitive boxes and centroids; sahara
    /// only).
    pub input_bytes_per_triangle: Option<f64>,
    /// The most heap bytes per triangle live at once during `Builder::build`, above what was
    /// live before it (the scene and the `BuildInput` not counted): the build's working memory
    /// and the binary tree it returns (sahara only).
    pub peak_build_bytes_per_triangle: Option<f64>,
    /// As `peak_build_bytes_per_triangle`, over the build and the collapse of its tree to bvh8
    /// with leaf packets (the binary tree stays live during the collapse; sahara only).
    pub peak_build_bvh8_bytes_per_triangle: Option<f64>,
    /// Bytes per triangle of the binary tree the build returns (32-byte nodes and 4-byte
    /// references; sahara only).
    pub bvh2_bytes_per_triangle: Option<f64>,
    /// Bytes per triangle live in Embree's monitor before `rtcCommitScene`: its vertex and
    /// index buffers (Embree only).
    pub embree_buffer_bytes_per_triangle: Option<f64>,
    /// The most bytes per triangle Embree's monitor saw live at once, buffers included (the
    /// monitor's own peak over the scene's life; Embree only).
    pub embree_total_peak_bytes_per_triangle: Option<f64>,
}

/// The heap bytes of one sahara build and its collapse to bvh8, from the counting allocator
/// (see the fields of [`BenchRow`]).
#[derive(Clone, Copy, Debug, Default)]
struct SaharaMemory {
    input: usize,
    build: usize,
    build_bvh8: usize,
    bvh2: usize,
    bvh8: usize,
}

/// Builds `tris` with `builder` (in `pool`) once, from a new `BuildInput`, and collapses the
/// tree to bvh8, measuring the heap (process-wide: nothing else may run meanwhile).
fn sahara_memory(
    builder: &dyn sahara_builders::Builder,
    tris: &[sahara_geom::Triangle],
    cost: CostModel,
    pool: &rayon::ThreadPool,
) -> Result<SaharaMemory> {
    pool.install(|| {
        let before_input = alloc_count::reset_peak();
        let input = BuildInput::new(tris, cost)?;
        let base = alloc_count::reset_peak();
        let bvh = builder.build(&input)?;
        let build = alloc_count::peak().saturating_sub(base);
        let wide = sahara_traverse::wide::WideBvh::<8>::from_bvh(&bvh, tris);
        let build_bvh8 = alloc_count::peak().saturating_sub(base);
        Ok(SaharaMemory {
            input: base.saturating_sub(before_input),
            build,
            build_bvh8,
            bvh2: bvh.nodes.len() * std::mem::size_of::<sahara_bvh::Node>()
                + bvh.prim_indices.len() * std::mem::size_of::<u32>(),
            bvh8: wide.memory_bytes(),
        })
    })
}

/// One engine's memory figures on a scene, in bytes (not per triangle).
#[derive(Clone, Copy, Debug)]
enum Memory {
    Sahara(SaharaMemory),
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Embree {
        buffers: usize,
        commit_peak: usize,
        retained: usize,
    },
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

/// Embree's memory figures of one untimed build at `quality` (its device memory monitor,
/// `BuildTimer::measure_memory`).
#[cfg_attr(not(feature = "embree"), allow(unused_variables))]
fn embree_memory(
    timer: &Option<Timer>,
    tris: &[sahara_geom::Triangle],
    quality: u8,
) -> Result<Memory> {
    #[cfg(feature = "embree")]
    {
        let m = timer
            .as_ref()
            .expect("a timer when Embree is measured")
            .measure_memory(tris, quality)?;
        if m.left_after_release != 0 {
            eprintln!(
                "note: Embree's monitor counts {} bytes live after the scene's release",
                m.left_after_release
            );
        }
        Ok(Memory::Embree {
            buffers: m.scene_bytes,
            commit_peak: m.commit_peak_bytes,
            retained: m.retained_bytes,
        })
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
    memory: Option<Memory>,
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
        // Memory, untimed: one build per engine.
        for (e, s) in engines.iter().zip(samples.iter_mut()) {
            s.memory = Some(match e {
                BuildEngine::Sahara(_, b, level) => {
                    simd::set_max(*level);
                    Memory::Sahara(sahara_memory(b.as_ref(), tris, cost, &pool)?)
                }
                BuildEngine::Embree(_, q) => embree_memory(&timer, tris, *q)?,
            });
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
            let per = |bytes: usize| bytes as f64 / tris.len().max(1) as f64;
            let memory = s.memory.expect("measured above");
            let (peak, structure) = match memory {
                Memory::Sahara(m) => (m.input + m.build_bvh8, m.bvh8),
                Memory::Embree {
                    commit_peak,
                    retained,
                    ..
                } => (commit_peak, retained),
            };
            let sahara_memory = match memory {
                Memory::Sahara(m) => Some(m),
                Memory::Embree { .. } => None,
            };
            let embree_buffers = match memory {
                Memory::Embree { buffers, .. } => Some(buffers),
                Memory::Sahara(_) => None,
            };
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
                peak_bytes_per_triangle: per(peak),
                structure_bytes_per_triangle: per(structure),
                input_bytes_per_triangle: sahara_memory.map(|m| per(m.input)),
                peak_build_bytes_per_triangle: sahara_memory.map(|m| per(m.build)),
                peak_build_bvh8_bytes_per_triangle: sahara_memory.map(|m| per(m.build_bvh8)),
                bvh2_bytes_per_triangle: sahara_memory.map(|m| per(m.bvh2)),
                embree_buffer_bytes_per_triangle: embree_buffers.map(per),
                embree_total_peak_bytes_per_triangle: embree_buffers.map(|b| per(b + peak)),
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
    print_memory(&rows);
    Ok(())
}

/// The memory table: bytes per triangle of every engine on every scene.
fn print_memory(rows: &[BenchRow]) {
    println!();
    println!(
        "memory in bytes per triangle (one untimed build): sahara: heap above the scene, from \
         the counting allocator; Embree: its memory monitor, above its vertex and index buffers"
    );
    println!(
        "{:<18} {:<14} {:>8} {:>8} {:>11} {:>8} {:>10} {:>8} {:>11}",
        "scene",
        "engine",
        "input",
        "build",
        "build+bvh8",
        "peak",
        "structure",
        "buffers",
        "peak+buffers"
    );
    let f = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1}"));
    for r in rows {
        println!(
            "{:<18} {:<14} {:>8} {:>8} {:>11} {:>8.1} {:>10.1} {:>8} {:>11}",
            r.scene,
            r.engine,
            f(r.input_bytes_per_triangle),
            f(r.peak_build_bytes_per_triangle),
            f(r.peak_build_bvh8_bytes_per_triangle),
            r.peak_bytes_per_triangle,
            r.structure_bytes_per_triangle,
            f(r.embree_buffer_bytes_per_triangle),
            f(r.embree_total_peak_bytes_per_triangle),
        );
    }
    println!(
        "input: BuildInput; build, build+bvh8: peak above the input; peak: the comparable \
         figure (sahara: input + build+bvh8; Embree: peak of rtcCommitScene above its buffers); \
         structure: the finished bvh8 / Embree's retained tree"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_build_holds_at_least_its_trees() {
        let _only = alloc_count::MEASURING
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        let tris = sahara_scene::soup(20_000, 1).triangles();
        let pool = util::pool(Some(2)).unwrap();
        for name in ["binned", "sbvh"] {
            let b = util::builder(name).unwrap();
            let m = sahara_memory(b.as_ref(), &tris, CostModel::default(), &pool).unwrap();
            // Boxes and centroids: more than 24 bytes per triangle.
            assert!(m.input > 24 * tris.len(), "{name}: {m:?}");
            assert!(m.bvh2 > 0 && m.bvh8 > 0, "{name}: {m:?}");
            // The binary tree is live at the build's end, and still during the collapse; the
            // peak over the build and the collapse is at least the build's.
            assert!(m.build >= m.bvh2, "{name}: {m:?}");
            assert!(m.build_bvh8 >= m.bvh2 + m.bvh8, "{name}: {m:?}");
            assert!(m.build_bvh8 >= m.build, "{name}: {m:?}");
        }
    }
}
