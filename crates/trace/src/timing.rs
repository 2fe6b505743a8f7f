//! Timing: medians of repeated runs, and rays per second.

use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Wall-clock time of repeated runs of one piece of work, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// The median of the timed passes (the mean of the two middle ones for an even count).
    pub median: f64,
    /// The fastest pass.
    pub min: f64,
    /// The slowest pass.
    pub max: f64,
    /// Number of timed passes.
    pub passes: usize,
}

impl Timing {
    /// The statistics of a list of durations in seconds (all zero for an empty list; NaNs
    /// sort last).
    pub fn from_samples(samples: &[f64]) -> Self {
        if samples.is_empty() {
            return Self::default();
        }
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let median = if n % 2 == 1 {
            s[n / 2]
        } else {
            0.5 * (s[n / 2 - 1] + s[n / 2])
        };
        Self {
            median,
            min: s[0],
            max: s[n - 1],
            passes: n,
        }
    }

    /// The same statistics in milliseconds.
    pub fn millis(&self) -> Timing {
        Timing {
            median: self.median * 1e3,
            min: self.min * 1e3,
            max: self.max * 1e3,
            passes: self.passes,
        }
    }

    /// Throughput in millions of rays per second for `rays` rays per pass: the median pass
    /// gives `median`, the slowest pass `min`, the fastest pass `max`.
    pub fn mrays_per_s(&self, rays: usize) -> Throughput {
        Throughput {
            median: mrays_per_s(rays, self.median),
            min: mrays_per_s(rays, self.max),
            max: mrays_per_s(rays, self.min),
        }
    }
}

/// A rate in millions of rays per second.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Throughput {
    /// From the median pass.
    pub median: f64,
    /// From the slowest pass.
    pub min: f64,
    /// From the fastest pass.
    pub max: f64,
}

/// Millions of rays per second: `rays / seconds / 1e6` (`+inf` for a zero duration with rays,
/// 0 for no ray).
pub fn mrays_per_s(rays: usize, seconds: f64) -> f64 {
    if rays == 0 {
        0.0
    } else {
        rays as f64 / seconds / 1e6
    }
}

/// Runs `f` `warmup` times untimed, then `passes` times timed (at least once), and returns the
/// median, minimum and maximum wall-clock time of the timed passes. The result of every call
/// goes through [`std::hint::black_box`] so the work is not optimised away.
///
/// ```
/// let t = sahara_trace::measure(5, 1, || (0..1000u64).sum::<u64>());
/// assert_eq!(t.passes, 5);
/// assert!(t.min <= t.median && t.median <= t.max);
/// ```
pub fn measure<R, F: FnMut() -> R>(passes: usize, warmup: usize, mut f: F) -> Timing {
    for _ in 0..warmup {
        std::hint::black_box(f());
    }
    let samples: Vec<f64> = (0..passes.max(1))
        .map(|_| {
            let start = Instant::now();
            std::hint::black_box(f());
            start.elapsed().as_secs_f64()
        })
        .collect();
    Timing::from_samples(&samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics() {
        let t = Timing::from_samples(&[3.0, 1.0, 2.0, 10.0]);
        assert_eq!((t.median, t.min, t.max, t.passes), (2.5, 1.0, 10.0, 4));
        let t = Timing::from_samples(&[3.0, 1.0, 2.0]);
        assert_eq!(t.median, 2.0);
        let m = t.mrays_per_s(2_000_000);
        assert_eq!((m.median, m.min, m.max), (1.0, 2.0 / 3.0, 2.0));
        assert_eq!(Timing::from_samples(&[]), Timing::default());
        assert_eq!(mrays_per_s(0, 0.0), 0.0);
    }

    #[test]
    fn measure_counts_calls() {
        let mut calls = 0;
        let t = measure(3, 2, || calls += 1);
        assert_eq!((calls, t.passes), (5, 3));
        let t = measure(0, 0, || ());
        assert_eq!(t.passes, 1);
    }
}
