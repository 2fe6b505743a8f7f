//! Building trees and measuring them, shared by `bvh`, `eval` and `scaling`: one builder's
//! tree on one scene with its build times, SAH, EPO, shape and memory ([`BuildReport`],
//! [`MemoryReport`]), and build time against the number of triangles with its fitted exponent
//! ([`Series`], [`measure_scaling`]). Not a command.

use crate::util::{self, Spread};
use anyhow::Result;
use sahara_builders::{BuildInput, CostModel};
use sahara_scene::Procedural;
use serde::Serialize;

/// The JSON record of one build (its fields are a contract: `docs/command-line.md`).
#[derive(Clone, Debug, Serialize)]
pub struct BuildReport {
    pub scene: String,
    pub triangles: usize,
    pub builder: String,
    pub config: String,
    pub threads: usize,
    pub build_ms: Spread,
    pub sah: f64,
    pub epo: Option<f64>,
    pub nodes: usize,
    pub leaves: usize,
    pub references: usize,
    pub max_leaf: usize,
    pub depth: usize,
}

/// The memory figures of `bvh --json` (field `memory`): exact heap bytes from the xtask's
/// counting allocator ([`crate::alloc_count`]) and the sizes of the traversal layouts.
#[derive(Clone, Debug, Serialize)]
pub struct MemoryReport {
    /// Heap bytes the `BuildInput` (primitive boxes and centroids) allocated.
    pub input_bytes: usize,
    /// The most heap bytes the build held at once above what was live when it started (its
    /// working memory and the tree it returns), the largest over the timed builds.
    pub peak_build_bytes: usize,
    /// `peak_build_bytes` per triangle.
    pub peak_build_bytes_per_triangle: f64,
    /// Bytes per triangle of the binary tree (32-byte nodes and 4-byte references).
    pub bvh2_bytes_per_triangle: f64,
    /// Bytes per triangle of the 4-wide layout (nodes and 4-triangle leaf packets).
    pub bvh4_bytes_per_triangle: f64,
    /// Bytes per triangle of the 8-wide layout (nodes and 4-triangle leaf packets).
    pub bvh8_bytes_per_triangle: f64,
}

/// Builds `runs` times on `threads` threads and measures the last tree (its EPO only
/// `with_epo`); also returns the input's heap bytes and the builds' peak heap bytes (see
/// [`MemoryReport`]).
pub fn build_and_measure(
    scene: &str,
    tris: &[sahara_geom::Triangle],
    builder_name: &str,
    threads: Option<usize>,
    runs: usize,
    with_epo: bool,
) -> Result<(BuildReport, sahara_bvh::Bvh, usize, usize)> {
    let builder = util::builder(builder_name)?;
    let cost = CostModel::default();
    let before_input = crate::alloc_count::reset_peak();
    let input = BuildInput::new(tris, cost)?;
    let input_bytes = crate::alloc_count::live().saturating_sub(before_input);
    let mut peak = 0usize;
    let (times, bvh) = util::with_threads(threads, || {
        util::time_runs(runs, || {
            let base = crate::alloc_count::reset_peak();
            let r = builder.build(&input);
            peak = peak.max(crate::alloc_count::peak().saturating_sub(base));
            r
        })
    })?;
    let bvh = bvh?;
    let stats = bvh.stats();
    let epo = if with_epo {
        Some(util::with_threads(threads, || {
            sahara_metrics::epo(&bvh, tris, &cost)
        })?)
    } else {
        None
    };
    let report = BuildReport {
        scene: scene.to_string(),
        triangles: tris.len(),
        builder: builder_name.to_string(),
        config: builder.describe(),
        threads: util::with_threads(threads, rayon::current_num_threads)?,
        build_ms: Spread::of(&times).map(|s| s * 1e3),
        sah: sahara_metrics::sah(&bvh, &cost),
        epo,
        nodes: stats.nodes,
        leaves: stats.leaves,
        references: stats.references,
        max_leaf: stats.max_leaf,
        depth: stats.depth,
    };
    Ok((report, bvh, input_bytes, peak))
}

/// The memory figures of a build (see [`MemoryReport`]).
pub fn memory_report(
    bvh: &sahara_bvh::Bvh,
    tris: &[sahara_geom::Triangle],
    input_bytes: usize,
    peak_build_bytes: usize,
) -> MemoryReport {
    let per = |bytes: usize| bytes as f64 / tris.len().max(1) as f64;
    let bvh2 = bvh.nodes.len() * std::mem::size_of::<sahara_bvh::Node>()
        + bvh.prim_indices.len() * std::mem::size_of::<u32>();
    let bvh4 = sahara_traverse::wide::WideBvh::<4>::from_bvh(bvh, tris).memory_bytes();
    let bvh8 = sahara_traverse::wide::WideBvh::<8>::from_bvh(bvh, tris).memory_bytes();
    MemoryReport {
        input_bytes,
        peak_build_bytes,
        peak_build_bytes_per_triangle: per(peak_build_bytes),
        bvh2_bytes_per_triangle: per(bvh2),
        bvh4_bytes_per_triangle: per(bvh4),
        bvh8_bytes_per_triangle: per(bvh8),
    }
}

/// One builder's series.
#[derive(Clone, Debug, Serialize)]
pub struct Series {
    pub builder: String,
    pub points: Vec<(usize, Spread)>,
    /// Fitted exponent of N over all points.
    pub exponent: Option<f64>,
    /// Fitted exponent over the points with N >= 10^4 (the asymptotic regime).
    pub exponent_large: Option<f64>,
}

/// Least-squares slope of `ln y` against `ln x`.
pub fn fit_exponent(points: &[(f64, f64)]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Measures every builder on every size. With `respect_limits`, a builder stops at sizes above
/// its registry entry's practical limit.
#[allow(clippy::too_many_arguments)]
pub fn measure_scaling(
    builders: &[String],
    scene: Procedural,
    sizes: &[usize],
    runs: usize,
    max_seconds: f64,
    threads: Option<usize>,
    respect_limits: bool,
    mut progress: impl FnMut(&str, usize, f64),
) -> Result<Vec<Series>> {
    let mut out = Vec::new();
    for name in builders {
        let builder = util::builder(name)?;
        let limit = sahara_builders::registry::entries()
            .iter()
            .find(|e| e.name == name.as_str())
            .and_then(|e| e.max_practical_triangles)
            .filter(|_| respect_limits);
        let mut points = Vec::new();
        for &n in sizes {
            if limit.is_some_and(|m| n > m) {
                break;
            }
            let tris = scene.scene(n, sahara_scene::DEFAULT_SEED).triangles();
            let input = BuildInput::new(&tris, CostModel::default())?;
            let (times, bvh) =
                util::with_threads(threads, || util::time_runs(runs, || builder.build(&input)))?;
            bvh?;
            let spread = Spread::of(&times);
            progress(name, tris.len(), spread.median);
            points.push((tris.len(), spread));
            if spread.median > max_seconds {
                break;
            }
        }
        let xy: Vec<(f64, f64)> = points.iter().map(|(n, s)| (*n as f64, s.median)).collect();
        let large: Vec<(f64, f64)> = xy.iter().copied().filter(|p| p.0 >= 1e4).collect();
        out.push(Series {
            builder: name.clone(),
            exponent: fit_exponent(&xy),
            exponent_large: fit_exponent(&large),
            points,
        });
    }
    Ok(out)
}

/// Every registered builder practical at any scene size (not `small_inputs_only`): the
/// default builders of `scaling` and of `eval --full`.
pub fn builders_for_large_inputs() -> Vec<String> {
    sahara_builders::registry::entries()
        .into_iter()
        .filter(|e| !e.small_inputs_only)
        .map(|e| e.name.to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::fit_exponent;

    #[test]
    fn fits_power_laws() {
        let pts: Vec<(f64, f64)> = [1e3, 1e4, 1e5].iter().map(|&n| (n, 3.0 * n * n)).collect();
        assert!((fit_exponent(&pts).unwrap() - 2.0).abs() < 1e-9);
        assert!(fit_exponent(&pts[..1]).is_none());
    }
}
