//! `results.csv`: one line per build and per trace.

use super::*;

/// One row per build and per trace: the build columns are empty in trace rows and the other
/// way round; a missing value is an empty field.
pub(super) fn csv(r: &Results) -> String {
    let mut s = String::from(
        "kind,scene,triangles,builder,layout,rays,ray_count,threads,build_ms_median,build_ms_min,build_ms_max,sah,epo,nodes,leaves,references,max_leaf,depth,mrays_median,mrays_min,mrays_max,inner_per_ray,leaves_per_ray,triangles_per_ray,work_cost,lcv,hits,checksum,speed_vs_sweep,work_vs_sweep,speed_vs_sbvh,work_vs_sbvh,backend\n",
    );
    let o = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v}"));
    for b in &r.builds {
        let _ = writeln!(
            s,
            "build,{},{},{},,,,{},{},{},{},{},{},{},{},{},{},{},,,,,,,,,,,,,,,",
            b.scene,
            b.triangles,
            b.builder,
            b.threads,
            b.build_ms.median,
            b.build_ms.min,
            b.build_ms.max,
            b.sah,
            o(b.epo),
            b.nodes,
            b.leaves,
            b.references,
            b.max_leaf,
            b.depth
        );
    }
    for t in &r.traces {
        let x = &t.report;
        let _ = writeln!(
            s,
            "trace,{},{},{},{},{},{},{},,,,,,,,,,,{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            x.scene,
            x.triangles,
            x.builder,
            x.layout,
            x.ray_kind,
            x.rays,
            x.threads,
            x.mrays_s.median,
            x.mrays_s.min,
            x.mrays_s.max,
            x.inner_per_ray,
            x.leaves_per_ray,
            x.triangles_per_ray,
            t.work_cost,
            x.lcv,
            x.hits,
            x.checksum,
            o(t.speed_vs_sweep),
            o(t.work_vs_sweep),
            o(t.speed_vs_sbvh),
            o(t.work_vs_sbvh),
            x.backend
        );
    }
    s
}
