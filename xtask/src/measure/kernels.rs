//! `measure wide-bench|kernels`: single-thread speed of the traversal kernels, every ray traced
//! one after the other on the calling thread (`crates/traverse/README.md`, "Benchmark";
//! `docs/embree.md`). Every kernel's hits are checked against the scalar binary kernel's
//! (a checksum of distances and primitives); a disagreement is an error.

use super::{load, Common, Out, Row};
use crate::{engine, util};
use anyhow::{bail, Context, Result};
use sahara_builders::{BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Ray, Triangle};
use sahara_trace::{Bvh2Tracer, RaySet};
use sahara_traverse::{scalar, simd_backend, Backend, Bvh4, Bvh8, Hit, NoStats, WorkCounters};
use serde::Serialize;

/// `measure wide-bench`.
#[derive(clap::Args, Clone, Debug)]
pub struct WideBenchArgs {
    /// The scene. Its primary rays come from its catalog camera: for the bunny, the "framed"
    /// camera of docs/baselines.md.
    #[arg(long, default_value = "stanford_bunny")]
    pub scene: String,
    /// Registered builder of the binary tree (default: the fixed binned SAH tree of
    /// `sahara_fixtures::trees::sah_bvh`, 16 bins on the longest axis, leaves of at most
    /// `--leaf`).
    #[arg(long)]
    pub builder: Option<String>,
    /// Largest leaf of the default tree.
    #[arg(long, default_value_t = 4)]
    pub leaf: usize,
    /// Image width (one primary ray per pixel).
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 768)]
    pub height: u32,
    /// Timed passes per kernel after one warm-up pass; the median is printed.
    #[arg(long, default_value_t = 5)]
    pub passes: usize,
    #[command(flatten)]
    pub common: Common,
}

/// `measure kernels`.
#[derive(clap::Args, Clone, Debug)]
pub struct KernelsArgs {
    /// The scene.
    #[arg(long)]
    pub scene: String,
    /// primary, diffuse or ao (generated from the scene's camera as by `trace`), or a ray file
    /// (`cargo xtask trace --dump-rays`, 32-byte records). Every ray is traced for its closest
    /// hit.
    #[arg(long)]
    pub rays: String,
    /// Registered builder of the binary tree.
    #[arg(long, default_value = "sweep")]
    pub builder: String,
    /// Interleaved rounds: each times every kernel once, in a rotating order.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Kernels to time (the work per ray is counted for all three): to compare builds of a
    /// kernel in interleaved processes, time `bvh8` alone.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "bvh2,bvh4,bvh8",
        value_parser = ["bvh2", "bvh4", "bvh8"]
    )]
    pub kernels: Vec<String>,
    /// Timed passes per kernel and round, after one warm-up pass (the median counts).
    #[arg(long, default_value_t = 5)]
    pub passes: usize,
    /// Image width of generated rays.
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Image height of generated rays.
    #[arg(long, default_value_t = 768)]
    pub height: u32,
    /// Seed of generated secondary rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[command(flatten)]
    pub common: Common,
}

/// A checksum of the hits of `rays` traced by `trace`.
fn checksum(rays: &[Ray], trace: &mut impl FnMut(&Ray) -> Hit) -> u64 {
    rays.iter().fold(0u64, |sum, r| {
        let h = trace(r);
        sum.wrapping_add(h.prim as u64 ^ h.t.to_bits() as u64)
    })
}

/// Mrays/s of the median of `passes` timed passes after one warm-up pass, and the warm-up
/// pass's checksum.
fn speed(rays: &[Ray], passes: usize, mut trace: impl FnMut(&Ray) -> Hit) -> (f64, u64) {
    let check = checksum(rays, &mut trace);
    let t = sahara_trace::measure(passes, 0, || checksum(rays, &mut trace));
    (sahara_trace::mrays_per_s(rays.len(), t.median), check)
}

/// Work per ray of one layout.
#[derive(Clone, Debug, Serialize)]
pub struct Work {
    pub layout: String,
    pub inner: f64,
    pub leaves: f64,
    pub triangles: f64,
}

fn work(layout: &str, rays: &[Ray], mut trace: impl FnMut(&Ray, &mut WorkCounters)) -> Work {
    let mut c = WorkCounters::default();
    for r in rays {
        trace(r, &mut c);
    }
    let n = rays.len().max(1) as f64;
    Work {
        layout: layout.to_string(),
        inner: c.inner as f64 / n,
        leaves: c.leaves as f64 / n,
        triangles: c.triangles as f64 / n,
    }
}

/// One kernel's closest-hit speed in `measure wide-bench`.
#[derive(Clone, Debug, Serialize)]
pub struct KernelSpeed {
    /// `bvh2 scalar`, or the layout and the backend (`bvh8 avx2`).
    pub kernel: String,
    pub mrays_s: f64,
    pub vs_bvh2: f64,
}

/// The record of `measure wide-bench`.
#[derive(Clone, Debug, Serialize)]
pub struct WideBenchReport {
    pub scene: String,
    pub triangles: usize,
    /// The binary tree's builder.
    pub builder: String,
    pub build_ms: f64,
    /// SAH of the binary tree with traversal and intersection costs 1.
    pub sah_unit: f64,
    /// The scene's bounds, minimum and maximum.
    pub bounds: [[f32; 3]; 2],
    pub rays: usize,
    /// Fraction of the rays that hit.
    pub hit_fraction: f64,
    pub bvh2_nodes: usize,
    pub bvh4_nodes: usize,
    pub bvh4_packets: usize,
    pub bvh4_refs_per_packet: f64,
    pub bvh8_nodes: usize,
    pub bvh8_packets: usize,
    /// Time of one collapse (the mean of bvh4's and bvh8's).
    pub collapse_ms: f64,
    /// `sahara_traverse::simd_backend()`: the backend the wide layouts use by default.
    pub simd_backend: String,
    /// Closest hit: the scalar binary kernel, then bvh4 and bvh8 with every available backend.
    pub kernels: Vec<KernelSpeed>,
    pub any_hit_bvh2_mrays_s: f64,
    pub any_hit_bvh8_mrays_s: f64,
    /// Closest-hit work per ray of bvh2, bvh4 and bvh8.
    pub work: Vec<Work>,
}

impl Row for WideBenchReport {
    fn line(&self) -> String {
        let mut s = format!(
            "{}: {} triangles, {}: {:.0} ms, SAH {:.1}\n",
            self.scene, self.triangles, self.builder, self.build_ms, self.sah_unit
        );
        s += &format!(
            "bounds {:?} - {:?}; {:.1}% of the {} primary rays hit\n",
            self.bounds[0],
            self.bounds[1],
            100.0 * self.hit_fraction,
            self.rays
        );
        s += &format!(
            "binary: {} nodes; bvh4: {} nodes, {} packets ({:.2} refs/packet); bvh8: {} nodes, {} packets; collapse {:.1} ms per tree\n",
            self.bvh2_nodes,
            self.bvh4_nodes,
            self.bvh4_packets,
            self.bvh4_refs_per_packet,
            self.bvh8_nodes,
            self.bvh8_packets,
            self.collapse_ms
        );
        s += &format!("simd backend: {}\n", self.simd_backend);
        s += &format!("{:<16} {:>8} {:>8}\n", "kernel", "Mrays/s", "vs bvh2");
        for k in &self.kernels {
            s += &format!("{:<16} {:>8.2} {:>7.2}x\n", k.kernel, k.mrays_s, k.vs_bvh2);
        }
        s += &format!(
            "any-hit: bvh2 scalar {:.2} Mrays/s, bvh8 {:.2} Mrays/s ({:.2}x)",
            self.any_hit_bvh2_mrays_s,
            self.any_hit_bvh8_mrays_s,
            self.any_hit_bvh8_mrays_s / self.any_hit_bvh2_mrays_s
        );
        for w in &self.work {
            s += &format!(
                "\n{}: {:.1} inner nodes, {:.1} leaves, {:.1} triangles per ray",
                w.layout, w.inner, w.leaves, w.triangles
            );
        }
        s
    }
}

/// The binary tree of `tris` by the registered builder `name`, validated, with its
/// description and build time in milliseconds.
fn registered_tree(name: &str, tris: &[Triangle]) -> Result<(Bvh, String, f64)> {
    let builder = util::builder(name)?;
    let input = BuildInput::new(tris, CostModel::default())?;
    let (times, bvh) = util::time_runs(1, || builder.build(&input));
    let bvh = bvh.with_context(|| format!("building with {name}"))?;
    bvh.validate(tris)
        .with_context(|| format!("{name}: invalid tree"))?;
    Ok((
        bvh,
        format!("{name} ({})", builder.describe()),
        times[0] * 1e3,
    ))
}

pub fn wide_bench(a: &WideBenchArgs) -> Result<Option<WideBenchReport>> {
    let Some(scene) = load(&a.common.catalog(), &a.scene) else {
        return Ok(None);
    };
    let tris = &scene.triangles;
    let (bvh, builder, build_ms) = match &a.builder {
        Some(name) => registered_tree(name, tris)?,
        None => {
            let (times, bvh) = util::time_runs(1, || sahara_fixtures::trees::sah_bvh(tris, a.leaf));
            bvh.validate(tris)
                .context("the binned SAH tree is invalid")?;
            let label = format!("binned SAH of sahara-fixtures, leaves <= {}", a.leaf);
            (bvh, label, times[0] * 1e3)
        }
    };
    let bounds: Aabb = sahara_trace::scene_bounds(tris);
    let camera = scene.camera;
    let rays = RaySet::primary(&camera, a.width, a.height).rays;
    let hits = rays
        .iter()
        .filter(|r| scalar::closest_hit(&bvh, tris, r, &mut NoStats).is_hit())
        .count();

    let t0 = std::time::Instant::now();
    let w4 = Bvh4::from_bvh(&bvh, tris);
    let w8 = Bvh8::from_bvh(&bvh, tris);
    let collapse_ms = t0.elapsed().as_secs_f64() * 1e3 / 2.0;

    let (m2, c2) = speed(&rays, a.passes, |r| {
        scalar::closest_hit(&bvh, tris, r, &mut NoStats)
    });
    let mut kernels = vec![KernelSpeed {
        kernel: "bvh2 scalar".into(),
        mrays_s: m2,
        vs_bvh2: 1.0,
    }];
    for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
        let (m4, c4) = speed(&rays, a.passes, |r| w4.closest_hit_with(b, r, &mut NoStats));
        let (m8, c8) = speed(&rays, a.passes, |r| w8.closest_hit_with(b, r, &mut NoStats));
        for (kernel, m, c) in [(format!("bvh4 {b}"), m4, c4), (format!("bvh8 {b}"), m8, c8)] {
            if c != c2 {
                bail!(
                    "{kernel} disagrees with the scalar kernel on {}",
                    scene.name
                );
            }
            kernels.push(KernelSpeed {
                kernel,
                mrays_s: m,
                vs_bvh2: m / m2,
            });
        }
    }
    let occluded = |h: bool| Hit {
        prim: h as u32,
        ..Hit::MISS
    };
    let (a2, _) = speed(&rays, a.passes, |r| {
        occluded(scalar::any_hit(&bvh, tris, r, &mut NoStats))
    });
    let (a8, _) = speed(&rays, a.passes, |r| occluded(w8.any_hit(r, &mut NoStats)));
    let work = vec![
        work("bvh2", &rays, |r, c| {
            scalar::closest_hit(&bvh, tris, r, c);
        }),
        work("bvh4", &rays, |r, c| {
            w4.closest_hit(r, c);
        }),
        work("bvh8", &rays, |r, c| {
            w8.closest_hit(r, c);
        }),
    ];
    let report = WideBenchReport {
        scene: scene.name.clone(),
        triangles: tris.len(),
        builder,
        build_ms,
        sah_unit: sahara_metrics::sah(&bvh, &CostModel::UNIT),
        bounds: [bounds.min.to_array(), bounds.max.to_array()],
        rays: rays.len(),
        hit_fraction: hits as f64 / rays.len().max(1) as f64,
        bvh2_nodes: bvh.nodes.len(),
        bvh4_nodes: w4.node_count(),
        bvh4_packets: w4.packet_count(),
        bvh4_refs_per_packet: w4.reference_count() as f64 / w4.packet_count().max(1) as f64,
        bvh8_nodes: w8.node_count(),
        bvh8_packets: w8.packet_count(),
        collapse_ms,
        simd_backend: simd_backend().to_string(),
        kernels,
        any_hit_bvh2_mrays_s: a2,
        any_hit_bvh8_mrays_s: a8,
        work,
    };
    a.common.out().row(&report)?;
    Ok(Some(report))
}

/// One kernel of `measure kernels`.
#[derive(Clone, Debug, Serialize)]
pub struct KernelRow {
    pub scene: String,
    pub builder: String,
    /// The `--rays` given (a kind or a file).
    pub ray_set: String,
    pub rays: usize,
    /// `bvh2 scalar`, `bvh4` or `bvh8` (the wide layouts with the best available backend).
    pub kernel: String,
    /// Over the rounds: the median, slowest and fastest round's Mrays/s.
    pub mrays_s: util::Spread,
    /// The median of the per-round ratios to bvh8 (`null` when bvh8 is not timed).
    pub vs_bvh8: Option<f64>,
    /// Closest-hit work per ray.
    pub inner: f64,
    pub leaves: f64,
    pub triangles: f64,
}

impl Row for KernelRow {
    fn line(&self) -> String {
        format!(
            "{:<12} {:>8.2} {:>7.2}-{:<7.2} {:>8.3}x   {:.2}, {:.2}, {:.2}",
            self.kernel,
            self.mrays_s.median,
            self.mrays_s.min,
            self.mrays_s.max,
            self.vs_bvh8.unwrap_or(f64::NAN),
            self.inner,
            self.leaves,
            self.triangles
        )
    }
}

pub fn kernels(a: &KernelsArgs) -> Result<Vec<KernelRow>> {
    let Some(scene) = load(&a.common.catalog(), &a.scene) else {
        return Ok(Vec::new());
    };
    let tris = &scene.triangles;
    let (bvh, _, _) = registered_tree(&a.builder, tris)?;
    let reference = Bvh2Tracer::new(&bvh, tris);
    let set = engine::ray_set(&a.rays, &scene, &reference, a.width, a.height, a.seed)?;
    let rays = &set.rays;
    let t0 = std::time::Instant::now();
    let w8 = Bvh8::from_bvh(&bvh, tris);
    let collapse_ms = t0.elapsed().as_secs_f64() * 1e3;
    let w4 = Bvh4::from_bvh(&bvh, tris);
    let out: Out = a.common.out();
    out.note(&format!(
        "{} ({} triangles, {}): {} rays; bvh8: {} nodes, {} packets ({:.2} refs/packet), collapse {collapse_ms:.0} ms",
        scene.name,
        tris.len(),
        a.builder,
        rays.len(),
        w8.node_count(),
        w8.packet_count(),
        w8.reference_count() as f64 / w8.packet_count().max(1) as f64,
    ));
    let work = [
        work("bvh2", rays, |r, c| {
            scalar::closest_hit(&bvh, tris, r, c);
        }),
        work("bvh4", rays, |r, c| {
            w4.closest_hit(r, c);
        }),
        work("bvh8", rays, |r, c| {
            w8.closest_hit(r, c);
        }),
    ];
    let names = ["bvh2 scalar", "bvh4", "bvh8"];
    let timed: Vec<usize> = ["bvh2", "bvh4", "bvh8"]
        .iter()
        .enumerate()
        .filter(|(_, k)| a.kernels.iter().any(|w| w == *k))
        .map(|(i, _)| i)
        .collect();
    let mut speeds: [Vec<f64>; 3] = Default::default();
    let mut checks: [Option<u64>; 3] = [None; 3];
    for round in 0..a.rounds.max(1) {
        for j in 0..timed.len() {
            let i = timed[(j + round) % timed.len()];
            let (m, check) = match i {
                0 => speed(rays, a.passes, |r| {
                    scalar::closest_hit(&bvh, tris, r, &mut NoStats)
                }),
                1 => speed(rays, a.passes, |r| w4.closest_hit(r, &mut NoStats)),
                _ => speed(rays, a.passes, |r| w8.closest_hit(r, &mut NoStats)),
            };
            speeds[i].push(m);
            checks[i] = Some(check);
        }
    }
    let mut sums = checks.iter().flatten();
    let first = sums.next();
    if !sums.all(|c| Some(c) == first) {
        bail!("the kernels disagree on {}", scene.name);
    }
    out.header(&[&format!(
        "{:<12} {:>8} {:>15} {:>9}   work per ray (inner, leaves, triangles)",
        "kernel", "Mrays/s", "range", "vs bvh8"
    )]);
    let mut rows = Vec::new();
    for &i in &timed {
        let s = &speeds[i];
        let ratios: Vec<f64> = s.iter().zip(&speeds[2]).map(|(a, b)| a / b).collect();
        let row = KernelRow {
            scene: scene.name.clone(),
            builder: a.builder.clone(),
            ray_set: a.rays.clone(),
            rays: rays.len(),
            kernel: names[i].to_string(),
            mrays_s: util::Spread::of(s),
            vs_bvh8: (!ratios.is_empty()).then(|| util::Spread::of(&ratios).median),
            inner: work[i].inner,
            leaves: work[i].leaves,
            triangles: work[i].triangles,
        };
        out.keep(&mut rows, row)?;
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{parse, temp_dir};
    use super::super::What;
    use super::*;

    #[test]
    fn wide_bench_runs_on_a_tiny_scene() {
        let What::WideBench(a) = parse(&[
            "wide-bench",
            "--scene",
            "sphere_in_box:1000",
            "--width",
            "32",
            "--height",
            "24",
            "--passes",
            "1",
        ])
        .unwrap() else {
            panic!()
        };
        assert_eq!(a.leaf, 4);
        let r = wide_bench(&a)
            .unwrap()
            .expect("a procedural scene is never missing");
        let backends = Backend::ALL.iter().filter(|b| b.is_available()).count();
        assert_eq!(r.kernels.len(), 1 + 2 * backends);
        assert_eq!(r.kernels[0].vs_bvh2, 1.0);
        assert!(r.kernels.iter().all(|k| k.mrays_s > 0.0), "{:?}", r.kernels);
        assert_eq!(r.rays, 32 * 24);
        // The camera is inside the closed box: every ray hits, and tests a triangle.
        assert_eq!(r.hit_fraction, 1.0);
        assert!(r.work.iter().all(|w| w.triangles >= 1.0), "{:?}", r.work);
        assert!(r.builder.contains("leaves <= 4"), "{}", r.builder);
        assert!(r.line().contains("bvh8 "), "{}", r.line());
        // A registered builder instead, and a missing scene.
        let What::WideBench(a) = parse(&[
            "wide-bench",
            "--scene",
            "soup:500",
            "--builder",
            "sweep",
            "--width",
            "16",
            "--height",
            "12",
            "--passes",
            "1",
            "--json",
        ])
        .unwrap() else {
            panic!()
        };
        let r = wide_bench(&a).unwrap().unwrap();
        assert!(r.builder.contains("sweep"), "{}", r.builder);
        let What::WideBench(a) = parse(&["wide-bench", "--scene", "no_such_scene"]).unwrap() else {
            panic!()
        };
        assert!(wide_bench(&a).unwrap().is_none());
    }

    #[test]
    fn kernels_run_on_generated_rays_and_on_a_ray_file() {
        let base = [
            "kernels",
            "--scene",
            "sphere_in_box:1000",
            "--width",
            "16",
            "--height",
            "12",
            "--passes",
            "1",
            "--rounds",
            "2",
        ];
        let with = |extra: &[&str]| {
            let v: Vec<&str> = base.iter().chain(extra).copied().collect();
            match parse(&v).unwrap() {
                What::Kernels(a) => a,
                _ => panic!(),
            }
        };
        let rows = kernels(&with(&["--rays", "diffuse"])).unwrap();
        let names: Vec<&str> = rows.iter().map(|r| r.kernel.as_str()).collect();
        assert_eq!(names, ["bvh2 scalar", "bvh4", "bvh8"]);
        assert_eq!(rows[2].vs_bvh8, Some(1.0));
        assert!(rows
            .iter()
            .all(|r| r.rays == 16 * 12 && r.mrays_s.min > 0.0));
        assert!(rows.iter().all(|r| r.mrays_s.min <= r.mrays_s.median));

        // The same scene's primary rays through a file, bvh2 alone: no ratio to bvh8.
        let dir = temp_dir("kernels");
        let file = dir.join("primary.rays");
        let scene = util::load_scene("sphere_in_box:1000").unwrap();
        let camera = scene.camera;
        let rays = RaySet::primary(&camera, 10, 7).rays;
        sahara_trace::write_rays(&file, &rays).unwrap();
        let path = file.to_str().unwrap();
        let rows = kernels(&with(&["--rays", path, "--kernels", "bvh2", "--json"])).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!((rows[0].rays, rows[0].vs_bvh8), (70, None));
        assert!(rows[0].triangles >= 1.0);
        assert!(kernels(&with(&["--rays", "no/such/file.rays"])).is_err());
        assert!(parse(&[
            "kernels",
            "--scene",
            "soup",
            "--rays",
            "ao",
            "--kernels",
            "bvh16"
        ])
        .is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
