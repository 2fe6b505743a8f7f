//! The hard cases.

use std::sync::Arc;

use sahara_geom::{rng::Pcg32, Ray, Triangle, Vec3A};
use sahara_scene::{
    closed_box, soup, tessellated_sphere, uv_sphere, Camera, Mesh, Procedural, DEFAULT_SEED,
};

use crate::rays::{
    aimed, axis_and_diagonal, corruptions, edge_and_vertex_targets, in_ball, inside_random, probe,
    unit,
};
use crate::{Case, Category, Level};

/// Triangle count above which [`Level::Full`] skips the determinism check (three builds per
/// builder) to keep the run in minutes.
const FULL_DETERMINISM_MAX: usize = 200_000;

/// Every case of the level, in a fixed order: watertightness, bad rays, bad geometry,
/// non-finite input, procedural scenes, and (in [`Level::Full`]) more than 2^24 triangles.
///
/// Every case is deterministic (fixed seeds of [`Pcg32`]), so a failure reproduces.
pub fn cases(level: Level) -> Vec<Case> {
    let mut v = Vec::new();
    watertight_cases(level, &mut v);
    bad_ray_cases(level, &mut v);
    bad_geometry_cases(level, &mut v);
    non_finite_cases(&mut v);
    procedural_cases(level, &mut v);
    flat_floor_cases(level, &mut v);
    if level == Level::Full {
        v.push(huge_case());
    }
    if level == Level::Full {
        for c in &mut v {
            c.check_determinism &= c.triangle_count() <= FULL_DETERMINISM_MAX;
        }
    }
    v
}

fn base_case(name: String, category: Category, note: &str, tris: Vec<Triangle>) -> Case {
    Case {
        name,
        category,
        note: note.to_string(),
        triangles: Arc::new(tris),
        rays: Vec::new(),
        must_hit: 0,
        expect_non_finite: None,
        check_determinism: true,
        only_builders: None,
        oracle: false,
    }
}

// ---------------------------------------------------------------------------------------------
// Watertightness

/// A closed mesh with rays from strictly inside: along the axes and diagonals from the centre,
/// aimed at vertices and edges from the centre and from random inner points, and in random
/// directions. All must hit.
fn watertight(
    level: Level,
    name: String,
    note: &str,
    mesh: Mesh,
    center: Vec3A,
    inner_radius: f32,
    seed: u64,
) -> Case {
    let mut rng = Pcg32::new(seed, 11);
    let (n_random, n_aimed) = match level {
        Level::Fast => (768, 1536),
        // Brute force traces every ray through every triangle: fewer rays on huge meshes.
        Level::Full if mesh.triangle_count() > 200_000 => (2048, 4096),
        Level::Full => (8192, 16384),
    };
    let targets = edge_and_vertex_targets(&mesh, n_aimed, &mut rng);
    let mut origins = vec![center];
    for _ in 0..7 {
        origins.push(in_ball(&mut rng, center, inner_radius));
    }
    let mut rays: Vec<Ray> = axis_and_diagonal(center);
    let half = targets.len() / 2;
    rays.extend(aimed(&[center], &targets[..half]));
    rays.extend(aimed(&origins, &targets[half..]));
    rays.extend(inside_random(&mut rng, center, inner_radius, n_random));
    let mut case = base_case(name, Category::Watertight, note, mesh.triangles());
    case.must_hit = rays.len();
    case.rays = rays;
    case
}

fn offset_vector(o: f32) -> Vec3A {
    // Different magnitudes (and so different ulps) on each axis, both signs.
    Vec3A::new(1.0, -0.75, 0.5) * o
}

fn watertight_cases(level: Level, v: &mut Vec<Case>) {
    let fast = level == Level::Fast;
    // Icospheres at the origin, from 20 triangles to 1.3 million.
    let subdivs: &[u32] = if fast { &[0, 2, 4] } else { &[0, 2, 4, 6, 8] };
    for &s in subdivs {
        let mesh = tessellated_sphere(Vec3A::ZERO, 1.0, s);
        v.push(watertight(
            level,
            format!("watertight/icosphere-s{s}"),
            "icosphere of radius 1 at the origin",
            mesh,
            Vec3A::ZERO,
            0.5,
            u64::from(s),
        ));
    }
    // Offset icospheres: the radius grows with the offset so that the sphere stays many ulps
    // wide; the vertices are rounded independently but shared by index, so the mesh is still
    // closed.
    let offsets: &[(f32, f32, u32)] = if fast {
        &[
            (1e4, 1.0, 3),
            (1e5, 0.25, 3),
            (1e6, 100.0, 3),
            (1e7, 1000.0, 3),
        ]
    } else {
        &[
            (1e4, 1.0, 5),
            (1e5, 1.0, 5),
            (1e5, 10.0, 7),
            (1e6, 100.0, 6),
            (1e7, 1000.0, 5),
            (1e7, 64.0, 4),
            (1e7, 1000.0, 8),
        ]
    };
    for &(o, r, s) in offsets {
        let c = offset_vector(o);
        v.push(watertight(
            level,
            format!("watertight/icosphere-s{s}-r{r}@{o:e}"),
            "icosphere offset far from the origin (vertices rounded to the f32 grid there)",
            tessellated_sphere(c, r, s),
            c,
            0.5 * r,
            u64::from(s) + 100,
        ));
    }
    // Boxes: flat faces, axis-aligned edges, lattice vertices hit exactly by axis and diagonal
    // rays from the centre (zero direction components, origins on slab planes).
    let boxes: &[(f32, f32, u32)] = if fast {
        &[(0.0, 1.0, 1), (0.0, 1.0, 16), (1e5, 1.0, 8), (1e7, 32.0, 8)]
    } else {
        &[
            (0.0, 1.0, 1),
            (0.0, 1.0, 40),
            (1e4, 1.0, 100),
            (1e5, 1.0, 30),
            (1e7, 32.0, 16),
            (1e4, 1.0, 290),
        ]
    };
    for &(o, h, n) in boxes {
        let c = offset_vector(o);
        v.push(watertight(
            level,
            format!("watertight/box-n{n}-h{h}@{o:e}"),
            "closed box, each face split into n x n quads",
            closed_box(c - Vec3A::splat(h), c + Vec3A::splat(h), n),
            c,
            0.5 * h,
            u64::from(n) + 200,
        ));
    }
    // UV spheres: fans of many thin triangles meeting at the poles.
    let uvs: &[(f32, f32, u32, u32)] = if fast {
        &[(0.0, 1.0, 48, 24), (1e6, 100.0, 32, 16)]
    } else {
        &[(0.0, 1.0, 720, 360), (1e5, 10.0, 1000, 500)]
    };
    for &(o, r, seg, rings) in uvs {
        let c = offset_vector(o);
        v.push(watertight(
            level,
            format!("watertight/uvsphere-{seg}x{rings}-r{r}@{o:e}"),
            "UV sphere: fans of thin triangles at the poles",
            uv_sphere(c, r, seg, rings),
            c,
            0.5 * r,
            u64::from(seg) + 300,
        ));
    }
}

// ---------------------------------------------------------------------------------------------
// Bad rays

fn bad_rays_from(base: &[Ray]) -> Vec<Ray> {
    let mut rays = base.to_vec();
    for (_, f) in corruptions() {
        rays.extend(base.iter().map(|&r| f(r)));
    }
    rays
}

fn bad_ray_cases(level: Level, v: &mut Vec<Case>) {
    let n_base = if level == Level::Fast { 48 } else { 512 };
    // Inside a closed box: the uncorrupted rays must hit.
    let scene = Procedural::SphereInBox.scene(3000, DEFAULT_SEED);
    let tris = scene.triangles();
    let mut rng = Pcg32::new(5, 21);
    let eye = scene.camera.eye;
    let base: Vec<Ray> = (0..n_base)
        .map(|_| Ray::new(eye, unit(&mut rng), 0.0, f32::INFINITY))
        .collect();
    let mut case = base_case(
        "bad-rays/sphere_in_box".to_string(),
        Category::BadRays,
        "rays from inside a closed box, corrupted in every field",
        tris,
    );
    case.rays = bad_rays_from(&base);
    case.must_hit = base.len();
    v.push(case);

    // A triangle soup probed from outside (hits and misses), corrupted.
    let tris = soup(if level == Level::Fast { 1000 } else { 20_000 }, 3).triangles();
    let base = probe(&tris, n_base, &mut rng);
    let mut case = base_case(
        "bad-rays/soup".to_string(),
        Category::BadRays,
        "rays through a triangle soup, corrupted in every field",
        tris,
    );
    case.rays = bad_rays_from(&base);
    v.push(case);

    // The 12 triangles of a box, with rays along and across its faces and edges.
    let tris = closed_box(Vec3A::splat(-1.0), Vec3A::splat(1.0), 1).triangles();
    let mut base = axis_and_diagonal(Vec3A::ZERO);
    // Rays lying in the face planes and along the edges, from outside.
    for d in [Vec3A::X, Vec3A::Y, Vec3A::Z] {
        for o in [
            Vec3A::new(1.0, 1.0, 1.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(0.0, 1.0, 1.0),
        ] {
            base.push(Ray::new(o - d * 5.0, d, 0.0, f32::INFINITY));
        }
    }
    let mut case = base_case(
        "bad-rays/box-edges".to_string(),
        Category::BadRays,
        "axis-parallel rays along the faces and edges of a 12-triangle box, corrupted",
        tris,
    );
    case.rays = bad_rays_from(&base);
    case.must_hit = 26; // the axis and diagonal rays from the centre
    v.push(case);

    // Rays ending (tmax = 1) or starting (tmin = 1) exactly on a surface, as shadow rays
    // towards a point on a light or rays leaving a surface do: whether the surface counts is
    // up to rounding, but every kernel must decide like brute force. Axis-aligned triangles
    // give flat leaf boxes whose entry distance is the hit distance.
    let n = if level == Level::Fast { 300 } else { 3000 };
    let mut tris = Vec::with_capacity(n);
    for i in 0..n {
        let mut t = random_triangle(&mut rng, Vec3A::ZERO, 1.0);
        match i % 4 {
            0 => t.v.iter_mut().for_each(|p| p.x = 5.0),
            1 => t.v.iter_mut().for_each(|p| p.y = -3.0),
            2 => t.v.iter_mut().for_each(|p| p.z = 0.1),
            _ => {}
        }
        tris.push(t);
    }
    let n_rays = if level == Level::Fast { 3000 } else { 30_000 };
    let mut rays = Vec::with_capacity(n_rays);
    for i in 0..n_rays {
        let t = &tris[rng.below(tris.len() as u32) as usize];
        let target = crate::rays::on_triangle(&mut rng, t);
        let origin = in_ball(&mut rng, Vec3A::ZERO, 8.0);
        let d = target - origin;
        rays.push(if i % 2 == 0 {
            Ray::new(origin, d, 0.0, 1.0)
        } else {
            Ray::new(origin, d, 1.0, f32::INFINITY)
        });
    }
    let mut case = base_case(
        "bad-rays/tmax-on-surface".to_string(),
        Category::BadRays,
        "rays whose tmax or tmin lies exactly on a surface (shadow rays), flat leaf boxes",
        tris,
    );
    case.rays = rays;
    v.push(case);
}

// ---------------------------------------------------------------------------------------------
// Bad geometry

fn random_triangle(rng: &mut Pcg32, center: Vec3A, size: f32) -> Triangle {
    let p = |rng: &mut Pcg32| {
        center
            + Vec3A::new(
                rng.range_f32(-size, size),
                rng.range_f32(-size, size),
                rng.range_f32(-size, size),
            )
    };
    Triangle::new(p(rng), p(rng), p(rng))
}

fn scaled(tris: &[Triangle], s: f32, offset: Vec3A) -> Vec<Triangle> {
    tris.iter()
        .map(|t| {
            Triangle::new(
                t.v[0] * s + offset,
                t.v[1] * s + offset,
                t.v[2] * s + offset,
            )
        })
        .collect()
}

fn geometry(level: Level, name: &str, note: &str, tris: Vec<Triangle>, seed: u64) -> Case {
    let mut rng = Pcg32::new(seed, 31);
    let n_rays = if level == Level::Fast { 512 } else { 4096 };
    let rays = probe(&tris, n_rays, &mut rng);
    let mut case = base_case(
        format!("bad-geometry/{name}"),
        Category::BadGeometry,
        note,
        tris,
    );
    case.rays = rays;
    case
}

fn bad_geometry_cases(level: Level, v: &mut Vec<Case>) {
    let n = if level == Level::Fast { 500 } else { 20_000 };
    let mut rng = Pcg32::new(77, 41);

    // Every other triangle has zero area (repeated vertex, or collinear vertices).
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let t = random_triangle(&mut rng, Vec3A::ZERO, 1.0);
            match i % 4 {
                0 => Triangle::new(t.v[0], t.v[0], t.v[1]),
                1 => Triangle::new(t.v[0], t.v[1], t.v[0] + (t.v[1] - t.v[0]) * 0.5),
                _ => t,
            }
        })
        .collect();
    v.push(geometry(
        level,
        "zero-area-mix",
        "half the triangles have zero area",
        tris,
        1,
    ));

    // Only collinear triangles on random lines (thin boxes) and on the x axis (zero-area
    // boxes).
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let a = Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            );
            let d = unit(&mut rng) * 0.1;
            if i % 2 == 0 {
                Triangle::new(a, a + d, a + d * 3.0)
            } else {
                let x = a.x;
                Triangle::new(
                    Vec3A::new(x, 0.0, 0.0),
                    Vec3A::new(x + 0.1, 0.0, 0.0),
                    Vec3A::new(x + 0.05, 0.0, 0.0),
                )
            }
        })
        .collect();
    v.push(geometry(
        level,
        "collinear",
        "every triangle is a segment (some on the x axis)",
        tris,
        2,
    ));

    // One triangle repeated: every hit is an exact tie (lowest index wins).
    let t = Triangle::new(
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(0.0, 1.0, 0.0),
    );
    v.push(geometry(
        level,
        "duplicates",
        "one triangle repeated n times (exact ties)",
        vec![t; n],
        3,
    ));

    // Duplicates with rotated and reversed vertex orders.
    let distinct: Vec<Triangle> = (0..n / 10)
        .map(|_| random_triangle(&mut rng, Vec3A::ZERO, 1.0))
        .collect();
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let t = distinct[i % distinct.len()];
            let [a, b, c] = t.v;
            match (i / distinct.len()) % 4 {
                0 => t,
                1 => Triangle::new(b, c, a),
                2 => Triangle::new(c, b, a),
                _ => Triangle::new(a, c, b),
            }
        })
        .collect();
    v.push(geometry(
        level,
        "duplicates-permuted",
        "triangles repeated with permuted vertex orders",
        tris,
        4,
    ));

    // Index-degenerate triangles of an indexed mesh, mixed with its real triangles.
    let mut mesh = tessellated_sphere(Vec3A::ZERO, 1.0, if level == Level::Fast { 2 } else { 5 });
    let nv = mesh.positions.len() as u32;
    for i in 0..(n as u32 / 2) {
        let (a, b) = (i % nv, (i * 7 + 3) % nv);
        mesh.indices.push(match i % 3 {
            0 => [a, a, b],
            1 => [a, b, b],
            _ => [a, a, a],
        });
    }
    v.push(geometry(
        level,
        "index-degenerate",
        "a sphere plus triangles that repeat a vertex index",
        mesh.triangles(),
        5,
    ));

    // Everything at one point.
    let p = Vec3A::new(1.0, 2.0, 3.0);
    v.push(geometry(
        level,
        "one-point",
        "n triangles collapsed onto one point",
        vec![Triangle::new(p, p, p); n],
        6,
    ));
    v.push(geometry(
        level,
        "one-point-origin",
        "n triangles collapsed onto the origin",
        vec![Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO); n],
        7,
    ));

    // A fan: all triangles share one vertex, their bounds centroids are spread.
    let tris: Vec<Triangle> = (0..n)
        .map(|_| Triangle::new(p, p + unit(&mut rng), p + unit(&mut rng)))
        .collect();
    v.push(geometry(
        level,
        "fan",
        "n triangles sharing one vertex",
        tris,
        8,
    ));

    // Triangles whose bounds share one centroid (nested, mirrored): centroid splits cannot
    // separate them.
    let tris: Vec<Triangle> = (0..n)
        .map(|i| {
            let s = 1.0 + i as f32 * 0.01;
            let d = unit(&mut rng);
            Triangle::new(p - Vec3A::splat(s), p + Vec3A::splat(s), p + d * (0.5 * s))
        })
        .collect();
    v.push(geometry(
        level,
        "same-centroid",
        "nested triangles with one common bounds centroid",
        tris,
        9,
    ));

    // Extreme coordinates.
    let unit_soup: Vec<Triangle> = (0..n)
        .map(|_| random_triangle(&mut rng, Vec3A::ZERO, 1.0))
        .collect();
    v.push(geometry(
        level,
        "coords-1e30",
        "a soup scaled to +-1e30",
        scaled(&unit_soup, 1e30, Vec3A::ZERO),
        10,
    ));
    v.push(geometry(
        level,
        "coords-near-1e30",
        "a soup of size 1e28 around (1e30, -1e30, 1e30)",
        scaled(&unit_soup, 1e28, Vec3A::new(1e30, -1e30, 1e30)),
        11,
    ));
    v.push(geometry(
        level,
        "coords-1e38",
        "a soup scaled to +-1e38 (extents overflow f32)",
        scaled(&unit_soup, 1e38, Vec3A::ZERO),
        12,
    ));
    v.push(geometry(
        level,
        "coords-1e-30",
        "a soup scaled to +-1e-30 (areas underflow)",
        scaled(&unit_soup, 1e-30, Vec3A::ZERO),
        13,
    ));
    v.push(geometry(
        level,
        "coords-near-1e-30",
        "a soup of size 1e-32 around (1e-30, -1e-30, 1e-30)",
        scaled(&unit_soup, 1e-32, Vec3A::new(1e-30, -1e-30, 1e-30)),
        14,
    ));
    v.push(geometry(
        level,
        "coords-denormal",
        "a soup scaled to +-1e-40 (subnormal coordinates)",
        scaled(&unit_soup, 1e-40, Vec3A::ZERO),
        15,
    ));

    // Mixed scales: tiny triangles next to huge ones.
    let mut tris: Vec<Triangle> = (0..n / 2)
        .map(|_| random_triangle(&mut rng, Vec3A::ZERO, 1e-6))
        .collect();
    tris.extend((0..n / 2).map(|_| random_triangle(&mut rng, Vec3A::ZERO, 1e6)));
    v.push(geometry(
        level,
        "mixed-scales",
        "triangles of size 1e-6 next to triangles of size 1e6",
        tris,
        16,
    ));
    let mut tris: Vec<Triangle> = (0..n / 2)
        .map(|_| random_triangle(&mut rng, Vec3A::splat(1e6), 1e-6))
        .collect();
    tris.extend((0..n / 2).map(|_| random_triangle(&mut rng, Vec3A::ZERO, 1e6)));
    v.push(geometry(
        level,
        "mixed-scales-far",
        "1e-6 triangles at 1e6 (below the ulp: they collapse) among 1e6 triangles",
        tris,
        17,
    ));

    // Flat scenes.
    let side = ((n / 2) as f32).sqrt().ceil() as u32;
    let mut flat = Mesh::default();
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (i as f32, j as f32);
            let q = |dx: f32, dy: f32| Vec3A::new(x + dx, y + dy, 0.0);
            flat.push_triangle(q(0.0, 0.0), q(1.0, 0.0), q(1.0, 1.0));
            flat.push_triangle(q(0.0, 0.0), q(1.0, 1.0), q(0.0, 1.0));
        }
    }
    let mut case = geometry(
        level,
        "flat-z",
        "a grid of quads in the plane z = 0",
        flat.triangles(),
        18,
    );
    // Rays inside the plane (edge-on: nothing to hit) and straight down onto grid vertices
    // and edges.
    for i in 0..64 {
        let x = (i % side) as f32;
        case.rays.push(Ray::new(
            Vec3A::new(-1.0, x + 0.5, 0.0),
            Vec3A::X,
            0.0,
            f32::INFINITY,
        ));
        case.rays.push(Ray::new(
            Vec3A::new(x, -1.0, 0.0),
            Vec3A::Y,
            0.0,
            f32::INFINITY,
        ));
        case.rays.push(Ray::new(
            Vec3A::new(x, x, 5.0),
            -Vec3A::Z,
            0.0,
            f32::INFINITY,
        ));
        case.rays.push(Ray::new(
            Vec3A::new(x + 0.5, x, 5.0),
            -Vec3A::Z,
            0.0,
            f32::INFINITY,
        ));
        case.rays.push(Ray::new(
            Vec3A::new(x + 0.5, x + 0.5, 5.0),
            -Vec3A::Z,
            0.0,
            f32::INFINITY,
        ));
    }
    v.push(case);
    let tris: Vec<Triangle> = (0..n)
        .map(|_| {
            let mut t = random_triangle(&mut rng, Vec3A::ZERO, 1.0);
            for p in &mut t.v {
                p.x = 5.0;
            }
            t
        })
        .collect();
    v.push(geometry(
        level,
        "flat-x",
        "random triangles in the plane x = 5",
        tris,
        19,
    ));

    // Long slivers.
    let tris: Vec<Triangle> = (0..n)
        .map(|_| {
            let a = Vec3A::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            );
            let d = unit(&mut rng) * 2.0;
            let e = unit(&mut rng) * 1e-7;
            Triangle::new(a, a + d, a + e)
        })
        .collect();
    v.push(geometry(
        level,
        "slivers",
        "long triangles of width 1e-7",
        tris,
        20,
    ));

    // Tiny scenes.
    v.push(geometry(level, "single", "one triangle", vec![t], 21));
    v.push(geometry(
        level,
        "single-degenerate",
        "one zero-area triangle",
        vec![Triangle::new(p, p, p + Vec3A::X)],
        22,
    ));
    v.push(geometry(
        level,
        "two-identical",
        "the same triangle twice",
        vec![t, t],
        23,
    ));
    let mut case = geometry(level, "empty", "no triangle", Vec::new(), 24);
    case.rays.extend(axis_and_diagonal(Vec3A::ZERO));
    v.push(case);
}

// ---------------------------------------------------------------------------------------------
// Non-finite input

fn non_finite_cases(v: &mut Vec<Case>) {
    let tris = soup(1000, 9).triangles();
    let mut push =
        |name: &str, mut tris: Vec<Triangle>, at: usize, vertex: usize, axis: usize, value: f32| {
            tris[at].v[vertex][axis] = value;
            let mut case = base_case(
                format!("non-finite/{name}"),
                Category::NonFinite,
                "a NaN or infinite coordinate: BuildInput::new must return BuildError::NonFinite",
                tris,
            );
            case.expect_non_finite = Some(at);
            case.check_determinism = false;
            v.push(case);
        };
    let n = tris.len();
    push("nan-first", tris.clone(), 0, 0, 0, f32::NAN);
    push("inf-middle", tris.clone(), n / 2, 2, 2, f32::INFINITY);
    push("neg-inf-last", tris.clone(), n - 1, 1, 1, f32::NEG_INFINITY);
    push("nan-single", tris[..1].to_vec(), 0, 1, 2, -f32::NAN);
}

// ---------------------------------------------------------------------------------------------
// Procedural scenes

/// A `n × n` grid of primary rays of a camera ([`Camera::primary_rays`] of an `n × n` image).
pub fn camera_rays(cam: &Camera, n: u32) -> Vec<Ray> {
    cam.primary_rays(n, n)
}

fn procedural_cases(level: Level, v: &mut Vec<Case>) {
    for (k, p) in Procedural::ALL.into_iter().enumerate() {
        let (size, grid, n_probe) = match level {
            Level::Fast => (2000, 32, 1024),
            Level::Full => (p.default_size(), 100, 8192),
        };
        let scene = p.scene(size, DEFAULT_SEED);
        let tris = scene.triangles();
        let mut rays = camera_rays(&scene.camera, grid);
        let mut rng = Pcg32::new(k as u64, 51);
        rays.extend(probe(&tris, n_probe, &mut rng));
        let mut case = base_case(
            format!("procedural/{}", p.name()),
            Category::Procedural,
            p.description(),
            tris,
        );
        case.rays = rays;
        v.push(case);
    }
}

// ---------------------------------------------------------------------------------------------
// Axis-aligned floors and walls

/// A floor-and-wall level ([`crate::floors`]) at each scale from 1 to 10^4, at the origin and
/// far from it, with camera, grazing, secondary and AO rays; brute force is also judged by the
/// exact oracle.
fn flat_floor_cases(level: Level, v: &mut Vec<Case>) {
    let n = match level {
        Level::Fast => 250,
        Level::Full => 4000,
    };
    for l in crate::floors::levels() {
        let tris = l.triangles();
        let rays = crate::floors::flat_rays(&tris, l.scale, l.offset, n, 100 + l.seed)
            .into_iter()
            .map(|(_, r)| r)
            .collect();
        let mut case = base_case(
            format!("flat-floors/level-{}", l.name),
            Category::FlatFloors,
            "axis-aligned floors and walls: large flat triangles, grazing and secondary rays",
            tris,
        );
        case.rays = rays;
        case.oracle = true;
        // Equality and the oracle are the point here; the other categories cover
        // determinism of every builder.
        case.check_determinism = l.name == "x1@origin";
        v.push(case);
    }
}

// ---------------------------------------------------------------------------------------------
// More than 2^24 triangles

/// Builders fast enough for 17 million triangles.
pub(crate) const HUGE_BUILDERS: [&str; 3] = ["binned", "binned-8", "sweep"];

fn huge_case() -> Case {
    let n = (1usize << 24) + (1 << 16);
    let tris = soup(n, 24).triangles();
    let mut rng = Pcg32::new(24, 61);
    let rays = probe(&tris, 96, &mut rng);
    let mut case = base_case(
        format!("huge/soup-{n}"),
        Category::Huge,
        "more than 2^24 triangles: counts beyond f32's exact integers",
        tris,
    );
    case.rays = rays;
    case.check_determinism = false;
    case.only_builders = Some(HUGE_BUILDERS.iter().map(|s| s.to_string()).collect());
    case
}
