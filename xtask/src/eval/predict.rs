//! Fits and scores the trace-cost predictors on the evaluation's own measurements.
//!
//! Per ray type, every tree of every scene gives a sample `(SAH, EPO, measured)`, normalised
//! to the sweep tree of its scene. Predictors:
//!
//! * `SAH` (α = 0);
//! * `SAH-EPO α=0.71` (the value quoted from Aila et al. 2013);
//! * `SAH-EPO fitted` (α fitted per ray type by least squares on relative error);
//! * `ray-weighted SAH-EPO` (our reading of the paper's improved predictor, see
//!   `docs/metrics.md`): the SAH term's surface-area ratios are replaced by the fraction of a
//!   sample of the ray type's own rays (every 16th ray, cut at its closest hit) that reach each
//!   node, so primary rays are weighted by the camera's frustum and secondary rays by where
//!   they really start and end; α is fitted the same way;
//! * `camera SAH-EPO` (primary rays only): frustum-weighted SAH and the EPO of the points the
//!   camera sees (`sahara_trace::weighted::primary_ray_metrics` on a 128-row grid), α fitted.
//!
//! Each predictor is scored against measured time per ray and against work per ray.

use super::{Settings, TraceRow, REFERENCE};
use crate::engine::Engine;
use crate::tree::BuildReport;
use crate::util::LoadedScene;
use anyhow::Result;
use sahara_bvh::Bvh;
use sahara_geom::Ray;
use sahara_metrics::{ForecastReport, PredictorSample, SahEpoPredictor};
use serde::Serialize;

/// One predictor's score for one ray type and one measured quantity.
#[derive(Clone, Debug, Serialize)]
pub struct PredictorRow {
    pub ray_kind: String,
    pub predictor: String,
    pub target: String,
    pub alpha: Option<f64>,
    pub report: Option<ForecastReport>,
    pub note: String,
}

/// A predicted/measured pair (normalised to sweep) for the plots.
#[derive(Clone, Debug, Serialize)]
pub struct PredictedPoint {
    pub ray_kind: String,
    pub predictor: String,
    pub scene: String,
    pub builder: String,
    pub predicted: f64,
    pub measured: f64,
}

/// A scene's trees with the ray sample of each ray type (for the ray-weighted predictor).
pub struct SceneTrees {
    pub scene: LoadedScene,
    pub trees: Vec<(String, Bvh)>,
    /// Per ray type: a sample of its rays with `tmax` cut at the closest hit.
    pub samples: Vec<(String, Vec<Ray>)>,
}

/// Every 16th ray of `rays` (at most 8192), each cut at its closest hit in `hits`.
pub fn ray_sample(rays: &[Ray], hits: Option<&[sahara_trace::Hit]>) -> Vec<Ray> {
    let step = (rays.len() / 8192).max(16);
    rays.iter()
        .enumerate()
        .step_by(step)
        .map(|(i, r)| {
            let mut r = *r;
            if let Some(h) = hits.and_then(|h| h.get(i)) {
                if h.is_hit() {
                    r.tmax = h.t;
                }
            }
            r
        })
        .collect()
}

pub fn evaluate(
    scenes: &[SceneTrees],
    builds: &[BuildReport],
    traces: &[TraceRow],
    s: &Settings,
) -> Result<(Vec<PredictorRow>, Vec<PredictedPoint>)> {
    let layout0 = s.layouts.first().copied().unwrap_or(Engine::Bvh2).name();
    let cost = s.cost_model;
    let mut rows = Vec::new();
    let mut points = Vec::new();
    let kinds: Vec<String> = s
        .rays
        .iter()
        .filter_map(|r| r.parse::<sahara_trace::RayKind>().ok())
        .map(|k| k.name().to_string())
        .collect();
    for kind in &kinds {
        // (scene, builder, sah, epo, ray-weighted sah, time per ray, work per ray)
        let mut raw = Vec::new();
        for st in scenes {
            let sample = st.samples.iter().find(|(k, _)| k == kind).map(|(_, r)| r);
            for (b, bvh) in &st.trees {
                let Some(build) = builds
                    .iter()
                    .find(|x| x.scene == st.scene.name && &x.builder == b)
                else {
                    continue;
                };
                let Some(t) = traces.iter().find(|t| {
                    t.report.scene == st.scene.name
                        && &t.report.builder == b
                        && t.report.layout == layout0
                        && &t.report.ray_kind == kind
                }) else {
                    continue;
                };
                let camera = (kind == "primary").then(|| {
                    let aspect = s.width as f32 / s.height as f32;
                    let grid = sahara_trace::weighted::grid_frame(&st.scene.camera, aspect, 128);
                    let m = sahara_trace::weighted::primary_ray_metrics(
                        bvh,
                        &st.scene.triangles,
                        &cost,
                        &grid,
                    );
                    (m.frustum_sah, m.visible_epo)
                });
                let weighted = sample.map(|rays| {
                    let w = sahara_metrics::segment_node_weights(bvh, rays);
                    sahara_metrics::weighted_sah_from_node_weights(bvh, &cost, &w)
                });
                raw.push((
                    st.scene.name.clone(),
                    b.clone(),
                    build.sah,
                    build.epo.unwrap_or(0.0),
                    weighted,
                    1.0 / t.report.mrays_s.median.max(1e-12),
                    t.work_cost,
                    camera,
                ));
            }
        }
        for (target, pick) in [("time per ray", 0usize), ("work per ray", 1usize)] {
            // 0: SAH and EPO; 1: ray-weighted SAH and EPO; 2: camera SAH and visible EPO.
            let samples = |variant: u8| -> Vec<PredictorSample> {
                raw.iter()
                    .map(|r| {
                        let (sah, epo) = match variant {
                            0 => (r.2, r.3),
                            1 => (r.4.unwrap_or(0.0), r.3),
                            _ => r.7.unwrap_or((0.0, 0.0)),
                        };
                        PredictorSample {
                            scene: r.0.clone(),
                            builder: r.1.clone(),
                            sah,
                            epo,
                            measured: if pick == 0 { r.5 } else { r.6 },
                        }
                    })
                    .collect()
            };
            let plain = samples(0);
            let weighted = samples(1);
            let camera = samples(2);
            let fitted = SahEpoPredictor::fit(&plain, REFERENCE);
            let wfit = SahEpoPredictor::fit(&weighted, REFERENCE);
            let cfit = SahEpoPredictor::fit(&camera, REFERENCE);
            let candidates: Vec<(
                String,
                Result<SahEpoPredictor, String>,
                &Vec<PredictorSample>,
            )> = vec![
                ("SAH".into(), Ok(SahEpoPredictor { alpha: 0.0 }), &plain),
                ("SAH-EPO α=0.71".into(), Ok(SahEpoPredictor::AILA), &plain),
                (
                    "SAH-EPO fitted".into(),
                    fitted.map_err(|e| e.to_string()),
                    &plain,
                ),
                (
                    "ray-weighted SAH-EPO".into(),
                    wfit.map_err(|e| e.to_string()),
                    &weighted,
                ),
            ];
            let mut candidates = candidates;
            if kind == "primary" {
                candidates.push((
                    "camera SAH-EPO".into(),
                    cfit.map_err(|e| e.to_string()),
                    &camera,
                ));
            }
            for (name, pred, smp) in candidates {
                match pred {
                    Ok(p) => {
                        let report = p.report(smp, REFERENCE).ok();
                        if pick == 0 {
                            if let Ok(norm) = sahara_metrics::predictor::normalise(smp, REFERENCE) {
                                for n in norm {
                                    points.push(PredictedPoint {
                                        ray_kind: kind.clone(),
                                        predictor: name.clone(),
                                        scene: n.scene.clone(),
                                        builder: n.builder.clone(),
                                        predicted: p.predict(n.sah, n.epo),
                                        measured: n.measured,
                                    });
                                }
                            }
                        }
                        rows.push(PredictorRow {
                            ray_kind: kind.clone(),
                            predictor: name,
                            target: target.into(),
                            alpha: Some(p.alpha),
                            report,
                            note: String::new(),
                        });
                    }
                    Err(e) => rows.push(PredictorRow {
                        ray_kind: kind.clone(),
                        predictor: name,
                        target: target.into(),
                        alpha: None,
                        report: None,
                        note: e,
                    }),
                }
            }
        }
    }
    Ok((rows, points))
}
