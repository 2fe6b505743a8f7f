//! One trace measurement: an engine's tracer timed on a ray set and its work counted, and the
//! record of it ([`TraceReport`], the JSON of `cargo xtask trace --json` and a row of the
//! evaluation).

use super::Engine;
use crate::util;
use anyhow::Result;
use sahara_trace::{measure, trace_set, trace_set_counted, RaySet, Throughput, Tracer, WorkPerRay};
use serde::Serialize;

/// The JSON record of one trace measurement (its fields are a contract: `docs/command-line.md`).
#[derive(Clone, Debug, Serialize)]
pub struct TraceReport {
    pub scene: String,
    pub triangles: usize,
    pub builder: String,
    pub layout: String,
    /// The kernels that ran: the SIMD backend of bvh4/bvh8, `scalar` for bvh2, the ISA asked
    /// of Embree (or `default`), `avx2` for tinybvh, `default` for obvhs.
    pub backend: String,
    /// The triangle test: `exact` or `fast` for sahara's layouts, `native` for foreign engines.
    pub precision: String,
    pub ray_kind: String,
    pub rays: usize,
    pub threads: usize,
    pub mrays_s: Throughput,
    pub trace_ms: sahara_trace::Timing,
    pub work: WorkPerRay,
    pub inner_per_ray: f64,
    pub leaves_per_ray: f64,
    pub triangles_per_ray: f64,
    /// Standard deviation of the leaves visited per ray (leaf count variability).
    pub lcv: f64,
    pub hits: usize,
    pub checksum: String,
}

/// Times `set` through `tracer` (one warm-up, `passes` timed passes) and counts its work.
pub fn measure_trace(
    tracer: &dyn Tracer,
    set: &RaySet,
    threads: Option<usize>,
    passes: usize,
) -> Result<(
    sahara_trace::Timing,
    sahara_trace::CountedTrace<sahara_trace::TraceResults>,
)> {
    util::with_threads(threads, || {
        let timing = measure(passes.max(1), 1, || trace_set(tracer, set));
        let counted = trace_set_counted(tracer, set);
        (timing, counted)
    })
}

/// Assembles the report of one measurement.
#[allow(clippy::too_many_arguments)]
pub fn report(
    scene: &str,
    triangles: usize,
    builder: &str,
    engine: Engine,
    backend: &str,
    precision: sahara_traverse::Precision,
    set: &RaySet,
    threads: Option<usize>,
    timing: sahara_trace::Timing,
    counted: &sahara_trace::CountedTrace<sahara_trace::TraceResults>,
) -> TraceReport {
    let work = counted.per_ray();
    let leaves: Vec<u32> = counted.work.iter().map(|w| w.leaves as u32).collect();
    TraceReport {
        scene: scene.to_string(),
        triangles,
        builder: builder.to_string(),
        layout: engine.name().to_string(),
        backend: backend.to_string(),
        precision: engine.precision_name(precision).to_string(),
        ray_kind: set.kind.name().to_string(),
        rays: set.len(),
        threads: util::thread_count(threads),
        mrays_s: timing.mrays_per_s(set.len()),
        trace_ms: timing.millis(),
        work,
        inner_per_ray: work.inner,
        leaves_per_ray: work.leaves,
        triangles_per_ray: work.triangles,
        lcv: sahara_metrics::lcv(&leaves),
        hits: counted.results.hit_count(),
        checksum: format!("{:016x}", counted.results.checksum()),
    }
}
