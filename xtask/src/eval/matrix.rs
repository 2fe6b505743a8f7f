//! The evaluation matrix as data: the scenes, builders and layouts of the quick, default and
//! full runs with their image sizes, rounds, builds and scaling sizes ([`QUICK`], [`DEFAULT`],
//! [`FULL`]), and the settings of a run derived from them and the flags
//! ([`Args::settings`](super::Args)).

use super::{Args, Settings, REFERENCE, SPATIAL_REFERENCE};
use crate::engine::Engine;
use crate::{tree, util};

/// The defaults of one kind of run: `--quick`, none or `--full`.
pub struct Matrix {
    /// Scenes (catalog names, `procedural:size`); `None`: one file per model of the catalog,
    /// then [`PROCEDURAL`] at their default sizes.
    pub scenes: Option<&'static [&'static str]>,
    /// Builders in report order (those the registry knows); `None`: every registered builder
    /// practical at any size.
    pub builders: Option<&'static [&'static str]>,
    /// Layouts (those this build has); `None`: every layout of this build.
    pub layouts: Option<&'static [Engine]>,
    /// Image width and height of the ray sets.
    pub width: u32,
    pub height: u32,
    /// Timed interleaved trace rounds.
    pub passes: usize,
    /// Seconds of timed rounds per scene and ray type (0: always `passes` rounds).
    pub round_budget: f64,
    /// Timed builds per builder (builds slower than 1 s run once).
    pub build_runs: usize,
    /// Triangle counts of the build-time-against-N section (procedural `soup`).
    pub scaling_sizes: &'static [usize],
    /// Timed builds per size, and the build time after which a builder's series stops.
    pub scaling_runs: usize,
    pub scaling_max_seconds: f64,
}

/// The default run: every scene, [`DEFAULT_BUILDERS`], [`DEFAULT_LAYOUTS`].
pub const DEFAULT: Matrix = Matrix {
    scenes: None,
    builders: Some(DEFAULT_BUILDERS),
    layouts: Some(DEFAULT_LAYOUTS),
    width: 320,
    height: 240,
    passes: 15,
    round_budget: 20.0,
    build_runs: 3,
    scaling_sizes: &[1_000, 10_000, 100_000],
    scaling_runs: 1,
    scaling_max_seconds: 5.0,
};

/// `--quick`: the default run made small (about two minutes on two cores): the procedural
/// scenes at small sizes, one preset of each strategy, smaller images, fewer rounds.
pub const QUICK: Matrix = Matrix {
    scenes: Some(&[
        "sphere_in_box:20000",
        "teapot_stadium:20000",
        "city:20000",
        "hairball:10000",
    ]),
    builders: Some(QUICK_BUILDERS),
    width: 256,
    height: 192,
    passes: 11,
    scaling_sizes: &[1_000, 4_000, 16_000],
    ..DEFAULT
};

/// `--full`: every registered builder, every layout, 1024×768, no round budget (over an
/// hour).
pub const FULL: Matrix = Matrix {
    scenes: None,
    builders: None,
    layouts: None,
    width: 1024,
    height: 768,
    passes: 11,
    round_budget: 0.0,
    build_runs: 5,
    scaling_sizes: &[1_000, 10_000, 100_000, 1_000_000],
    scaling_runs: 3,
    scaling_max_seconds: 300.0,
};

/// The procedural scenes of the default and full runs, after the catalog's files.
pub const PROCEDURAL: &[&str] = &["sphere_in_box", "teapot_stadium", "city", "hairball"];

/// The default matrix's builders, in report order: the references, the paper's builders,
/// and the best presets of other work (reinsertion, PLOC). A name joins the run only when the
/// registry knows it ([`sahara_builders::registry::by_name`]), so presets still under way on
/// other branches appear by themselves once registered. Chosen to fit 20 minutes on two
/// cores with the shared scenes (timings in `docs/evaluation.md`).
pub const DEFAULT_BUILDERS: &[&str] = &[
    "sweep",
    "sbvh",
    "binned",
    "tsah-topk",
    "hybrid",
    "tsah-sbvh",
    "ploc",
    "sweep+reinsert",
    "sbvh+reinsert",
    "tsah-topk+reinsert",
    "ploc+reinsert",
];

/// The quick matrix keeps one preset of each strategy.
pub const QUICK_BUILDERS: &[&str] = &["sweep", "sbvh", "binned", "tsah-topk", "hybrid"];

/// The layouts of the default and quick matrices: the binary kernel (the paper's comparison)
/// and the 8-wide one (the headline: what users run); `--full` traces every layout.
pub const DEFAULT_LAYOUTS: &[Engine] = &[
    Engine::Bvh2,
    Engine::Bvh8,
    Engine::Embree,
    Engine::Tinybvh,
    Engine::TinybvhHq,
    Engine::Obvhs,
];

impl Matrix {
    /// The matrix of a run.
    pub fn of(quick: bool, full: bool) -> &'static Matrix {
        if quick {
            &QUICK
        } else if full {
            &FULL
        } else {
            &DEFAULT
        }
    }

    /// The scenes of a run without `--scenes`.
    fn default_scenes(&self) -> Vec<String> {
        if let Some(s) = self.scenes {
            return s.iter().map(|s| s.to_string()).collect();
        }
        let catalog = sahara_scene::Catalog::discover();
        let mut v: Vec<String> = util::scene_files(&catalog)
            .into_iter()
            .map(|(name, _)| name)
            .collect();
        v.extend(PROCEDURAL.iter().map(|s| s.to_string()));
        v
    }

    /// The builders of a run without `--builders`. A listed name joins the run only when the
    /// registry knows it ([`sahara_builders::registry::by_name`]), so presets still under way
    /// on other branches appear by themselves once registered.
    fn default_builders(&self) -> Vec<String> {
        match self.builders {
            None => tree::builders_for_large_inputs(),
            Some(list) => list
                .iter()
                .filter(|n| sahara_builders::registry::by_name(n).is_some())
                .map(|n| n.to_string())
                .collect(),
        }
    }

    /// The layouts of a run without `--layouts`: those of this build, in [`Engine::ALL`]'s
    /// order.
    fn default_layouts(&self) -> Vec<Engine> {
        Engine::built()
            .into_iter()
            .filter(|l| self.layouts.is_none_or(|d| d.contains(l)))
            .collect()
    }
}

/// The layout whose speed the summary reports: `bvh8` when traced, else the first.
pub fn headline_layout(layouts: &[Engine]) -> Engine {
    layouts
        .iter()
        .find(|l| **l == Engine::Bvh8)
        .or(layouts.first())
        .copied()
        .unwrap_or(Engine::Bvh2)
}

/// True when `builder` splits triangles: the registry's `spatial` flag, or Embree's
/// spatial-split tree (`embree-high`, not a registry entry). An unknown name is not spatial
/// (it fails later, when it is built).
pub fn is_spatial(builder: &str) -> bool {
    builder == "embree-high"
        || sahara_builders::registry::entries()
            .iter()
            .any(|e| e.name == builder && e.spatial)
}

/// True when `builder` should be skipped on a scene of `triangles` (only for builders the
/// user did not name: a named builder always runs).
pub fn impractical(builder: &str, triangles: usize, named: bool) -> bool {
    !named
        && sahara_builders::registry::entries()
            .iter()
            .any(|e| e.name == builder && e.max_practical_triangles.is_some_and(|m| triangles > m))
}

impl Args {
    /// The backend of the run: `--backend`, else the best of this CPU.
    pub fn backend(&self) -> sahara_trace::Backend {
        self.backend.unwrap_or_else(sahara_trace::Backend::best)
    }

    /// The settings of the run: the flags, and the [`Matrix`] of the run where a flag is
    /// absent.
    pub fn settings(&self) -> Settings {
        let (q, full) = (self.quick, self.full);
        let m = Matrix::of(q, full);
        let mut builders = if self.builders.is_empty() {
            m.default_builders()
        } else {
            self.builders.clone()
        };
        // The references the run's comparisons need come first: `sweep` always, `sbvh` when a
        // spatial-split builder is in the run (only their "vs sbvh" figures use it).
        let needs_spatial = builders.iter().any(|b| is_spatial(b));
        for r in [SPATIAL_REFERENCE, REFERENCE] {
            let needed = r == REFERENCE || needs_spatial;
            if needed && !builders.iter().any(|b| b == r) {
                builders.insert(0, r.to_string());
            }
        }
        builders.sort_by_key(|b| (b != REFERENCE, b != SPATIAL_REFERENCE));
        Settings {
            quick: q,
            full,
            scenes: if self.scenes.is_empty() {
                m.default_scenes()
            } else {
                self.scenes.clone()
            },
            builders,
            rays: self.rays.clone(),
            layouts: if self.layouts.is_empty() {
                m.default_layouts()
            } else {
                self.layouts.clone()
            },
            backend: self.backend().name().to_string(),
            width: self.width.unwrap_or(m.width),
            height: self.height.unwrap_or(m.height),
            passes: self.passes.unwrap_or(m.passes),
            round_budget: self.round_budget.unwrap_or(m.round_budget),
            build_runs: self.build_runs.unwrap_or(m.build_runs),
            threads: util::thread_count(self.threads),
            seed: self.seed,
            cost_model: sahara_metrics::CostModel::default(),
        }
    }
}

#[cfg(test)]
mod reference_tests {
    use super::super::Args;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        eval: Args,
    }

    fn builders(args: &[&str]) -> Vec<String> {
        let cli = Cli::parse_from(std::iter::once("eval").chain(args.iter().copied()));
        cli.eval.settings().builders
    }

    /// `sweep` joins every run first; `sbvh` only runs with a spatial-split builder to compare.
    #[test]
    fn the_spatial_reference_joins_only_runs_with_spatial_builders() {
        assert_eq!(builders(&["--builders", "binned"]), ["sweep", "binned"]);
        assert_eq!(
            builders(&["--builders", "ploc,tsah-topk"]),
            ["sweep", "ploc", "tsah-topk"]
        );
        assert_eq!(
            builders(&["--builders", "tsah-sbvh"]),
            ["sweep", "sbvh", "tsah-sbvh"]
        );
        assert_eq!(
            builders(&["--builders", "binned,sbvh+reinsert"]),
            ["sweep", "sbvh", "binned", "sbvh+reinsert"]
        );
        assert_eq!(builders(&["--builders", "sbvh,sweep"]), ["sweep", "sbvh"]);
        let default = builders(&[]);
        assert_eq!(&default[..2], ["sweep", "sbvh"], "{default:?}");
    }
}
