//! How fast a refitted tree's quality decays under motion: for three procedural animations,
//! the SAH cost of the frame-0 tree refitted to each of 10 frames against a tree rebuilt for
//! that frame (same builder), and the refitted 8-wide tree's traced work against the rebuilt
//! one's. Prints the Markdown table of `docs/refit.md`.
//!
//! `cargo run --release -p sahara-traverse --example refit_decay [builder] [size]`
//! (defaults: `binned`, 100000).
//!
//! `cargo run --release -p sahara-traverse --example refit_decay levels [size]`: the compact
//! tables of `docs/refit.md` for the builders of the four façade levels (`cluster-binned`, `sweep`,
//! `spatial-binned`, `tsah-sbvh`: `Quality::Fast` to `Quality::Best`), `binned` and `sbvh`, frames 0,
//! 1, 2, 5 and 10, and the refit of the spatial-split trees to unmoved triangles without their
//! cut records (how refit worked before the records: whole triangle boxes).

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_fixtures::rays::point_in;
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_scene::{Mesh, Procedural};
use sahara_traverse::{Bvh8, WorkCounters};
use std::time::Instant;

/// An animation: the triangles of frame `f` (0 = rest pose).
struct Motion {
    name: &'static str,
    what: &'static str,
    frame: Box<dyn Fn(usize) -> Vec<Triangle>>,
}

fn motions(size: usize) -> Vec<Motion> {
    let city = Procedural::City.mesh(size, 1);
    let diag = city_diag(&city);
    let jitter_mesh = city.clone();
    let mut rng = Pcg32::new(3, 3);
    let dirs: Vec<Vec3A> = (0..city.positions.len())
        .map(|_| {
            Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            )
        })
        .collect();
    let jitter = move |f: usize| {
        // Every vertex moves by up to 0.1% of the scene diagonal per frame, in its own
        // direction (the mesh tears apart slowly, as under noise).
        let a = 0.001 * diag * f as f32;
        let pos: Vec<Vec3A> = jitter_mesh
            .positions
            .iter()
            .zip(&dirs)
            .map(|(&p, &d)| p + d * a)
            .collect();
        Mesh::new(pos, jitter_mesh.indices.clone()).triangles()
    };

    let sib = Procedural::SphereInBox.mesh(size, 1);
    let sib_tris = sib.triangles();
    let centre = sib_tris
        .iter()
        .fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
        .centroid();
    let rotate = move |f: usize| {
        // The triangles right of the centre turn about the vertical axis through it, 4° per
        // frame; the others stay (a part moving through the rest).
        let (s, c) = (4.0f32 * f as f32).to_radians().sin_cos();
        sib_tris
            .iter()
            .map(|t| {
                if t.centroid().x <= centre.x {
                    return *t;
                }
                let r = |p: Vec3A| {
                    let d = p - centre;
                    centre + Vec3A::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
                };
                Triangle::new(r(t.v[0]), r(t.v[1]), r(t.v[2]))
            })
            .collect()
    };

    let soup = Procedural::Soup.mesh(size, 2).triangles();
    let sdiag = soup
        .iter()
        .fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
        .extent()
        .length();
    let mut rng = Pcg32::new(4, 4);
    let vel: Vec<Vec3A> = (0..soup.len())
        .map(|_| {
            Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            ) * (0.01 * sdiag)
        })
        .collect();
    let explode = move |f: usize| {
        // Every triangle flies off in its own direction at up to 1% of the diagonal per
        // frame (rigidly).
        soup.iter()
            .zip(&vel)
            .map(|(t, &v)| {
                let d = v * f as f32;
                Triangle::new(t.v[0] + d, t.v[1] + d, t.v[2] + d)
            })
            .collect()
    };
    vec![
        Motion {
            name: "jitter",
            what: "city, vertices drift 0.1% of the diagonal per frame",
            frame: Box::new(jitter),
        },
        Motion {
            name: "rotate",
            what: "sphere_in_box, the right half turns 4° per frame",
            frame: Box::new(rotate),
        },
        Motion {
            name: "explode",
            what: "soup, triangles fly apart at up to 1% of the diagonal per frame",
            frame: Box::new(explode),
        },
    ]
}

fn city_diag(m: &Mesh) -> f32 {
    m.positions
        .iter()
        .fold(Aabb::EMPTY, |b, &p| b.grown(p))
        .extent()
        .length()
}

/// Rays for the work measurement: random segments through the frame's bounds.
fn rays(tris: &[Triangle], n: usize) -> Vec<Ray> {
    let b = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
    let mut rng = Pcg32::new(7, 3);
    let mut p = || point_in(&b, &mut rng);
    (0..n)
        .map(|_| {
            let (o, e) = (p(), p());
            Ray::new(o, e - o, 0.0, f32::INFINITY)
        })
        .collect()
}

fn work(w: &Bvh8, rays: &[Ray]) -> f64 {
    let mut c = WorkCounters::default();
    for r in rays {
        w.closest_hit(r, &mut c);
    }
    // Node tests plus triangle tests per ray (the cost model's two terms, unweighted).
    (c.inner + c.triangles) as f64 / rays.len() as f64
}

/// The builders of `Quality::Fast`, `Medium`, `High` and `Best`, and `binned` and `sbvh`
/// (`Fast` and `High` until 2026-12-07).
const LEVELS: [(&str, &str); 6] = [
    ("Fast", "cluster-binned"),
    ("Medium", "sweep"),
    ("High", "spatial-binned"),
    ("Best", "tsah-sbvh"),
    ("former Fast", "binned"),
    ("former High", "sbvh"),
];

/// The frames of the compact tables.
const FRAMES: [usize; 5] = [0, 1, 2, 5, 10];

/// SAH and traced work (bvh8) of `tree` over `tris` relative to a rebuild's.
fn ratios(
    tree: &sahara_bvh::Bvh,
    wide: &Bvh8,
    fresh: &sahara_bvh::Bvh,
    fresh_wide: &Bvh8,
    rays: &[Ray],
) -> (f64, f64) {
    let cost = CostModel::default();
    let sah = sahara_metrics::sah(tree, &cost) / sahara_metrics::sah(fresh, &cost);
    (sah, work(wide, rays) / work(fresh_wide, rays))
}

/// The compact tables of every level (see the module documentation).
fn levels(size: usize) {
    let cost = CostModel::default();
    println!("levels, about {size} triangles per scene\n");
    let mut before = Vec::new();
    for m in motions(size) {
        println!("**{}** ({})\n", m.name, m.what);
        let head: Vec<String> = FRAMES.iter().map(|f| format!("f{f}")).collect();
        println!(
            "| level (builder) | SAH refit / rebuilt: {} | work refit / rebuilt (bvh8): {} |",
            head.join(", "),
            head.join(", ")
        );
        println!("|---|---|---|");
        let frames: Vec<Vec<Triangle>> = FRAMES.iter().map(|&f| (m.frame)(f)).collect();
        let rays: Vec<Vec<Ray>> = frames.iter().map(|t| rays(t, 10_000)).collect();
        for (level, name) in LEVELS {
            let builder = registry::by_name(name).expect("registered");
            let build = |t: &[Triangle]| builder.build(&BuildInput::new(t, cost).unwrap()).unwrap();
            let f0 = &frames[0];
            let mut tree = build(f0);
            let mut wide = Bvh8::from_bvh(&tree, f0);
            let (mut sahs, mut works) = (Vec::new(), Vec::new());
            for (tris, rays) in frames.iter().zip(&rays) {
                tree.refit_triangles(tris).unwrap();
                wide.refit_triangles(tris).unwrap();
                tree.validate(tris).unwrap();
                let fresh = build(tris);
                let fresh_wide = Bvh8::from_bvh(&fresh, tris);
                let (s, w) = ratios(&tree, &wide, &fresh, &fresh_wide, rays);
                sahs.push(format!("{s:.3}"));
                works.push(format!("{w:.3}"));
            }
            println!(
                "| {level} (`{name}`) | {} | {} |",
                sahs.join(", "),
                works.join(", ")
            );
            if tree.ref_cuts.is_some() {
                // Refit to the unmoved frame 0 as before the cut records: whole boxes.
                let built = build(f0);
                let mut old = built.clone();
                old.ref_cuts = None;
                old.refit_triangles(f0).unwrap();
                let mut old_wide = Bvh8::from_bvh(&old, f0);
                old_wide.refit_triangles(f0).unwrap();
                let mut new = built.clone();
                new.refit_triangles(f0).unwrap();
                let mut new_wide = Bvh8::from_bvh(&built, f0);
                new_wide.refit_triangles(f0).unwrap();
                let built_wide = Bvh8::from_bvh(&built, f0);
                let (s0, w0) = ratios(&old, &old_wide, &built, &built_wide, &rays[0]);
                let (s1, w1) = ratios(&new, &new_wide, &built, &built_wide, &rays[0]);
                before.push(format!(
                    "| {} | {level} (`{name}`) | {s0:.3} | {w0:.3} | {s1:.3} | {w1:.3} |",
                    m.name
                ));
            }
        }
        println!();
    }
    println!("**refit to unmoved triangles** (frame 0), relative to the built tree\n");
    println!(
        "| scene | level | SAH, whole boxes (before) | work, whole boxes | SAH, cut records (now) | work, cut records |"
    );
    println!("|---|---|---:|---:|---:|---:|");
    for row in before {
        println!("{row}");
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let builder_name = args.get(1).map_or("binned", |s| s.as_str()).to_string();
    let size: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    if builder_name == "levels" {
        levels(size);
        return;
    }
    let builder = registry::by_name(&builder_name).expect("unknown builder");
    let cost = CostModel::default();
    println!("builder `{builder_name}`, about {size} triangles per scene\n");
    for m in motions(size) {
        let f0 = (m.frame)(0);
        let mut tree = builder.build(&BuildInput::new(&f0, cost).unwrap()).unwrap();
        let mut wide = Bvh8::from_bvh(&tree, &f0);
        println!("**{}** ({}; {} triangles)\n", m.name, m.what, f0.len());
        println!(
            "| frame | SAH refit / rebuilt | work refit / rebuilt (bvh8) | refit ms | rebuild ms |"
        );
        println!("|---:|---:|---:|---:|---:|");
        for f in 0..=10 {
            let tris = (m.frame)(f);
            let t = Instant::now();
            tree.refit_triangles(&tris).unwrap();
            wide.refit_triangles(&tris).unwrap();
            let refit_ms = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            let fresh = builder
                .build(&BuildInput::new(&tris, cost).unwrap())
                .unwrap();
            let fresh_wide = Bvh8::from_bvh(&fresh, &tris);
            let build_ms = t.elapsed().as_secs_f64() * 1e3;
            tree.validate(&tris).unwrap();
            let sah = sahara_metrics::sah(&tree, &cost) / sahara_metrics::sah(&fresh, &cost);
            let rays = rays(&tris, 20_000);
            let wr = work(&wide, &rays) / work(&fresh_wide, &rays);
            println!("| {f} | {sah:.3} | {wr:.3} | {refit_ms:.1} | {build_ms:.1} |");
        }
        println!();
    }
}
