//! The SAH-EPO trace-cost predictor of Aila, Karras and Laine (2013): fitting its weight and
//! measuring its forecasting error.
//!
//! The predictor is `predicted = (1 - α) SAH + α EPO`, with every quantity of a scene
//! **normalised to that scene's reference builder** (the full-sweep SAH tree, registry name
//! `"sweep"`): a sample's SAH, EPO and measured cost are divided by those of the reference tree
//! on the same scene and ray set. The normalised predictor of the reference is therefore exactly
//! 1, and the predictor forecasts how much faster or slower than the reference a tree traces.
//!
//! `α` is fitted per ray type (call [`SahEpoPredictor::fit`] once per ray type, with the
//! samples of that ray type) by minimising the squared relative error over every non-reference
//! sample of every scene:
//!
//! ```text
//! α* = argmin_α Σ_i ((1-α) s_i + α e_i - m_i)² / m_i²
//!    = Σ_i (e_i - s_i)(m_i - s_i) / m_i²  /  Σ_i (e_i - s_i)² / m_i²       (clamped to [0, 1])
//! ```
//!
//! with `s, e, m` the normalised SAH, EPO and measured cost. The measured quantity is whatever
//! the caller passes: measured time per ray or deterministic work per ray.
//!
//! The same machinery fits the improved primary-ray predictor: pass the camera-weighted SAH
//! and the visible end-point overlap of [`crate::weighted`] as `sah` and `epo`.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;

/// One tree's metrics and measured trace cost for one ray type.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PredictorSample {
    /// The scene (samples are normalised per scene).
    pub scene: String,
    /// The builder that made the tree (the reference builder's sample normalises its scene).
    pub builder: String,
    /// The tree's SAH cost (or the SAH-like term of the predictor, e.g. a camera-weighted SAH).
    pub sah: f64,
    /// The tree's EPO (or the EPO-like term of the predictor).
    pub epo: f64,
    /// The measured cost of tracing the ray type: time per ray or work per ray. Must be > 0.
    pub measured: f64,
}

/// The linear SAH-EPO predictor on per-scene normalised quantities.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SahEpoPredictor {
    /// Weight of EPO: `predicted = (1 - α) SAH + α EPO`.
    pub alpha: f64,
}

/// Forecasting error of a predictor against measurement (see [`SahEpoPredictor::report`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForecastReport {
    /// The predictor's `α`.
    pub alpha: f64,
    /// Number of non-reference samples the errors are taken over.
    pub samples: usize,
    /// Mean of `|predicted - measured| / measured` over non-reference samples (normalised
    /// quantities).
    pub mean_relative_error: f64,
    /// Maximum of the same relative errors.
    pub max_relative_error: f64,
    /// Spearman rank correlation between normalised predicted and measured costs, pooled over
    /// all scenes (non-reference samples); `None` with fewer than two samples or when either
    /// side is constant.
    pub spearman: Option<f64>,
    /// Mean over scenes of the Spearman correlation between predicted and measured cost of
    /// the scene's builders (reference included), over scenes where it is defined.
    pub mean_scene_spearman: Option<f64>,
}

/// Why samples cannot be normalised or fitted.
#[derive(Clone, Debug, PartialEq)]
pub enum FitError {
    /// A scene has no sample from the reference builder.
    MissingReference {
        /// The scene.
        scene: String,
    },
    /// A scene has several samples from the reference builder.
    DuplicateReference {
        /// The scene.
        scene: String,
    },
    /// A sample has a quantity that is not finite and positive (`sah`, `epo` of the reference
    /// and every `measured` must be; other `sah` and `epo` must be finite and non-negative).
    BadValue {
        /// The scene.
        scene: String,
        /// The builder.
        builder: String,
        /// Which quantity (`"sah"`, `"epo"` or `"measured"`).
        quantity: &'static str,
    },
    /// No non-reference sample distinguishes SAH from EPO (`Σ (e - s)² / m² = 0` up to
    /// rounding), so `α` is undetermined.
    Degenerate,
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitError::MissingReference { scene } => {
                write!(f, "scene {scene} has no reference-builder sample")
            }
            FitError::DuplicateReference { scene } => {
                write!(f, "scene {scene} has several reference-builder samples")
            }
            FitError::BadValue {
                scene,
                builder,
                quantity,
            } => write!(
                f,
                "{quantity} of {builder} on {scene} is not a valid positive finite number"
            ),
            FitError::Degenerate => write!(f, "SAH and EPO never differ: alpha is undetermined"),
        }
    }
}

impl std::error::Error for FitError {}

impl SahEpoPredictor {
    /// `α = 0.71`, the value commonly quoted from Aila et al. (2013).
    pub const AILA: SahEpoPredictor = SahEpoPredictor { alpha: 0.71 };

    /// `(1 - α) sah + α epo`.
    #[inline]
    pub fn predict(&self, sah: f64, epo: f64) -> f64 {
        (1.0 - self.alpha) * sah + self.alpha * epo
    }

    /// Fits `α` by least squares on relative errors of the per-scene normalised samples (see
    /// the [module documentation](crate::predictor)), clamped to `[0, 1]`.
    ///
    /// `samples` are the samples of one ray type, from any number of scenes and builders;
    /// `reference` is the builder every scene is normalised to (`"sweep"`).
    pub fn fit(samples: &[PredictorSample], reference: &str) -> Result<Self, FitError> {
        let norm = normalise(samples, reference)?;
        let (mut num, mut den, mut scale) = (0.0f64, 0.0f64, 0.0f64);
        for s in norm.iter().filter(|s| s.builder != reference) {
            let w = 1.0 / (s.measured * s.measured);
            let d = s.epo - s.sah;
            num += w * d * (s.measured - s.sah);
            den += w * d * d;
            scale += w * (s.sah * s.sah + s.epo * s.epo);
        }
        // SAH and EPO equal up to rounding (relative differences below ~1e-12) leave α
        // undetermined.
        if den.is_nan() || den <= 1e-24 * scale || !den.is_finite() {
            return Err(FitError::Degenerate);
        }
        Ok(Self {
            alpha: (num / den).clamp(0.0, 1.0),
        })
    }

    /// The forecasting error of this predictor on `samples` (normalised per scene to
    /// `reference`). The reference samples are exact by construction and excluded from the
    /// error statistics and the pooled Spearman correlation; they take part in the per-scene
    /// rank correlations.
    pub fn report(
        &self,
        samples: &[PredictorSample],
        reference: &str,
    ) -> Result<ForecastReport, FitError> {
        let norm = normalise(samples, reference)?;
        let others: Vec<&PredictorSample> =
            norm.iter().filter(|s| s.builder != reference).collect();
        let errors: Vec<f64> = others
            .iter()
            .map(|s| (self.predict(s.sah, s.epo) - s.measured).abs() / s.measured)
            .collect();
        let mean = if errors.is_empty() {
            0.0
        } else {
            errors.iter().sum::<f64>() / errors.len() as f64
        };
        let max = errors.iter().copied().fold(0.0f64, f64::max);
        let pred: Vec<f64> = others.iter().map(|s| self.predict(s.sah, s.epo)).collect();
        let meas: Vec<f64> = others.iter().map(|s| s.measured).collect();
        let pooled = spearman(&pred, &meas);

        let mut per_scene: BTreeMap<&str, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
        for s in &norm {
            let e = per_scene.entry(s.scene.as_str()).or_default();
            e.0.push(self.predict(s.sah, s.epo));
            e.1.push(s.measured);
        }
        let rhos: Vec<f64> = per_scene
            .values()
            .filter_map(|(p, m)| spearman(p, m))
            .collect();
        let mean_scene = if rhos.is_empty() {
            None
        } else {
            Some(rhos.iter().sum::<f64>() / rhos.len() as f64)
        };
        Ok(ForecastReport {
            alpha: self.alpha,
            samples: errors.len(),
            mean_relative_error: mean,
            max_relative_error: max,
            spearman: pooled,
            mean_scene_spearman: mean_scene,
        })
    }
}

/// The samples with `sah`, `epo` and `measured` divided by those of the `reference` builder's
/// sample on the same scene (input order kept; the reference samples become `1, 1, 1`).
pub fn normalise(
    samples: &[PredictorSample],
    reference: &str,
) -> Result<Vec<PredictorSample>, FitError> {
    let bad = |s: &PredictorSample, quantity| FitError::BadValue {
        scene: s.scene.clone(),
        builder: s.builder.clone(),
        quantity,
    };
    let mut refs: BTreeMap<&str, &PredictorSample> = BTreeMap::new();
    for s in samples {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let nonneg = |x: f64| x.is_finite() && x >= 0.0;
        if !pos(s.measured) {
            return Err(bad(s, "measured"));
        }
        let is_ref = s.builder == reference;
        if !(if is_ref { pos(s.sah) } else { nonneg(s.sah) }) {
            return Err(bad(s, "sah"));
        }
        if !(if is_ref { pos(s.epo) } else { nonneg(s.epo) }) {
            return Err(bad(s, "epo"));
        }
        if is_ref && refs.insert(s.scene.as_str(), s).is_some() {
            return Err(FitError::DuplicateReference {
                scene: s.scene.clone(),
            });
        }
    }
    samples
        .iter()
        .map(|s| {
            let r = refs
                .get(s.scene.as_str())
                .ok_or_else(|| FitError::MissingReference {
                    scene: s.scene.clone(),
                })?;
            Ok(PredictorSample {
                scene: s.scene.clone(),
                builder: s.builder.clone(),
                sah: s.sah / r.sah,
                epo: s.epo / r.epo,
                measured: s.measured / r.measured,
            })
        })
        .collect()
}

/// Ranks `1..=n` of the values, ties sharing the average of the ranks they span.
///
/// ```
/// assert_eq!(sahara_metrics::average_ranks(&[10.0, 20.0, 10.0]), vec![1.5, 3.0, 1.5]);
/// ```
pub fn average_ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut ranks = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i + 1;
        while j < idx.len() && x[idx[j]] == x[idx[i]] {
            j += 1;
        }
        // Ranks i+1 ..= j share their mean.
        let r = (i + 1 + j) as f64 / 2.0;
        for &k in &idx[i..j] {
            ranks[k] = r;
        }
        i = j;
    }
    ranks
}

/// Spearman's rank correlation: the Pearson correlation of the [`average_ranks`] of `x` and
/// `y` (the correct form with ties). `None` when the lengths differ, there are fewer than two
/// values, or either side is constant.
///
/// ```
/// let rho = sahara_metrics::spearman(&[1.0, 2.0, 3.0], &[1.0, 4.0, 9.0]).unwrap();
/// assert!((rho - 1.0).abs() < 1e-12);
/// ```
pub fn spearman(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() != y.len() || x.len() < 2 {
        return None;
    }
    pearson(&average_ranks(x), &average_ranks(y))
}

/// Pearson's correlation coefficient; `None` when undefined (as for [`spearman`]).
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    if x.len() != y.len() || x.len() < 2 {
        return None;
    }
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (dx, dy) = (a - mx, b - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    Some((sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0))
}
