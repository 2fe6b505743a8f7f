//! Times the exact EPO on a scene file.
//!
//! ```text
//! cargo run --release -p sahara-metrics --example epo_timing -- SCENE.obj[.gz] [TREE.bvh]
//! ```
//!
//! Reads a plain OBJ (`v` and `f` lines, polygons fanned; gzip when the name ends in `.gz`),
//! builds a binned-SAH tree (16 bins, leaves of at most 8 triangles) with the small builder
//! below, or loads `TREE.bvh` (a tree saved with `Bvh::save` over the same triangles, e.g. a
//! `sweep` tree), then prints the SAH and the EPO and the wall-clock time of each (the primary-ray metrics
//! of a camera are `sahara_trace::weighted`'s).

use sahara_bvh::{Bvh, Node};
use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_metrics::{epo_breakdown, sah, CostModel};
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
}

fn load_obj(path: &str) -> Vec<Triangle> {
    let file = std::fs::File::open(path).expect("open scene");
    let reader: Box<dyn Read> = if path.ends_with(".gz") {
        Box::new(flate2::read::MultiGzDecoder::new(file))
    } else {
        Box::new(file)
    };
    let mut verts: Vec<Vec3A> = Vec::new();
    let mut tris = Vec::new();
    for line in BufReader::new(reader).lines() {
        let line = line.expect("read scene");
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|x| x.parse().expect("coordinate")).collect();
                verts.push(Vec3A::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|w| {
                        let i: i64 = w.split('/').next().unwrap().parse().expect("index");
                        if i < 0 {
                            (verts.len() as i64 + i) as usize
                        } else {
                            i as usize - 1
                        }
                    })
                    .collect();
                for k in 1..idx.len().saturating_sub(1) {
                    tris.push(Triangle::new(
                        verts[idx[0]],
                        verts[idx[k]],
                        verts[idx[k + 1]],
                    ));
                }
            }
            _ => {}
        }
    }
    tris
}

/// A plain sequential binned-SAH builder (16 bins per axis, leaves of at most 8 triangles).
fn binned_sah(tris: &[Triangle]) -> Bvh {
    let mut refs: Vec<(Aabb, Vec3A, u32)> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| (t.bounds(), t.centroid(), i as u32))
        .collect();
    let mut bvh = Bvh::empty();
    if !refs.is_empty() {
        rec(&mut refs, &mut bvh, &CostModel::default());
    }
    bvh
}

fn rec(refs: &mut [(Aabb, Vec3A, u32)], bvh: &mut Bvh, cost: &CostModel) -> usize {
    const BINS: usize = 16;
    const MAX_LEAF: usize = 8;
    let bounds = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(&r.0));
    let cb = Aabb::from_points(refs.iter().map(|r| r.1));
    let me = bvh.nodes.len();
    bvh.nodes.push(Node::default());
    let n = refs.len();
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bin)
    for axis in 0..3 {
        let (lo, ext) = (cb.min[axis], cb.max[axis] - cb.min[axis]);
        if ext <= 0.0 {
            continue;
        }
        let bin_of = |c: Vec3A| (((c[axis] - lo) / ext * BINS as f32) as usize).min(BINS - 1);
        let mut bb = [Aabb::EMPTY; BINS];
        let mut cnt = [0usize; BINS];
        for r in refs.iter() {
            let b = bin_of(r.1);
            bb[b].grow_aabb(&r.0);
            cnt[b] += 1;
        }
        let mut right_area = [0.0f64; BINS];
        let mut right_cnt = [0usize; BINS];
        let (mut acc, mut rb) = (0usize, Aabb::EMPTY);
        for b in (1..BINS).rev() {
            rb.grow_aabb(&bb[b]);
            acc += cnt[b];
            right_area[b] = rb.half_area() as f64;
            right_cnt[b] = acc;
        }
        let (mut lb, mut lc) = (Aabb::EMPTY, 0usize);
        for b in 1..BINS {
            lb.grow_aabb(&bb[b - 1]);
            lc += cnt[b - 1];
            if lc == 0 || right_cnt[b] == 0 {
                continue;
            }
            let c = cost.split_cost(
                bounds.half_area() as f64,
                lb.half_area() as f64,
                lc,
                right_area[b],
                right_cnt[b],
            );
            if best.is_none_or(|(bc, _, _)| c < bc) {
                best = Some((c, axis, b));
            }
        }
    }
    let split = match best {
        Some((c, axis, b)) if c < cost.leaf_cost(n) || n > MAX_LEAF => {
            let (lo, ext) = (cb.min[axis], cb.max[axis] - cb.min[axis]);
            let bin_of = |c: Vec3A| (((c[axis] - lo) / ext * BINS as f32) as usize).min(BINS - 1);
            let mut i = 0;
            for j in 0..n {
                if bin_of(refs[j].1) < b {
                    refs.swap(i, j);
                    i += 1;
                }
            }
            Some(i)
        }
        None if n > MAX_LEAF => Some(n / 2),
        _ => None,
    };
    match split {
        Some(mid) => {
            let (l, r) = refs.split_at_mut(mid);
            rec(l, bvh, cost);
            let right = rec(r, bvh, cost);
            bvh.nodes[me] = Node::inner(&bounds, right as u32);
        }
        None => {
            let first = bvh.prim_indices.len() as u32;
            bvh.prim_indices.extend(refs.iter().map(|r| r.2));
            bvh.nodes[me] = Node::leaf(&bounds, first, n as u32);
        }
    }
    me
}
