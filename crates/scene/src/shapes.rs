//! Tessellated closed shapes: building blocks of the procedural scenes and of hard-case
//! tests.
//!
//! Every shape is an indexed mesh whose vertices are shared by index, and every closed shape
//! ([`closed_box`], [`tessellated_sphere`], [`uv_sphere`], [`torus`]) is watertight: each
//! edge is shared by exactly two triangles, with opposite directions (consistent outward
//! winding, counter-clockwise seen from outside).

use std::collections::HashMap;
use std::f32::consts::PI;

use sahara_geom::Vec3A;

use crate::Mesh;

/// A closed axis-aligned box from `min` to `max`, each face split into
/// `subdivisions × subdivisions` quads of two triangles: `12 · subdivisions²` triangles and
/// `6 · subdivisions² + 2` vertices. `subdivisions` is clamped to at least 1.
pub fn closed_box(min: Vec3A, max: Vec3A, subdivisions: u32) -> Mesh {
    let n = subdivisions.max(1);
    let mut mesh = Mesh::default();
    let mut lattice: HashMap<[u32; 3], u32> = HashMap::new();
    let coord = |axis: usize, i: u32| -> f32 {
        if i == 0 {
            min[axis]
        } else if i == n {
            max[axis]
        } else {
            min[axis] + (max[axis] - min[axis]) * (i as f32 / n as f32)
        }
    };
    let mut vertex = |mesh: &mut Mesh, ijk: [u32; 3]| -> u32 {
        *lattice.entry(ijk).or_insert_with(|| {
            mesh.push_vertex(Vec3A::new(
                coord(0, ijk[0]),
                coord(1, ijk[1]),
                coord(2, ijk[2]),
            ))
        })
    };
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n] {
            for j in 0..n {
                for i in 0..n {
                    let mut corner = |di: u32, dj: u32| {
                        let mut ijk = [0u32; 3];
                        ijk[axis] = side;
                        ijk[u] = i + di;
                        ijk[v] = j + dj;
                        vertex(&mut mesh, ijk)
                    };
                    let (p00, p10, p11, p01) =
                        (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
                    if side == n {
                        // e_u × e_v = +e_axis: counter-clockwise seen from outside.
                        mesh.indices.push([p00, p10, p11]);
                        mesh.indices.push([p00, p11, p01]);
                    } else {
                        mesh.indices.push([p00, p11, p10]);
                        mesh.indices.push([p00, p01, p11]);
                    }
                }
            }
        }
    }
    mesh
}

/// An icosphere: a regular icosahedron whose faces are split `subdivisions` times into four,
/// with every vertex projected onto the sphere: `20 · 4^subdivisions` triangles.
/// `subdivisions` is clamped to at most 10 (about 21 million triangles).
pub fn tessellated_sphere(center: Vec3A, radius: f32, subdivisions: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3A> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3A::from_array(p).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions.min(10) {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3A>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let p = ((positions[a as usize] + positions[b as usize]) * 0.5).normalize();
                positions.push(p);
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.push([a, ab, ca]);
            next.push([b, bc, ab]);
            next.push([c, ca, bc]);
            next.push([ab, bc, ca]);
        }
        faces = next;
    }
    for p in &mut positions {
        *p = center + *p * radius;
    }
    Mesh::new(positions, faces)
}

/// A UV (latitude/longitude) sphere around the y axis with `segments` meridians and
/// `rings` bands from pole to pole (single pole vertices, fans at the poles):
/// `2 · segments · (rings − 1)` triangles. `segments` is clamped to at least 3 and `rings`
/// to at least 2.
pub fn uv_sphere(center: Vec3A, radius: f32, segments: u32, rings: u32) -> Mesh {
    let segments = segments.max(3);
    let rings = rings.max(2);
    let mut mesh = Mesh::default();
    let north = mesh.push_vertex(center + Vec3A::Y * radius);
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        let (st, ct) = theta.sin_cos();
        for s in 0..segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            let (sp, cp) = phi.sin_cos();
            mesh.push_vertex(center + Vec3A::new(st * cp, ct, st * sp) * radius);
        }
    }
    let south = mesh.push_vertex(center - Vec3A::Y * radius);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        mesh.indices.push([north, ring(1, s + 1), ring(1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b) = (ring(r, s), ring(r, s + 1));
            let (c, d) = (ring(r + 1, s), ring(r + 1, s + 1));
            mesh.indices.push([a, b, d]);
            mesh.indices.push([a, d, c]);
        }
    }
    for s in 0..segments {
        mesh.indices
            .push([ring(rings - 1, s), ring(rings - 1, s + 1), south]);
    }
    mesh
}

/// A torus around the y axis (lying flat on the xz plane) with ring radius `major` and tube
/// radius `minor`, `major_segments` steps around the ring and `minor_segments` around the
/// tube: `2 · major_segments · minor_segments` triangles. Both counts are clamped to at
/// least 3.
pub fn torus(
    center: Vec3A,
    major: f32,
    minor: f32,
    major_segments: u32,
    minor_segments: u32,
) -> Mesh {
    let nu = major_segments.max(3);
    let nv = minor_segments.max(3);
    let mut mesh = Mesh::default();
    for i in 0..nu {
        let (su, cu) = (2.0 * PI * i as f32 / nu as f32).sin_cos();
        for j in 0..nv {
            let (sv, cv) = (2.0 * PI * j as f32 / nv as f32).sin_cos();
            let rho = major + minor * cv;
            mesh.push_vertex(center + Vec3A::new(rho * cu, minor * sv, rho * su));
        }
    }
    let id = |i: u32, j: u32| (i % nu) * nv + j % nv;
    for i in 0..nu {
        for j in 0..nv {
            let (p00, p10, p11, p01) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            mesh.indices.push([p00, p11, p10]);
            mesh.indices.push([p00, p01, p11]);
        }
    }
    mesh
}

/// A surface of revolution around the vertical axis through `center`: the polyline
/// `profile` of `(radius, height)` points is swept through `segments` steps, and the x
/// coordinate is then multiplied by `x_stretch` (1 for a circular shape). A first profile
/// point of radius 0 becomes a single vertex (a fan). The surface is open unless the profile
/// starts and ends on the axis. Triangles face up (counter-clockwise seen from above) when
/// the radius grows along the profile.
pub fn revolve(center: Vec3A, profile: &[(f32, f32)], segments: u32, x_stretch: f32) -> Mesh {
    let segments = segments.max(3);
    let mut mesh = Mesh::default();
    if profile.len() < 2 {
        return mesh;
    }
    let mut rows: Vec<Option<u32>> = Vec::with_capacity(profile.len()); // start of each row
    let mut apex: Vec<Option<u32>> = Vec::with_capacity(profile.len());
    for &(r, h) in profile {
        if r == 0.0 {
            apex.push(Some(mesh.push_vertex(center + Vec3A::new(0.0, h, 0.0))));
            rows.push(None);
        } else {
            apex.push(None);
            rows.push(Some(mesh.positions.len() as u32));
            for s in 0..segments {
                let (sp, cp) = (2.0 * PI * s as f32 / segments as f32).sin_cos();
                mesh.push_vertex(center + Vec3A::new(r * cp * x_stretch, h, r * sp));
            }
        }
    }
    let at = |row: usize, s: u32| -> u32 {
        match (rows[row], apex[row]) {
            (Some(start), _) => start + s % segments,
            (None, Some(a)) => a,
            (None, None) => unreachable!(),
        }
    };
    for k in 0..profile.len() - 1 {
        for s in 0..segments {
            let (a, b) = (at(k, s), at(k, s + 1));
            let (c, d) = (at(k + 1, s), at(k + 1, s + 1));
            // Inner row (a, b), outer row (c, d); normal up for growing radius.
            if a != b {
                mesh.indices.push([a, b, d]);
            }
            if c != d {
                mesh.indices.push([a, d, c]);
            }
        }
    }
    mesh
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Every directed edge appears once and its reverse once: closed and consistently wound.
    pub(crate) fn is_closed(mesh: &Mesh) -> bool {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &mesh.indices {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        edges
            .iter()
            .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
    }

    fn signed_volume(mesh: &Mesh) -> f64 {
        mesh.triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.v.map(|p| p.as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn closed_shapes_are_watertight_and_outward() {
        let b = closed_box(Vec3A::splat(-1.0), Vec3A::new(2.0, 3.0, 4.0), 3);
        assert_eq!(b.triangle_count(), 12 * 9);
        assert_eq!(b.vertex_count(), 6 * 9 + 2);
        assert!(is_closed(&b));
        assert!((signed_volume(&b) - 3.0 * 4.0 * 5.0).abs() < 1e-3);

        let s = tessellated_sphere(Vec3A::new(1.0, 2.0, 3.0), 2.0, 3);
        assert_eq!(s.triangle_count(), 20 * 64);
        assert!(is_closed(&s));
        let v = signed_volume(&s);
        assert!(v > 0.9 * 4.0 / 3.0 * std::f64::consts::PI * 8.0, "{v}");

        let u = uv_sphere(Vec3A::ZERO, 1.0, 16, 8);
        assert_eq!(u.triangle_count(), 2 * 16 * 7);
        assert!(is_closed(&u));
        assert!(signed_volume(&u) > 3.0);

        let t = torus(Vec3A::ZERO, 2.0, 0.5, 24, 12);
        assert_eq!(t.triangle_count(), 2 * 24 * 12);
        assert!(is_closed(&t));
        assert!(signed_volume(&t) > 0.0);
    }

    #[test]
    fn revolve_makes_a_bowl_facing_up() {
        let m = revolve(Vec3A::ZERO, &[(0.0, 0.0), (1.0, 0.0), (2.0, 1.0)], 8, 1.5);
        assert_eq!(m.triangle_count(), 8 + 16);
        assert_eq!(m.vertex_count(), 1 + 16);
        assert!(m.triangles()[0].cross().y > 0.0);
        assert!(m.triangles()[8].cross().y > 0.0);
        assert!((m.bounds().max.x - 3.0).abs() < 1e-6);
    }
}
