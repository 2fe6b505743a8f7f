//! Times the exact EPO on a scene file.
//!
//! ```text
//! cargo run --release -p sahara-metrics --example epo_timing -- SCENE.obj[.gz] [TREE.bvh]
//! ```
//!
//! Reads a plain OBJ (`v` and `f` lines, polygons fanned; gzip when the name ends in `.gz`),
//! builds a binned-SAH tree (16 bins, leaves of at most 8 triangles) with the small builder
//! below, or loads `TREE.bvh` (a tree saved with `Bvh::save` over the same triangles, e.g. a
//! `sweep` tree), then prints the SAH, the EPO, the primary-ray metrics of a framing camera
//! on grids of 32, 64 and 128 rows, and the wall-clock time of each.

use sahara_bvh::{Bvh, Node};
use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_metrics::{epo_breakdown, primary_ray_metrics, sah, CameraGrid, CostModel};
use std::io::{BufRead, BufReader, Read};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: epo_timing SCENE.obj[.gz] [TREE.bvh]");
        std::process::exit(2);
    };
    let t0 = Instant::now();
    let tris = load_obj(path);
    println!(
        "{path}: {} triangles, parsed in {:.2?}",
        tris.len(),
        t0.elapsed()
    );

    let t0 = Instant::now();
    let bvh = match args.get(1) {
        Some(tree) => {
            let mut f = std::fs::File::open(tree).expect("open tree");
            Bvh::load(&mut f).expect("load tree")
        }
        None => binned_sah(&tris),
    };
    println!(
        "tree: {} nodes, {} references ({}), in {:.2?}",
        bvh.nodes.len(),
        bvh.prim_indices.len(),
        if args.len() > 1 {
            "loaded"
        } else {
            "binned SAH"
        },
        t0.elapsed()
    );
    bvh.validate(&tris).expect("valid tree");

    let cost = CostModel::default();
    let t0 = Instant::now();
    let s = sah(&bvh, &cost);
    println!("SAH = {s:.4} in {:.2?}", t0.elapsed());
    let t0 = Instant::now();
    let e = epo_breakdown(&bvh, &tris, &cost);
    println!(
        "EPO = {:.4} (inner {:.4}, leaf {:.4}) in {:.2?} on {} threads",
        e.total(),
        e.inner,
        e.leaf,
        t0.elapsed(),
        rayon::current_num_threads()
    );

    // The primary-ray metrics for the default framing camera of sahara-scene (front, slightly
    // above, 45° vertical field of view), on grids of 32, 64 and 128 rows.
    let b = bvh.bounds();
    let eye = b.centroid() + Vec3A::new(0.0, 0.1, 1.0).normalize() * (1.2 * b.extent().length());
    for rows in [32, 64, 128] {
        let cam = CameraGrid::new(eye, b.centroid(), Vec3A::Y, 45.0, 1.0, rows, rows);
        let t0 = Instant::now();
        let m = primary_ray_metrics(&bvh, &tris, &cost, &cam);
        println!(
            "primary {rows}x{rows} ({} hits): frustum SAH {:.4}, occluded SAH {:.4}, visible EPO {:.4} in {:.2?}",
            m.hits,
            m.frustum_sah,
            m.occluded_sah,
            m.visible_epo,
            t0.elapsed()
        );
    }
}
