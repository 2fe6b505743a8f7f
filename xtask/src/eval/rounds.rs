//! The timed rounds of a scene and the speed ratios they give: how many rounds fit the
//! budget, every tracer timed round by round in turn, and each row related to the reference
//! trees' rows of the same rounds.

use super::{TraceRow, REFERENCE, SPATIAL_REFERENCE};
use crate::interval;
use sahara_trace::RaySet;

/// The fewest timed rounds the round budget may leave (the bootstrap intervals need a few).
pub const MIN_ROUNDS: usize = 5;

/// How many timed rounds fit `budget` seconds when one round takes `round` seconds: `passes`
/// when they fit (or when the budget is 0, off), else as many as fit, but at least
/// [`MIN_ROUNDS`] (and never more than `passes`).
pub fn rounds_within(round: f64, budget: f64, passes: usize) -> usize {
    if budget <= 0.0 || round <= 0.0 || round * passes as f64 <= budget {
        return passes;
    }
    ((budget / round).floor() as usize).clamp(MIN_ROUNDS.min(passes), passes)
}

/// Times every tracer on `set`: one untimed warm-up round, then `passes` rounds (fewer when
/// they would exceed `budget` seconds, see [`rounds_within`]), each round tracing the whole set
/// once with every tracer in turn; the seconds of every round, per tracer.
pub fn interleaved_timings(
    tracers: &[&dyn sahara_trace::Tracer],
    set: &RaySet,
    passes: usize,
    budget: f64,
) -> Vec<Vec<f64>> {
    let warm_up = std::time::Instant::now();
    for t in tracers {
        std::hint::black_box(sahara_trace::trace_set(*t, set));
    }
    let rounds = rounds_within(warm_up.elapsed().as_secs_f64(), budget, passes.max(1));
    let mut samples = vec![Vec::with_capacity(rounds); tracers.len()];
    for _ in 0..rounds {
        for (i, t) in tracers.iter().enumerate() {
            let t0 = std::time::Instant::now();
            std::hint::black_box(sahara_trace::trace_set(*t, set));
            samples[i].push(t0.elapsed().as_secs_f64());
        }
    }
    samples
}

/// Fills the relative columns of one scene's rows: work ratios, and speed ratios with their
/// intervals from the per-round ratios against the reference's rows of the same layout and
/// rays (the median of the throughput ratio when rounds are missing).
pub fn relate(rows: &mut [TraceRow]) {
    let find = |rows: &[TraceRow], b: &str, r: &TraceRow| {
        rows.iter()
            .find(|x| {
                x.report.builder == b
                    && x.report.layout == r.report.layout
                    && x.report.ray_kind == r.report.ray_kind
            })
            .map(|x| {
                (
                    x.report.mrays_s.median,
                    x.work_cost,
                    x.round_seconds.clone(),
                )
            })
    };
    let snapshot: Vec<TraceRow> = rows.to_vec();
    for r in rows.iter_mut() {
        let speed = |r: &TraceRow, (mrays, _, rounds): &(f64, f64, Vec<f64>)| {
            let ci = interval::median_interval(&interval::round_ratios(rounds, &r.round_seconds));
            let point = ci.map_or(r.report.mrays_s.median / mrays, |i| i.estimate);
            (Some(point), ci)
        };
        if let Some(reference) = find(&snapshot, REFERENCE, r) {
            (r.speed_vs_sweep, r.speed_vs_sweep_ci) = speed(r, &reference);
            r.work_vs_sweep = Some(reference.1 / r.work_cost);
        }
        if let Some(reference) = find(&snapshot, SPATIAL_REFERENCE, r) {
            (r.speed_vs_sbvh, r.speed_vs_sbvh_ci) = speed(r, &reference);
            r.work_vs_sbvh = Some(reference.1 / r.work_cost);
        }
    }
}

#[cfg(test)]
mod round_budget_tests {
    use super::{rounds_within, MIN_ROUNDS};

    #[test]
    fn rounds_that_fit_the_budget_are_all_traced() {
        assert_eq!(rounds_within(1.0, 20.0, 15), 15);
        assert_eq!(rounds_within(1.0, 0.0, 15), 15, "a budget of 0 is off");
        assert_eq!(rounds_within(100.0, 0.0, 15), 15);
    }

    #[test]
    fn slow_rounds_are_cut_but_never_below_the_minimum() {
        assert_eq!(rounds_within(2.0, 20.0, 15), 10);
        assert_eq!(rounds_within(19.0, 20.0, 15), MIN_ROUNDS);
        assert_eq!(rounds_within(19.0, 20.0, 3), 3, "never more than asked for");
    }
}
