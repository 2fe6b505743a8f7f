//! Instances: a grid of rotated, scaled copies of three procedural meshes (a vase, a torus and
//! a sphere), each mesh one bottom-level `Bvh8`, the instances under a top-level tree built
//! from their world boxes with a registered builder. Camera rays and random segments are
//! traced through the two levels and compared:
//!
//! * with the two-level brute-force reference (the same ray transforms and hit rule, brute
//!   force over each instance's triangles): equal bit for bit;
//! * with the instances flattened into one mesh (vertices transformed) under its own tree:
//!   equal hit or miss, same triangle and distances within a relative `TOLERANCE`, except for
//!   rays that graze an edge (a barycentric coordinate below `GRAZE` in either answer), which
//!   are counted.
//!
//! `cargo run --release -p sahara-traverse --example instances` (a 10 × 10 grid; the tests run
//! the same code on a smaller one: `tests/instances.rs`).

use glam::{Affine3A, Quat, Vec3};
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_scene::{revolve, torus, uv_sphere, Camera, UpAxis};
use sahara_traverse::instance::{Instance, InstanceHit, InstanceSet};
use sahara_traverse::{brute, Bvh8, Hit, NoStats, WorkCounters};

/// Distance tolerance between tracing instances and tracing the flattened mesh, as a length
/// relative to the coordinates' magnitude: `|t_instance - t_flat| · |direction| <= TOLERANCE ·
/// max(|origin|, |hit point|)`. The two differ by the rounding of the vertex transform (each
/// world vertex within a few ulps of its exact position) and of the inverse ray transform
/// (origin and direction within a few ulps of the exact inverse image): errors of a few ulps
/// of the coordinates, not of `t` (a ray starting next to a surface has a tiny `t` and the same
/// absolute error), amplified for triangles seen at grazing angles. 2^-13 leaves a wide margin
/// over the differences measured (see `docs/primitives.md`).
pub const TOLERANCE: f32 = 1.0 / 8192.0;

/// A hit whose barycentric coordinates `(1 - u - v, u, v)` have one below this grazes an
/// edge: the two ways of rounding may pick the neighbouring triangle or miss the silhouette.
pub const GRAZE: f32 = 1e-4;

/// The bottom-level meshes, in object space around the origin, about 2 units wide.
pub fn meshes() -> Vec<Vec<Triangle>> {
    let vase = revolve(
        Vec3A::ZERO,
        &[
            (0.0, -1.0),
            (0.6, -1.0),
            (0.9, -0.5),
            (1.0, 0.0),
            (0.6, 0.6),
            (0.4, 1.0),
            (0.5, 1.2),
        ],
        48,
        1.0,
    );
    vec![
        vase.triangles(),
        torus(Vec3A::ZERO, 0.8, 0.3, 48, 24).triangles(),
        uv_sphere(Vec3A::ZERO, 1.0, 32, 16).triangles(),
    ]
}

/// A `grid × grid` arrangement of instances of the `n_meshes` meshes: spacing 3, random
/// rotation, scale between 0.6 and 1.4, a little random lift.
pub fn grid(grid: usize, n_meshes: usize, seed: u64) -> Vec<Instance> {
    let mut rng = Pcg32::new(seed, 21);
    let mut out = Vec::new();
    for i in 0..grid {
        for j in 0..grid {
            let axis = Vec3::new(
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-1.0, 1.0),
            )
            .normalize_or(Vec3::Y);
            let rot = Quat::from_axis_angle(axis, rng.range_f32(0.0, std::f32::consts::TAU));
            let s = rng.range_f32(0.6, 1.4);
            let pos = Vec3::new(3.0 * i as f32, rng.range_f32(0.0, 0.5), 3.0 * j as f32);
            out.push(Instance {
                blas: ((i * grid + j) % n_meshes) as u32,
                transform: Affine3A::from_scale_rotation_translation(Vec3::splat(s), rot, pos),
            });
        }
    }
    out
}

/// What [`run`] found.
#[derive(Debug, Default)]
pub struct Report {
    /// Instances and triangles of the flattened mesh.
    pub instances: usize,
    /// Triangles of the flattened mesh.
    pub flat_triangles: usize,
    /// Rays traced.
    pub rays: usize,
    /// Rays that hit something.
    pub hits: usize,
    /// Rays whose answer differs from the flattened mesh's only at a grazed edge (excluded).
    pub grazing: usize,
    /// The largest distance difference with the flattened mesh over the other rays (a length
    /// relative to the coordinates' magnitude, as [`TOLERANCE`]).
    pub max_rel_dt: f32,
    /// Rays whose answer differs from the flattened mesh's beyond the tolerance, not grazing
    /// (must be 0).
    pub flat_mismatches: usize,
    /// Top-level work.
    pub top: WorkCounters,
}

/// Builds the instance set over a `n × n` grid, traces `rays_side²` camera rays plus as many
/// random segments, asserts equality with the two-level brute-force reference and counts the
/// differences with the flattened mesh.
pub fn run(n: usize, rays_side: u32) -> Report {
    let meshes = meshes();
    let cost = CostModel::default();
    let builder = registry::by_name("binned").unwrap();
    let blases: Vec<Bvh8> = meshes
        .iter()
        .map(|tris| {
            let bvh = builder
                .build(&BuildInput::new(tris, cost).unwrap())
                .unwrap();
            Bvh8::from_bvh(&bvh, tris)
        })
        .collect();
    let instances = grid(n, meshes.len(), 5);
    let set = InstanceSet::new(blases, instances.clone(), |boxes: &[Aabb]| {
        let top = registry::by_name("sweep").unwrap();
        top.build(&BuildInput::from_boxes(boxes, cost).unwrap())
            .unwrap()
    })
    .unwrap();

    // The flattened scene: every instance's triangles transformed into world space.
    let mut flat = Vec::new();
    let mut offsets = Vec::new();
    for inst in &instances {
        offsets.push(flat.len() as u32);
        let m = &inst.transform;
        for t in &meshes[inst.blas as usize] {
            let v = t.v.map(|p| m.transform_point3a(p));
            flat.push(Triangle::new(v[0], v[1], v[2]));
        }
    }
    let flat_bvh = builder
        .build(&BuildInput::new(&flat, cost).unwrap())
        .unwrap();
    let flat_wide = Bvh8::from_bvh(&flat_bvh, &flat);

    let bounds = set
        .world_boxes()
        .iter()
        .fold(Aabb::EMPTY, |b, x| b.union(x));
    let cam = Camera::framing(&bounds, UpAxis::Y);
    let mut rays = cam.primary_rays(rays_side, rays_side);
    let mut rng = Pcg32::new(9, 4);
    let mut p = || {
        Vec3A::new(
            rng.range_f32(bounds.min.x, bounds.max.x),
            rng.range_f32(bounds.min.y, bounds.max.y),
            rng.range_f32(bounds.min.z, bounds.max.z),
        )
    };
    for _ in 0..rays_side * rays_side {
        let (o, e) = (p(), p());
        rays.push(Ray::new(o, e - o, 0.0, 1.0));
    }

    let mut r = Report {
        instances: instances.len(),
        flat_triangles: flat.len(),
        rays: rays.len(),
        ..Report::default()
    };
    let brute_blas = |blas: u32, ray: &Ray| brute::closest_hit(&meshes[blas as usize], ray);
    let key = |h: &Option<InstanceHit>| {
        h.map(|h| {
            (
                h.t.to_bits(),
                h.instance,
                h.prim,
                h.u.to_bits(),
                h.v.to_bits(),
            )
        })
    };
    for ray in &rays {
        let got = set.closest_hit(ray, &mut r.top);
        let want = set.brute_closest_hit(ray, brute_blas);
        assert_eq!(key(&got), key(&want), "two-level reference, {ray:?}");
        let any = set.any_hit(ray, &mut NoStats);
        let want_any =
            set.brute_any_hit(ray, |blas, ray| brute::any_hit(&meshes[blas as usize], ray));
        assert_eq!(any, want_any, "two-level any hit, {ray:?}");
        assert_eq!(any, got.is_some(), "any hit and closest hit, {ray:?}");
        r.hits += got.is_some() as usize;

        let f = flat_wide.closest_hit(ray, &mut NoStats);
        let grazes = |u: f32, v: f32| u.min(v).min(1.0 - u - v) < GRAZE;
        let graze = got.is_some_and(|h| grazes(h.u, h.v)) || (f.is_hit() && grazes(f.u, f.v));
        let same = match got {
            None => !f.is_hit(),
            Some(h) => {
                let len = ray.direction().length();
                let scale = ray.origin.length().max(ray.at(f.t.min(h.t)).length());
                let rel = (h.t - f.t).abs() * len / scale.max(f32::MIN_POSITIVE);
                let ok = f.is_hit()
                    && offsets[h.instance as usize] + h.prim == f.prim
                    && rel <= TOLERANCE;
                if ok {
                    r.max_rel_dt = r.max_rel_dt.max(rel);
                }
                ok
            }
        };
        if !same {
            if graze {
                r.grazing += 1;
            } else {
                r.flat_mismatches += 1;
                eprintln!("flattened mesh differs: {ray:?}: instances {got:?}, flat {f:?}");
            }
        }
        let _: Hit = f;
    }
    r
}

#[allow(dead_code)]
fn main() {
    let r = run(10, 256);
    println!(
        "{} instances ({} triangles flattened), {} rays, {} hits",
        r.instances, r.flat_triangles, r.rays, r.hits
    );
    println!("two-level brute force: every answer equal, bit for bit");
    println!(
        "flattened mesh: {} rays differ at grazed edges (excluded), {} beyond the tolerance; \
         largest distance difference {:.2e} (relative to the coordinates) (tolerance {:.2e})",
        r.grazing, r.flat_mismatches, r.max_rel_dt, TOLERANCE
    );
    println!(
        "top level per ray: {:.1} nodes, {:.1} leaves, {:.1} instances tested",
        r.top.inner as f64 / r.rays as f64,
        r.top.leaves as f64 / r.rays as f64,
        r.top.triangles as f64 / r.rays as f64
    );
    assert_eq!(r.flat_mismatches, 0);
}
