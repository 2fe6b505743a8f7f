//! 95% intervals for speed ratios, from the per-round ratios of interleaved timing rounds.
//!
//! The eval traces every tree of a scene once per round, all trees in turn, for many short
//! rounds. Within one round the trees see the same machine state, so the ratio of two trees'
//! times in the same round is far steadier than either time. A speed ratio is the median of
//! those per-round ratios; its interval is a percentile bootstrap of that median (resampling
//! rounds with replacement, a fixed seed so that a report is reproducible from its samples).
//! Averages over scenes resample each scene's rounds separately (a stratified bootstrap) and
//! take the geometric mean of the scenes' medians.

use sahara_oracle::SplitMix64;
use serde::Serialize;

/// Bootstrap resamples per interval.
pub const RESAMPLES: usize = 2000;
/// The bootstrap's seed (fixed: the same samples always give the same interval).
pub const SEED: u64 = 0x5a4a_7a15;
/// The interval's coverage.
pub const LEVEL: f64 = 0.95;

/// A ratio with its 95% interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Interval {
    /// The point estimate (median of the per-round ratios, or their scenes' geometric mean).
    pub estimate: f64,
    /// Lower end of the interval.
    pub low: f64,
    /// Upper end of the interval.
    pub high: f64,
}

impl Interval {
    /// True when the interval contains 1: the measurement cannot tell the two trees apart.
    pub fn contains_one(&self) -> bool {
        self.low <= 1.0 && 1.0 <= self.high
    }
}

/// Per-round speed ratios `reference[i] / this[i]` of two trees' trace times in the same
/// rounds (> 1: this tree is faster); rounds with a non-positive or non-finite time are
/// dropped.
pub fn round_ratios(reference: &[f64], this: &[f64]) -> Vec<f64> {
    reference
        .iter()
        .zip(this)
        .filter(|(r, t)| r.is_finite() && t.is_finite() && **r > 0.0 && **t > 0.0)
        .map(|(r, t)| r / t)
        .collect()
}

/// The median of the ratios with its percentile-bootstrap interval (`None` without samples).
pub fn median_interval(ratios: &[f64]) -> Option<Interval> {
    geomean_of_medians_interval(&[ratios.to_vec()])
}

/// The geometric mean over groups (scenes) of each group's median ratio, with a stratified
/// percentile-bootstrap interval: each resample redraws every group's rounds with replacement.
/// Empty groups are ignored; `None` when all are empty or a ratio is not positive.
pub fn geomean_of_medians_interval(groups: &[Vec<f64>]) -> Option<Interval> {
    let groups: Vec<&Vec<f64>> = groups.iter().filter(|g| !g.is_empty()).collect();
    if groups.is_empty()
        || groups.iter().any(|g| {
            g.iter()
                .any(|x| x.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !x.is_finite())
        })
    {
        return None;
    }
    let geomean = |medians: &[f64]| {
        (medians.iter().map(|m| m.ln()).sum::<f64>() / medians.len() as f64).exp()
    };
    let point: Vec<f64> = groups.iter().map(|g| median(&mut g.to_vec())).collect();
    let mut rng = SplitMix64(SEED);
    let mut stats = Vec::with_capacity(RESAMPLES);
    let mut scratch = Vec::new();
    let mut medians = vec![0.0; groups.len()];
    for _ in 0..RESAMPLES {
        for (m, g) in medians.iter_mut().zip(&groups) {
            scratch.clear();
            scratch.extend((0..g.len()).map(|_| g[rng.below(g.len())]));
            *m = median(&mut scratch);
        }
        stats.push(geomean(&medians));
    }
    stats.sort_by(f64::total_cmp);
    let tail = (1.0 - LEVEL) / 2.0;
    Some(Interval {
        estimate: geomean(&point),
        low: quantile(&stats, tail),
        high: quantile(&stats, 1.0 - tail),
    })
}

/// The median (mean of the two middle values for an even count); `v` is reordered.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The `q`-quantile of sorted `v`, linear between closest ranks.
fn quantile(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let i = pos.floor() as usize;
    let j = (i + 1).min(v.len() - 1);
    v[i] + (v[j] - v[i]) * (pos - i as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_pair_rounds_and_drop_bad_ones() {
        let r = round_ratios(&[2.0, 3.0, 0.0, 4.0, f64::NAN], &[1.0, 3.0, 1.0, 8.0, 1.0]);
        assert_eq!(r, vec![2.0, 1.0, 0.5]);
    }

    #[test]
    fn constant_ratios_give_a_point_interval() {
        let i = median_interval(&[1.25; 12]).unwrap();
        assert_eq!((i.estimate, i.low, i.high), (1.25, 1.25, 1.25));
        assert!(!i.contains_one());
    }

    #[test]
    fn known_sample_gives_its_recorded_interval() {
        // Twenty rounds: ratios 1.01, 1.02, …, 1.20 in a scrambled order.
        let ratios: Vec<f64> = (0..20)
            .map(|i| 1.0 + ((i * 7) % 20 + 1) as f64 / 100.0)
            .collect();
        let i = median_interval(&ratios).unwrap();
        assert!((i.estimate - 1.105).abs() < 1e-12, "{i:?}");
        // The percentile bootstrap of the median of 20 evenly spread values (fixed seed).
        assert!(
            (i.low - 1.065).abs() < 1e-9 && (i.high - 1.145).abs() < 1e-9,
            "{i:?}"
        );
        assert!(i.low < i.estimate && i.estimate < i.high);
        assert!(!i.contains_one());
        // Deterministic: the same sample gives the same interval.
        assert_eq!(median_interval(&ratios), Some(i));
    }

    #[test]
    fn interval_straddling_one_is_flagged() {
        let ratios: Vec<f64> = (0..15).map(|i| 0.9 + 0.015 * i as f64).collect();
        let i = median_interval(&ratios).unwrap();
        assert!(i.low < 1.0 && i.high > 1.0, "{i:?}");
        assert!(i.contains_one());
    }

    #[test]
    fn geomean_over_scenes() {
        let i = geomean_of_medians_interval(&[vec![2.0; 5], vec![0.5; 9], vec![]]).unwrap();
        assert!((i.estimate - 1.0).abs() < 1e-12 && i.contains_one());
        assert_eq!(geomean_of_medians_interval(&[vec![]]), None);
        assert_eq!(median_interval(&[1.0, -1.0]), None);
    }
}
