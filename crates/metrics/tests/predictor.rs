//! Fitting the SAH-EPO predictor and measuring forecasting errors on synthetic data.

use proptest::prelude::*;
use sahara_geom::rng::Pcg32;
use sahara_metrics::{average_ranks, lcv, spearman, FitError, PredictorSample, SahEpoPredictor};

/// Scenes × builders of unnormalised samples whose normalised measured cost is exactly
/// `(1 - alpha) s + alpha e` (times `1 + noise · u`, u uniform in [-1, 1]).
fn synthetic(alpha: f64, noise: f64, seed: u64) -> Vec<PredictorSample> {
    let mut rng = Pcg32::new(seed, 3);
    let mut out = Vec::new();
    for scene in 0..4 {
        // Per-scene scales of the raw quantities: normalisation must remove them.
        let (ks, ke, km) = (
            10.0 + scene as f64 * 7.0,
            0.5 + scene as f64,
            1e-6 * (1.0 + scene as f64),
        );
        for b in 0..7 {
            let (s, e) = if b == 0 {
                (1.0, 1.0)
            } else {
                (
                    0.7 + 0.6 * rng.next_f32() as f64,
                    0.6 + 0.8 * rng.next_f32() as f64,
                )
            };
            let m = ((1.0 - alpha) * s + alpha * e)
                * (1.0 + noise * (2.0 * rng.next_f32() as f64 - 1.0));
            let m = if b == 0 { 1.0 } else { m };
            out.push(PredictorSample {
                scene: format!("scene{scene}"),
                builder: if b == 0 {
                    "sweep".into()
                } else {
                    format!("b{b}")
                },
                sah: s * ks,
                epo: e * ke,
                measured: m * km,
            });
        }
    }
    out
}

#[test]
fn recovers_a_known_alpha() {
    for alpha in [0.0, 0.3, 0.71, 1.0] {
        let samples = synthetic(alpha, 0.0, 1);
        let p = SahEpoPredictor::fit(&samples, "sweep").unwrap();
        assert!(
            (p.alpha - alpha).abs() < 1e-9,
            "fitted {} for {alpha}",
            p.alpha
        );
        let r = p.report(&samples, "sweep").unwrap();
        assert_eq!(r.samples, 4 * 6);
        assert!(
            r.mean_relative_error < 1e-9 && r.max_relative_error < 1e-9,
            "{r:?}"
        );
        assert!((r.spearman.unwrap() - 1.0).abs() < 1e-12);
        assert!((r.mean_scene_spearman.unwrap() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn noisy_fit_is_close_and_reports_errors() {
    let samples = synthetic(0.6, 0.02, 2);
    let p = SahEpoPredictor::fit(&samples, "sweep").unwrap();
    assert!((p.alpha - 0.6).abs() < 0.1, "{}", p.alpha);
    let r = p.report(&samples, "sweep").unwrap();
    assert!(r.mean_relative_error > 0.0 && r.mean_relative_error <= r.max_relative_error);
    assert!(r.max_relative_error < 0.03, "{r:?}");
    // The fitted alpha minimises the squared relative error: nudging it makes it worse.
    let sq = |a: f64| {
        let p = SahEpoPredictor { alpha: a };
        let n = sahara_metrics::predictor::normalise(&samples, "sweep").unwrap();
        n.iter()
            .map(|s| ((p.predict(s.sah, s.epo) - s.measured) / s.measured).powi(2))
            .sum::<f64>()
    };
    assert!(sq(p.alpha) <= sq(p.alpha + 1e-3) && sq(p.alpha) <= sq(p.alpha - 1e-3));
}

#[test]
fn alpha_is_clamped() {
    // Measured cost follows 1.5 EPO - 0.5 SAH: least squares gives 1.5, clamped to 1.
    let samples = synthetic(1.5, 0.0, 3);
    assert_eq!(SahEpoPredictor::fit(&samples, "sweep").unwrap().alpha, 1.0);
    let samples = synthetic(-0.4, 0.0, 3);
    assert_eq!(SahEpoPredictor::fit(&samples, "sweep").unwrap().alpha, 0.0);
}

#[test]
fn errors() {
    let mut samples = synthetic(0.5, 0.0, 4);
    assert!(matches!(
        SahEpoPredictor::fit(&samples, "nope"),
        Err(FitError::MissingReference { .. })
    ));
    let mut dup = samples.clone();
    dup.push(samples[0].clone());
    assert!(matches!(
        SahEpoPredictor::fit(&dup, "sweep"),
        Err(FitError::DuplicateReference { .. })
    ));
    for s in samples.iter_mut() {
        s.epo = s.sah * 3.0; // normalised EPO == normalised SAH everywhere
    }
    assert_eq!(
        SahEpoPredictor::fit(&samples, "sweep"),
        Err(FitError::Degenerate)
    );
    samples[3].measured = 0.0;
    assert!(matches!(
        SahEpoPredictor::fit(&samples, "sweep"),
        Err(FitError::BadValue {
            quantity: "measured",
            ..
        })
    ));
}

#[test]
fn aila_predictor() {
    assert_eq!(SahEpoPredictor::AILA.alpha, 0.71);
    assert!((SahEpoPredictor::AILA.predict(1.0, 2.0) - 1.71).abs() < 1e-12);
}

#[test]
fn spearman_with_ties() {
    assert_eq!(average_ranks(&[3.0, 1.0, 2.0]), vec![3.0, 1.0, 2.0]);
    assert_eq!(average_ranks(&[5.0, 5.0, 5.0]), vec![2.0, 2.0, 2.0]);
    assert_eq!(
        average_ranks(&[1.0, 2.0, 2.0, 3.0]),
        vec![1.0, 2.5, 2.5, 4.0]
    );
    // Ranks (1, 2.5, 2.5, 4) against (1, 2, 3, 4): 4.5 / sqrt(4.5 · 5).
    let rho = spearman(&[1.0, 2.0, 2.0, 3.0], &[10.0, 20.0, 30.0, 40.0]).unwrap();
    assert!((rho - 4.5 / (4.5f64 * 5.0).sqrt()).abs() < 1e-12);
    assert!((spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap() + 1.0).abs() < 1e-12);
    assert_eq!(spearman(&[1.0, 1.0], &[1.0, 2.0]), None);
    assert_eq!(spearman(&[1.0], &[1.0]), None);
    assert_eq!(spearman(&[1.0, 2.0], &[1.0]), None);
}

#[test]
fn lcv_is_population_deviation() {
    assert_eq!(lcv(&[]), 0.0);
    assert_eq!(lcv(&[7]), 0.0);
    assert_eq!(lcv(&[4, 4, 4]), 0.0);
    assert!((lcv(&[2, 4, 4, 4, 5, 5, 7, 9]) - 2.0).abs() < 1e-12);
    assert!((lcv(&[0, 10]) - 5.0).abs() < 1e-12);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn spearman_of_monotone_relation_is_one(xs in proptest::collection::vec(-1e3f64..1e3, 2..40)) {
        let ys: Vec<f64> = xs.iter().map(|x| x.powi(3) + 2.0 * x).collect();
        match spearman(&xs, &ys) {
            Some(r) => prop_assert!((r - 1.0).abs() < 1e-12),
            None => prop_assert!(xs.iter().all(|&x| x == xs[0])),
        }
    }

    #[test]
    fn lcv_is_shift_invariant(xs in proptest::collection::vec(0u32..1000, 0..50), k in 0u32..1000) {
        let shifted: Vec<u32> = xs.iter().map(|x| x + k).collect();
        prop_assert!((lcv(&xs) - lcv(&shifted)).abs() < 1e-9);
    }
}
