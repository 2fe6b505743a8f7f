//! What a run of the evaluation produces (`results.json`, and everything the report is made
//! from): its settings and facts, each scene's entry, each trace row with its comparisons.

use crate::engine::{Engine, TraceReport};
use crate::interval;
use crate::tree::{self, BuildReport};
use serde::Serialize;

use super::{predict, saved_study};

/// Settings after defaults are applied.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    pub quick: bool,
    pub full: bool,
    pub scenes: Vec<String>,
    pub builders: Vec<String>,
    pub rays: Vec<String>,
    pub layouts: Vec<Engine>,
    /// The backend of the bvh4/bvh8 kernels (`--backend`), also matched by Embree's ISA.
    pub backend: String,
    pub width: u32,
    pub height: u32,
    pub passes: usize,
    /// Seconds of timed rounds per scene and ray type (0: always `passes` rounds).
    pub round_budget: f64,
    pub build_runs: usize,
    pub threads: usize,
    pub seed: u64,
    pub cost_model: sahara_metrics::CostModel,
}

/// Facts about the run, written into every report.
#[derive(Clone, Debug, Serialize)]
pub struct Meta {
    pub date: String,
    pub commit: String,
    pub cpu: String,
    pub simd: String,
    pub settings: Settings,
    pub seconds: f64,
}

/// One scene's entry in the results.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    pub name: String,
    pub triangles: usize,
    pub render: Option<String>,
    pub heat_maps: Vec<(String, String)>,
    /// The work per pixel at the top of every heat map's colour scale (shared by the scene's
    /// trees).
    pub heat_scale: f64,
    /// Per builder other than sweep: the image of its per-pixel work minus the sweep tree's
    /// (blue: less work than sweep, red: more).
    pub diff_maps: Vec<(String, String)>,
    /// The work difference per pixel at either end of the difference maps' colour scale.
    pub diff_scale: f64,
    /// The camera of the primary rays (`eye=… target=… up=… fov=…`).
    pub camera: String,
    /// Where it comes from (`generator`, `cameras.tsv`, `command line`, `placed (…)`, …).
    pub camera_source: String,
    /// Timed rounds per ray type (`primary`, …), fewer than `passes` where the round budget
    /// cut them.
    pub rounds: Vec<(String, usize)>,
}

/// A trace measurement with its comparisons.
#[derive(Clone, Debug, Serialize)]
pub struct TraceRow {
    #[serde(flatten)]
    pub report: TraceReport,
    /// Trace cost per ray in SAH units, `c_t · inner + c_i · triangles`.
    pub work_cost: f64,
    /// Speed relative to the sweep tree on the same rays and layout (> 1 is faster).
    pub speed_vs_sweep: Option<f64>,
    /// Work relative to the sweep tree (sweep work / this work; > 1 is less work).
    pub work_vs_sweep: Option<f64>,
    /// Speed relative to SBVH (spatial-split builders).
    pub speed_vs_sbvh: Option<f64>,
    /// Work relative to SBVH.
    pub work_vs_sbvh: Option<f64>,
    /// The seconds of each timed round (the rounds of every tree of the scene are
    /// interleaved, so round `i` of two rows was taken in the same time window).
    pub round_seconds: Vec<f64>,
    /// The 95% interval of `speed_vs_sweep` (median of per-round ratios, bootstrapped).
    pub speed_vs_sweep_ci: Option<interval::Interval>,
    /// The 95% interval of `speed_vs_sbvh`.
    pub speed_vs_sbvh_ci: Option<interval::Interval>,
}

/// Everything the report is made from (`results.json`).
#[derive(Clone, Debug, Serialize)]
pub struct Results {
    pub meta: Meta,
    pub scenes: Vec<SceneInfo>,
    /// Builders left out on scenes where they are impractical.
    pub skipped: Vec<String>,
    pub builds: Vec<BuildReport>,
    pub traces: Vec<TraceRow>,
    pub predictors: Vec<predict::PredictorRow>,
    pub predicted_points: Vec<predict::PredictedPoint>,
    pub scaling: Vec<tree::Series>,
    /// The study's claims table and its saved run (read from `docs/`, not recomputed).
    pub study: Option<saved_study::SavedStudy>,
}
