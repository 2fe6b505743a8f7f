//! sahara for renderers: build a BVH over triangles with one quality knob, and trace rays
//! on the fastest SIMD layout of the CPU.
//!
//! * [`Accel::build`] (triangles) and [`Accel::build_indexed`] (vertex positions and index
//!   triples) build with a [`Quality`] level or full [`BuildOptions`] (cost model, threads);
//! * [`Accel::closest_hit`], [`Accel::any_hit`] (occlusion) and the batch queries
//!   [`Accel::closest_hits`] and [`Accel::any_hits`] (on rayon, results in the order of the
//!   rays, the same whatever the thread count); a closest hit is an [`AccelHit`] (triangle,
//!   `t`, barycentrics, unnormalised geometric normal);
//! * [`Accel::closest_point`] and the batch [`Accel::closest_points`]: the point of the
//!   triangles nearest to a point within a distance ([`PointHit`]), equal to a brute-force
//!   scan bit for bit (ties: the lowest triangle index);
//! * [`Accel::build_from_file`] and [`SceneBuilder::add_file`]: from a `.obj`, `.obj.gz`,
//!   `.gltf` or `.glb` file (the loaders of [`sahara_scene`]) to a built structure, a missing
//!   or broken file an [`Error::File`];
//! * [`Accel::save`] and [`Accel::load`] store the whole structure in a versioned,
//!   checksummed file (the layout is rebuilt on load; see [`file`](mod@file)); a broken file is a
//!   [`LoadError`].
//!
//! **The façade adds no algorithm**: it chooses a registered builder of `sahara-builders` by
//! quality level, checks its tree, collapses it into the 8-wide layout of `sahara-traverse`
//! and calls that crate's kernels, whose SIMD backend (AVX-512, AVX2, SSE2 or portable) is
//! picked at run time ([`Accel::backend`]). Every answer is the one of the scalar reference
//! kernel, bit for bit (ties at equal distance: the lowest triangle index), so a brute-force
//! loop over the triangles gives the same hits.
//!
//! **Why 8-wide everywhere.** bvh8 traced faster than bvh4 on the same CPU with both the SSE2
//! and the AVX2 kernels (bunny primary rays, 2026-11-25: bvh4 2.4–2.6×, bvh8 2.6–3.1× the
//! binary tree), and 2.4–4.7× faster than the binary tree on the shared scenes; see
//! `docs/facade.md`.
//!
//! **Bad input.** Non-finite vertices, bad indices and invalid cost models are typed
//! [`Error`]s; degenerate and duplicate triangles are built like any other (and never hit);
//! an invalid ray (NaN or infinite origin, zero or non-finite direction, `tmin > tmax`; see
//! [`Ray::is_valid`]) misses.
//!
//! * [`Instances`] places many copies of a few shared [`Accel`]s (`Arc<Accel>`) with affine
//!   transforms (a two-level structure) and traces them as one scene:
//!   [`Instances::set_transform`] moves an instance by rebuilding the top level only,
//!   [`Instances::set_mask`] gives it a 32-bit mask that the queries' ray mask tests, and an
//!   [`InstanceHit`] gives the instance, mesh, triangle, `t`, `u`, `v` and the world-space
//!   normal; [`Instances::closest_hit_filtered`] and [`Instances::any_hit_filtered`] take
//!   an any-hit filter as [`Scene`]'s queries do; [`Accel::refit`] moves the vertices and updates the bounds of the tree and of its
//!   layout without rebuilding.
//!
//! * [`Scene`] ([`SceneBuilder`]) holds many geometries under one BVH: triangle meshes and
//!   user primitives (boxes plus an intersection callback), each with a [`GeometryId`] and a
//!   32-bit mask; queries take a ray mask and an optional any-hit filter (alpha testing), and
//!   return a [`SceneHit`] (geometry, primitive, `t`, `u`, `v`, geometric normal);
//!   [`Scene::refit`] moves a geometry's triangles and refits the scene's tree.
//!
//! * [`Scene::save`] and [`Scene::load`] store a scene of triangle geometries (masks, tree and
//!   triangles; the layout rebuilt on load), a broken file a [`LoadError`].
//!
//! **Not here yet.** Saving a [`Scene`] with user primitives (their callbacks cannot be
//! stored), instances of scenes (instances place [`Accel`]s of triangles only). The lower crates ([`sahara_builders`], [`sahara_traverse`]) are re-exported for
//! everything the façade does not cover.
//!
//! # Example
//!
//! The README's example (compiled and run as a doctest):
#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

mod error;
pub mod file;
mod instances;
mod mesh_file;
mod point;
mod quality;
mod scene;

use std::io::{Read, Write};
use std::path::Path;

use rayon::prelude::*;
use sahara_traverse::HitLocation;

pub use error::{BuildError, Error, LoadError, ValidationError};
pub use instances::{Affine3A, InstanceHit, Instances};
pub use point::PointHit;
pub use quality::{BuildOptions, Quality};
pub use sahara_bvh::Bvh;
pub use sahara_geom::{Aabb, Ray, Triangle, Vec3, Vec3A};
pub use sahara_metrics::CostModel;
pub use sahara_traverse::{Backend, Bvh8, Hit};
pub use scene::{GeometryId, Intersection, Scene, SceneBuilder, SceneError, SceneHit, ALL_MASK};

/// The lower crates, for what the façade does not cover (other builders, other layouts,
/// work counters, metrics, scene files and procedural scenes).
pub use {sahara_builders, sahara_bvh, sahara_geom, sahara_metrics, sahara_scene, sahara_traverse};

/// `query` of every item, in parallel on the current rayon pool, in the order of `items`: the
/// batch queries of every structure (at least 64 items to a task).
fn batch<I: Sync, T: Send>(items: &[I], query: impl Fn(&I) -> T + Sync + Send) -> Vec<T> {
    items.par_iter().with_min_len(64).map(query).collect()
}

/// A closest hit on an [`Accel`] ([`Accel::closest_hit`]): the triangle, where, and its
/// geometric normal.
///
/// `prim`, `t`, `u` and `v` are the kernel's one hit type's ([`Hit`]); `normal` is
/// derived from the hit triangle:
///
/// * `u`, `v`: the barycentric weights of vertices 1 and 2 (the point is
///   `(1 - u - v) · v0 + u · v1 + v · v2`);
/// * `normal`: the **unnormalised** geometric normal `(v1 - v0) × (v2 - v0)` of the triangle
///   hit (its direction follows the winding, whichever side the ray came from; its length is
///   twice the triangle's area), as [`SceneHit::normal`] and, before the instance's
///   transform, [`InstanceHit::normal`]. It is computed from the vertices of the leaf packet
///   where the kernel found the hit (which the traversal has just loaded; the same vertices
///   as [`Accel::triangles`]'s, bit for bit), so it costs no extra memory access
///   (`docs/facade.md` measures it).
///
/// ```
/// use sahara::{Accel, AccelHit, Quality, Ray, Triangle, Vec3A};
/// // A triangle in the plane z = 1, wound clockwise seen from above.
/// let tri = Triangle::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(0.0, 2.0, 1.0), Vec3A::new(2.0, 0.0, 1.0));
/// let accel = Accel::build(&[tri], Quality::Medium)?;
/// let hit: AccelHit = accel.closest_hit(&Ray::new(Vec3A::new(0.5, 0.5, 3.0), -Vec3A::Z, 0.0, 9.0)).unwrap();
/// assert_eq!((hit.prim, hit.t), (0, 2.0));
/// assert_eq!(hit.normal, Vec3A::new(0.0, 0.0, -4.0)); // length 2 × area
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelHit {
    /// Index of the triangle hit (its position in [`Accel::triangles`]).
    pub prim: u32,
    /// Ray parameter of the hit.
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
    /// Geometric normal, unnormalised: `(v1 - v0) × (v2 - v0)`.
    pub normal: Vec3A,
}

/// A ray-tracing acceleration structure over triangles: the triangles, the binary tree
/// built over them at a [`Quality`] level, and its 8-wide SIMD layout.
///
/// ```
/// use sahara::{Accel, Quality, Ray, Triangle, Vec3A};
///
/// let tris: Vec<Triangle> = (0..100)
///     .map(|i| {
///         let o = Vec3A::new((i % 10) as f32, (i / 10) as f32, 4.0);
///         Triangle::new(o, o + Vec3A::X, o + Vec3A::Y)
///     })
///     .collect();
/// let accel = Accel::build(&tris, Quality::High)?;
/// let ray = Ray::new(Vec3A::new(2.25, 3.25, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
/// assert_eq!(accel.closest_hit(&ray).map(|h| h.prim), Some(32));
/// assert!(!accel.any_hit(&Ray::new(Vec3A::ZERO, -Vec3A::Z, 0.0, f32::INFINITY)));
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Accel {
    triangles: Vec<Triangle>,
    bvh: Bvh,
    wide: Bvh8,
    quality: Quality,
    cost: CostModel,
}

impl Accel {
    /// Builds over `triangles` (copied) with a quality level or [`BuildOptions`].
    ///
    /// Fails with [`Error::Build`] on a non-finite vertex or an invalid cost model. An empty
    /// slice gives a structure that every ray misses.
    pub fn build(triangles: &[Triangle], options: impl Into<BuildOptions>) -> Result<Accel, Error> {
        Self::build_owned(triangles.to_vec(), options.into())
    }

    /// Builds over an indexed mesh: vertex positions (glam [`Vec3`], [`Vec3A`] or `[f32; 3]`)
    /// and one index triple per triangle. Hits report the triple's position in `indices`.
    ///
    /// Fails with [`Error::IndexOutOfRange`] when a triple names a missing vertex.
    ///
    /// ```
    /// use sahara::{Accel, Quality, Ray, Vec3A};
    /// let positions = [[0.0f32, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
    /// let accel = Accel::build_indexed(&positions, &[[0, 1, 2]], Quality::Fast)?;
    /// assert_eq!(accel.len(), 1);
    /// assert!(matches!(
    ///     Accel::build_indexed(&positions, &[[0, 1, 3]], Quality::Fast),
    ///     Err(sahara::Error::IndexOutOfRange { triangle: 0, index: 3, vertices: 3 })
    /// ));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn build_indexed<P: Copy + Into<Vec3A>>(
        positions: &[P],
        indices: &[[u32; 3]],
        options: impl Into<BuildOptions>,
    ) -> Result<Accel, Error> {
        let mut triangles = Vec::with_capacity(indices.len());
        for (triangle, idx) in indices.iter().enumerate() {
            let mut v = [Vec3A::ZERO; 3];
            for (slot, &index) in v.iter_mut().zip(idx) {
                *slot = positions
                    .get(index as usize)
                    .copied()
                    .ok_or(Error::IndexOutOfRange {
                        triangle,
                        index,
                        vertices: positions.len(),
                    })?
                    .into();
            }
            triangles.push(Triangle::new(v[0], v[1], v[2]));
        }
        Self::build_owned(triangles, options.into())
    }

    fn build_owned(triangles: Vec<Triangle>, options: BuildOptions) -> Result<Accel, Error> {
        let name = options.quality.builder_name();
        let builder =
            sahara_builders::registry::by_name(name).ok_or(Error::MissingBuilder(name))?;
        let input = sahara_builders::BuildInput::new(&triangles, options.cost)?;
        let bvh = match options.threads {
            None => builder.build(&input)?,
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n.get())
                .build()
                .map_err(|e| Error::ThreadPool(e.to_string()))?
                .install(|| builder.build(&input))?,
        };
        drop(input);
        // Never trace an unchecked tree: the wide collapse indexes it without bounds checks.
        bvh.validate(&triangles)?;
        Ok(Self::assemble(
            triangles,
            bvh,
            options.quality,
            options.cost,
        ))
    }

    /// The structure over a checked tree.
    pub(crate) fn assemble(
        triangles: Vec<Triangle>,
        bvh: Bvh,
        quality: Quality,
        cost: CostModel,
    ) -> Accel {
        let wide = Bvh8::from_bvh(&bvh, &triangles);
        Accel {
            triangles,
            bvh,
            wide,
            quality,
            cost,
        }
    }

    /// The façade's hit from the kernel's one hit type: adds the geometric normal of the
    /// triangle hit (`hit` must be a hit, not [`Hit::MISS`]).
    #[inline]
    fn accel_hit(&self, hit: &Hit) -> AccelHit {
        AccelHit {
            prim: hit.prim,
            t: hit.t,
            u: hit.u,
            v: hit.v,
            normal: self.triangles[hit.prim as usize].cross(),
        }
    }

    /// The closest hit in `[ray.tmin, ray.tmax]`, or `None`: the triangle, `t`, the
    /// barycentrics and the unnormalised geometric normal ([`AccelHit`]). At equal distance
    /// the lowest triangle index wins. Invalid rays miss. Equals
    /// [`Accel::brute_closest_hit`] bit for bit.
    ///
    /// ```
    /// use sahara::{Accel, Quality, Ray, Triangle, Vec3A};
    /// let accel = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let hit = accel.closest_hit(&Ray::new(Vec3A::new(0.25, 0.5, 2.0), -Vec3A::Z, 0.0, 9.0)).unwrap();
    /// assert_eq!((hit.prim, hit.t, hit.u, hit.v), (0, 2.0, 0.25, 0.5));
    /// assert_eq!(hit.normal, Vec3A::Z); // (v1 - v0) × (v2 - v0)
    /// # Ok::<(), sahara::Error>(())
    /// ```
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<AccelHit> {
        let mut at = HitLocation::default();
        let hit = self.wide.closest_hit(ray, &mut at);
        hit.is_hit().then(|| self.located_hit(&hit, &at))
    }

    /// [`Accel::accel_hit`] with the triangle read from the wide tree's leaf packet where the
    /// kernel found it (just loaded by the traversal, so no cache miss, unlike the input
    /// array), the same vertices bit for bit.
    #[inline]
    fn located_hit(&self, hit: &Hit, at: &HitLocation) -> AccelHit {
        match self.wide.located_triangle(at) {
            Some(tri) => AccelHit {
                prim: hit.prim,
                t: hit.t,
                u: hit.u,
                v: hit.v,
                normal: tri.cross(),
            },
            None => self.accel_hit(hit),
        }
    }

    /// The brute-force twin of [`Accel::closest_hit`]: every triangle in index order with the
    /// exact watertight test (`sahara_traverse::brute::closest_hit`), no tree; the normal
    /// computed as the query computes it. The query equals it bit for bit.
    ///
    /// ```
    /// use sahara::{Accel, Quality, Ray, Triangle, Vec3A};
    /// let accel = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.25, 0.5, 2.0), -Vec3A::Z, 0.0, 9.0);
    /// assert_eq!(accel.brute_closest_hit(&ray), accel.closest_hit(&ray));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_closest_hit(&self, ray: &Ray) -> Option<AccelHit> {
        let hit = sahara_traverse::brute::closest_hit(&self.triangles, ray);
        hit.is_hit().then(|| self.accel_hit(&hit))
    }

    /// True when any triangle is hit in `[ray.tmin, ray.tmax]` (occlusion; stops at the first
    /// hit found). Invalid rays miss.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.wide.any_hit(ray, &mut sahara_traverse::NoStats)
    }

    /// [`Accel::closest_hit`] of every ray, traced in parallel on the current rayon pool
    /// (use `ThreadPool::install` to choose one), in the order of `rays`.
    ///
    /// The normal of each hit comes from the wide tree's leaf packet where the kernel found
    /// it, which the traversal has just loaded (reading the input triangle instead cost
    /// 7–20% of the batch; `docs/facade.md`).
    ///
    /// ```
    /// use sahara::{Accel, Quality, Ray, Triangle, Vec3A};
    /// let accel = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let rays: Vec<Ray> = (0..1000)
    ///     .map(|i| Ray::new(Vec3A::new((i as f32 + 0.5) / 1000.0, 0.25, 1.0), -Vec3A::Z, 0.0, 2.0))
    ///     .collect();
    /// let hits = accel.closest_hits(&rays);
    /// assert!(rays.iter().zip(&hits).all(|(r, h)| *h == accel.closest_hit(r)));
    /// assert_eq!(hits.iter().flatten().count(), 750);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<AccelHit>> {
        batch(rays, |r| self.closest_hit(r))
    }

    /// [`Accel::any_hit`] of every ray, in parallel, in the order of `rays`.
    pub fn any_hits(&self, rays: &[Ray]) -> Vec<bool> {
        crate::batch(rays, |r| self.any_hit(r))
    }

    /// Moves the triangles to `triangles` (the same number, in the same order: triangle `i`'s
    /// new position) and refits the tree and its 8-wide layout bottom-up, keeping their
    /// topology: much cheaper than a rebuild, and exact (every answer equals brute force over
    /// the new triangles), but the tree's quality decays as the motion grows
    /// (`docs/refit.md` measures how fast, per level). Refitting to unmoved triangles is the
    /// identity, bit for bit, at every level: a tree with spatial splits ([`Quality::High`],
    /// [`Quality::Best`]) keeps where its builder cut each triangle ([`Bvh::ref_cuts`]) and
    /// clips the moved triangles again at those planes, so its boxes stay clipped (a structure
    /// loaded from a file of an older version, without those records, refits with whole
    /// triangle boxes: still exact, looser).
    ///
    /// Fails, leaving the structure unchanged, with [`Error::RefitCount`] when the count
    /// differs and [`Error::Refit`] on a NaN or infinite coordinate.
    pub fn refit(&mut self, triangles: &[Triangle]) -> Result<(), Error> {
        if triangles.len() != self.triangles.len() {
            return Err(Error::RefitCount {
                expected: self.triangles.len(),
                given: triangles.len(),
            });
        }
        // Checked before anything changes, so that the tree and the layout stay in step.
        if let Some(i) = triangles.iter().position(|t| !t.is_finite()) {
            return Err(sahara_bvh::RefitError::InvalidBox { prim: i as u32 }.into());
        }
        self.bvh.refit_triangles(triangles)?;
        self.wide.refit_triangles(triangles)?;
        self.triangles.copy_from_slice(triangles);
        Ok(())
    }

    /// Writes the structure (format in [`file`](mod@file)).
    pub fn save<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        file::save(self, w)
    }

    /// Reads a structure written by [`Accel::save`]: checks the magic, version, sizes and
    /// checksums, that the triangles are finite and that the tree fits them, then rebuilds
    /// the 8-wide layout. Never panics on any bytes.
    pub fn load<R: Read>(r: &mut R) -> Result<Accel, LoadError> {
        file::load(r)
    }

    /// [`Accel::save`] to a file.
    pub fn save_to_path(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
        self.save(&mut w)?;
        w.flush()
    }

    /// [`Accel::load`] from a file.
    pub fn load_from_path(path: impl AsRef<Path>) -> Result<Accel, LoadError> {
        Self::load(&mut std::io::BufReader::new(std::fs::File::open(path)?))
    }

    /// The triangles, in the order hits index them.
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }

    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles (every ray misses).
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The quality level it was built at.
    pub fn quality(&self) -> Quality {
        self.quality
    }

    /// The cost model it was built with.
    pub fn cost(&self) -> CostModel {
        self.cost
    }

    /// The binary tree (for metrics such as `sahara_metrics::sah`, or the scalar kernels).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The 8-wide layout the queries run on.
    pub fn wide(&self) -> &Bvh8 {
        &self.wide
    }

    /// The SIMD backend the queries use on this CPU.
    pub fn backend(&self) -> Backend {
        self.wide.backend()
    }

    /// Bounds of all triangles (empty when there are none).
    pub fn bounds(&self) -> Aabb {
        self.wide.bounds()
    }
}
