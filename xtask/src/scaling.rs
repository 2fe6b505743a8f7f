//! `cargo xtask scaling`: build time against N, with the fitted exponent of N per builder.
//!
//! Each builder builds procedural scenes of growing size; the exponent `b` of
//! `time ≈ a · N^b` is fitted by least squares on `log time` against `log N`. An
//! `N log N` builder shows `b` a little above 1, an `N log² N` builder a little more, a
//! quadratic one 2.

use crate::{tree, util};
use anyhow::Result;
use sahara_scene::Procedural;

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

pub fn run(a: Args) -> Result<()> {
    let builders = if a.builders.is_empty() {
        tree::builders_for_large_inputs()
    } else {
        a.builders.clone()
    };
    let scene = Procedural::from_name(&a.scene)
        .ok_or_else(|| anyhow::anyhow!("'{}' is not a procedural scene", a.scene))?;
    let series = tree::measure_scaling(
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
