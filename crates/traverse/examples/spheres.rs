//! Spheres as user primitives: a tree built over their boxes (object splits with `binned`,
//! spatial splits with `sbvh` and a sphere-clipping callback), traced with a sphere
//! intersection callback on the binary tree and on the 8-wide tree, and compared ray by ray
//! with brute force over all spheres.
//!
//! `cargo run --release -p sahara-traverse --example spheres` (the tests run the same code
//! on a smaller scene: `tests/custom.rs`).

use sahara_builders::split::spatial::SplitPrimitive;
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::{rng::Pcg32, Aabb, Axis, Ray, Vec3A};
use sahara_traverse::{custom, Bvh8, NoStats, WorkCounters};

/// A sphere: centre and radius.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    /// Centre.
    pub c: Vec3A,
    /// Radius.
    pub r: f32,
}

impl Sphere {
    /// The sphere's box.
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.c - self.r, self.c + self.r)
    }

    /// The nearest intersection in `[tmin, tmax]` (the entry point, or the exit point when
    /// the entry lies before `tmin`), with the unnormalised outward normal as data. The answer
    /// for a `tmax` is the one for the ray's whole interval when it lies before `tmax`, as
    /// the callbacks must.
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<(f32, Vec3A)> {
        let oc = ray.origin - self.c;
        let a = ray.direction().dot(ray.direction());
        let b = oc.dot(ray.direction());
        let k = oc.dot(oc) - self.r * self.r;
        let disc = b * b - a * k;
        // `disc < 0` or NaN: no real root.
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let near = (-b - s) / a;
        let far = (-b + s) / a;
        let t = if near >= tmin { near } else { far };
        (t >= tmin && t <= tmax).then(|| (t, ray.at(t) - self.c))
    }
}

/// Cuts spheres for spatial splits: the part of a sphere on one side of a plane lies in the
/// sphere's box clipped by the plane and, when the part is a cap (the centre on the other
/// side), within the cap's circle radius on the other two axes. Conservative: the radius is
/// rounded up, and the result is clipped to the reference's box.
pub struct SphereSplitter<'a>(pub &'a [Sphere]);

impl SplitPrimitive for SphereSplitter<'_> {
    fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        let s = self.0[prim as usize];
        let part = |below: bool| {
            let mut b = s.bounds();
            let d = pos - s.c[axis];
            if below {
                b.max[axis] = b.max[axis].min(pos);
            } else {
                b.min[axis] = b.min[axis].max(pos);
            }
            // A cap: the centre is on the other side of the plane.
            if (below && d < 0.0) || (!below && d > 0.0) {
                let rho = ((s.r * s.r - d * d).max(0.0)).sqrt() * (1.0 + 1e-5);
                for a in (0..3).filter(|&a| a != axis) {
                    b.min[a] = b.min[a].max(s.c[a] - rho);
                    b.max[a] = b.max[a].min(s.c[a] + rho);
                }
            }
            let b = b.intersection(bounds);
            if b.is_empty() {
                Aabb::EMPTY
            } else {
                b
            }
        };
        (part(true), part(false))
    }
}

/// `n` random spheres in `[-10, 10]^3`, radii between 0.05 and 0.5.
pub fn spheres(n: usize, seed: u64) -> Vec<Sphere> {
    let mut rng = Pcg32::new(seed, 11);
    (0..n)
        .map(|_| {
            let c = Vec3A::new(
                rng.range_f32(-10.0, 10.0),
                rng.range_f32(-10.0, 10.0),
                rng.range_f32(-10.0, 10.0),
            );
            Sphere {
                c,
                r: rng.range_f32(0.05, 0.5),
            }
        })
        .collect()
}

/// `n` rays: from random points on a sphere of radius 20 towards random points of the scene,
/// half of them segments `[0, 1]` to that point, half unbounded.
pub fn rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 12);
    let mut p = |s: f32| {
        Vec3A::new(
            rng.range_f32(-s, s),
            rng.range_f32(-s, s),
            rng.range_f32(-s, s),
        )
    };
    (0..n)
        .map(|i| {
            let o = p(1.0).normalize_or(Vec3A::X) * 20.0;
            let target = p(10.0);
            let tmax = if i % 2 == 0 { 1.0 } else { f32::INFINITY };
            Ray::new(o, target - o, 0.0, tmax)
        })
        .collect()
}

/// What [`run`] found.
#[derive(Debug)]
pub struct Report {
    /// Rays traced per builder.
    pub rays: usize,
    /// Rays that hit a sphere.
    pub hits: usize,
    /// Per builder: name, references (more than spheres with spatial splits), work.
    pub builders: Vec<(String, usize, WorkCounters)>,
}

/// Builds over `n` spheres with `binned` and with `sbvh` plus [`SphereSplitter`], traces
/// `n_rays` rays on the binary and the 8-wide trees (closest and any hit), and checks every
/// answer against brute force bit for bit (panics on a difference).
pub fn run(n: usize, n_rays: usize) -> Report {
    let spheres = spheres(n, 1);
    let boxes: Vec<Aabb> = spheres.iter().map(Sphere::bounds).collect();
    let rays = rays(n_rays, 2);
    let intersect =
        |ray: &Ray, p: u32, tmin: f32, tmax: f32| spheres[p as usize].intersect(ray, tmin, tmax);
    let expected: Vec<_> = rays
        .iter()
        .map(|r| custom::brute_closest_hit(&boxes, r, intersect))
        .collect();
    let hits = expected.iter().filter(|h| h.is_some()).count();
    let splitter = SphereSplitter(&spheres);
    let mut builders = Vec::new();
    for (name, split) in [("binned", false), ("sbvh", true)] {
        let mut input = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
        if split {
            input = input.with_splitter(&splitter);
        }
        let bvh = registry::by_name(name).unwrap().build(&input).unwrap();
        bvh.validate_structure().unwrap();
        let wide = Bvh8::from_boxes(&bvh, &boxes);
        let mut work = WorkCounters::default();
        for (ray, want) in rays.iter().zip(&expected) {
            let got = custom::closest_hit(&bvh, &boxes, ray, intersect, &mut work);
            assert_eq!(bits(&got), bits(want), "{name}, binary tree, {ray:?}");
            let got = wide.closest_hit_custom(&boxes, ray, intersect, &mut NoStats);
            assert_eq!(bits(&got), bits(want), "{name}, bvh8, {ray:?}");
            let any = custom::brute_any_hit(&boxes, ray, intersect);
            assert_eq!(any, want.is_some());
            assert_eq!(
                custom::any_hit(&bvh, &boxes, ray, intersect, &mut NoStats),
                any
            );
            assert_eq!(
                wide.any_hit_custom(&boxes, ray, intersect, &mut NoStats),
                any
            );
        }
        builders.push((name.to_string(), bvh.prim_indices.len(), work));
    }
    Report {
        rays: rays.len(),
        hits,
        builders,
    }
}

/// A hit as bits (distance, primitive, normal), for exact comparisons.
fn bits(h: &Option<custom::PrimHit<Vec3A>>) -> Option<(u32, u32, [u32; 3])> {
    h.map(|h| (h.t.to_bits(), h.prim, h.data.to_array().map(f32::to_bits)))
}

#[allow(dead_code)]
fn main() {
    let r = run(20_000, 20_000);
    println!(
        "{} rays, {} hit a sphere; every answer equals brute force",
        r.rays, r.hits
    );
    for (name, refs, w) in &r.builders {
        println!(
            "{name:>7}: {refs} references, per ray {:.1} inner nodes, {:.1} leaves, {:.1} spheres tested",
            w.inner as f64 / r.rays as f64,
            w.leaves as f64 / r.rays as f64,
            w.triangles as f64 / r.rays as f64
        );
    }
}
