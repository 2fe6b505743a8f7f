//! `measure sbvh|tsah-spatial`: registered builders with their reference counts and depths,
//! and the spatial temporary-subtree builder's configurations against SBVH, each tree
//! validated (`docs/builders-classic.md`, "Measurements").

use super::{loaded_scenes, relative, valid_tree, Common, Row};
use crate::util;
use anyhow::{bail, Result};
use sahara_builders::sbvh::{SbvhBuilder, SbvhConfig};
use sahara_builders::tsah_spatial::{TemporarySearch, TsahSpatialBuilder, TsahSpatialConfig};
use sahara_builders::{BuildInput, Builder, CostModel};
use sahara_metrics::sah;
use serde::Serialize;

/// `measure sbvh`.
#[derive(clap::Args, Clone, Debug)]
pub struct SbvhArgs {
    /// Scenes (catalog names, `procedural:size` or paths).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sibenik,sponza_dabrovic,san_francisco_osm,teapot_in_stadium"
    )]
    pub scenes: Vec<String>,
    /// Registered builders.
    #[arg(long, value_delimiter = ',', default_value = "binned,sweep,sbvh")]
    pub builders: Vec<String>,
    /// Builds per builder and scene; the best time is printed.
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    #[command(flatten)]
    pub common: Common,
}

/// `measure tsah-spatial`.
#[derive(clap::Args, Clone, Debug)]
pub struct TsahSpatialArgs {
    /// Scenes (catalog names, `procedural:size` or paths).
    #[arg(long, value_delimiter = ',', default_value = "sibenik,sponza_dabrovic")]
    pub scenes: Vec<String>,
    /// Configurations of `tsah-sbvh`, by name: default, exact, fast, top-k, k2+2, k6+6,
    /// min256, refine1, fast-temps, old-default (the default before issue #4: exact
    /// temporaries, plain top-k candidates, `min_size` 256). Measured in this order.
    #[arg(long, value_delimiter = ',', default_value = "default,fast")]
    pub configs: Vec<String>,
    #[command(flatten)]
    pub common: Common,
}

/// One tree of `measure sbvh`.
#[derive(Clone, Debug, Serialize)]
pub struct SbvhRow {
    pub scene: String,
    pub builder: String,
    pub triangles: usize,
    /// The best of `--repeat` builds.
    pub build_ms: f64,
    /// SAH with the default cost model (c_t = 1.2, c_i = 1).
    pub sah: f64,
    pub references: usize,
    pub depth: usize,
}

impl Row for SbvhRow {
    fn line(&self) -> String {
        format!(
            "{:<20} {:<14} {:>9} {:>10.1} {:>10.3} {:>10} {:>7}",
            self.scene,
            self.builder,
            self.triangles,
            self.build_ms,
            self.sah,
            self.references,
            self.depth
        )
    }
}

pub fn sbvh(a: &SbvhArgs) -> Result<Vec<SbvhRow>> {
    let builders: Vec<Box<dyn Builder>> = a
        .builders
        .iter()
        .map(|n| util::builder(n))
        .collect::<Result<_>>()?;
    let out = a.common.out();
    out.note(&format!(
        "threads: {}; cost model c_t = 1.2, c_i = 1",
        rayon::current_num_threads()
    ));
    out.header(&[&format!(
        "{:<20} {:<14} {:>9} {:>10} {:>10} {:>10} {:>7}",
        "scene", "builder", "tris", "build_ms", "sah", "refs", "depth"
    )]);
    let catalog = a.common.catalog();
    let mut rows = Vec::new();
    for s in loaded_scenes(&catalog, &a.scenes) {
        let input = BuildInput::new(&s.triangles, CostModel::default())?;
        for (name, builder) in a.builders.iter().zip(&builders) {
            let (times, bvh) = util::time_runs(a.repeat, || builder.build(&input));
            let bvh = valid_tree(bvh, name, &s.name, &s.triangles)?;
            let row = SbvhRow {
                scene: s.name.clone(),
                builder: name.clone(),
                triangles: s.triangles.len(),
                build_ms: times.iter().copied().fold(f64::INFINITY, f64::min) * 1e3,
                sah: sah(&bvh, &input.cost),
                references: bvh.prim_indices.len(),
                depth: bvh.stats().depth,
            };
            out.keep(&mut rows, row)?;
        }
    }
    Ok(rows)
}

/// The named configurations of `measure tsah-spatial`, in table order.
pub fn spatial_configs() -> Vec<(&'static str, TsahSpatialConfig)> {
    vec![
        ("default", TsahSpatialConfig::DEFAULT),
        ("exact", TsahSpatialConfig::EXACT),
        ("fast", TsahSpatialConfig::FAST),
        (
            "top-k",
            TsahSpatialConfig {
                object_separation: 0.0,
                spatial_separation: 0,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "k2+2",
            TsahSpatialConfig {
                object_candidates: 2,
                spatial_candidates: 2,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "k6+6",
            TsahSpatialConfig {
                object_candidates: 6,
                spatial_candidates: 6,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "min256",
            TsahSpatialConfig {
                min_size: 256,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "refine1",
            TsahSpatialConfig {
                temporary_search: TemporarySearch::Estimated {
                    bins_per_ref: 1,
                    min_bins: 4,
                    refine: 1,
                },
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "fast-temps",
            TsahSpatialConfig {
                temporary: SbvhConfig::FAST,
                ..TsahSpatialConfig::DEFAULT
            },
        ),
        (
            "old-default",
            TsahSpatialConfig {
                object_separation: 0.0,
                spatial_separation: 0,
                min_size: 256,
                ..TsahSpatialConfig::EXACT
            },
        ),
    ]
}

/// One tree of `measure tsah-spatial`: the SBVH reference (`config` = `sbvh`) or a
/// configuration compared with it.
#[derive(Clone, Debug, Serialize)]
pub struct SpatialRow {
    pub scene: String,
    pub config: String,
    pub build_ms: f64,
    /// SAH with the default cost model (c_t = 1.2, c_i = 1).
    pub sah: f64,
    /// `sah / sah(sbvh) - 1`; `null` for the SBVH row.
    pub sah_vs_sbvh: Option<f64>,
    pub references: usize,
}

impl Row for SpatialRow {
    fn line(&self) -> String {
        let (scene, config, ms, s) = (&self.scene, &self.config, self.build_ms, self.sah);
        match self.sah_vs_sbvh {
            None => format!(
                "{scene:<18} {config:<12} {ms:>10.0} ms  sah {s:.3}  refs {}",
                self.references
            ),
            Some(r) => format!(
                "{scene:<18} {config:<12} {ms:>10.0} ms  sah {s:.3} ({:+.2}% vs sbvh)  refs {}",
                100.0 * r,
                self.references
            ),
        }
    }
}

pub fn tsah_spatial(a: &TsahSpatialArgs) -> Result<Vec<SpatialRow>> {
    let mut configs = spatial_configs();
    let known: Vec<&str> = configs.iter().map(|(n, _)| *n).collect();
    for c in &a.configs {
        if !known.contains(&c.as_str()) {
            bail!("unknown configuration '{c}'; known: {}", known.join(", "));
        }
    }
    configs.retain(|(n, _)| a.configs.iter().any(|w| w == n));
    let out = a.common.out();
    out.note(&format!("threads: {}", rayon::current_num_threads()));
    let catalog = a.common.catalog();
    let mut rows = Vec::new();
    for s in loaded_scenes(&catalog, &a.scenes) {
        let input = BuildInput::new(&s.triangles, CostModel::default())?;
        let build =
            |name: &str, b: &dyn Builder, base: Option<&SpatialRow>| -> Result<SpatialRow> {
                let (times, bvh) = util::time_runs(1, || b.build(&input));
                let bvh = valid_tree(bvh, name, &s.name, &s.triangles)?;
                let sah = sah(&bvh, &input.cost);
                Ok(SpatialRow {
                    scene: s.name.clone(),
                    config: name.to_string(),
                    build_ms: times[0] * 1e3,
                    sah,
                    sah_vs_sbvh: base.map(|b| relative(sah, b.sah)),
                    references: bvh.prim_indices.len(),
                })
            };
        let reference = build("sbvh", &SbvhBuilder::new(SbvhConfig::DEFAULT), None)?;
        out.keep(&mut rows, reference.clone())?;
        for (name, config) in &configs {
            let row = build(name, &TsahSpatialBuilder::new(*config), Some(&reference))?;
            out.keep(&mut rows, row)?;
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::super::tests::parse;
    use super::super::What;
    use super::*;

    #[test]
    fn defaults_are_the_harness_defaults() {
        let What::Sbvh(a) = parse(&["sbvh"]).unwrap() else {
            panic!()
        };
        assert_eq!(a.builders, ["binned", "sweep", "sbvh"]);
        assert_eq!((a.scenes.len(), a.repeat), (4, 1));
        let What::TsahSpatial(a) = parse(&["tsah-spatial"]).unwrap() else {
            panic!()
        };
        assert_eq!(a.configs, ["default", "fast"]);
        assert_eq!(a.scenes, ["sibenik", "sponza_dabrovic"]);
        assert_eq!(spatial_configs().len(), 10);
    }

    #[test]
    fn sbvh_runs_on_a_tiny_scene() {
        let What::Sbvh(a) = parse(&[
            "sbvh",
            "--scenes",
            "sphere_in_box:800,missing_scene",
            "--builders",
            "binned,sbvh",
            "--repeat",
            "2",
        ])
        .unwrap() else {
            panic!()
        };
        let rows = sbvh(&a).unwrap();
        assert_eq!(rows.len(), 2);
        let (binned, spatial) = (&rows[0], &rows[1]);
        assert_eq!(binned.references, binned.triangles);
        assert!(spatial.references >= spatial.triangles);
        assert!(binned.depth > 1 && spatial.sah.is_finite() && spatial.sah > 0.0);
        assert!(
            binned.line().starts_with("sphere_in_box"),
            "{}",
            binned.line()
        );
    }

    #[test]
    fn tsah_spatial_runs_and_refuses_unknown_configurations() {
        let What::TsahSpatial(a) = parse(&[
            "tsah-spatial",
            "--scenes",
            "sphere_in_box:600",
            "--configs",
            "fast,k2+2",
            "--json",
        ])
        .unwrap() else {
            panic!()
        };
        let rows = tsah_spatial(&a).unwrap();
        // The reference, then the configurations in table order (not the order given).
        let names: Vec<&str> = rows.iter().map(|r| r.config.as_str()).collect();
        assert_eq!(names, ["sbvh", "fast", "k2+2"]);
        assert!(rows[0].sah_vs_sbvh.is_none());
        for r in &rows[1..] {
            let rel = r.sah_vs_sbvh.unwrap();
            assert!((rel - relative(r.sah, rows[0].sah)).abs() < 1e-12, "{r:?}");
            assert!(r.line().contains("vs sbvh"), "{}", r.line());
        }
        let What::TsahSpatial(a) = parse(&["tsah-spatial", "--configs", "default,bogus"]).unwrap()
        else {
            panic!()
        };
        let e = tsah_spatial(&a).err().unwrap().to_string();
        assert!(e.contains("bogus") && e.contains("old-default"), "{e}");
    }
}
