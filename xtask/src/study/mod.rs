//! `cargo xtask study`: the sensitivity study of issue 15. Why do the temporary-subtree
//! builders of Wodniok & Goesele save a few percent of work per ray against full-sweep SAH on
//! our scenes where the paper reports up to 37%?
//!
//! One factor varies at a time (cost constants, leaf policy, candidate breadth, where the rule
//! applies, temporary quality, camera; every row also carries the bvh8 kernel's work), and
//! every setting is compared with the reference tree built **under the same settings** (the
//! sweep tree with the same cost model and leaf size; SBVH for the spatial variant). Work per
//! ray, `c_t · inner nodes + c_i · triangles` with the setting's own cost model, is counted
//! exactly and is the primary, noise-free column; SAH, EPO and build time come with every row;
//! `--speed` adds measured speed ratios (median of per-round ratios of interleaved rounds, with
//! 95% bootstrap intervals; an undecided cell is rerun with more rounds, see `measure::needs_more_rounds`).
//!
//! Results go to a folder (default `docs/results/<date>-study/`, quick runs
//! `docs/results/<date>-study-quick/`): `study.csv`, one row per scene and setting, and
//! `README.md`, rendered from the CSV alone by [`render_markdown`] (the eval report can call it
//! on the latest saved CSV instead of rerunning the study; `--render <csv>` re-renders), and
//! `claims.md`, the paper's claims against the study's figures, rendered from the CSV alone by
//! [`render_claims`] (the claims table of `docs/study.md`).
//!
//! The modules: `settings.rs` (every setting of every factor, as data), `measure.rs` (trees,
//! work per ray, speed cells, cameras), `render.rs` (the README's tables), `claims.rs` (the
//! claims table).

mod claims;
mod measure;
mod render;
mod settings;

pub use claims::render_claims;
pub use render::render_markdown;

use crate::util;
use anyhow::{Context, Result};
use measure::{build, inside, outside_camera, speed, work, SpeedCell, Tree, KINDS, LAYOUTS};
use sahara_trace::RaySet;
use settings::{settings, CameraKind, Setting, FACTORS};
use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// Command-line arguments of `cargo xtask study`.
#[derive(clap::Args, Clone)]
pub struct Args {
    /// Small study: procedural scenes at small sizes, a few levels of each factor (≤ 5 min).
    #[arg(long)]
    pub quick: bool,
    /// Scenes (catalog names or `procedural:size`; default: every shared scene file plus
    /// hairball, city and teapot_stadium; quick: the procedural ones at 20k/10k triangles).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Factors to run (default all): cost, leaf, breadth, where, temporary, camera, reinsert,
    /// combined.
    #[arg(long, value_delimiter = ',')]
    pub factors: Vec<String>,
    /// Measure speed (bvh2 and bvh8) against the reference in interleaved rounds. The full
    /// study does by default; `--quick` only with this flag.
    #[arg(long)]
    pub speed: bool,
    /// Skip the speed measurement (work per ray, SAH, EPO and build time only).
    #[arg(long, conflicts_with = "speed")]
    pub no_speed: bool,
    /// Timed rounds per speed cell (default 5, quick 3).
    #[arg(long)]
    pub rounds: Option<usize>,
    /// Output folder (default docs/results/<date>-study[-quick]).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Image width of the ray sets (default 384, quick 192).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 288, quick 144).
    #[arg(long)]
    pub height: Option<u32>,
    /// Seed of the secondary rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Skip settings whose builder is slow on scenes above this many triangles (exhaustive
    /// candidates, exact SBVH temporaries, k = 8). Default 150000.
    #[arg(long, default_value_t = 150_000)]
    pub heavy_limit: usize,
    /// Only re-render the markdown of an existing study.csv (written next to it).
    #[arg(long)]
    pub render: Option<PathBuf>,
}

fn default_scenes(quick: bool) -> Vec<String> {
    if quick {
        return ["teapot_stadium:20000", "city:20000", "hairball:2000"]
            .map(String::from)
            .to_vec();
    }
    let mut files = util::scene_files(&sahara_scene::Catalog::discover());
    // Smallest first, so that a run cut short has covered the most scenes.
    files.sort_by_key(|(_, triangles)| triangles.unwrap_or(0));
    let mut v: Vec<String> = files.into_iter().map(|(name, _)| name).collect();
    v.extend(["teapot_stadium", "city", "hairball"].map(String::from));
    v
}

/// The CSV columns, in order.
const COLUMNS: &[&str] = &[
    "scene",
    "triangles",
    "factor",
    "builder",
    "level",
    "reference",
    "c_t",
    "c_i",
    "camera",
    "camera_inside",
    "build_s",
    "ref_build_s",
    "sah",
    "ref_sah",
    "epo",
    "ref_epo",
    "work_bvh2_primary",
    "ref_work_bvh2_primary",
    "work_bvh2_diffuse",
    "ref_work_bvh2_diffuse",
    "work_bvh2_ao",
    "ref_work_bvh2_ao",
    "work_bvh8_primary",
    "ref_work_bvh8_primary",
    "work_bvh8_diffuse",
    "ref_work_bvh8_diffuse",
    "work_bvh8_ao",
    "ref_work_bvh8_ao",
    "speed_bvh2_primary",
    "speed_bvh2_diffuse",
    "speed_bvh2_ao",
    "speed_bvh8_primary",
    "speed_bvh8_diffuse",
    "speed_bvh8_ao",
    "speed_bvh2_primary_low",
    "speed_bvh2_primary_high",
    "speed_bvh2_diffuse_low",
    "speed_bvh2_diffuse_high",
    "speed_bvh2_ao_low",
    "speed_bvh2_ao_high",
    "speed_bvh8_primary_low",
    "speed_bvh8_primary_high",
    "speed_bvh8_diffuse_low",
    "speed_bvh8_diffuse_high",
    "speed_bvh8_ao_low",
    "speed_bvh8_ao_high",
    "speed_rounds",
];

fn csv_field(s: &str) -> String {
    s.replace([',', '\n'], ";")
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.6}")).unwrap_or_default()
}

/// One line of `study.csv`: a setting on a scene, with its tree's and its reference's figures.
struct Line<'a> {
    scene: &'a str,
    triangles: usize,
    setting: &'a Setting,
    eye_inside: bool,
    tree: &'a Tree,
    reference: &'a Tree,
    /// Work per ray per (layout, ray kind), of the tree and of the reference.
    work: &'a [f64],
    ref_work: &'a [f64],
    /// Speed cells per (layout, ray kind), when the study measures speed.
    speed: Option<&'a [SpeedCell]>,
}

impl Line<'_> {
    /// The line in the order of [`COLUMNS`], with its newline.
    fn csv(&self) -> String {
        let mut row = vec![
            csv_field(self.scene),
            self.triangles.to_string(),
            self.setting.factor.to_string(),
            self.setting.builder.to_string(),
            csv_field(self.setting.level),
            csv_field(&self.setting.reference.name()),
            self.setting.cost.traversal.to_string(),
            self.setting.cost.intersection.to_string(),
            self.setting.camera.name().to_string(),
            self.eye_inside.to_string(),
            format!("{:.4}", self.tree.build_s),
            format!("{:.4}", self.reference.build_s),
            format!("{:.6}", self.tree.sah),
            format!("{:.6}", self.reference.sah),
            format!("{:.6}", self.tree.epo),
            format!("{:.6}", self.reference.epo),
        ];
        for i in 0..6 {
            row.push(format!("{:.6}", self.work[i]));
            row.push(format!("{:.6}", self.ref_work[i]));
        }
        for i in 0..6 {
            row.push(fmt_opt(self.speed.map(|v| v[i].interval.estimate)));
        }
        for i in 0..6 {
            row.push(fmt_opt(self.speed.map(|v| v[i].interval.low)));
            row.push(fmt_opt(self.speed.map(|v| v[i].interval.high)));
        }
        row.push(
            self.speed
                .map(|v| v.iter().map(|c| c.rounds).max().unwrap_or(0).to_string())
                .unwrap_or_default(),
        );
        row.join(",") + "\n"
    }
}

/// Runs the study.
pub fn run(a: Args) -> Result<()> {
    if let Some(csv) = &a.render {
        let text =
            std::fs::read_to_string(csv).with_context(|| format!("reading {}", csv.display()))?;
        let md = render_markdown(&text)?;
        let out = csv.with_file_name("README.md");
        std::fs::write(&out, md)?;
        println!("rendered {}", out.display());
        let claims = csv.with_file_name("claims.md");
        std::fs::write(&claims, render_claims(&text)?)?;
        println!("rendered {}", claims.display());
        return Ok(());
    }
    let t0 = Instant::now();
    let q = a.quick;
    let (width, height) = (
        a.width.unwrap_or(if q { 192 } else { 384 }),
        a.height.unwrap_or(if q { 144 } else { 288 }),
    );
    let rounds = a.rounds.unwrap_or(if q { 3 } else { 5 });
    let measure_speed = if q { a.speed } else { !a.no_speed };
    let factors: Vec<String> = if a.factors.is_empty() {
        FACTORS.iter().map(|s| s.to_string()).collect()
    } else {
        a.factors.clone()
    };
    let mut plan = Vec::new();
    for f in &factors {
        plan.extend(settings(f, q)?);
    }
    let scenes = if a.scenes.is_empty() {
        default_scenes(q)
    } else {
        a.scenes.clone()
    };
    let suffix = if a.quick { "-study-quick" } else { "-study" };
    let out = util::out_dir(
        a.out.as_deref(),
        "docs/results",
        &format!("{}{suffix}", util::utc_date()),
    );
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let csv_path = out.join("study.csv");
    let mut csv = COLUMNS.join(",") + "\n";
    std::fs::write(&csv_path, &csv)?;
    let catalog = sahara_scene::Catalog::discover();
    for scene_name in &scenes {
        let scene = match util::load_scene_from(&catalog, scene_name) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping scene {scene_name}: {e:#}");
                continue;
            }
        };
        let tris = &scene.triangles;
        let n = tris.len();
        eprintln!(
            "[{:>6.0} s] {} ({n} triangles)",
            t0.elapsed().as_secs_f64(),
            scene.name
        );
        // Reference trees by (reference, cost), candidate trees by (description, cost),
        // ray sets by camera, reference work by (reference, cost, camera).
        let mut refs: HashMap<String, Tree> = HashMap::new();
        let mut cands: HashMap<String, (Tree, String)> = HashMap::new();
        let mut sets: HashMap<CameraKind, (Vec<RaySet>, bool)> = HashMap::new();
        let mut ref_work: HashMap<String, Vec<f64>> = HashMap::new();
        // Speed cells by (candidate, reference, camera): a tree shared by several rows
        // (tsah-topk appears in most factors) is timed once.
        let mut speeds: HashMap<String, Vec<SpeedCell>> = HashMap::new();
        for s in &plan {
            if s.heavy && n > a.heavy_limit {
                eprintln!(
                    "  skip {} / {} / {} (heavy above {} triangles)",
                    s.factor, s.builder, s.level, a.heavy_limit
                );
                continue;
            }
            let cost_key = format!("{}/{}", s.cost.traversal, s.cost.intersection);
            let rkey = format!("{} {cost_key}", s.reference.name());
            if let Entry::Vacant(slot) = refs.entry(rkey.clone()) {
                slot.insert(build(
                    s.reference.builder().as_ref(),
                    tris,
                    s.cost,
                    a.threads,
                )?);
            }
            if let Entry::Vacant(slot) = sets.entry(s.camera) {
                let reference = &refs[&rkey];
                let tracer = sahara_trace::Bvh2Tracer::new(&reference.bvh, tris);
                let camera = match s.camera {
                    CameraKind::Catalog => scene.camera,
                    CameraKind::Outside => outside_camera(tris, &scene.camera),
                };
                let eye_inside = inside(tris, camera.eye);
                let v = util::with_threads(a.threads, || {
                    KINDS
                        .iter()
                        .map(|&k| {
                            RaySet::generate(k, &camera, width, height, &tracer, tris, a.seed)
                        })
                        .collect::<Vec<_>>()
                })?;
                slot.insert((v, eye_inside));
            }
            let builder = s.make.builder(n);
            let ckey = format!("{} {cost_key}", builder.describe());
            let t_build = Instant::now();
            if let Entry::Vacant(slot) = cands.entry(ckey.clone()) {
                let t = build(builder.as_ref(), tris, s.cost, a.threads)?;
                slot.insert((t, builder.describe()));
            }
            let (set, eye_inside) = &sets[&s.camera];
            let reference = &refs[&rkey];
            let wkey = format!("{rkey} {}", s.camera.name());
            if let Entry::Vacant(slot) = ref_work.entry(wkey.clone()) {
                slot.insert(work(reference, tris, set, s.cost, a.threads)?);
            }
            let (tree, _) = &cands[&ckey];
            let w = work(tree, tris, set, s.cost, a.threads)?;
            let rw = &ref_work[&wkey];
            let sp = if measure_speed {
                let skey = format!("{ckey} | {wkey}");
                if let Entry::Vacant(slot) = speeds.entry(skey.clone()) {
                    slot.insert(if tree.bvh == reference.bvh {
                        // The same tree: the ratio is 1 by definition, nothing to time.
                        vec![SpeedCell::IDENTICAL; LAYOUTS.len() * set.len()]
                    } else {
                        speed(tree, reference, tris, set, rounds, a.threads)?
                    });
                }
                Some(speeds[&skey].clone())
            } else {
                None
            };
            let line = Line {
                scene: &scene.name,
                triangles: n,
                setting: s,
                eye_inside: *eye_inside,
                tree,
                reference,
                work: &w,
                ref_work: rw,
                speed: sp.as_deref(),
            }
            .csv();
            csv.push_str(&line);
            std::fs::write(&csv_path, &csv)?;
            eprintln!(
                "  {:>9} {:<11} {:<44} SAH {:.3}  primary {:.3} diffuse {:.3} ao {:.3} (bvh8 {:.3})  {:.1} s",
                s.factor,
                s.builder,
                s.level,
                reference.sah / tree.sah,
                rw[0] / w[0],
                rw[1] / w[1],
                rw[2] / w[2],
                rw[3] / w[3],
                t_build.elapsed().as_secs_f64()
            );
        }
    }
    let mut md = render_markdown(&csv)?;
    let _ = write!(
        md,
        "\n---\n\nRun: `cargo xtask study{}` at commit `{}` on {} ({} threads), rays {width}×{height} per \
         camera, seed {}, {:.0} s in all.\n",
        if q { " --quick" } else { "" },
        util::git_commit(),
        util::cpu_name(),
        util::thread_count(a.threads),
        a.seed,
        t0.elapsed().as_secs_f64()
    );
    std::fs::write(out.join("README.md"), md)?;
    std::fs::write(out.join("claims.md"), render_claims(&csv)?)?;
    println!(
        "study written to {} ({:.0} s)",
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_factor_has_settings() {
        for f in FACTORS {
            assert!(!settings(f, true).unwrap().is_empty());
            assert!(!settings(f, false).unwrap().is_empty());
        }
        assert!(settings("nope", true).is_err());
    }
}
