//! Indexed triangle meshes.

use std::path::Path;

use sahara_geom::{Aabb, Triangle, Vec3A};

use crate::SceneError;

/// An indexed triangle mesh: positions and triangles as triples of indices into them.
///
/// Only geometry is kept: no normals, texture coordinates or materials. A mesh returned by
/// a loader or a generator of this crate is *valid*: every coordinate is finite and every
/// index is in range (see [`Mesh::validate`]). Degenerate triangles (zero area, or an index
/// repeated) are kept as they are; [`Mesh::stats`] counts them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3A>,
    /// Triangles, each three indices into `positions`, in winding order.
    pub indices: Vec<[u32; 3]>,
}

/// Statistics of a [`Mesh`], as [`Mesh::stats`] computes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshStats {
    /// Number of triangles.
    pub triangles: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Triangles with three distinct indices but zero area (computed in `f64`).
    pub zero_area: usize,
    /// Triangles that repeat a vertex index.
    pub index_degenerate: usize,
    /// Vertices no triangle references.
    pub unused_vertices: usize,
    /// Bounds of the triangles (of the referenced vertices); [`Aabb::EMPTY`] for no triangle.
    pub bounds: Aabb,
    /// Sum of the triangle areas.
    pub total_area: f64,
    /// Smallest non-zero triangle area (`0.0` when every triangle is degenerate).
    pub min_nonzero_area: f64,
    /// Largest triangle area.
    pub max_area: f64,
}

impl Mesh {
    /// A mesh from positions and triangles (not validated: see [`Mesh::validate`]).
    pub fn new(positions: Vec<Vec3A>, indices: Vec<[u32; 3]>) -> Self {
        Self { positions, indices }
    }

    /// A mesh from a triangle soup: three new vertices per triangle.
    pub fn from_triangles(triangles: &[Triangle]) -> Self {
        let mut m = Mesh::default();
        m.positions.reserve(triangles.len() * 3);
        m.indices.reserve(triangles.len());
        for t in triangles {
            m.push_triangle(t.v[0], t.v[1], t.v[2]);
        }
        m
    }

    /// Number of triangles.
    #[inline]
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Number of vertices.
    #[inline]
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// True when the mesh has no triangle.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Triangle `i`. Panics when `i` or one of its indices is out of range.
    #[inline]
    pub fn triangle(&self, i: usize) -> Triangle {
        let [a, b, c] = self.indices[i];
        Triangle::new(
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        )
    }

    /// All triangles, in index order (triangle `i` of the result is [`Mesh::triangle`]`(i)`).
    pub fn triangles(&self) -> Vec<Triangle> {
        (0..self.indices.len()).map(|i| self.triangle(i)).collect()
    }

    /// The bounding box of the triangles (unreferenced vertices are ignored);
    /// [`Aabb::EMPTY`] for a mesh without triangles.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for tri in &self.indices {
            for &i in tri {
                b.grow(self.positions[i as usize]);
            }
        }
        b
    }

    /// Adds a vertex and returns its index.
    #[inline]
    pub fn push_vertex(&mut self, p: Vec3A) -> u32 {
        let i = self.positions.len() as u32;
        self.positions.push(p);
        i
    }

    /// Adds a triangle with three new vertices.
    #[inline]
    pub fn push_triangle(&mut self, a: Vec3A, b: Vec3A, c: Vec3A) {
        let i = self.push_vertex(a);
        self.push_vertex(b);
        self.push_vertex(c);
        self.indices.push([i, i + 1, i + 2]);
    }

    /// Appends the vertices and triangles of `other` (its indices shifted accordingly).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.indices
            .extend(other.indices.iter().map(|t| t.map(|i| i + base)));
    }

    /// Applies `f` to every vertex position.
    pub fn transform_positions(&mut self, mut f: impl FnMut(Vec3A) -> Vec3A) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }

    /// Checks that every coordinate is finite and every index in range.
    ///
    /// `file` is only used to name the mesh in the error.
    pub fn validate(&self, file: &Path) -> Result<(), SceneError> {
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::NonFinite {
                file: file.to_path_buf(),
                vertex_index: i,
                value: self.positions[i].to_array(),
            });
        }
        let n = self.positions.len();
        for (t, tri) in self.indices.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(SceneError::IndexOutOfRange {
                        file: file.to_path_buf(),
                        triangle: t,
                        index: i64::from(i),
                        vertex_count: n,
                    });
                }
            }
        }
        Ok(())
    }

    /// A loader's last step: the mesh when [`Mesh::validate`] passes and it has a triangle,
    /// else the error naming `file` ([`SceneError::Empty`] for no triangles).
    pub(crate) fn checked(self, file: &Path) -> Result<Mesh, SceneError> {
        self.validate(file)?;
        if self.indices.is_empty() {
            return Err(SceneError::Empty {
                file: file.to_path_buf(),
            });
        }
        Ok(self)
    }

    /// Counts triangles, vertices, degenerate triangles and unused vertices, and measures
    /// bounds and areas. Linear in the size of the mesh.
    pub fn stats(&self) -> MeshStats {
        let mut used = vec![false; self.positions.len()];
        let mut s = MeshStats {
            triangles: self.indices.len(),
            vertices: self.positions.len(),
            zero_area: 0,
            index_degenerate: 0,
            unused_vertices: 0,
            bounds: Aabb::EMPTY,
            total_area: 0.0,
            min_nonzero_area: f64::INFINITY,
            max_area: 0.0,
        };
        for (t, idx) in self.indices.iter().enumerate() {
            for &i in idx {
                used[i as usize] = true;
            }
            let tri = self.triangle(t);
            s.bounds = s.bounds.union(&tri.bounds());
            let area = tri.area();
            if idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2] {
                s.index_degenerate += 1;
            } else if area == 0.0 {
                s.zero_area += 1;
            }
            s.total_area += area;
            if area > 0.0 {
                s.min_nonzero_area = s.min_nonzero_area.min(area);
            }
            s.max_area = s.max_area.max(area);
        }
        if s.min_nonzero_area == f64::INFINITY {
            s.min_nonzero_area = 0.0;
        }
        s.unused_vertices = used.iter().filter(|&&u| !u).count();
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_count_degenerates_separately() {
        let m = Mesh::new(
            vec![
                Vec3A::ZERO,
                Vec3A::X,
                Vec3A::Y,
                Vec3A::new(2.0, 0.0, 0.0),
                Vec3A::splat(9.0),
            ],
            vec![[0, 1, 2], [0, 0, 1], [0, 1, 3]],
        );
        let s = m.stats();
        assert_eq!(s.triangles, 3);
        assert_eq!(s.index_degenerate, 1);
        assert_eq!(s.zero_area, 1);
        assert_eq!(s.unused_vertices, 1);
        assert_eq!(s.max_area, 0.5);
        assert_eq!(s.min_nonzero_area, 0.5);
        assert_eq!(s.bounds, Aabb::new(Vec3A::ZERO, Vec3A::new(2.0, 1.0, 0.0)));
        assert_eq!(m.bounds(), s.bounds);
        m.validate(Path::new("x")).unwrap();
    }

    #[test]
    fn append_shifts_indices() {
        let mut a = Mesh::from_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)]);
        let b = a.clone();
        a.append(&b);
        assert_eq!(a.indices, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(a.triangles()[1], b.triangle(0));
    }
}
