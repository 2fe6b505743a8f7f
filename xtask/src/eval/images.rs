//! The evaluation's images: the scene's shaded render, the heat maps of per-pixel work and
//! the difference maps against the sweep tree (`images/` of the report folder).

use super::{SceneInfo, REFERENCE};
use crate::util::{self, file_stem};
use anyhow::Result;
use sahara_trace::RaySet;
use std::path::Path;

/// The percentile of per-pixel work that the heat maps' colour scale tops out at.
pub const HEAT_PERCENTILE: f64 = 99.0;

/// The scene's shaded render (once per scene, from the first tree's primary hits).
pub fn write_render(
    out: &Path,
    scene: &util::LoadedScene,
    set: &RaySet,
    counted: &sahara_trace::CountedTrace<sahara_trace::TraceResults>,
    info: &mut SceneInfo,
) -> Result<()> {
    if info.render.is_some() {
        return Ok(());
    }
    if let sahara_trace::TraceResults::Closest(hits) = &counted.results {
        let path = format!("images/{}-render.png", file_stem(&scene.name));
        sahara_trace::shade(
            set.width,
            set.height,
            &set.pixel,
            &set.rays,
            hits,
            &scene.triangles,
            sahara_trace::Shading::Grey,
        )
        .write_png(out.join(&path))?;
        info.render = Some(path);
    }
    Ok(())
}

/// Heat maps of primary-ray work, one per tree, all on one colour scale: the largest of the
/// trees' [`HEAT_PERCENTILE`]-th percentiles of per-pixel work, so that a colour means the same
/// work in every image of the scene (recorded in `info.heat_scale`).
pub fn write_heat_maps(
    out: &Path,
    scene: &str,
    heat: &[(String, sahara_trace::PixelWork)],
    info: &mut SceneInfo,
) -> Result<()> {
    let scale = heat
        .iter()
        .map(|(_, w)| w.percentile(HEAT_PERCENTILE))
        .fold(1.0, f64::max);
    for (builder, work) in heat {
        let path = format!("images/{}-{}-heat.png", file_stem(scene), builder);
        work.heat_map(scale, HEAT_PERCENTILE)
            .image
            .write_png(out.join(&path))?;
        info.heat_maps.push((builder.clone(), path));
    }
    info.heat_scale = scale;
    Ok(())
}

/// Per pixel of `set`'s image, the summed work of its rays (`None` for pixels without a
/// ray), as [`sahara_trace::PixelWork`] sums it.
pub fn per_pixel_work(set: &RaySet, work: &[sahara_trace::WorkCounters]) -> Vec<Option<u64>> {
    let mut v = vec![None; set.width as usize * set.height as usize];
    for (&p, w) in set.pixel.iter().zip(work) {
        if let Some(slot) = v.get_mut(p as usize) {
            *slot = Some(slot.unwrap_or(0) + sahara_trace::work_total(w));
        }
    }
    v
}

/// The diverging colour of `x` in `[-1, 1]` (clamped; NaN as 0): blue for negative (less
/// work than sweep), near-white at 0, red for positive (ColorBrewer RdBu ends).
pub fn diverging(x: f64) -> [u8; 3] {
    const BLUE: [f64; 3] = [33.0, 102.0, 172.0];
    const MID: [f64; 3] = [247.0, 247.0, 247.0];
    const RED: [f64; 3] = [178.0, 24.0, 43.0];
    let x = if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) };
    let (end, t) = if x < 0.0 { (BLUE, -x) } else { (RED, x) };
    std::array::from_fn(|c| (MID[c] + (end[c] - MID[c]) * t + 0.5) as u8)
}

/// One image per tree other than sweep: its per-pixel work minus the sweep tree's, coloured
/// by [`diverging`] on one symmetric scale for the scene (the largest of the trees'
/// [`HEAT_PERCENTILE`]-th percentiles of the absolute difference, at least 1). Pixels without
/// a ray are black.
pub fn write_diff_maps(
    out: &Path,
    scene: &str,
    width: u32,
    height: u32,
    work: &[(String, Vec<Option<u64>>)],
    info: &mut SceneInfo,
) -> Result<()> {
    let Some((_, reference)) = work.iter().find(|(b, _)| b == REFERENCE) else {
        return Ok(());
    };
    let diffs: Vec<(&String, Vec<Option<f64>>)> = work
        .iter()
        .filter(|(b, _)| b != REFERENCE)
        .map(|(b, w)| {
            let d = w
                .iter()
                .zip(reference)
                .map(|(x, r)| {
                    Some(x.unwrap_or(0) as f64 - r.unwrap_or(0) as f64)
                        .filter(|_| x.is_some() || r.is_some())
                })
                .collect();
            (b, d)
        })
        .collect();
    let scale = diffs
        .iter()
        .map(|(_, d)| {
            let mut a: Vec<f64> = d.iter().flatten().map(|x| x.abs()).collect();
            a.sort_by(f64::total_cmp);
            let rank = ((HEAT_PERCENTILE / 100.0) * a.len() as f64).ceil() as usize;
            a.get(rank.clamp(1, a.len().max(1)) - 1)
                .copied()
                .unwrap_or(0.0)
        })
        .fold(1.0, f64::max);
    for (builder, d) in diffs {
        let mut image = sahara_trace::RgbImage::new(width, height);
        for (i, v) in d.iter().enumerate() {
            if let Some(v) = v {
                image.set(i, diverging(v / scale));
            }
        }
        let path = format!(
            "images/{}-{}-diff.png",
            file_stem(scene),
            file_stem(builder)
        );
        image.write_png(out.join(&path))?;
        info.diff_maps.push((builder.clone(), path));
    }
    info.diff_scale = scale;
    Ok(())
}
