//! Axis-aligned floors and walls: the geometry of game levels and architectural models, where
//! large flat triangles have bounding boxes of zero extent on one axis.
//!
//! A level is two storeys of rooms on an integer grid (level editors snap to one): floors,
//! ceilings and walls are rectangles at constant `z`, `x` or `y`, each triangulated as a fan
//! from one corner to points spread along the opposite edges, so most triangles are long,
//! thin and large (like those of a level's brush faces split at T-junctions), plus crates and
//! pillars (closed boxes, two triangles a face). Everything is scaled by `scale` and moved by
//! `offset`, so the same level exists at 1 to 10^4 units and near or far from the origin.
//!
//! [`flat_rays`] makes the rays that such levels get: camera rays from inside the rooms,
//! grazing rays just above a floor, secondary rays leaving a surface (origin pushed off the
//! surface as renderers do, or on it with a small `tmin`), and ambient-occlusion rays.

use crate::rays::{on_triangle, unit};
use sahara_geom::{rng::Pcg32, Ray, Triangle, Vec3A};

/// What a ray of [`flat_rays`] is, which decides its query.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FlatRayKind {
    /// From a random point inside a room in a random direction (closest hit).
    Camera,
    /// Just above a floor and nearly parallel to it (closest hit).
    Grazing,
    /// Leaving a floor, wall or crate surface into its hemisphere (closest hit).
    Secondary,
    /// Like `Secondary` with a short `tmax` (any hit).
    AmbientOcclusion,
}

impl FlatRayKind {
    /// Every kind, in report order.
    pub const ALL: [FlatRayKind; 4] = [
        FlatRayKind::Camera,
        FlatRayKind::Grazing,
        FlatRayKind::Secondary,
        FlatRayKind::AmbientOcclusion,
    ];

    /// A short lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            FlatRayKind::Camera => "camera",
            FlatRayKind::Grazing => "grazing",
            FlatRayKind::Secondary => "secondary",
            FlatRayKind::AmbientOcclusion => "ao",
        }
    }

    /// True for the kinds traced for any hit.
    pub fn uses_any_hit(self) -> bool {
        self == FlatRayKind::AmbientOcclusion
    }
}

/// Size of a level in grid units: rooms of `ROOM` × `ROOM` × `STOREY`, `ROOMS` × `ROOMS` of
/// them per storey, two storeys with a slab of `SLAB` between them (so that a ceiling and the
/// floor above are not coplanar: coincident faces make ties that no `f32` test can order).
const ROOM: f32 = 64.0;
const STOREY: f32 = 24.0;
const SLAB: f32 = 1.0;
const ROOMS: usize = 3;

/// One floor-and-wall level (see the module documentation). About 1 500 triangles.
pub fn floors_and_walls(scale: f32, offset: Vec3A, seed: u64) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 21);
    let mut tris = Vec::new();
    let p = |v: Vec3A| v * scale + offset;
    for storey in 0..2 {
        let z0 = storey as f32 * (STOREY + SLAB);
        for rx in 0..ROOMS {
            for ry in 0..ROOMS {
                let x0 = rx as f32 * ROOM;
                let y0 = ry as f32 * ROOM;
                let (x1, y1, z1) = (x0 + ROOM, y0 + ROOM, z0 + STOREY);
                // Floor and ceiling (constant z), walls (constant x, constant y).
                fan_rect(&mut tris, &mut rng, 2, [x0, y0], [x1, y1], z0, &p);
                fan_rect(&mut tris, &mut rng, 2, [x0, y0], [x1, y1], z1, &p);
                fan_rect(&mut tris, &mut rng, 0, [y0, z0], [y1, z1], x0, &p);
                fan_rect(&mut tris, &mut rng, 1, [x0, z0], [x1, z1], y0, &p);
                // Crates and a pillar standing on the floor.
                for _ in 0..2 {
                    let cx = x0 + 4.0 + rng.below(ROOM as u32 - 16) as f32;
                    let cy = y0 + 4.0 + rng.below(ROOM as u32 - 16) as f32;
                    let (w, h) = (2.0 + rng.below(6) as f32, 1.0 + rng.below(4) as f32);
                    boxed(&mut tris, [cx, cy, z0], [cx + w, cy + w, z0 + h], false, &p);
                }
                let (px, py) = (x0 + ROOM * 0.5, y0 + ROOM * 0.5);
                boxed(&mut tris, [px, py, z0], [px + 2.0, py + 2.0, z1], true, &p);
            }
        }
    }
    // The outer walls of the last row and column.
    let (xe, ye) = (ROOMS as f32 * ROOM, ROOMS as f32 * ROOM);
    let top = 2.0 * STOREY + SLAB;
    fan_rect(&mut tris, &mut rng, 0, [0.0, 0.0], [ye, top], xe, &p);
    fan_rect(&mut tris, &mut rng, 1, [0.0, 0.0], [xe, top], ye, &p);
    tris
}

/// A rectangle at constant coordinate `c` on `axis`, spanning `lo..hi` on the two other axes
/// (in their usual order), triangulated as a fan from its `lo` corner to integer points spread
/// along the two far edges: long thin triangles whose boxes are flat on `axis`.
fn fan_rect(
    out: &mut Vec<Triangle>,
    rng: &mut Pcg32,
    axis: usize,
    lo: [f32; 2],
    hi: [f32; 2],
    c: f32,
    p: &impl Fn(Vec3A) -> Vec3A,
) {
    let point = |a: f32, b: f32| {
        let mut v = [0.0f32; 3];
        let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        v[axis] = c;
        v[i] = a;
        v[j] = b;
        p(Vec3A::from_array(v))
    };
    // Points along the far edge of the first axis (a = hi[0]) then along the far edge of the
    // second (b = hi[1]), from corner (hi[0], lo[1]) to corner (lo[0], hi[1]).
    let mut rim = vec![(hi[0], lo[1])];
    let cuts = 2 + rng.below(4);
    let mut along = |n: u32, from: f32, to: f32| {
        let mut ts: Vec<f32> = (0..n)
            .map(|_| from + 1.0 + rng.below((to - from) as u32 - 2) as f32)
            .collect();
        ts.sort_by(f32::total_cmp);
        ts.dedup();
        ts
    };
    for b in along(cuts, lo[1], hi[1]) {
        rim.push((hi[0], b));
    }
    rim.push((hi[0], hi[1]));
    let mut back = along(cuts, lo[0], hi[0]);
    back.reverse();
    for a in back {
        rim.push((a, hi[1]));
    }
    rim.push((lo[0], hi[1]));
    let apex = point(lo[0], lo[1]);
    for w in rim.windows(2) {
        out.push(Triangle::new(
            apex,
            point(w[0].0, w[0].1),
            point(w[1].0, w[1].1),
        ));
    }
}

/// A box standing on a floor, two triangles a face, without its bottom face (and without its
/// top face when `to_ceiling`): hidden faces coplanar with the floor or ceiling would make
/// exact ties that no `f32` test can order, which is not what these levels test.
fn boxed(
    out: &mut Vec<Triangle>,
    lo: [f32; 3],
    hi: [f32; 3],
    to_ceiling: bool,
    p: &impl Fn(Vec3A) -> Vec3A,
) {
    let c = |i: usize| {
        p(Vec3A::new(
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ))
    };
    let top = [[4, 5, 7, 6]];
    let sides = [[0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let faces = sides
        .iter()
        .chain(if to_ceiling { &[][..] } else { &top[..] });
    for &[a, b, cc, d] in faces {
        out.push(Triangle::new(c(a), c(b), c(cc)));
        out.push(Triangle::new(c(a), c(cc), c(d)));
    }
}

/// The scales of the levels every check uses: 1 to 10^4 units.
pub const SCALES: [f32; 5] = [1.0, 10.0, 100.0, 1000.0, 10000.0];

/// One floor-and-wall level of the standard set ([`levels`]).
#[derive(Clone, Debug)]
pub struct FlatLevel {
    /// `x<scale>@origin` or `x<scale>@far`.
    pub name: String,
    /// Grid unit in scene units.
    pub scale: f32,
    /// Where the level's grid origin is.
    pub offset: Vec3A,
    /// The level's index in [`levels`] order of scales (its geometry seed).
    pub seed: u64,
}

impl FlatLevel {
    /// The level's triangles ([`floors_and_walls`]).
    pub fn triangles(&self) -> Vec<Triangle> {
        floors_and_walls(self.scale, self.offset, self.seed)
    }

    /// `n` rays of `kind` ([`flat_rays`] with `seed`, filtered).
    pub fn rays(&self, tris: &[Triangle], n: usize, seed: u64, kind: FlatRayKind) -> Vec<Ray> {
        flat_rays(tris, self.scale, self.offset, n, seed)
            .into_iter()
            .filter(|(k, _)| *k == kind)
            .map(|(_, r)| r)
            .collect()
    }
}

/// The standard set: every scale of [`SCALES`], at the origin and at [`far_offset`].
pub fn levels() -> Vec<FlatLevel> {
    let mut v = Vec::new();
    for (k, scale) in SCALES.into_iter().enumerate() {
        for far in [false, true] {
            v.push(FlatLevel {
                name: format!("x{scale}@{}", if far { "far" } else { "origin" }),
                scale,
                offset: if far { far_offset(scale) } else { Vec3A::ZERO },
                seed: k as u64,
            });
        }
    }
    v
}

/// The offset of a level "far from the origin" at `scale`: about 25 level sizes away on every
/// axis, where a level's coordinates have lost about five bits to the offset.
pub fn far_offset(scale: f32) -> Vec3A {
    Vec3A::new(5000.0, -3500.0, 1500.0) * scale
}

/// `n` rays of each kind of [`FlatRayKind`] for a level made by [`floors_and_walls`] with the
/// same `scale` and `offset` (deterministic from `seed`).
pub fn flat_rays(
    tris: &[Triangle],
    scale: f32,
    offset: Vec3A,
    n: usize,
    seed: u64,
) -> Vec<(FlatRayKind, Ray)> {
    let mut rng = Pcg32::new(seed, 22);
    let mut out = Vec::with_capacity(4 * n);
    let ext = ROOMS as f32 * ROOM;
    let inside = |rng: &mut Pcg32| {
        Vec3A::new(
            rng.range_f32(0.5, ext - 0.5),
            rng.range_f32(0.5, ext - 0.5),
            rng.range_f32(0.5, 2.0 * STOREY + SLAB - 0.5),
        ) * scale
            + offset
    };
    for _ in 0..n {
        let o = inside(&mut rng);
        out.push((
            FlatRayKind::Camera,
            Ray::new(o, unit(&mut rng), 0.0, f32::INFINITY),
        ));
    }
    for _ in 0..n {
        // 10^-4 to 1 grid units above a floor, 10^-5 to 10^-1 of vertical direction.
        let storey = rng.below(2) as f32 * (STOREY + SLAB);
        let h = 10f32.powf(rng.range_f32(-4.0, 0.0));
        let mut o = inside(&mut rng);
        o.z = (storey + h) * scale + offset.z;
        let a = rng.range_f32(0.0, std::f32::consts::TAU);
        let dz = 10f32.powf(rng.range_f32(-5.0, -1.0)) * if rng.below(2) == 0 { -1.0 } else { 1.0 };
        let d = Vec3A::new(a.cos(), a.sin(), dz);
        out.push((FlatRayKind::Grazing, Ray::new(o, d, 0.0, f32::INFINITY)));
    }
    let diag = {
        let mut lo = Vec3A::splat(f32::INFINITY);
        let mut hi = Vec3A::splat(f32::NEG_INFINITY);
        for t in tris {
            for v in t.v {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (hi - lo).length()
    };
    for kind in [FlatRayKind::Secondary, FlatRayKind::AmbientOcclusion] {
        for i in 0..n {
            let tri = &tris[rng.below(tris.len() as u32) as usize];
            let p = on_triangle(&mut rng, tri);
            let mut nrm = (tri.v[1] - tri.v[0])
                .cross(tri.v[2] - tri.v[0])
                .normalize_or_zero();
            if rng.below(2) == 0 {
                nrm = -nrm;
            }
            // Cosine-weighted, with one ray in four nearly tangent to the surface.
            let mut d = unit(&mut rng);
            if d.dot(nrm) < 0.0 {
                d = -d;
            }
            if i % 4 == 0 {
                d = (d - nrm * d.dot(nrm) * 0.999).normalize_or_zero();
            }
            // Renderers either push the origin off the surface (by about 10^-4 of its
            // magnitude) and start at 0, or keep it and start at a small distance.
            let eps = 1e-4 * (1e-3 * diag).max(p.abs().max_element());
            let (o, tmin) = if i % 2 == 0 {
                (p + nrm * eps, 0.0)
            } else {
                (p, eps)
            };
            let tmax = match kind {
                FlatRayKind::AmbientOcclusion => rng.range_f32(0.002, 0.2) * diag,
                _ => f32::INFINITY,
            };
            out.push((kind, Ray::new(o, d, tmin, tmax)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_flat_and_deterministic() {
        let a = floors_and_walls(10.0, far_offset(10.0), 3);
        let b = floors_and_walls(10.0, far_offset(10.0), 3);
        assert_eq!(a.len(), b.len());
        assert!(a.iter().zip(&b).all(|(x, y)| x.v == y.v));
        assert!(a.len() > 500, "{} triangles", a.len());
        // Every triangle's box is flat on one axis.
        for t in &a {
            let e = t.bounds().extent();
            assert!(e.min_element() == 0.0, "{t:?}");
        }
        let rays = flat_rays(&a, 10.0, far_offset(10.0), 10, 1);
        assert_eq!(rays.len(), 40);
        assert!(rays.iter().all(|(_, r)| r.is_valid()));
    }
}
