//! `cargo xtask scaling`: build time against N, with the fitted exponent of N per builder.
//!
//! Each builder builds procedural scenes of growing size; the exponent `b` of
//! `time ≈ a · N^b` is fitted by least squares on `log time` against `log N`. An
//! `N log N` builder shows `b` a little above 1, an `N log² N` builder a little more, a
//! quadratic one 2.

use crate::util::{self, Spread};
use anyhow::Result;
use sahara_builders::{BuildInput, CostModel};
use sahara_scene::Procedural;
use serde::Serialize;

#[derive(clap::Args)]
pub struct Args {
    /// Builders (default: every registered builder that is not for small inputs only).
    #[arg(long, value_delimiter = ',')]
    builders: Vec<String>,
    /// Procedural scene to scale.
    #[arg(long, default_value = "soup")]
    scene: String,
    /// Triangle counts.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1000,10000,100000,1000000"
    )]
    sizes: Vec<usize>,
    /// Timed builds per size (the median is used).
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Stop a builder's series once one build takes longer than this many seconds.
    #[arg(long, default_value_t = 600.0)]
    max_seconds: f64,
    /// Rayon threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
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
pub fn measure(
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

pub fn default_builders() -> Vec<String> {
    sahara_builders::registry::entries()
        .into_iter()
        .filter(|e| !e.small_inputs_only)
        .map(|e| e.name.to_string())
        .collect()
}

pub fn run(a: Args) -> Result<()> {
    let builders = if a.builders.is_empty() {
        default_builders()
    } else {
        a.builders.clone()
    };
    let scene = Procedural::from_name(&a.scene)
        .ok_or_else(|| anyhow::anyhow!("'{}' is not a procedural scene", a.scene))?;
    let series = measure(
        &builders,
        scene,
        &a.sizes,
        a.runs,
        a.max_seconds,
        a.threads,
        a.builders.is_empty(),
        |b, n, s| eprintln!("{b:<16} N = {n:>9}: {:.3} s", s),
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&series)?);
        return Ok(());
    }
    println!(
        "build time (median of {} runs, {} threads) on procedural '{}'",
        a.runs,
        util::thread_count(a.threads),
        a.scene
    );
    print!("{:<16}", "builder");
    for n in &a.sizes {
        print!(" {:>12}", format!("N={n}"));
    }
    println!(" {:>8} {:>10}", "exp(all)", "exp(N≥1e4)");
    for s in &series {
        print!("{:<16}", s.builder);
        for i in 0..a.sizes.len() {
            match s.points.get(i) {
                Some((_, t)) => print!(" {:>10.3}ms", t.median * 1e3),
                None => print!(" {:>12}", "-"),
            }
        }
        let f = |e: Option<f64>| e.map_or("-".into(), |e| format!("{e:.2}"));
        println!(" {:>8} {:>10}", f(s.exponent), f(s.exponent_large));
    }
    Ok(())
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
