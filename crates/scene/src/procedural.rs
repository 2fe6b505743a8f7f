//! Procedural scenes: deterministic from a seed and an approximate triangle count.
//!
//! Each generator is a pure function of `(size, seed)` built on [`sahara_geom::rng::Pcg32`],
//! so a scene is bit-identical on every machine and across versions of the workspace (a
//! change to a generator is a breaking change of the evaluation's inputs). `size` is the
//! requested number of triangles; the result is within a few percent of it for sizes from
//! 10^3 to 10^7 (and never empty: very small sizes are rounded up to the smallest
//! meaningful scene).

use sahara_geom::rng::Pcg32;
use sahara_geom::Vec3A;

use crate::shapes::{closed_box, revolve, torus, uv_sphere};
use crate::{Camera, Mesh, Scene, SceneSource};

/// The seed that [`Procedural::scene`] uses when none is given (catalog names without a
/// seed).
pub const DEFAULT_SEED: u64 = 1;

/// The built-in procedural scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Procedural {
    /// A closed UV sphere inside a closed box, both watertight (an interior: the camera is
    /// inside the box).
    SphereInBox,
    /// Random triangles of random sizes and orientations in a cube.
    Soup,
    /// A dense tiny torus on the floor of a huge sparse stadium bowl (the "teapot in a
    /// stadium" problem: extreme differences of triangle size and density).
    TeapotStadium,
    /// Long thin randomly oriented triangles filling a ball.
    Hairball,
    /// Boxes of very different sizes (props, houses, towers) on a ground plane.
    City,
    /// Triangles of many sizes whose centroids nearly coincide (jittered by 1e-6 around one
    /// point) inside a large closed box: centroid-based splits cannot separate them.
    Clustered,
}

impl Procedural {
    /// Every procedural scene, in catalog order.
    pub const ALL: [Procedural; 6] = [
        Procedural::SphereInBox,
        Procedural::Soup,
        Procedural::TeapotStadium,
        Procedural::Hairball,
        Procedural::City,
        Procedural::Clustered,
    ];

    /// The catalog name (`sphere_in_box`, `soup`, `teapot_stadium`, `hairball`, `city`,
    /// `clustered`).
    pub fn name(self) -> &'static str {
        match self {
            Procedural::SphereInBox => "sphere_in_box",
            Procedural::Soup => "soup",
            Procedural::TeapotStadium => "teapot_stadium",
            Procedural::Hairball => "hairball",
            Procedural::City => "city",
            Procedural::Clustered => "clustered",
        }
    }

    /// The scene with catalog name `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// A one-line description.
    pub fn description(self) -> &'static str {
        match self {
            Procedural::SphereInBox => "closed UV sphere inside a closed box (watertight interior)",
            Procedural::Soup => "random triangle soup in a cube",
            Procedural::TeapotStadium => "dense tiny torus inside a huge sparse stadium bowl",
            Procedural::Hairball => "long thin randomly oriented triangles in a ball",
            Procedural::City => "boxes of very different sizes on a ground plane",
            Procedural::Clustered => "triangles with nearly coincident centroids inside a box",
        }
    }

    /// The default approximate triangle count (suitable for tests: 10k–50k).
    pub fn default_size(self) -> usize {
        match self {
            Procedural::SphereInBox => 20_000,
            Procedural::Soup => 20_000,
            Procedural::TeapotStadium => 30_000,
            Procedural::Hairball => 20_000,
            Procedural::City => 30_000,
            Procedural::Clustered => 10_000,
        }
    }

    /// The mesh for `size` (approximate triangle count) and `seed`.
    pub fn mesh(self, size: usize, seed: u64) -> Mesh {
        self.generate(size, seed).0
    }

    /// The mesh and its default camera.
    pub fn generate(self, size: usize, seed: u64) -> (Mesh, Camera) {
        let size = size.max(16);
        match self {
            Procedural::SphereInBox => gen_sphere_in_box(size, seed),
            Procedural::Soup => gen_soup(size, seed),
            Procedural::TeapotStadium => gen_teapot_stadium(size, seed),
            Procedural::Hairball => gen_hairball(size, seed),
            Procedural::City => gen_city(size, seed),
            Procedural::Clustered => gen_clustered(size, seed),
        }
    }

    /// The complete scene: named [`Procedural::name`] for the default size and seed, and
    /// `name:size:seed` otherwise (the form [`Catalog::load`](crate::Catalog::load)
    /// accepts).
    pub fn scene(self, size: usize, seed: u64) -> Scene {
        let (mesh, camera) = self.generate(size, seed);
        let name = if size == self.default_size() && seed == DEFAULT_SEED {
            self.name().to_string()
        } else {
            format!("{}:{size}:{seed}", self.name())
        };
        Scene {
            name,
            mesh,
            source: SceneSource::Procedural {
                generator: self,
                size,
                seed,
            },
            camera,
            camera_source: crate::CameraSource::Generator,
        }
    }

    /// The scene at its default size and seed.
    pub fn default_scene(self) -> Scene {
        self.scene(self.default_size(), DEFAULT_SEED)
    }
}

impl std::fmt::Display for Procedural {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// [`Procedural::SphereInBox`]: about `size` triangles.
pub fn sphere_in_box(size: usize, seed: u64) -> Mesh {
    Procedural::SphereInBox.mesh(size, seed)
}

/// [`Procedural::Soup`]: about `size` triangles.
pub fn soup(size: usize, seed: u64) -> Mesh {
    Procedural::Soup.mesh(size, seed)
}

/// [`Procedural::TeapotStadium`]: about `size` triangles.
pub fn teapot_stadium(size: usize, seed: u64) -> Mesh {
    Procedural::TeapotStadium.mesh(size, seed)
}

/// [`Procedural::Hairball`]: about `size` triangles.
pub fn hairball(size: usize, seed: u64) -> Mesh {
    Procedural::Hairball.mesh(size, seed)
}

/// [`Procedural::City`]: about `size` triangles.
pub fn city(size: usize, seed: u64) -> Mesh {
    Procedural::City.mesh(size, seed)
}

/// [`Procedural::Clustered`]: about `size` triangles.
pub fn clustered(size: usize, seed: u64) -> Mesh {
    Procedural::Clustered.mesh(size, seed)
}

fn rng(seed: u64, generator: Procedural) -> Pcg32 {
    Pcg32::new(seed, 0x5a4a_0000 + generator as u64)
}

fn round_u32(x: f64) -> u32 {
    x.round().clamp(0.0, u32::MAX as f64) as u32
}

/// A uniform point in the unit ball (rejection sampling).
fn in_ball(r: &mut Pcg32) -> Vec3A {
    loop {
        let p = Vec3A::new(
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
        );
        if p.length_squared() <= 1.0 {
            return p;
        }
    }
}

/// A uniform unit vector.
fn on_sphere(r: &mut Pcg32) -> Vec3A {
    loop {
        let p = in_ball(r);
        let l = p.length();
        if l > 1e-3 {
            return p / l;
        }
    }
}

/// Log-uniform in `[lo, hi)`.
fn log_uniform(r: &mut Pcg32, lo: f32, hi: f32) -> f32 {
    (r.range_f32(lo.ln(), hi.ln())).exp()
}

fn gen_sphere_in_box(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::SphereInBox);
    let n = size as f64;
    // A quarter of the triangles for the box (12 b^2), the rest for the sphere
    // (2 s (k - 1) with s = 2 k meridians and k bands).
    let b = round_u32((n / 48.0).sqrt()).max(1);
    let rest = (n - 12.0 * f64::from(b * b)).max(32.0);
    let k = round_u32(0.5 + (0.25 + rest / 4.0).sqrt()).max(2);
    let centre = Vec3A::new(0.3, -0.2, 0.1)
        + Vec3A::new(
            r.range_f32(-0.1, 0.1),
            r.range_f32(-0.1, 0.1),
            r.range_f32(-0.1, 0.1),
        );
    let mut mesh = closed_box(Vec3A::splat(-2.0), Vec3A::splat(2.0), b);
    mesh.append(&uv_sphere(centre, 0.8, 2 * k, k));
    let camera = Camera::new(Vec3A::new(-1.5, 1.0, 1.7), centre, Vec3A::Y, 60.0);
    (mesh, camera)
}

fn gen_soup(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::Soup);
    let spacing = (8.0 / size as f32).cbrt();
    let mut mesh = Mesh::default();
    mesh.positions.reserve(3 * size);
    mesh.indices.reserve(size);
    for _ in 0..size {
        let c = Vec3A::new(
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
            r.range_f32(-1.0, 1.0),
        );
        let s = spacing * log_uniform(&mut r, 0.25, 4.0);
        let mut v = || c + Vec3A::new(r.range_f32(-s, s), r.range_f32(-s, s), r.range_f32(-s, s));
        let (a, b, cc) = (v(), v(), v());
        mesh.push_triangle(a, b, cc);
    }
    let camera = Camera::framing(&mesh.bounds(), crate::UpAxis::Y);
    (mesh, camera)
}

fn gen_teapot_stadium(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::TeapotStadium);
    let n = size as f64;
    // Stadium: a quarter of the triangles. With T tiers the profile has 2 T + 3 points and
    // each of the s segments 4 T + 3 triangles.
    let budget = (n / 4.0).max(64.0);
    let segments = round_u32((2.0 * budget).sqrt()).max(8);
    let tiers = round_u32((budget / f64::from(segments) - 3.0) / 4.0).clamp(1, 400);
    let (field, inner, outer, height) = (60.0f32, 62.0f32, 100.0f32, 28.0f32);
    let mut profile = vec![(0.0, 0.0), (field, 0.0), (inner, 0.0)];
    let (run, rise) = (
        (outer - inner) / tiers as f32,
        (height - 2.0) / tiers as f32,
    );
    for t in 0..tiers {
        let x = inner + run * t as f32;
        let y = rise * (t + 1) as f32;
        profile.push((x, y)); // riser
        profile.push((x + run, y)); // tread
    }
    profile.push((outer + 0.5, height)); // outer wall top
    let mut mesh = revolve(Vec3A::ZERO, &profile, segments, 1.35);
    let stadium = mesh.triangle_count() as f64;

    // Tiny torus: the rest, with 3 tube steps around the ring per step around the tube.
    let rest = (n - stadium).max(36.0);
    let nv = round_u32((rest / 6.0).sqrt()).max(3);
    let nu = 3 * nv;
    let (major, minor) = (0.12f32, 0.04f32);
    let angle = r.range_f32(0.0, std::f32::consts::TAU);
    let centre = Vec3A::new(0.0, minor + 0.001, 0.0);
    let mut tiny = torus(Vec3A::ZERO, major, minor, nu, nv);
    let (sa, ca) = angle.sin_cos();
    tiny.transform_positions(|p| {
        centre + Vec3A::new(ca * p.x - sa * p.z, p.y, sa * p.x + ca * p.z)
    });
    mesh.append(&tiny);
    let camera = Camera::new(Vec3A::new(0.0, 0.8, 3.0), centre, Vec3A::Y, 45.0);
    (mesh, camera)
}

fn gen_hairball(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::Hairball);
    let mut mesh = Mesh::default();
    mesh.positions.reserve(3 * size);
    mesh.indices.reserve(size);
    for _ in 0..size {
        let a = in_ball(&mut r);
        let b = in_ball(&mut r);
        let d = b - a;
        let len = d.length();
        let side = d.cross(on_sphere(&mut r)).normalize_or_zero();
        let w = len * log_uniform(&mut r, 0.002, 0.02);
        let c = (a + b) * 0.5 + side * w;
        mesh.push_triangle(a, b, c);
    }
    let camera = Camera::framing(&mesh.bounds(), crate::UpAxis::Y);
    (mesh, camera)
}

fn gen_city(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::City);
    let n = size as f64;
    let g = round_u32((0.05 * n / 2.0).sqrt()).max(1);
    let boxes = ((n - 2.0 * f64::from(g * g)) / 12.0).round().max(1.0) as u32;
    let lots = (f64::from(boxes).sqrt().ceil() as u32).max(1);
    let lot = 25.0f32;
    let half = lots as f32 * lot * 0.5;
    let mut mesh = Mesh::default();
    // Ground: a g x g grid, facing up.
    for j in 0..=g {
        for i in 0..=g {
            let x = -half + 2.0 * half * i as f32 / g as f32;
            let z = -half + 2.0 * half * j as f32 / g as f32;
            mesh.push_vertex(Vec3A::new(x, 0.0, z));
        }
    }
    for j in 0..g {
        for i in 0..g {
            let p = |di: u32, dj: u32| (j + dj) * (g + 1) + i + di;
            mesh.indices.push([p(0, 0), p(0, 1), p(1, 1)]);
            mesh.indices.push([p(0, 0), p(1, 1), p(1, 0)]);
        }
    }
    for k in 0..boxes {
        let (li, lj) = (k % lots, k / lots);
        let lot_min_x = -half + li as f32 * lot;
        let lot_min_z = -half + lj as f32 * lot;
        let class = r.next_f32();
        let (w, d, h) = if class < 0.2 {
            // Street furniture.
            let s = log_uniform(&mut r, 0.1, 1.0);
            (s, s * r.range_f32(0.5, 2.0), log_uniform(&mut r, 0.2, 3.0))
        } else if class < 0.93 {
            // Houses and blocks.
            (
                log_uniform(&mut r, 3.0, 22.0),
                log_uniform(&mut r, 3.0, 22.0),
                log_uniform(&mut r, 3.0, 40.0),
            )
        } else {
            // Towers and halls, larger than a lot.
            (
                log_uniform(&mut r, 15.0, 60.0),
                log_uniform(&mut r, 15.0, 60.0),
                log_uniform(&mut r, 30.0, 300.0),
            )
        };
        let x0 = lot_min_x + r.range_f32(0.0, (lot - w).max(0.0));
        let z0 = lot_min_z + r.range_f32(0.0, (lot - d).max(0.0));
        mesh.append(&closed_box(
            Vec3A::new(x0, 0.0, z0),
            Vec3A::new(x0 + w, h, z0 + d),
            1,
        ));
    }
    let camera = Camera::new(
        Vec3A::new(0.3 * half, 0.8 * half, 1.1 * half),
        Vec3A::ZERO,
        Vec3A::Y,
        50.0,
    );
    (mesh, camera)
}

fn gen_clustered(size: usize, seed: u64) -> (Mesh, Camera) {
    let mut r = rng(seed, Procedural::Clustered);
    let n = size as f64;
    let b = round_u32((0.02 * n / 12.0).sqrt()).max(1);
    let mut mesh = closed_box(Vec3A::splat(-10.0), Vec3A::splat(10.0), b);
    let cluster = (n - mesh.triangle_count() as f64).max(1.0) as usize;
    let p = Vec3A::new(1.2345, 0.5432, -2.101);
    for _ in 0..cluster {
        let c = p + Vec3A::new(
            r.range_f32(-1e-6, 1e-6),
            r.range_f32(-1e-6, 1e-6),
            r.range_f32(-1e-6, 1e-6),
        );
        let s = log_uniform(&mut r, 1e-4, 1e-1);
        let o0 = on_sphere(&mut r) * s;
        let o1 = on_sphere(&mut r) * s;
        mesh.push_triangle(c + o0, c + o1, c - (o0 + o1));
    }
    let camera = Camera::new(p + Vec3A::new(0.0, 0.08, 0.3), p, Vec3A::Y, 45.0);
    (mesh, camera)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::tests::is_closed;

    #[test]
    fn sizes_are_close_to_requested() {
        for p in Procedural::ALL {
            for size in [1_000usize, 10_000, 100_000] {
                let m = p.mesh(size, 7);
                let got = m.triangle_count() as f64;
                let ratio = got / size as f64;
                assert!((0.85..=1.15).contains(&ratio), "{p}: {size} -> {got}");
                m.validate(std::path::Path::new(p.name())).unwrap();
            }
        }
    }

    #[test]
    fn sphere_in_box_is_closed_at_many_sizes() {
        for size in [16, 500, 3_000, 20_000] {
            assert!(is_closed(&sphere_in_box(size, 3)), "{size}");
        }
    }

    #[test]
    fn names_round_trip() {
        for p in Procedural::ALL {
            assert_eq!(Procedural::from_name(p.name()), Some(p));
            let s = p.default_scene();
            assert_eq!(s.name, p.name());
            assert!(s.camera.eye.is_finite());
            assert_ne!(s.camera.eye, s.camera.target);
        }
    }
}
