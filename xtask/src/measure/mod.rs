//! `cargo xtask measure <what>`: the measurement harnesses whose figures the documents quote,
//! one subcommand each (until issue 15 they were `#[ignore]`d tests steered by environment
//! variables; the flags replace the variables, with the same defaults):
//!
//! * [`tsah`]: `presets`, `knobs`, `dragon`, `configs`, `popov-configs`: build time, CPU time,
//!   SAH (and EPO) of the sweep, temporary-subtree and look-ahead builders against the sweep
//!   tree (`docs/builders-tsah.md`);
//! * [`sbvh`]: `sbvh` (registered builders: build time, SAH, references, depth) and
//!   `tsah-spatial` (the spatial temporary-subtree builder's knobs against SBVH;
//!   `docs/builders-classic.md`);
//! * [`kernels`]: `wide-bench` (every kernel and backend on one thread, primary rays of the
//!   bunny) and `kernels` (bvh2, bvh4 and bvh8 on a ray set or ray file in interleaved rounds;
//!   `crates/traverse/README.md`, `docs/embree.md`);
//! * [`oracle`]: `oracle` (the exact oracle's build and query speed, `crates/oracle/README.md`).
//!
//! Scenes are catalog names, `procedural:size` or paths, loaded by [`util::load_scene_from`];
//! a scene that is missing or fails to load is skipped with a message. Tables go to standard
//! output as rows are measured (with `--json`, one JSON record per row instead), progress and
//! notes to standard error.

mod kernels;
mod oracle;
mod sbvh;
mod tsah;

use crate::util;
use anyhow::{Context, Result};
use sahara_builders::{BuildError, Bvh};
use sahara_geom::Triangle;
use serde::Serialize;
use std::path::PathBuf;

/// Command-line arguments of `cargo xtask measure`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

/// The harnesses.
#[derive(clap::Subcommand)]
pub enum What {
    /// Registered presets on the shared scenes: build time, CPU time, SAH (and EPO) against
    /// sweep.
    Presets(tsah::PresetsArgs),
    /// The temporary-subtree builder's knobs (k, per-axis candidates, greedy threshold, binned
    /// candidates and temporaries) against sweep.
    Knobs(tsah::KnobsArgs),
    /// The 871k-triangle Stanford dragon with the sweep and top-k presets.
    Dragon(tsah::DragonArgs),
    /// Temporary-subtree configurations given as a JSON array of `TsahConfig`, against sweep.
    Configs(tsah::ConfigsArgs),
    /// Look-ahead configurations given as a JSON array of `PopovConfig`, against sweep.
    PopovConfigs(tsah::PopovConfigsArgs),
    /// Registered builders (binned, sweep, SBVH, ...): best build time, SAH, references, depth.
    Sbvh(sbvh::SbvhArgs),
    /// The spatial temporary-subtree builder's configurations against SBVH.
    TsahSpatial(sbvh::TsahSpatialArgs),
    /// Single-thread speed of every kernel and backend on a scene's primary rays (the bunny by
    /// default), closest and any hit, with the work per ray.
    WideBench(kernels::WideBenchArgs),
    /// Single-thread speed of bvh2, bvh4 and bvh8 on a ray set or a ray file, timed in
    /// interleaved rounds, with the work per ray.
    Kernels(kernels::KernelsArgs),
    /// The exact oracle's speed: its BVH build, candidates and judgements per ray, one exact
    /// test.
    Oracle(oracle::OracleArgs),
}

pub fn run(a: Args) -> Result<()> {
    match a.what {
        What::Presets(a) => tsah::presets(&a).map(drop),
        What::Knobs(a) => tsah::knobs(&a).map(drop),
        What::Dragon(a) => tsah::dragon(&a).map(drop),
        What::Configs(a) => tsah::configs(&a).map(drop),
        What::PopovConfigs(a) => tsah::popov_configs(&a).map(drop),
        What::Sbvh(a) => sbvh::sbvh(&a).map(drop),
        What::TsahSpatial(a) => sbvh::tsah_spatial(&a).map(drop),
        What::WideBench(a) => kernels::wide_bench(&a).map(drop),
        What::Kernels(a) => kernels::kernels(&a).map(drop),
        What::Oracle(a) => oracle::oracle(&a).map(drop),
    }
}

/// The options every scene harness takes.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Common {
    /// Take scene files from this folder only (procedural scenes and paths still work),
    /// instead of the catalog's folders (`scenes/`, `$SAHARA_SCENES`, `../shared/scenes`).
    #[arg(long)]
    pub scene_dir: Option<PathBuf>,
    /// Print one JSON record per row on standard output instead of the table.
    #[arg(long)]
    pub json: bool,
}

impl Common {
    /// The catalog the scenes are looked up in.
    pub fn catalog(&self) -> sahara_scene::Catalog {
        match &self.scene_dir {
            None => sahara_scene::Catalog::discover(),
            Some(dir) => {
                let mut c = sahara_scene::Catalog::procedural();
                c.add_dir(dir, sahara_scene::Origin::Env);
                c
            }
        }
    }

    /// Where the rows go.
    pub fn out(&self) -> Out {
        Out { json: self.json }
    }
}

/// Loads scene `name`, or says why it is skipped and returns `None`.
pub fn load(catalog: &sahara_scene::Catalog, name: &str) -> Option<util::LoadedScene> {
    match util::load_scene_from(catalog, name) {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!("skipping scene {name}: {e:#}");
            None
        }
    }
}

/// The scenes of `names` that load, in order, each loaded when the iteration reaches it (a
/// scene that does not load is skipped with a message, [`load`]).
pub fn loaded_scenes<'a>(
    catalog: &'a sahara_scene::Catalog,
    names: &'a [String],
) -> impl Iterator<Item = util::LoadedScene> + 'a {
    names.iter().filter_map(move |name| load(catalog, name))
}

/// A harness's tree over `tris`, validated; the errors name the builder `label` and `scene`.
pub fn valid_tree(
    built: std::result::Result<Bvh, BuildError>,
    label: &str,
    scene: &str,
    tris: &[Triangle],
) -> Result<Bvh> {
    let bvh = built.with_context(|| format!("{label} on {scene}"))?;
    bvh.validate(tris)
        .with_context(|| format!("{label} on {scene}: invalid tree"))?;
    Ok(bvh)
}

/// A row of a harness's table: its line of the table, and (its `Serialize`) its JSON record.
pub trait Row: Serialize {
    fn line(&self) -> String;
}

/// The output of a harness: the table on standard output, or one JSON record per row.
#[derive(Clone, Copy, Debug)]
pub struct Out {
    pub json: bool,
}

impl Out {
    /// Lines printed above the table (none with `--json`).
    pub fn header(&self, lines: &[&str]) {
        if !self.json {
            for l in lines {
                println!("{l}");
            }
        }
    }

    /// A note about the run: part of the table's output, or on standard error with `--json`.
    pub fn note(&self, line: &str) {
        if self.json {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    }

    /// One row: its table line, or its JSON record on one line.
    pub fn row<R: Row>(&self, r: &R) -> Result<()> {
        if self.json {
            println!("{}", serde_json::to_string(r)?);
        } else {
            println!("{}", r.line());
        }
        Ok(())
    }

    /// [`row`](Self::row), then `r` kept in `rows` (the table the harness returns).
    pub fn keep<R: Row>(&self, rows: &mut Vec<R>, r: R) -> Result<()> {
        self.row(&r)?;
        rows.push(r);
        Ok(())
    }
}

/// `a / b − 1`, the relative change the tables print as a percentage.
pub fn relative(a: f64, b: f64) -> f64 {
    a / b - 1.0
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use clap::Parser;

    /// Parses `cargo xtask measure <args>` with the real command line of `main.rs`.
    pub fn parse(args: &[&str]) -> Result<What, clap::Error> {
        let v: Vec<&str> = ["cargo xtask", "measure"]
            .iter()
            .chain(args)
            .copied()
            .collect();
        match crate::Cli::try_parse_from(v)?.cmd {
            crate::Cmd::Measure(a) => Ok(a.what),
            _ => unreachable!("`measure` parses as Cmd::Measure"),
        }
    }

    /// A folder under the system's temporary folder, empty, unique to this test.
    pub fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("xtask-measure-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn every_subcommand_parses_and_unknown_ones_do_not() {
        for what in [
            "presets",
            "knobs",
            "dragon",
            "sbvh",
            "tsah-spatial",
            "wide-bench",
            "oracle",
        ] {
            parse(&[what]).unwrap_or_else(|e| panic!("{what}: {e}"));
        }
        // These need their inputs.
        assert!(parse(&["configs"]).is_err());
        assert!(parse(&["popov-configs"]).is_err());
        assert!(parse(&["kernels", "--scene", "soup"]).is_err());
        assert!(parse(&["kernels", "--scene", "soup", "--rays", "ao"]).is_ok());
        assert!(parse(&["bunny"]).is_err());
        assert!(parse(&[]).is_err());
        assert!(parse(&["presets", "--no-such-flag"]).is_err());
    }

    #[test]
    fn scene_dir_is_the_only_folder_and_missing_scenes_are_skipped() {
        let dir = temp_dir("scene-dir");
        std::fs::write(
            dir.join("quad.obj"),
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
        )
        .unwrap();
        let common = Common {
            scene_dir: Some(dir.clone()),
            json: false,
        };
        let catalog = common.catalog();
        assert_eq!(catalog.dirs().len(), 1, "{:?}", catalog.dirs());
        assert_eq!(load(&catalog, "quad").unwrap().triangles.len(), 2);
        // A name that is not in the folder is skipped, not an error; procedural scenes stay.
        assert!(load(&catalog, "stanford_bunny").is_none());
        assert!(!load(&catalog, "soup:300").unwrap().triangles.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
