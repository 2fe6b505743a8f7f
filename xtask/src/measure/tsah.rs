//! `measure presets|knobs|dragon|configs|popov-configs`: the sweep, temporary-subtree and
//! look-ahead builders on the shared scenes, each tree validated; wall and CPU build time,
//! SAH (and with `--epo` EPO) against the sweep tree of the same scene
//! (`docs/builders-tsah.md`, "Results" and "Reproducing").

use super::{load, loaded_scenes, relative, valid_tree, Common, Out, Row};
use crate::util;
use anyhow::{Context, Result};
use sahara_builders::popov::{PopovBuilder, PopovConfig};
use sahara_builders::tsah::{Candidates, Temporary, TsahBuilder, TsahConfig};
use sahara_builders::{BuildInput, Builder, CostModel, Strategy};
use sahara_geom::Triangle;
use sahara_metrics::sah;
use serde::Serialize;

/// The options the harnesses of this module share: `--epo` and [`Common`].
#[derive(clap::Args, Clone, Debug)]
pub struct Options {
    /// Also compute each tree's EPO.
    #[arg(long)]
    pub epo: bool,
    #[command(flatten)]
    pub common: Common,
}

/// `measure presets`.
#[derive(clap::Args, Clone, Debug)]
pub struct PresetsArgs {
    /// Scenes (catalog names, `procedural:size` or paths).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sibenik,sponza_dabrovic,stanford_bunny,teapot_in_stadium"
    )]
    pub scenes: Vec<String>,
    /// Registered builders, in table order; rows after `sweep` are compared with it.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sweep,tsah-topk,tsah-binned,popov-d2,hybrid"
    )]
    pub builders: Vec<String>,
    #[command(flatten)]
    pub options: Options,
}

/// `measure knobs`.
#[derive(clap::Args, Clone, Debug)]
pub struct KnobsArgs {
    /// Scenes; `soup` and `mesh` are the procedural inputs of the original harness
    /// (`sahara_fixtures::soups::box_soup(100000, 5)` and `meshes::mesh_like(200, 6)`), not the
    /// catalog's (`soup:100k` is the catalog's soup).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sibenik,stanford_bunny,teapot_in_stadium,soup,mesh"
    )]
    pub scenes: Vec<String>,
    /// The `greedy_below` of every configuration compared.
    #[arg(long, default_value_t = 8)]
    pub greedy_below: usize,
    /// Compare many more configurations (k = 1..16, greedy thresholds 0..256, more binnings).
    #[arg(long)]
    pub wide: bool,
    #[command(flatten)]
    pub options: Options,
}

/// `measure dragon`.
#[derive(clap::Args, Clone, Debug)]
pub struct DragonArgs {
    /// The scene.
    #[arg(long, default_value = "stanford_dragon")]
    pub scene: String,
    /// Registered builders, in table order; rows after `sweep` are compared with it.
    #[arg(long, value_delimiter = ',', default_value = "sweep,tsah-topk")]
    pub builders: Vec<String>,
    #[command(flatten)]
    pub options: Options,
}

/// `measure configs`.
#[derive(clap::Args, Clone, Debug)]
pub struct ConfigsArgs {
    /// A JSON array of `TsahConfig`, for example `[{"candidates":{"Binned":{"bins_per_axis":2}},
    /// "temporary":"Sweep","greedy_below":32,"always_include_greedy_best":true,"max_leaf_size":8}]`.
    #[arg(long)]
    pub configs: String,
    /// Scenes (catalog names, `procedural:size` or paths).
    #[arg(long, value_delimiter = ',', default_value = "sibenik,sponza_dabrovic")]
    pub scenes: Vec<String>,
    #[command(flatten)]
    pub options: Options,
}

/// `measure popov-configs`.
#[derive(clap::Args, Clone, Debug)]
pub struct PopovConfigsArgs {
    /// A JSON array of `PopovConfig` (`crates/builders/src/popov.rs`).
    #[arg(long)]
    pub configs: String,
    /// Scenes (catalog names, `procedural:size` or paths).
    #[arg(long, value_delimiter = ',', default_value = "sibenik,sponza_dabrovic")]
    pub scenes: Vec<String>,
    #[command(flatten)]
    pub options: Options,
}

/// One tree: a row of the tables (and the JSON record of `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct BuildRow {
    pub scene: String,
    pub triangles: usize,
    /// The registry name, or the configuration (its `describe()` or the knob's label).
    pub builder: String,
    /// Wall-clock build time.
    pub build_ms: f64,
    /// CPU time of the process during the build (all threads).
    pub cpu_ms: f64,
    /// SAH with the default cost model (c_t = 1.2, c_i = 1).
    pub sah: f64,
    /// `sah / sah(sweep) - 1`; `null` for the sweep row and rows before it.
    pub sah_vs_sweep: Option<f64>,
    /// EPO with the default cost model (`--epo`), else `null`.
    pub epo: Option<f64>,
    /// `epo / epo(sweep) - 1`, when both are known.
    pub epo_vs_sweep: Option<f64>,
    pub leaves: usize,
}

impl Row for BuildRow {
    fn line(&self) -> String {
        let rel = self
            .sah_vs_sweep
            .map_or(String::new(), |r| format!("{:+.2}%", 100.0 * r));
        let epo = match (self.epo, self.epo_vs_sweep) {
            (Some(e), Some(r)) => format!("{e:.3} ({:+.2}%)", 100.0 * r),
            (Some(e), None) => format!("{e:.3}"),
            _ => "-".into(),
        };
        format!(
            "| {} | {} | {} | {:.0} | {:.0} | {:.3} | {rel} | {epo} | {} |",
            self.scene,
            self.triangles,
            self.builder,
            self.build_ms,
            self.cpu_ms,
            self.sah,
            self.leaves
        )
    }
}

/// The table's two header lines, naming the third column `what`.
fn header(out: &Out, what: &str) {
    out.header(&[
        &format!(
            "| scene | triangles | {what} | build ms | CPU ms | SAH | vs sweep | EPO | leaves |"
        ),
        "|---|---:|---|---:|---:|---:|---:|---:|---:|",
    ]);
}

/// Builds `tris` with `builder` (validated), compared with `base` when given.
fn measure(
    scene: &str,
    label: &str,
    builder: &dyn Builder,
    tris: &[Triangle],
    epo: bool,
    base: Option<&BuildRow>,
) -> Result<BuildRow> {
    let input = BuildInput::new(tris, CostModel::default())?;
    let c0 = util::cpu_ms();
    let (times, bvh) = util::time_runs(1, || builder.build(&input));
    let cpu_ms = util::cpu_ms() - c0;
    let bvh = valid_tree(bvh, label, scene, tris)?;
    let sah = sah(&bvh, &input.cost);
    let epo = epo.then(|| sahara_metrics::epo(&bvh, tris, &input.cost));
    Ok(BuildRow {
        scene: scene.to_string(),
        triangles: tris.len(),
        builder: label.to_string(),
        build_ms: times[0] * 1e3,
        cpu_ms,
        sah,
        sah_vs_sweep: base.map(|b| relative(sah, b.sah)),
        epo,
        epo_vs_sweep: epo
            .zip(base.and_then(|b| b.epo))
            .map(|(e, b)| relative(e, b)),
        leaves: bvh.nodes.iter().filter(|n| n.is_leaf()).count(),
    })
}

/// Registered builders on each scene in turn, rows after `sweep` compared with it.
fn registered(scenes: &[String], names: &[String], options: &Options) -> Result<Vec<BuildRow>> {
    let (epo, common) = (options.epo, &options.common);
    let builders: Vec<Box<dyn Builder>> = names
        .iter()
        .map(|n| util::builder(n))
        .collect::<Result<_>>()?;
    let out = common.out();
    header(&out, "builder");
    let catalog = common.catalog();
    let mut rows = Vec::new();
    for s in loaded_scenes(&catalog, scenes) {
        let mut base: Option<BuildRow> = None;
        for (name, b) in names.iter().zip(&builders) {
            let row = measure(&s.name, name, b.as_ref(), &s.triangles, epo, base.as_ref())?;
            out.row(&row)?;
            if name == "sweep" {
                base = Some(row.clone());
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

/// Configurations on each scene, after the sweep tree they are compared with.
fn against_sweep(
    scenes: &[String],
    configs: &[(String, Box<dyn Builder>)],
    options: &Options,
    generated: impl Fn(&str) -> Option<Vec<Triangle>>,
) -> Result<Vec<BuildRow>> {
    let (epo, common) = (options.epo, &options.common);
    let sweep = util::builder("sweep")?;
    let out = common.out();
    header(&out, "config");
    let catalog = common.catalog();
    let mut rows = Vec::new();
    for scene in scenes {
        let (name, tris) = match generated(scene) {
            Some(t) => (scene.clone(), t),
            None => match load(&catalog, scene) {
                Some(s) => (s.name, s.triangles),
                None => continue,
            },
        };
        let base = measure(&name, "sweep", sweep.as_ref(), &tris, epo, None)?;
        out.keep(&mut rows, base.clone())?;
        for (label, b) in configs {
            let row = measure(&name, label, b.as_ref(), &tris, epo, Some(&base))?;
            out.keep(&mut rows, row)?;
        }
    }
    Ok(rows)
}

pub fn presets(a: &PresetsArgs) -> Result<Vec<BuildRow>> {
    registered(&a.scenes, &a.builders, &a.options)
}

pub fn dragon(a: &DragonArgs) -> Result<Vec<BuildRow>> {
    registered(std::slice::from_ref(&a.scene), &a.builders, &a.options)
}

/// The configurations of `measure knobs`, labelled.
pub fn knob_configs(greedy_below: usize, wide: bool) -> Vec<(String, TsahConfig)> {
    let base = TsahConfig {
        greedy_below,
        ..TsahConfig::TOP_K
    };
    let top = |k, per_axis| TsahConfig {
        candidates: Candidates::TopK { k, per_axis },
        ..base
    };
    let binned = |bins_per_axis, temporary| TsahConfig {
        candidates: Candidates::Binned { bins_per_axis },
        temporary,
        ..base
    };
    let mut configs = Vec::new();
    if wide {
        for k in [1, 2, 4, 8, 16] {
            configs.push((format!("top-{k}"), top(k, false)));
        }
        for gb in [0, 8, 32, 64, 256] {
            configs.push((
                format!("top-1/axis greedy<={gb}"),
                TsahConfig {
                    greedy_below: gb,
                    ..top(1, true)
                },
            ));
        }
        for (bins, tbins) in [(2, 8), (3, 8), (4, 8), (4, 16), (8, 16)] {
            configs.push((
                format!("binned {bins}, binned temps {tbins}"),
                binned(bins, Temporary::Binned { bins: tbins }),
            ));
        }
    }
    configs.push(("top-4".into(), top(4, false)));
    for k in [1, 2, 3] {
        configs.push((format!("top-{k}/axis"), top(k, true)));
    }
    for bins in [2, 3, 4] {
        configs.push((
            format!("binned {bins}, sweep temps"),
            binned(bins, Temporary::Sweep),
        ));
    }
    for (bins, tbins) in [(2, 8), (2, 16), (4, 8)] {
        configs.push((
            format!("binned {bins}, binned temps {tbins}"),
            binned(bins, Temporary::Binned { bins: tbins }),
        ));
    }
    configs
}

pub fn knobs(a: &KnobsArgs) -> Result<Vec<BuildRow>> {
    let configs: Vec<(String, Box<dyn Builder>)> = knob_configs(a.greedy_below, a.wide)
        .into_iter()
        .map(|(label, c)| (label, Box::new(TsahBuilder::new(c)) as Box<dyn Builder>))
        .collect();
    against_sweep(&a.scenes, &configs, &a.options, |scene| match scene {
        "soup" => Some(sahara_fixtures::soups::box_soup(100_000, 5)),
        "mesh" => Some(sahara_fixtures::meshes::mesh_like(200, 6)),
        _ => None,
    })
}

/// `--configs` of `configs` and `popov-configs`: a JSON array of configurations, each built by
/// `make` and labelled with its description.
fn json_configs<C: Strategy + serde::de::DeserializeOwned>(
    json: &str,
    make: fn(C) -> Box<dyn Builder>,
) -> Result<Vec<(String, Box<dyn Builder>)>> {
    let configs: Vec<C> = serde_json::from_str(json)
        .with_context(|| format!("--configs is not a JSON array of {}: {json}", C::NAME))?;
    Ok(configs
        .into_iter()
        .map(|c| (c.describe(), make(c)))
        .collect())
}

pub fn configs(a: &ConfigsArgs) -> Result<Vec<BuildRow>> {
    let configs = json_configs::<TsahConfig>(&a.configs, |c| Box::new(TsahBuilder::new(c)))?;
    against_sweep(&a.scenes, &configs, &a.options, |_| None)
}

pub fn popov_configs(a: &PopovConfigsArgs) -> Result<Vec<BuildRow>> {
    let configs = json_configs::<PopovConfig>(&a.configs, |c| Box::new(PopovBuilder::new(c)))?;
    against_sweep(&a.scenes, &configs, &a.options, |_| None)
}

#[cfg(test)]
mod tests {
    use super::super::tests::parse;
    use super::super::What;
    use super::*;

    const TINY: &str = "sphere_in_box:600";

    fn sweep_first(rows: &[BuildRow], per_scene: usize) {
        assert!(!rows.is_empty());
        for chunk in rows.chunks(per_scene) {
            assert_eq!(chunk[0].builder, "sweep");
            assert_eq!(chunk[0].sah_vs_sweep, None);
            for r in chunk {
                assert_eq!(r.scene, chunk[0].scene);
                assert!(r.sah.is_finite() && r.sah > 0.0, "{r:?}");
                assert!(r.leaves > 0 && r.build_ms >= 0.0, "{r:?}");
            }
            for r in &chunk[1..] {
                let rel = r.sah_vs_sweep.expect("compared with sweep");
                assert!((rel - relative(r.sah, chunk[0].sah)).abs() < 1e-12, "{r:?}");
            }
        }
    }

    #[test]
    fn defaults_are_the_harness_defaults() {
        let What::Presets(p) = parse(&["presets"]).unwrap() else {
            panic!()
        };
        assert_eq!(
            p.scenes,
            [
                "sibenik",
                "sponza_dabrovic",
                "stanford_bunny",
                "teapot_in_stadium"
            ]
        );
        assert_eq!(
            p.builders,
            ["sweep", "tsah-topk", "tsah-binned", "popov-d2", "hybrid"]
        );
        assert!(!p.options.epo && !p.options.common.json && p.options.common.scene_dir.is_none());
        let What::Knobs(k) = parse(&["knobs"]).unwrap() else {
            panic!()
        };
        assert_eq!(k.greedy_below, 8);
        assert!(!k.wide);
        assert_eq!(k.scenes.last().map(String::as_str), Some("mesh"));
        let What::Dragon(d) = parse(&["dragon"]).unwrap() else {
            panic!()
        };
        assert_eq!((d.scene.as_str(), d.builders.len()), ("stanford_dragon", 2));
        assert_eq!(knob_configs(8, false).len(), 10);
        assert_eq!(knob_configs(8, true).len(), 25);
        assert!(knob_configs(32, false)
            .iter()
            .all(|(_, c)| c.greedy_below == 32));
    }

    #[test]
    fn presets_and_dragon_run_on_a_tiny_scene() {
        let What::Presets(a) = parse(&[
            "presets",
            "--scenes",
            &format!("{TINY},no_such_scene,soup:400"),
            "--builders",
            "tsah-topk,sweep,tsah-binned",
            "--epo",
        ])
        .unwrap() else {
            panic!()
        };
        let rows = presets(&a).unwrap();
        // The missing scene is skipped; rows before sweep have nothing to compare with.
        assert_eq!(rows.len(), 6);
        for chunk in rows.chunks(3) {
            assert_eq!(chunk[0].sah_vs_sweep, None);
            assert_eq!(chunk[1].sah_vs_sweep, None);
            // With sweep temporaries and the greedy-best split always rated, top-k is never
            // worse than sweep.
            assert!(chunk[0].sah <= chunk[1].sah * (1.0 + 1e-9), "{chunk:?}");
            assert!(chunk[2].sah_vs_sweep.is_some() && chunk[2].epo_vs_sweep.is_some());
            assert!(chunk.iter().all(|r| r.epo.is_some_and(f64::is_finite)));
        }
        let What::Dragon(a) = parse(&["dragon", "--scene", TINY, "--json"]).unwrap() else {
            panic!()
        };
        let rows = dragon(&a).unwrap();
        sweep_first(&rows, 2);
        assert_eq!(rows[1].builder, "tsah-topk");
        assert!(rows[0].epo.is_none());
        // An unknown builder is an error naming the known ones, before any build.
        let What::Presets(a) = parse(&["presets", "--builders", "sweep,nope"]).unwrap() else {
            panic!()
        };
        let e = presets(&a).err().unwrap().to_string();
        assert!(e.contains("nope") && e.contains("tsah-topk"), "{e}");
    }

    #[test]
    fn knobs_run_on_tiny_scenes() {
        let What::Knobs(a) = parse(&["knobs", "--scenes", TINY, "--greedy-below", "16"]).unwrap()
        else {
            panic!()
        };
        let rows = knobs(&a).unwrap();
        sweep_first(&rows, 11);
        assert_eq!(rows.len(), 11);
        assert_eq!(rows[1].builder, "top-4");
        assert_eq!(rows[10].builder, "binned 4, binned temps 8");
    }

    #[test]
    fn json_configs_run_and_bad_json_is_an_error() {
        let json = serde_json::to_string(&[TsahConfig::BINNED, TsahConfig::TOP_K]).unwrap();
        let What::Configs(a) = parse(&["configs", "--configs", &json, "--scenes", TINY]).unwrap()
        else {
            panic!()
        };
        let rows = configs(&a).unwrap();
        sweep_first(&rows, 3);
        assert_eq!(rows[1].builder, TsahConfig::BINNED.describe());
        let json = serde_json::to_string(&[PopovConfig::D2]).unwrap();
        let What::PopovConfigs(a) = parse(&[
            "popov-configs",
            "--configs",
            &json,
            "--scenes",
            &format!("{TINY},soup:300"),
        ])
        .unwrap() else {
            panic!()
        };
        let rows = popov_configs(&a).unwrap();
        sweep_first(&rows, 2);
        assert_eq!(rows.len(), 4);
        assert_eq!(rows[3].builder, PopovConfig::D2.describe());
        let What::Configs(a) = parse(&["configs", "--configs", "[{\"k\":1}]"]).unwrap() else {
            panic!()
        };
        assert!(configs(&a).is_err());
    }

    #[test]
    fn table_lines_keep_the_harness_format() {
        let mut r = BuildRow {
            scene: "s".into(),
            triangles: 10,
            builder: "tsah-topk".into(),
            build_ms: 12.4,
            cpu_ms: 20.6,
            sah: 51.386,
            sah_vs_sweep: Some(-0.0456),
            epo: Some(4.112),
            epo_vs_sweep: Some(-0.1006),
            leaves: 7,
        };
        assert_eq!(
            r.line(),
            "| s | 10 | tsah-topk | 12 | 21 | 51.386 | -4.56% | 4.112 (-10.06%) | 7 |"
        );
        r.sah_vs_sweep = None;
        r.epo = None;
        assert_eq!(
            r.line(),
            "| s | 10 | tsah-topk | 12 | 21 | 51.386 |  | - | 7 |"
        );
        let v: serde_json::Value = serde_json::to_value(&r).unwrap();
        assert_eq!(v["sah"], 51.386);
        assert!(v["sah_vs_sweep"].is_null());
    }
}
