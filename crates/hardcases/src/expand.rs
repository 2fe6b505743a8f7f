//! Fuzz inputs that expand into big scenes: the check of the `big_scene` fuzz target
//! (`fuzz/fuzz_targets/big_scene.rs`), shared with the deterministic replay of its saved
//! corpus (`tests/files.rs`).
//!
//! A few header bytes choose a scene generator, a size (up to 150 000 triangles, past every
//! parallel threshold of the builders and the collapse and past the 1 MiB huge-page layout of
//! the wide trees), a builder of the registry, a seed and a coordinate scale; the bytes after
//! the header are adversarial edits, six bytes each (a vertex set to NaN, an infinity, zero,
//! a huge or a subnormal value; shared vertices, duplicated, collapsed, huge and tiny
//! triangles; rays at vertices, along edges, from surfaces, along axes, and invalid rays). So
//! libFuzzer reaches the big paths with inputs of a few dozen bytes. See [`Header`] and
//! [`Edit`] for the format, and [`check_big_scene`] for what must hold.

use std::sync::{Arc, OnceLock};

use glam::{Affine3A, Quat, Vec3};
use sahara_builders::registry::{self, Entry};
use sahara_builders::{BuildError, BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_geom::rng::Pcg32;
use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
use sahara_scene::Procedural;
use sahara_traverse::instance::{Instance, InstanceSet};
use sahara_traverse::{brute, scalar, Backend, Bvh8, Hit, NoStats, Precision, WideBvh};

use crate::catch_quiet;
use crate::fuzzing::{check_loaded_bvh, extent_overflows};

/// The sizes a header can ask for (triangles before edits): tiny scenes, then each parallel
/// threshold crossed (4096: the sweep builders' parallel subtrees and the parallel collapse;
/// 8192: parallel axes; 16 384: parallel sorts; 32 768: parallel binning; 131 072: the binned
/// builder's parallel partition) and the 1 MiB huge-page arrays of the wide trees (from about
/// 30 000 triangles).
pub const SIZES: [usize; 16] = [
    1, 2, 3, 5, 8, 17, 64, 300, 1_000, 4_200, 9_000, 17_000, 34_000, 70_000, 140_000, 150_000,
];

/// Builders that take longer than about a second for 150 000 triangles on one core run on at
/// most this many (the fuzzer's time per input stays near a second).
pub const SLOW_BUILDER_CAP: usize = 20_000;

/// Builders fast enough for every size of [`SIZES`].
const FAST_BUILDERS: &[&str] = &[
    "binned",
    "binned-8",
    "binned-128",
    "cluster-binned",
    "sweep",
    "ploc",
];

/// Builders run up to [`MID_BUILDER_CAP`] triangles: past the 32 768 references of the
/// parallel object-split bounds (`split/object.rs`), which the other spatial-split builders
/// reach only past [`SLOW_BUILDER_CAP`].
const MID_BUILDERS: &[&str] = &["sbvh-fast"];

/// The size cap of the spatial-split builders that are fast enough to pass the 32 768
/// references of the parallel object-split bounds (`sbvh-fast`); the others stop at
/// [`SLOW_BUILDER_CAP`].
pub const MID_BUILDER_CAP: usize = 34_000;

/// Builders that take seconds for 20 000 triangles run on at most this many.
pub const VERY_SLOW_BUILDER_CAP: usize = 3_000;

/// Builders slower than [`SLOW_BUILDER_CAP`] assumes.
const VERY_SLOW_BUILDERS: &[&str] = &["tsah-sbvh", "tsah-sbvh-exact"];

/// Brute force tests at most about this many ray-triangle pairs per traced ray set and
/// precision: the number of sampled rays shrinks as the scene grows.
const BRUTE_BUDGET: usize = 1 << 20;

/// The scene generators a header can choose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Generator {
    /// Random triangles of random sizes and orientations in a cube.
    Soup,
    /// Axis-aligned quads on a grid (flat boxes, shared edges and vertices, exact ties).
    Grid,
    /// A few distinct triangles, each repeated many times (identical boxes and centroids).
    Duplicates,
    /// Points, needles and slivers mixed with ordinary triangles.
    Degenerate,
    /// A closed icosphere (rays from inside must hit).
    Sphere,
    /// A procedural scene of the catalog ([`Procedural`]), chosen by the seed.
    Procedural,
    /// A case of the hard-case suite ([`crate::cases`] at [`crate::Level::Fast`]), chosen by
    /// the seed, with its rays.
    HardCase,
    /// Stacked coplanar triangles and triangles sharing one vertex (a fan).
    Stacked,
}

impl Generator {
    /// Every generator, in the order of the header's byte 0.
    pub const ALL: [Generator; 8] = [
        Generator::Soup,
        Generator::Grid,
        Generator::Duplicates,
        Generator::Degenerate,
        Generator::Sphere,
        Generator::Procedural,
        Generator::HardCase,
        Generator::Stacked,
    ];
}

/// The decoded header (the first [`Header::LEN`] bytes; missing bytes are zero).
#[derive(Clone, Copy, Debug)]
pub struct Header {
    /// Byte 0: the generator.
    pub generator: Generator,
    /// Byte 1: the requested size, an entry of [`SIZES`] (capped per builder).
    pub size: usize,
    /// Byte 2: the builder, an index into [`registry::entries`].
    pub builder: usize,
    /// Bytes 3–6: the generators' seed.
    pub seed: u32,
    /// Byte 7: coordinates are multiplied by `2^e`, `e` the byte as `i8` (so from `2^-128`,
    /// tiny, to `2^127`, where extents overflow `f32`).
    pub scale_exp: i32,
    /// Byte 8: the scene is moved by `2^k` along (1, 1, 1) (`k` from 0 to 127; 0 leaves it).
    pub offset_exp: i32,
    /// Byte 9: bit 0: refit after random motion; bit 1: instances; bit 2: a mutated saved
    /// file; bits 6–7: `2^k` times as many sampled rays.
    pub flags: u8,
}

impl Header {
    /// Bytes of the header.
    pub const LEN: usize = 10;

    /// Decodes the header.
    pub fn parse(data: &[u8]) -> Header {
        let b = |i: usize| data.get(i).copied().unwrap_or(0);
        Header {
            generator: Generator::ALL[b(0) as usize % Generator::ALL.len()],
            size: SIZES[b(1) as usize % SIZES.len()],
            builder: b(2) as usize,
            seed: u32::from_le_bytes([b(3), b(4), b(5), b(6)]),
            scale_exp: b(7) as i8 as i32,
            offset_exp: (b(8) % 128) as i32,
            flags: b(9),
        }
    }

    /// The header as bytes (for seeds).
    pub fn bytes(&self) -> [u8; Header::LEN] {
        let g = Generator::ALL.iter().position(|&g| g == self.generator);
        let s = SIZES.iter().position(|&s| s == self.size);
        let seed = self.seed.to_le_bytes();
        [
            g.unwrap_or(0) as u8,
            s.unwrap_or(0) as u8,
            self.builder as u8,
            seed[0],
            seed[1],
            seed[2],
            seed[3],
            self.scale_exp as i8 as u8,
            self.offset_exp as u8,
            self.flags,
        ]
    }
}

/// One adversarial edit: six bytes after the header, `[op, i0, i1, i2, a0, a1]` with the
/// triangle index `i` (24 bits, modulo the triangle count) and the argument `a` (16 bits).
#[derive(Clone, Copy, Debug)]
pub struct Edit {
    /// What to do (modulo 14): 0 a coordinate of a vertex set to a special value
    /// ([`SPECIAL`]); 1 a vertex copied from another triangle (a shared vertex); 2 a triangle
    /// copied onto another (a duplicate); 3 a triangle collapsed to a point; 4 to a segment; 5
    /// a triangle moved by `2^a`; 6 a triangle blown up by `2^a` about its centroid; 7 a
    /// triangle shrunk to a few ulps; 8 a ray at a vertex; 9 a ray at a point of an edge; 10 a
    /// ray along an edge's line; 11 an invalid or extreme ray; 12 a ray leaving a point of the
    /// surface; 13 an axis-aligned ray through the centroid.
    pub op: u8,
    /// The triangle.
    pub index: usize,
    /// The argument.
    pub arg: u16,
}

/// Byte length of an [`Edit`].
pub const EDIT_LEN: usize = 6;

/// The special values of edit 0 and of invalid rays.
pub const SPECIAL: [f32; 14] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    f32::MAX,
    -f32::MAX,
    f32::MIN_POSITIVE,
    1e-45,
    -1e-45,
    1e30,
    -1e30,
    1.0,
    16_777_217.0,
];

/// The edits after the header.
pub fn edits(data: &[u8]) -> Vec<Edit> {
    data.get(Header::LEN..)
        .unwrap_or(&[])
        .chunks_exact(EDIT_LEN)
        .map(|e| Edit {
            op: e[0] % 14,
            index: u32::from_le_bytes([e[1], e[2], e[3], 0]) as usize,
            arg: u16::from_le_bytes([e[4], e[5]]),
        })
        .collect()
}

/// The hard-case suite's cases (built once per process).
fn hard_cases() -> &'static [crate::Case] {
    static CASES: OnceLock<Vec<crate::Case>> = OnceLock::new();
    CASES.get_or_init(|| crate::cases(crate::Level::Fast))
}

fn tri_at(o: Vec3A, a: Vec3A, b: Vec3A) -> Triangle {
    Triangle::new(o, o + a, o + b)
}

fn unit(rng: &mut Pcg32) -> Vec3A {
    Vec3A::new(
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
    )
}

/// The scene of a header (before edits) and the rays that come with it (hard cases only).
pub fn generate(h: &Header, n: usize) -> (Vec<Triangle>, Vec<Ray>) {
    let mut rng = Pcg32::new(h.seed as u64, 46);
    let side = 1.0 / (n as f32).cbrt().max(1.0);
    let mut tris = Vec::with_capacity(n);
    let mut rays = Vec::new();
    match h.generator {
        Generator::Soup => {
            for _ in 0..n {
                let o = unit(&mut rng);
                let s = side * 2f32.powi(rng.below(6) as i32 - 2);
                tris.push(tri_at(o, unit(&mut rng) * s, unit(&mut rng) * s));
            }
        }
        Generator::Grid => {
            let k = ((n as f32 / 6.0).sqrt().ceil() as usize).max(1);
            let step = 2.0 / k as f32;
            'grid: for axis in 0..3 {
                for i in 0..k {
                    for j in 0..k {
                        if tris.len() >= n {
                            break 'grid;
                        }
                        let c = |x: usize, y: usize| {
                            let (a, b) = (x as f32 * step - 1.0, y as f32 * step - 1.0);
                            let mut p = [0.0f32; 3];
                            p[axis] = (axis as f32 - 1.0) * 0.5;
                            p[(axis + 1) % 3] = a;
                            p[(axis + 2) % 3] = b;
                            Vec3A::from(p)
                        };
                        tris.push(Triangle::new(c(i, j), c(i + 1, j), c(i + 1, j + 1)));
                        if tris.len() < n {
                            tris.push(Triangle::new(c(i, j), c(i + 1, j + 1), c(i, j + 1)));
                        }
                    }
                }
            }
        }
        Generator::Duplicates => {
            let distinct = (n >> (rng.below(12) + 1)).max(1);
            let base: Vec<Triangle> = (0..distinct)
                .map(|_| tri_at(unit(&mut rng), unit(&mut rng) * 0.3, unit(&mut rng) * 0.3))
                .collect();
            tris.extend((0..n).map(|i| base[i % distinct]));
        }
        Generator::Degenerate => {
            for _ in 0..n {
                let o = unit(&mut rng);
                let a = unit(&mut rng) * side;
                tris.push(match rng.below(4) {
                    0 => Triangle::new(o, o, o),
                    1 => Triangle::new(o, o + a, o + a * 2.0),
                    2 => Triangle::new(o, o + a, o + a + Vec3A::splat(1e-7)),
                    _ => tri_at(o, a, unit(&mut rng) * side),
                });
            }
        }
        Generator::Sphere => {
            let sub = (0..=7).find(|s| 20 << (2 * s) >= n).unwrap_or(7);
            tris = sahara_scene::tessellated_sphere(Vec3A::ZERO, 1.0, sub).triangles();
            for _ in 0..8 {
                let d = unit(&mut rng);
                rays.push(Ray::new(unit(&mut rng) * 0.5, d, 0.0, f32::INFINITY));
            }
        }
        Generator::Procedural => {
            let p = Procedural::ALL[h.seed as usize % Procedural::ALL.len()];
            tris = p.mesh(n.max(16), h.seed as u64).triangles();
        }
        Generator::HardCase => {
            let cases = hard_cases();
            let case = &cases[h.seed as usize % cases.len()];
            tris = case.triangles.to_vec();
            rays = case.rays.clone();
        }
        Generator::Stacked => {
            let hub = unit(&mut rng);
            for i in 0..n {
                let t = if i % 2 == 0 {
                    // Coplanar copies a hair apart in z.
                    let z = 1e-6 * rng.below(4) as f32;
                    let o = Vec3A::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), z);
                    tri_at(o, Vec3A::X * side * 4.0, Vec3A::Y * side * 4.0)
                } else {
                    tri_at(hub, unit(&mut rng), unit(&mut rng))
                };
                tris.push(t);
            }
        }
    }
    let scale = 2f32.powi(h.scale_exp);
    let offset = if h.offset_exp == 0 {
        Vec3A::ZERO
    } else {
        Vec3A::splat(2f32.powi(h.offset_exp))
    };
    if scale != 1.0 || offset != Vec3A::ZERO {
        let f = |p: Vec3A| p * scale + offset;
        for t in &mut tris {
            *t = Triangle::new(f(t.v[0]), f(t.v[1]), f(t.v[2]));
        }
        for r in &mut rays {
            *r = Ray::new(f(r.origin), r.direction(), r.tmin, r.tmax);
        }
    }
    (tris, rays)
}

/// Scene bounds, or a unit box for an empty or non-finite scene.
fn scene_box(tris: &[Triangle]) -> Aabb {
    let mut b = Aabb::EMPTY;
    for t in tris.iter().filter(|t| t.is_finite()) {
        b.grow_aabb(&t.bounds());
    }
    if b.min.is_finite() && b.max.is_finite() && b.min.cmple(b.max).all() {
        b
    } else {
        Aabb::new(Vec3A::splat(-1.0), Vec3A::ONE)
    }
}

/// Applies the edits to the triangles and adds the rays they ask for.
pub fn apply_edits(tris: &mut [Triangle], rays: &mut Vec<Ray>, edits: &[Edit], seed: u32) {
    let mut rng = Pcg32::new(seed as u64, 47);
    let n = tris.len();
    if n == 0 {
        return;
    }
    let bounds = scene_box(tris);
    let far = |rng: &mut Pcg32| {
        let c = (bounds.min + bounds.max) * 0.5;
        let r = (bounds.max - bounds.min).max_element().max(1e-30);
        c + unit(rng).normalize_or(Vec3A::X) * r * 2.0
    };
    for e in edits {
        let i = e.index % n;
        let a = e.arg as usize;
        let t = tris[i];
        match e.op {
            0 => {
                let mut v = t.v;
                v[a % 3][(a / 3) % 3] = SPECIAL[(a / 9) % SPECIAL.len()];
                tris[i] = Triangle::new(v[0], v[1], v[2]);
            }
            1 => {
                let mut v = t.v;
                v[a % 3] = tris[(a / 3) % n].v[(a / 3) % 3];
                tris[i] = Triangle::new(v[0], v[1], v[2]);
            }
            2 => tris[a % n] = t,
            3 => tris[i] = Triangle::new(t.v[0], t.v[0], t.v[0]),
            4 => tris[i] = Triangle::new(t.v[0], t.v[1], (t.v[0] + t.v[1]) * 0.5),
            5 => {
                let d = unit(&mut rng) * 2f32.powi((a % 140) as i32 - 10);
                tris[i] = Triangle::new(t.v[0] + d, t.v[1] + d, t.v[2] + d);
            }
            6 => {
                let c = t.centroid();
                let s = 2f32.powi((a % 128) as i32);
                let f = |p: Vec3A| c + (p - c) * s;
                tris[i] = Triangle::new(f(t.v[0]), f(t.v[1]), f(t.v[2]));
            }
            7 => {
                let up = |x: f32| f32::from_bits(x.to_bits().wrapping_add(1 + (a as u32 % 4)));
                let v0 = t.v[0];
                let v1 = Vec3A::new(up(v0.x), v0.y, v0.z);
                let v2 = Vec3A::new(v0.x, up(v0.y), v0.z);
                tris[i] = Triangle::new(v0, v1, v2);
            }
            8 => {
                let o = far(&mut rng);
                rays.push(Ray::new(o, t.v[a % 3] - o, 0.0, f32::INFINITY));
            }
            9 => {
                let s = (a >> 2) as f32 / 16_383.0;
                let (p, q) = (t.v[a % 3], t.v[(a + 1) % 3]);
                let o = far(&mut rng);
                rays.push(Ray::new(o, p + (q - p) * s - o, 0.0, f32::INFINITY));
            }
            10 => {
                let (p, q) = (t.v[a % 3], t.v[(a + 1) % 3]);
                let d = q - p;
                rays.push(Ray::new(p - d, d, 0.0, f32::INFINITY));
            }
            11 => {
                let s = |k: usize| SPECIAL[k % SPECIAL.len()];
                let o = t.centroid();
                let field = a % 8;
                let v = s(a / 8);
                let mut od = [o.x, o.y, o.z, -o.x, -o.y, -o.z + 1.0];
                let (mut tmin, mut tmax) = (0.0, f32::INFINITY);
                match field {
                    0..=5 => od[field] = v,
                    6 => tmin = v,
                    _ => tmax = v,
                }
                rays.push(Ray::new(
                    Vec3A::new(od[0], od[1], od[2]),
                    Vec3A::new(od[3], od[4], od[5]),
                    tmin,
                    tmax,
                ));
            }
            12 => {
                let (u, v) = (rng.next_f32() * 0.5, rng.next_f32() * 0.5);
                rays.push(Ray::new(t.point(u, v), unit(&mut rng), 0.0, f32::INFINITY));
            }
            _ => {
                let mut d = [0.0f32; 3];
                d[a % 3] = if a & 4 == 0 { 1.0 } else { -1.0 };
                let d = Vec3A::from(d);
                let o = t.centroid() - d * (bounds.max - bounds.min).max_element().max(1.0);
                rays.push(Ray::new(o, d, 0.0, f32::INFINITY));
            }
        }
    }
}

/// Rays sampled for a scene of `n` triangles: random rays through the scene's box and rays
/// aimed at vertices and edges of random triangles, as many as brute force affords
/// (`BRUTE_BUDGET`), at least 8.
pub fn sample_rays(tris: &[Triangle], h: &Header) -> Vec<Ray> {
    let mut rng = Pcg32::new(h.seed as u64, 48);
    let n = tris.len().max(1);
    let count = (BRUTE_BUDGET / n).clamp(8, 64) << (h.flags >> 6);
    let b = scene_box(tris);
    let ext = (b.max - b.min).max(Vec3A::splat(1e-30));
    let inside =
        |rng: &mut Pcg32| b.min + ext * Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..count)
        .map(|k| {
            let o = inside(&mut rng) + unit(&mut rng) * ext;
            let target = match (k % 3, tris.get(rng.below(n as u32) as usize)) {
                (1, Some(t)) => t.v[rng.below(3) as usize],
                (2, Some(t)) => {
                    let s = rng.next_f32();
                    t.v[0] + (t.v[1] - t.v[0]) * s
                }
                _ => inside(&mut rng),
            };
            Ray::new(o, target - o, 0.0, f32::INFINITY)
        })
        .collect()
}

/// The number of triangles the builder runs on: the header's size, capped for slow
/// ([`SLOW_BUILDER_CAP`], [`VERY_SLOW_BUILDER_CAP`]) and small-inputs-only builders (300).
pub fn capped_size(entry: &Entry, size: usize) -> usize {
    let mut cap = if FAST_BUILDERS.contains(&entry.name) {
        usize::MAX
    } else if MID_BUILDERS.contains(&entry.name) {
        MID_BUILDER_CAP
    } else {
        SLOW_BUILDER_CAP
    };
    if VERY_SLOW_BUILDERS.contains(&entry.name) {
        cap = VERY_SLOW_BUILDER_CAP;
    }
    if entry.small_inputs_only {
        cap = cap.min(300);
    }
    if let Some(m) = entry.max_practical_triangles {
        cap = cap.min(m / 8);
    }
    size.min(cap)
}

fn same_hit(a: &Hit, b: &Hit) -> bool {
    a.prim == b.prim
        && a.t.to_bits() == b.t.to_bits()
        && a.u.to_bits() == b.u.to_bits()
        && a.v.to_bits() == b.v.to_bits()
}

/// Every kernel against its brute-force twin, bit for bit, closest hit and any hit, at both
/// precisions: the scalar traversal of `bvh` (exact precision only) and the 4- and 8-wide
/// trees with every backend this CPU runs. The wide trees' precision is restored afterwards.
/// With `tolerate_known_bugs`, rays [`crate::fuzzing::explained_by_known_bug`] are skipped.
pub fn kernels_equal_brute(
    bvh: Option<&Bvh>,
    w4: &mut WideBvh<4>,
    w8: &mut WideBvh<8>,
    tris: &[Triangle],
    rays: &[Ray],
    tolerate_known_bugs: bool,
) -> Result<(), String> {
    let (p4, p8) = (w4.precision(), w8.precision());
    let result = (|| {
        for p in Precision::ALL {
            w4.set_precision(p);
            w8.set_precision(p);
            for (i, r) in rays.iter().enumerate() {
                let expect = brute::closest_hit_at(tris, r, p);
                let expect_any = brute::any_hit_at(tris, r, p);
                let mut got = Vec::new();
                if let (Some(bvh), Precision::Exact) = (bvh, p) {
                    got.push((
                        "bvh2".to_string(),
                        scalar::closest_hit(bvh, tris, r, &mut NoStats),
                        scalar::any_hit(bvh, tris, r, &mut NoStats),
                    ));
                }
                for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
                    got.push((
                        format!("bvh4-{}", b.name()),
                        w4.closest_hit_with(b, r, &mut NoStats),
                        w4.any_hit_with(b, r, &mut NoStats),
                    ));
                    got.push((
                        format!("bvh8-{}", b.name()),
                        w8.closest_hit_with(b, r, &mut NoStats),
                        w8.any_hit_with(b, r, &mut NoStats),
                    ));
                }
                for (k, h, any) in got {
                    if (!same_hit(&h, &expect) || any != expect_any)
                        && !(tolerate_known_bugs
                            && crate::fuzzing::explained_by_known_bug(tris, r).is_some())
                    {
                        return Err(format!(
                            "{k} ({}): ray {i} ({r:?}) gives {h:?}/{any}, brute force \
                             {expect:?}/{expect_any}",
                            p.name()
                        ));
                    }
                }
            }
        }
        Ok(())
    })();
    w4.set_precision(p4);
    w8.set_precision(p8);
    result
}

/// True when `f32` cannot represent the inside of triangle `prim` reliably: twice its area
/// is below `1e-4` of its longest edge squared (a sliver or needle, whose barycentric
/// coordinates one rounding of a vertex coordinate moves by more than the oracle's edge band).
fn thin(tris: &[Triangle], prim: u32) -> bool {
    let Some(t) = tris.get(prim as usize) else {
        return false;
    };
    let e = [t.v[1] - t.v[0], t.v[2] - t.v[1], t.v[0] - t.v[2]]
        .map(|d| d.as_dvec3().length_squared())
        .into_iter()
        .fold(0.0f64, f64::max);
    // NaN (a huge triangle) counts as thin.
    (2.0 * t.area()).partial_cmp(&(1e-4 * e)) != Some(std::cmp::Ordering::Greater)
}

/// True when a non-zero coordinate of `points` lies outside `[2^-40, 2^40]` in magnitude:
/// the watertight test's products of coordinate differences then overflow or underflow `f32`
/// (the `false-hit` class of docs/hardcases.md), so the oracle's verdict is not a promise.
fn extreme(points: &[Vec3A]) -> bool {
    points.iter().flat_map(|p| p.to_array()).any(|c| {
        let a = c.abs();
        a != 0.0 && !(2f32.powi(-40)..=2f32.powi(40)).contains(&a)
    })
}

/// The rounding error of the `f32` watertight test's barycentric coordinates for this ray
/// and triangle, bounded a priori (`f64`, from the `f32` inputs): `C · ε · M · S / |det|`
/// with `ε = 2^-24`, `M` the largest sheared vertex coordinate before cancellation
/// (`|a[kx]| + |s_x a[kz]|`, `a` the vertex minus the origin: what the translation and the
/// shear round), `S` the largest sheared coordinate after it (what the edge functions'
/// products multiply that error by), `det` the sum of the edge functions, and `C ε = 16 ε`
/// (the forward analysis gives about `11 ε M S` for an edge function: five roundings in each
/// sheared coordinate, two in each product). The bound is a worst case: the four hits it
/// explains in `tests/resolution.rs` lie 70–130 times inside it, where the test's actual
/// error happened to be. An exact
/// hit whose smallest barycentric is below it lies where `f32` may decide either way:
/// docs/robustness.md, "Limits". `+inf` when `det` is zero or the inputs are not finite.
pub fn barycentric_resolution(tri: &Triangle, ray: &Ray) -> f64 {
    let o = ray.origin.as_dvec3();
    let d = ray.direction().as_dvec3();
    let kz = d.abs().max_position();
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    let (sx, sy) = (d[kx] / d[kz], d[ky] / d[kz]);
    let (mut m, mut s) = (0.0f64, 0.0f64);
    let sheared = tri.v.map(|v| {
        let a = v.as_dvec3() - o;
        m = m.max(a[kx].abs() + (sx * a[kz]).abs());
        m = m.max(a[ky].abs() + (sy * a[kz]).abs());
        let p = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        s = s.max(p.0.abs()).max(p.1.abs());
        p
    });
    let [(ax, ay), (bx, by), (cx, cy)] = sheared;
    let det = (cx * by - cy * bx) + (ax * cy - ay * cx) + (bx * ay - by * ax);
    let bound = 32.0 * f64::from(f32::EPSILON) * 0.5 * m * s / det.abs();
    if bound.is_nan() {
        f64::INFINITY
    } else {
        bound
    }
}

/// The rounding error of the `f32` watertight test's distance `t` for this ray and triangle,
/// bounded a priori (`f64`, from the `f32` inputs): the test computes `t · det` as
/// `Σ e_i z_i` (the edge functions times the vertices' scaled distances along the ray), whose
/// terms can be far larger than their sum when the triangle is far larger than the hit's
/// distance (a triangle 10^8 wide hit 3 units from the origin: terms of 10^25 summing to
/// 10^18). Bound: `C ε (Σ |e_i z_i| + 3 M S Z) / |det|`, `Z` the largest `|z_i|` and `M`, `S`
/// as in [`barycentric_resolution`] (each edge function's own error times `Z`), `C ε = 16 ε`.
/// A hit whose exact `t` lies within it of an end of the ray's span may fall on either side
/// in `f32`. `+inf` when `det` is zero or the inputs are not finite.
pub fn distance_resolution(tri: &Triangle, ray: &Ray) -> f64 {
    let o = ray.origin.as_dvec3();
    let d = ray.direction().as_dvec3();
    let kz = d.abs().max_position();
    let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let (mut m, mut s, mut z) = (0.0f64, 0.0f64, 0.0f64);
    let sheared = tri.v.map(|v| {
        let a = v.as_dvec3() - o;
        m = m.max(a[kx].abs() + (sx * a[kz]).abs());
        m = m.max(a[ky].abs() + (sy * a[kz]).abs());
        let p = (a[kx] - sx * a[kz], a[ky] - sy * a[kz], sz * a[kz]);
        s = s.max(p.0.abs()).max(p.1.abs());
        z = z.max(p.2.abs());
        p
    });
    let [(ax, ay, az), (bx, by, bz), (cx, cy, cz)] = sheared;
    let e = [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax];
    let det = e[0] + e[1] + e[2];
    let terms = (e[0] * az).abs() + (e[1] * bz).abs() + (e[2] * cz).abs();
    let bound = 32.0 * f64::from(f32::EPSILON) * 0.5 * (terms + 3.0 * m * s * z) / det.abs();
    if bound.is_nan() {
        f64::INFINITY
    } else {
        bound
    }
}

/// True when the exact hit `h` (of the triangle it names) lies within the `f32` test's
/// rounding error of an edge of its triangle ([`barycentric_resolution`]) or of an end of the
/// ray's span ([`distance_resolution`]).
fn unresolvable(tris: &[Triangle], h: &sahara_oracle::ExactHit, ray: &Ray) -> bool {
    tris.get(h.prim as usize).is_some_and(|t| {
        let dt = distance_resolution(t, ray);
        h.min_bary < barycentric_resolution(t, ray)
            || h.t - f64::from(ray.tmin) < dt
            || f64::from(ray.tmax) - h.t < dt
    })
}

/// The exact precision's answers (brute force, which every exact kernel equals) judged by
/// the exact oracle ray by ray: no real hit missed, none nearer than the reported one, no
/// false hit. Rays on an edge and unorderable ties are counted apart ([`crate::pinning`]),
/// and so are failures on [`thin`] or [`extreme`] triangles (the decisive triangle of the
/// verdict, or the reported one) and of [`extreme`] rays: only a real hit missed is an
/// error.
fn oracle_agrees(tris: &[Triangle], rays: &[Ray]) -> Result<(), String> {
    use sahara_oracle::{judge_any, judge_closest_detailed, Class, OracleRay};
    let oracle = crate::pinning::oracle_for(tris);
    for (i, r) in rays.iter().enumerate() {
        let or = OracleRay {
            origin: r.origin.to_array(),
            dir: r.direction().to_array(),
            tmin: r.tmin,
            tmax: r.tmax,
        };
        let h = brute::closest_hit(tris, r);
        let v = judge_closest_detailed(&oracle, &or, h.is_hit().then_some((h.prim, h.t)));
        let any = brute::any_hit(tris, r);
        let va = judge_any(&oracle, &or, any);
        let fails = |c: Class| c == Class::Missed;
        let odd =
            |prim: u32| thin(tris, prim) || tris.get(prim as usize).is_some_and(|t| extreme(&t.v));
        // A miss (closest or any hit) is explained when every strict hit the oracle finds
        // lies within the test's rounding error of an edge; a farther hit when the nearest
        // one does.
        let below_resolution = || {
            if h.is_hit() {
                v.nearest.as_ref().is_some_and(|n| unresolvable(tris, n, r))
            } else {
                oracle
                    .candidates(&or, 0.0, sahara_oracle::Mode::Any)
                    .iter()
                    .filter(|c| c.is_strict())
                    .all(|c| unresolvable(tris, c, r))
            }
        };
        let explained = (h.is_hit() && odd(h.prim))
            || v.nearest.as_ref().is_some_and(|n| odd(n.prim))
            || extreme(&[r.origin, r.direction()])
            || below_resolution();
        if (fails(v.class) || fails(va)) && !explained {
            return Err(format!(
                "oracle: ray {i} ({r:?}): closest hit {h:?} is {:?} (exact nearest {:?}), \
                 any hit {any} is {va:?}",
                v.class,
                v.nearest.map(|n| (n.prim, n.t))
            ));
        }
    }
    Ok(())
}

/// Moves every vertex by a random fraction of the scene's size (finite results only).
fn moved(tris: &[Triangle], seed: u32) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed as u64, 49);
    let b = scene_box(tris);
    let s = (b.max - b.min).max_element() * 0.01;
    tris.iter()
        .map(|t| {
            let m = Triangle::new(
                t.v[0] + unit(&mut rng) * s,
                t.v[1] + unit(&mut rng) * s,
                t.v[2] + unit(&mut rng) * s,
            );
            if m.is_finite() {
                m
            } else {
                *t
            }
        })
        .collect()
}

/// Refit after random motion: the refitted binary tree validates against the moved triangles,
/// and the refitted wide trees trace them like brute force (and like trees collapsed from the
/// refitted binary tree).
fn check_refit(
    bvh: &Bvh,
    w4: &WideBvh<4>,
    w8: &WideBvh<8>,
    tris: &[Triangle],
    rays: &[Ray],
    seed: u32,
) -> Result<(), String> {
    let m = moved(tris, seed);
    let mut b = bvh.clone();
    b.refit_triangles(&m)
        .map_err(|e| format!("refit: binary tree refused: {e}"))?;
    b.validate(&m)
        .map_err(|e| format!("refit: refitted tree invalid: {e}"))?;
    let (mut r4, mut r8) = (w4.clone(), w8.clone());
    r4.refit_triangles(&m)
        .map_err(|e| format!("refit: bvh4 refused: {e}"))?;
    r8.refit_triangles(&m)
        .map_err(|e| format!("refit: bvh8 refused: {e}"))?;
    kernels_equal_brute(Some(&b), &mut r4, &mut r8, &m, rays, true)
        .map_err(|e| format!("refit: {e}"))
}

/// Instances of the scene's 8-wide tree (translated, rotated, scaled, mirrored by the seed):
/// the two-level traversal equals the two-level brute force, bit for bit.
fn check_instances(w8: &Bvh8, tris: &[Triangle], rays: &[Ray], seed: u32) -> Result<(), String> {
    let mut rng = Pcg32::new(seed as u64, 50);
    let b = scene_box(tris);
    let ext = (b.max - b.min).max_element();
    let count = 1 + rng.below(4) as usize;
    let instances: Vec<Instance> = (0..count)
        .map(|k| {
            let axis = Vec3::from(unit(&mut rng)).normalize_or(Vec3::Z);
            let rot = Quat::from_axis_angle(axis, rng.range_f32(-3.2, 3.2));
            let mut scale = Vec3::splat(2f32.powi(rng.below(5) as i32 - 2));
            if k % 2 == 1 {
                scale.x = -scale.x;
            }
            let shift = Vec3::from(unit(&mut rng)) * ext * 0.5;
            Instance {
                blas: 0,
                transform: Affine3A::from_scale_rotation_translation(scale, rot, shift),
            }
        })
        .collect();
    let top = |boxes: &[Aabb]| {
        let input = BuildInput::from_boxes(boxes, CostModel::default()).expect("finite boxes");
        registry::by_name("binned")
            .expect("the binned builder is registered")
            .build(&input)
            .expect("a top-level tree")
    };
    let set = match InstanceSet::new(vec![Arc::new(w8.clone())], instances, top) {
        Ok(s) => s,
        // A transform whose inverse overflows (huge scenes): a typed refusal is the answer.
        Err(sahara_traverse::instance::InstanceError::BadTransform { .. }) => return Ok(()),
        Err(e) => return Err(format!("instances: {e}")),
    };
    let budget = (BRUTE_BUDGET / (count * tris.len().max(1))).clamp(4, rays.len().max(4));
    for (i, r) in rays.iter().take(budget).enumerate() {
        let got = set.closest_hit(r, &mut NoStats);
        let want = set.brute_closest_hit(r, |_, o| brute::closest_hit(tris, o));
        let same = match (got, want) {
            (None, None) => true,
            (Some(g), Some(w)) => {
                g.instance == w.instance
                    && g.prim == w.prim
                    && g.t.to_bits() == w.t.to_bits()
                    && g.u.to_bits() == w.u.to_bits()
                    && g.v.to_bits() == w.v.to_bits()
            }
            _ => false,
        };
        let any = set.any_hit(r, &mut NoStats);
        let want_any = set.brute_any_hit(r, |_, o| brute::any_hit(tris, o));
        if !same || any != want_any {
            return Err(format!(
                "instances: ray {i} ({r:?}) gives {got:?}/{any}, brute force {want:?}/{want_any}"
            ));
        }
    }
    Ok(())
}

/// The tree saved, mutated at a few positions chosen by the seed (the checksum fixed when
/// the seed says so, so that mutations get past it), and loaded: a typed error or a tree that
/// passes its checks ([`crate::fuzzing::check_bvh_file`]'s promises, over this scene).
fn check_saved_file(bvh: &Bvh, tris: &[Triangle], rays: &[Ray], seed: u32) -> Result<(), String> {
    let mut file = Vec::new();
    bvh.save(&mut file)
        .map_err(|e| format!("save into memory failed: {e}"))?;
    let mut rng = Pcg32::new(seed as u64, 51);
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(file.len() as u32) as usize;
        file[at] ^= 1 << rng.below(8);
    }
    if rng.below(2) == 0 {
        crate::corpus::fix_bvh_checksum(&mut file);
    }
    check_loaded_bvh(&file, tris, rays).map_err(|e| format!("saved file: {e}"))
}

/// The check of the `big_scene` fuzz target: expands `data` ([`Header`], [`Edit`]s) into a
/// scene and rays, then checks that
///
/// * [`BuildInput::new`] rejects exactly a scene with a non-finite coordinate, naming the
///   first bad triangle (the scene then continues with those coordinates set to zero);
/// * the chosen builder ([`capped_size`]) returns a tree that passes [`Bvh::validate`], with
///   a finite SAH cost (unless the scene's extent overflows `f32`);
/// * every kernel equals its brute-force twin bit for bit at both precisions
///   ([`kernels_equal_brute`]) on the sampled and the edited rays, and for the exact
///   precision the exact oracle finds no real hit missed, none nearer, no false hit;
/// * by the header's flags: refit after random motion, instances, a mutated saved file.
///
/// `Err` describes the first broken promise (a panic counts as one).
pub fn check_big_scene(data: &[u8]) -> Result<(), String> {
    catch_quiet(|| check_big_scene_inner(data)).map_err(|p| format!("panicked: {p}"))?
}

fn check_big_scene_inner(data: &[u8]) -> Result<(), String> {
    let h = Header::parse(data);
    let entries = registry::entries();
    let entry = &entries[h.builder % entries.len()];
    let n = capped_size(entry, h.size);
    let (mut tris, mut rays) = generate(&h, n);
    // A hard case comes with its own size: the builder's cap still holds (the first
    // triangles of the case).
    tris.truncate(capped_size(entry, usize::MAX));
    // Bounded work for the scenes that come with many rays (hard cases).
    rays.truncate((BRUTE_BUDGET / tris.len().max(1)).clamp(64, 1024));
    apply_edits(&mut tris, &mut rays, &edits(data), h.seed);
    rays.extend(sample_rays(&tris, &h));

    let first_bad = tris.iter().position(|t| !t.is_finite());
    match (BuildInput::new(&tris, CostModel::default()), first_bad) {
        (Err(BuildError::NonFinite { triangle }), Some(i)) if triangle == i => {}
        (Ok(_), None) => {}
        (r, _) => {
            return Err(format!(
                "BuildInput::new: {:?} (first non-finite: {first_bad:?})",
                r.err()
            ))
        }
    }
    if first_bad.is_some() {
        for t in &mut tris {
            let f = |p: Vec3A| Vec3A::select(p.is_finite_mask(), p, Vec3A::ZERO);
            *t = Triangle::new(f(t.v[0]), f(t.v[1]), f(t.v[2]));
        }
    }
    let input = BuildInput::new(&tris, CostModel::default())
        .map_err(|e| format!("BuildInput::new on a finite scene: {e}"))?;
    let name = entry.name;
    let bvh = (entry.make)()
        .build(&input)
        .map_err(|e| format!("{name}: build error on finite input: {e}"))?;
    bvh.validate(&tris)
        .map_err(|e| format!("{name}: invalid tree: {e}"))?;
    let cost = sahara_metrics::sah(&bvh, &CostModel::default());
    if !cost.is_finite() && !extent_overflows(&tris) {
        return Err(format!("{name}: SAH cost {cost}"));
    }
    let mut w4 = WideBvh::<4>::from_bvh(&bvh, &tris);
    let mut w8 = WideBvh::<8>::from_bvh(&bvh, &tris);
    kernels_equal_brute(Some(&bvh), &mut w4, &mut w8, &tris, &rays, true)
        .map_err(|e| format!("{name}: {e}"))?;
    oracle_agrees(&tris, &rays).map_err(|e| format!("{name}: {e}"))?;
    if h.flags & 1 != 0 {
        check_refit(&bvh, &w4, &w8, &tris, &rays, h.seed).map_err(|e| format!("{name}: {e}"))?;
    }
    if h.flags & 2 != 0 {
        check_instances(&w8, &tris, &rays, h.seed).map_err(|e| format!("{name}: {e}"))?;
    }
    if h.flags & 4 != 0 {
        check_saved_file(&bvh, &tris, &rays, h.seed).map_err(|e| format!("{name}: {e}"))?;
    }
    Ok(())
}

/// Index of a builder in [`registry::entries`] (0 when it is not registered).
fn builder_index(name: &str) -> usize {
    registry::entries()
        .iter()
        .position(|e| e.name == name)
        .unwrap_or(0)
}

/// A header with the given fields (the rest zero).
fn header(generator: Generator, size: usize, builder: &str, seed: u32, flags: u8) -> Header {
    Header {
        generator,
        size,
        builder: builder_index(builder),
        seed,
        scale_exp: 0,
        offset_exp: 0,
        flags,
    }
}

/// Seed inputs for `fuzz/corpus/big_scene/`: every case of the hard-case suite (each with a
/// different builder, so every builder is seeded), every generator at a moderate size, and
/// the big scenes that cross the parallel thresholds and the huge-page layout with the fast
/// builders (with refit, instances and a mutated saved file), plus a few adversarial edits.
pub fn seeds() -> Vec<(String, Vec<u8>)> {
    let entries = registry::entries();
    let mut v = Vec::new();
    for (i, case) in hard_cases().iter().enumerate() {
        let mut h = header(Generator::HardCase, 1, "", i as u32, 0);
        h.builder = i % entries.len();
        let name = case.name.replace(['/', '@', ' '], "-");
        v.push((format!("hardcase-{name}"), h.bytes().to_vec()));
    }
    for (i, g) in Generator::ALL.into_iter().enumerate() {
        let h = header(g, 1_000, entries[i % entries.len()].name, i as u32, 7);
        v.push((format!("{g:?}-1000").to_lowercase(), h.bytes().to_vec()));
    }
    for (g, size, builder, flags) in [
        (Generator::Soup, 150_000, "binned", 0),
        (Generator::Grid, 140_000, "binned-8", 7),
        (Generator::Procedural, 70_000, "ploc", 1),
        (Generator::Duplicates, 34_000, "sweep", 2),
        (Generator::Soup, 17_000, "sbvh", 4),
    ] {
        let h = header(g, size, builder, 46, flags);
        v.push((
            format!("{g:?}-{size}-{builder}").to_lowercase(),
            h.bytes().to_vec(),
        ));
    }
    // Adversarial edits on a small soup: each kind of edit once.
    let mut d = header(Generator::Soup, 64, "sweep", 7, 7).bytes().to_vec();
    for op in 0..14u8 {
        d.extend_from_slice(&[op, op * 3, 0, 0, op.wrapping_mul(37), op]);
    }
    v.push(("soup-64-every-edit".to_string(), d));
    let mut d = header(Generator::Soup, 8, "binned", 9, 0).bytes().to_vec();
    d.extend_from_slice(&[0, 2, 0, 0, 9 * 8, 0]);
    v.push(("soup-8-nan".to_string(), d));
    v
}

/// Inputs of [`replay_inputs`] on which the exact oracle finds a real hit that brute force
/// (hence every exact kernel) misses, with ordinary coordinates: open findings of issue 46,
/// not yet triaged (docs/robustness.md, "Fuzzing"). The CI replay accepts exactly these
/// failures, each only while it still fails with an `oracle:` verdict. Empty: the four
/// findings of the earlier, registry-ordered inputs were hits within the `f32` test's
/// rounding error ([`barycentric_resolution`]; docs/robustness.md, "Fuzzing").
pub const OPEN_FINDINGS: &[&str] = &[];

/// The deterministic inputs of the CI replay (`tests/files.rs`) besides the saved corpus:
/// every generator with every builder at small sizes (at most 300 triangles), a header from a
/// fixed-seed PCG and a few random edits each. They take seconds in all.
pub fn replay_inputs() -> Vec<(String, Vec<u8>)> {
    let entries = registry::entries();
    let mut v = Vec::new();
    for (gi, g) in Generator::ALL.into_iter().enumerate() {
        for (bi, e) in entries.iter().enumerate() {
            // Each input's generator seeded by its own name, so that registering a builder
            // adds inputs without changing the others (and the open findings they name).
            let name = format!("{g:?} {}", e.name).to_lowercase();
            let seed = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
            });
            let mut rng = Pcg32::new(seed, 3);
            let mut d = vec![gi as u8, rng.below(8) as u8, bi as u8];
            d.extend((0..7).map(|_| rng.next_u32() as u8));
            // Scale and offset: mostly none, sometimes extreme.
            if rng.below(3) != 0 {
                d[7] = 0;
                d[8] = 0;
            }
            for _ in 0..rng.below(6) {
                d.extend((0..EDIT_LEN).map(|_| rng.next_u32() as u8));
            }
            v.push((name, d));
        }
    }
    v
}
