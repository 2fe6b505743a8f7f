//! Scenes of many geometries: triangle meshes and user primitives under one BVH, each
//! geometry with an id and a 32-bit mask, rays with a mask, and an optional any-hit filter.
//!
//! See [`Scene`] and [`SceneBuilder`]; `docs/facade.md` ("Scenes of many geometries") gives
//! the semantics in one place.

use std::cell::RefCell;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use sahara_builders::split::spatial::{Clipper, SplitPrimitive};
use sahara_builders::split::BinMap;
use sahara_builders::BuildInput;
use sahara_geom::intersect::{intersect_triangle, WatertightRay};
use sahara_geom::Axis;
use sahara_traverse::custom::{accept_primitive_hit, primitive_span, MixedPrims};
use sahara_traverse::NoStats;

use crate::{Aabb, Backend, BuildOptions, Bvh, Bvh8, CostModel, Error, Quality, Ray, Triangle};
use crate::{ValidationError, Vec3A};

/// All 32 bits set: the mask new geometries get, and the ray mask that tests every geometry
/// whose mask is not zero.
///
/// ```
/// assert_eq!(sahara::ALL_MASK, u32::MAX);
/// ```
pub const ALL_MASK: u32 = u32::MAX;

/// Names one geometry of one scene: the position of its `add_*` call on its [`SceneBuilder`]
/// (0, 1, 2, ...; [`GeometryId::index`]) and a tag of that builder, so that an id of another
/// scene is recognised ([`SceneError::UnknownGeometry`]) instead of naming some geometry here.
///
/// Ids order by builder, then by index; in one scene the tie-break "lowest geometry id" is
/// "lowest index".
///
/// ```
/// use sahara::{SceneBuilder, Triangle, Vec3A};
/// let mut b = SceneBuilder::new();
/// let first = b.add_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)]);
/// let second = b.add_triangles(&[]);
/// assert_eq!((first.index(), second.index()), (0, 1));
/// assert!(first < second);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GeometryId {
    scene: u64,
    index: u32,
}

impl GeometryId {
    /// The geometry's position in the order of the builder's `add_*` calls (0 for the first).
    /// A renderer's material table can be indexed by it.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// assert_eq!(b.add_triangles(&[]).index(), 0);
    /// ```
    pub fn index(self) -> u32 {
        self.index
    }
}

/// What a user primitive's intersection callback returns for a hit: the distance along the ray,
/// two surface coordinates and a normal (any length; the façade passes them through to
/// [`SceneHit`]).
///
/// ```
/// use sahara::{Intersection, Vec3A};
/// let hit = Intersection { t: 2.0, u: 0.0, v: 0.0, normal: -Vec3A::Z };
/// assert_eq!(hit.t, 2.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intersection {
    /// Ray parameter of the hit (before the hit rule clamps it into the primitive's box span).
    pub t: f32,
    /// First surface coordinate (free for the callback to define).
    pub u: f32,
    /// Second surface coordinate.
    pub v: f32,
    /// The normal to report (not normalised by the façade).
    pub normal: Vec3A,
}

/// A hit in a [`Scene`]: which geometry, which of its primitives, where.
///
/// * `t`: the ray parameter (for user primitives, the callback's distance after the hit rule
///   of `sahara_traverse::custom`, which clamps it into the ray's span through the primitive's
///   box);
/// * `u`, `v`: for triangles the barycentric weights of vertices 1 and 2 (the point is
///   `(1 - u - v) · v0 + u · v1 + v · v2`); for user primitives what the callback returned;
/// * `normal`: for triangles the **unnormalised** geometric normal `(v1 - v0) × (v2 - v0)`
///   (its direction follows the winding; its length is twice the triangle's area), as
///   Embree's `Ng`; for user primitives the callback's normal as it returned it. A
///   triangle's normal is computed from the scene's copy of its vertices: one memory access per
///   hit that the traversal has not cached (`docs/facade.md` measures it).
///
/// ```
/// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
/// let mut b = SceneBuilder::new();
/// let floor = b.add_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)]);
/// let scene = b.build(Quality::Fast)?;
/// let hit = scene
///     .closest_hit(&Ray::new(Vec3A::new(0.25, 0.25, 1.0), -Vec3A::Z, 0.0, 10.0), ALL_MASK)
///     .unwrap();
/// assert_eq!((hit.geometry, hit.primitive, hit.t), (floor, 0, 1.0));
/// assert_eq!((hit.u, hit.v), (0.25, 0.25));
/// assert_eq!(hit.normal, Vec3A::Z);
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The geometry hit.
    pub geometry: GeometryId,
    /// The primitive's index within its geometry (the triangle's position in the slice given
    /// to [`SceneBuilder::add_triangles`], the triple's in [`SceneBuilder::add_indexed`], the
    /// box's in [`SceneBuilder::add_primitives`]).
    pub primitive: u32,
    /// Ray parameter of the hit.
    pub t: f32,
    /// First surface coordinate (triangles: barycentric weight of vertex 1).
    pub u: f32,
    /// Second surface coordinate (triangles: barycentric weight of vertex 2).
    pub v: f32,
    /// Geometric normal (triangles: unnormalised `(v1 - v0) × (v2 - v0)`).
    pub normal: Vec3A,
}

/// Why a scene could not be built, or a geometry id was refused (inside
/// [`Error::Scene`]).
///
/// ```
/// use sahara::{Aabb, Error, Quality, SceneBuilder, SceneError, Vec3A};
/// let mut b = SceneBuilder::new();
/// b.add_primitives(&[Aabb::new(Vec3A::ONE, Vec3A::ZERO)], |_: &sahara::Ray, _, _, _| None);
/// let err = b.build(Quality::Fast).unwrap_err();
/// assert!(matches!(err, Error::Scene(SceneError::InvalidBox { geometry: 0, primitive: 0 })));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A triangle has a NaN or infinite coordinate.
    #[error("triangle {primitive} of geometry {geometry} has a non-finite coordinate")]
    NonFinite {
        /// The geometry's index.
        geometry: u32,
        /// The triangle's index within it.
        primitive: usize,
    },
    /// A user primitive's box has a NaN or infinite coordinate, or its minimum exceeds its
    /// maximum.
    #[error("primitive {primitive} of geometry {geometry} has a non-finite or inverted box")]
    InvalidBox {
        /// The geometry's index.
        geometry: u32,
        /// The primitive's index within it.
        primitive: usize,
    },
    /// The id is not a geometry of this scene (out of range, or made by another builder).
    #[error("{0:?} is not a geometry of this scene")]
    UnknownGeometry(GeometryId),
    /// [`Scene::refit`] was given a geometry of user primitives (it moves triangles only).
    #[error("{0:?} holds user primitives, not triangles: it cannot be refitted")]
    NotTriangles(GeometryId),
    /// [`Scene::refit`] was given another number of triangles than the geometry holds.
    #[error("geometry {geometry} has {expected} triangles, the refit gave {given}")]
    RefitCount {
        /// The geometry's index.
        geometry: u32,
        /// Triangles in the geometry.
        expected: usize,
        /// Triangles given.
        given: usize,
    },
    /// [`Scene::save`] was asked to save a geometry of user primitives (their intersection
    /// callbacks are code, which a file cannot hold).
    #[error("{0:?} holds user primitives: a scene with user primitives cannot be saved")]
    UserPrimitives(GeometryId),
    /// More primitives in all than a 32-bit reference can address.
    #[error("{0} primitives exceed the 2^32 - 1 a scene can hold")]
    TooManyPrimitives(usize),
}

/// The filter of a query on a scene with user primitives, which the triangle and the user
/// callbacks of the mixed traversal take turns with (never at once).
type SharedFilter<'a> = RefCell<Option<&'a mut dyn FnMut(&SceneHit) -> bool>>;

/// The intersection callback of a user geometry: `(ray, primitive, tmin, tmax)`.
type IntersectFn = dyn Fn(&Ray, u32, f32, f32) -> Option<Intersection> + Send + Sync;

#[derive(Clone)]
enum Kind {
    /// Triangles: `triangles[base..base + len]` of the scene's triangle table.
    Triangles { base: usize },
    /// User primitives traced by a callback.
    User(Arc<IntersectFn>),
}

#[derive(Clone)]
struct Geometry {
    kind: Kind,
    mask: u32,
    /// Global index of its first primitive.
    first: u32,
    len: u32,
}

/// A user geometry while building: its boxes and its optional splitter.
struct UserInput {
    boxes: Vec<Aabb>,
    intersect: Arc<IntersectFn>,
    splitter: Option<Box<dyn SplitPrimitive + Send>>,
}

enum Input {
    Triangles(Vec<Triangle>),
    User(UserInput),
}

static NEXT_SCENE: AtomicU64 = AtomicU64::new(1);

/// What a saved scene holds (see [`crate::file`]): per geometry its mask and triangle count,
/// all triangles in geometry order, the tree and how it was built.
pub(crate) struct SavedParts<'a> {
    pub geometries: Vec<(u32, u32)>,
    pub triangles: &'a [Triangle],
    pub bvh: &'a Bvh,
    pub quality: Quality,
    pub cost: CostModel,
}

/// Collects the geometries of a [`Scene`]: triangle soups, indexed meshes and user primitives
/// (boxes plus an intersection callback, optionally a splitter for spatial splits), each with
/// a [`GeometryId`] and a 32-bit mask (default [`ALL_MASK`]). [`SceneBuilder::build`] makes
/// one BVH over all their primitives.
///
/// ```
/// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A};
/// let tri = |z: f32| Triangle::new(Vec3A::new(-1.0, -1.0, z), Vec3A::new(1.0, -1.0, z), Vec3A::new(0.0, 1.0, z));
/// let mut b = SceneBuilder::new();
/// let glass = b.add_triangles(&[tri(1.0)]);
/// let wall = b.add_triangles(&[tri(2.0)]);
/// b.set_mask(glass, 0b10)?; // seen by camera rays only
/// let scene = b.build(Quality::Medium)?;
/// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
/// assert_eq!(scene.closest_hit(&ray, 0b10).unwrap().geometry, glass); // camera ray
/// assert_eq!(scene.closest_hit(&ray, 0b01).unwrap().geometry, wall); // shadow ray
/// # Ok::<(), sahara::Error>(())
/// ```
pub struct SceneBuilder {
    tag: u64,
    inputs: Vec<Input>,
    masks: Vec<u32>,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl fmt::Debug for SceneBuilder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SceneBuilder")
            .field("geometries", &self.inputs.len())
            .finish_non_exhaustive()
    }
}

impl SceneBuilder {
    /// An empty builder (a scene without geometries, which every ray misses).
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert!(scene.is_empty());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn new() -> Self {
        Self {
            tag: NEXT_SCENE.fetch_add(1, Ordering::Relaxed),
            inputs: Vec::new(),
            masks: Vec::new(),
        }
    }

    fn push(&mut self, input: Input) -> GeometryId {
        let index = u32::try_from(self.inputs.len()).expect("fewer than 2^32 geometries");
        self.inputs.push(input);
        self.masks.push(ALL_MASK);
        GeometryId {
            scene: self.tag,
            index,
        }
    }

    /// Adds a triangle soup (copied); hits on it report the triangle's index in `triangles`.
    /// Non-finite vertices are refused by [`SceneBuilder::build`] ([`SceneError::NonFinite`]).
    /// An empty slice is a valid, empty geometry.
    ///
    /// ```
    /// use sahara::{SceneBuilder, Triangle, Vec3A};
    /// let mut b = SceneBuilder::new();
    /// let id = b.add_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)]);
    /// assert_eq!(id.index(), 0);
    /// ```
    pub fn add_triangles(&mut self, triangles: &[Triangle]) -> GeometryId {
        self.push(Input::Triangles(triangles.to_vec()))
    }

    /// Adds an indexed mesh: vertex positions (glam [`Vec3`](crate::Vec3), [`Vec3A`] or
    /// `[f32; 3]`) and one index triple per triangle; hits report the triple's position in
    /// `indices`.
    ///
    /// Fails with [`Error::IndexOutOfRange`] when a triple names a missing vertex (nothing is
    /// added then).
    ///
    /// ```
    /// use sahara::SceneBuilder;
    /// let positions = [[0.0f32, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
    /// let mut b = SceneBuilder::new();
    /// let id = b.add_indexed(&positions, &[[0, 1, 2]])?;
    /// assert!(b.add_indexed(&positions, &[[0, 1, 3]]).is_err());
    /// assert_eq!(b.build(sahara::Quality::Fast)?.geometry_len(id), Some(1));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn add_indexed<P: Copy + Into<Vec3A>>(
        &mut self,
        positions: &[P],
        indices: &[[u32; 3]],
    ) -> Result<GeometryId, Error> {
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
        Ok(self.push(Input::Triangles(triangles)))
    }

    /// Adds user primitives: one box per primitive (copied; hits report the box's index) and
    /// the intersection callback `intersect(ray, primitive, tmin, tmax) -> Option<Intersection>`
    /// (`primitive` is the index within this geometry). Spatial splits ([`Quality::High`],
    /// [`Quality::Best`]) cut these primitives' references by clipping the reference's box at
    /// the plane (always conservative); give a [`SplitPrimitive`] with
    /// [`SceneBuilder::add_primitives_with_splitter`] for tighter parts.
    ///
    /// The callback must follow the contract of `sahara_traverse::custom` (the primitive
    /// inside its box; a pure function of its arguments; `tmax` only decides whether its `t` is
    /// reported): then every answer equals [`Scene::brute_closest_hit`] bit for bit. Its
    /// distance is clamped into the ray's span through the box. It must be `Send + Sync`
    /// (batch queries run it on several threads); a panic in it propagates out of the query,
    /// as a filter's does ([`Scene::closest_hit_filtered`]). Invalid boxes (non-finite,
    /// inverted) are refused by [`SceneBuilder::build`] ([`SceneError::InvalidBox`]).
    ///
    /// ```
    /// use sahara::{Aabb, Intersection, Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// // A unit sphere at the origin.
    /// let mut b = SceneBuilder::new();
    /// let ball = b.add_primitives(&[Aabb::new(-Vec3A::ONE, Vec3A::ONE)], |ray: &Ray, _, tmin, tmax| {
    ///     let (o, d) = (ray.origin, ray.direction());
    ///     let (a, h, c) = (d.dot(d), o.dot(d), o.dot(o) - 1.0);
    ///     let disc = h * h - a * c;
    ///     let t = (-h - disc.max(0.0).sqrt()) / a;
    ///     (disc >= 0.0 && t >= tmin && t <= tmax)
    ///         .then(|| Intersection { t, u: 0.0, v: 0.0, normal: ray.at(t) })
    /// });
    /// let scene = b.build(Quality::Medium)?;
    /// let hit = scene.closest_hit(&Ray::new(Vec3A::new(0.0, 0.0, -3.0), Vec3A::Z, 0.0, 9.0), ALL_MASK);
    /// assert_eq!(hit.map(|h| (h.geometry, h.t)), Some((ball, 2.0)));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn add_primitives<F>(&mut self, boxes: &[Aabb], intersect: F) -> GeometryId
    where
        F: Fn(&Ray, u32, f32, f32) -> Option<Intersection> + Send + Sync + 'static,
    {
        self.push(Input::User(UserInput {
            boxes: boxes.to_vec(),
            intersect: Arc::new(intersect),
            splitter: None,
        }))
    }

    /// [`SceneBuilder::add_primitives`] with a splitter: `splitter.split(primitive, axis,
    /// pos, bounds)` (primitive indices within this geometry) cuts the primitives for the
    /// spatial splits of [`Quality::High`] and [`Quality::Best`]. It is used during
    /// [`SceneBuilder::build`] only.
    ///
    /// ```
    /// use sahara::sahara_builders::split::spatial::SplitPrimitive;
    /// use sahara::{Aabb, Intersection, Quality, Ray, SceneBuilder, Vec3A};
    /// // Clips the box: what add_primitives does without a splitter.
    /// struct Halves;
    /// impl SplitPrimitive for Halves {
    ///     fn split(&self, _: u32, axis: usize, pos: f32, b: &Aabb) -> (Aabb, Aabb) {
    ///         let (mut l, mut r) = (*b, *b);
    ///         l.max[axis] = l.max[axis].min(pos);
    ///         r.min[axis] = r.min[axis].max(pos);
    ///         let fix = |x: Aabb| if x.is_empty() { Aabb::EMPTY } else { x };
    ///         (fix(l), fix(r))
    ///     }
    /// }
    /// let mut b = SceneBuilder::new();
    /// let never = |_: &Ray, _: u32, _: f32, _: f32| None::<Intersection>;
    /// b.add_primitives_with_splitter(&[Aabb::new(Vec3A::ZERO, Vec3A::ONE)], never, Halves);
    /// assert_eq!(b.build(Quality::High)?.len(), 1);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn add_primitives_with_splitter<F, P>(
        &mut self,
        boxes: &[Aabb],
        intersect: F,
        splitter: P,
    ) -> GeometryId
    where
        F: Fn(&Ray, u32, f32, f32) -> Option<Intersection> + Send + Sync + 'static,
        P: SplitPrimitive + Send + 'static,
    {
        self.push(Input::User(UserInput {
            boxes: boxes.to_vec(),
            intersect: Arc::new(intersect),
            splitter: Some(Box::new(splitter)),
        }))
    }

    /// Sets a geometry's mask (default [`ALL_MASK`]): a ray with mask `m` tests the geometry
    /// only when `mask & m != 0`. Fails with [`SceneError::UnknownGeometry`] for an id of
    /// another builder.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// let id = b.add_triangles(&[]);
    /// b.set_mask(id, 0b100)?;
    /// assert!(sahara::SceneBuilder::new().set_mask(id, 1).is_err());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn set_mask(&mut self, id: GeometryId, mask: u32) -> Result<(), Error> {
        if id.scene != self.tag || id.index as usize >= self.masks.len() {
            return Err(SceneError::UnknownGeometry(id).into());
        }
        self.masks[id.index as usize] = mask;
        Ok(())
    }

    /// Builds one BVH over every primitive of every geometry with a quality level or
    /// [`BuildOptions`]. A scene of triangles only is built as [`Accel`](crate::Accel) builds
    /// (triangle clipping for spatial splits) and traced with the SIMD triangle kernels; with
    /// user primitives, over all primitives' boxes (triangles still clipped exactly, user
    /// primitives by their splitter or by box clipping).
    ///
    /// Fails with [`SceneError::NonFinite`] / [`SceneError::InvalidBox`] naming the geometry and
    /// primitive, [`SceneError::TooManyPrimitives`], or the build errors of
    /// [`Accel::build`](crate::Accel::build).
    ///
    /// ```
    /// use sahara::{SceneBuilder, SceneError, Triangle, Vec3A, Error, Quality};
    /// let mut b = SceneBuilder::new();
    /// b.add_triangles(&[]);
    /// b.add_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::splat(f32::NAN))]);
    /// assert!(matches!(
    ///     b.build(Quality::Fast),
    ///     Err(Error::Scene(SceneError::NonFinite { geometry: 1, primitive: 0 }))
    /// ));
    /// ```
    pub fn build(self, options: impl Into<BuildOptions>) -> Result<Scene, Error> {
        let options = options.into();
        let mut total = 0usize;
        let mut mixed = false;
        for (g, input) in self.inputs.iter().enumerate() {
            let g = g as u32;
            match input {
                Input::Triangles(tris) => {
                    if let Some(p) = tris.iter().position(|t| !t.is_finite()) {
                        return Err(SceneError::NonFinite {
                            geometry: g,
                            primitive: p,
                        }
                        .into());
                    }
                    total += tris.len();
                }
                Input::User(u) => {
                    let bad = |b: &Aabb| {
                        !(b.min.is_finite() && b.max.is_finite()) || b.min.cmpgt(b.max).any()
                    };
                    if let Some(p) = u.boxes.iter().position(bad) {
                        return Err(SceneError::InvalidBox {
                            geometry: g,
                            primitive: p,
                        }
                        .into());
                    }
                    total += u.boxes.len();
                    mixed = true;
                }
            }
        }
        if total >= u32::MAX as usize {
            return Err(SceneError::TooManyPrimitives(total).into());
        }
        let mut triangles = Vec::new();
        let mut boxes = Vec::new();
        let mut triangle_of = Vec::new();
        let mut geometries = Vec::with_capacity(self.inputs.len());
        let mut first = 0u32;
        for (input, &mask) in self.inputs.iter().zip(&self.masks) {
            let (kind, len) = match input {
                Input::Triangles(tris) => {
                    let base = triangles.len();
                    triangles.extend_from_slice(tris);
                    if mixed {
                        boxes.extend(tris.iter().map(Triangle::bounds));
                        triangle_of.extend(base as u32..(base + tris.len()) as u32);
                    }
                    (Kind::Triangles { base }, tris.len())
                }
                Input::User(u) => {
                    boxes.extend_from_slice(&u.boxes);
                    triangle_of.resize(triangle_of.len() + u.boxes.len(), u32::MAX);
                    (Kind::User(u.intersect.clone()), u.boxes.len())
                }
            };
            geometries.push(Geometry {
                kind,
                mask,
                first,
                len: len as u32,
            });
            first += len as u32;
        }
        let name = options.quality.builder_name();
        let builder =
            sahara_builders::registry::by_name(name).ok_or(Error::MissingBuilder(name))?;
        let splitter = SceneSplitter {
            geometries: &geometries,
            inputs: &self.inputs,
            triangles: Clipper::Triangles(&triangles),
        };
        let input = if mixed {
            BuildInput::from_boxes(&boxes, options.cost)?.with_splitter(&splitter)
        } else {
            BuildInput::new(&triangles, options.cost)?
        };
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
        let wide = if mixed {
            check_box_tree(&bvh, boxes.len())?;
            Bvh8::from_mixed(
                &bvh,
                MixedPrims {
                    boxes: &boxes,
                    triangles: &triangles,
                    triangle_of: &triangle_of,
                },
            )
        } else {
            bvh.validate(&triangles)?;
            Bvh8::from_bvh(&bvh, &triangles)
        };
        let mut scene = Scene {
            tag: self.tag,
            geometries,
            triangles,
            boxes,
            triangle_of,
            bvh,
            wide,
            quality: options.quality,
            cost: options.cost,
            mixed,
            masks: Vec::new(),
        };
        scene.update_masks();
        Ok(scene)
    }
}

/// The checks of a tree over boxes before it is collapsed and traced: its structure, and every
/// primitive referenced, none out of range.
fn check_box_tree(bvh: &Bvh, len: usize) -> Result<(), ValidationError> {
    bvh.validate_structure()?;
    if bvh.nodes.is_empty() {
        return if len == 0 {
            Ok(())
        } else {
            Err(ValidationError::MissingRoot(len))
        };
    }
    let mut used = vec![false; len];
    for (i, node) in bvh.nodes.iter().enumerate() {
        if !node.is_leaf() {
            continue;
        }
        for &p in bvh.leaf_prims(node) {
            let Some(u) = used.get_mut(p as usize) else {
                return Err(ValidationError::PrimitiveOutOfRange {
                    node: i,
                    prim: p as usize,
                    count: len,
                });
            };
            *u = true;
        }
    }
    match used.iter().position(|&u| !u) {
        Some(prim) => Err(ValidationError::Unreferenced { prim }),
        None => Ok(()),
    }
}

/// The spatial-split callback of a scene with user primitives: triangles are clipped exactly
/// (as for [`BuildInput::new`]), user primitives by their splitter, else by box clipping.
struct SceneSplitter<'a> {
    geometries: &'a [Geometry],
    inputs: &'a [Input],
    triangles: Clipper<'a>,
}

enum Part<'a> {
    Triangle(u32),
    User(u32, &'a dyn SplitPrimitive),
    Box,
}

impl SceneSplitter<'_> {
    fn part(&self, prim: u32) -> Part<'_> {
        let g = geometry_of(self.geometries, prim);
        let geo = &self.geometries[g];
        let local = prim - geo.first;
        match (&geo.kind, &self.inputs[g]) {
            (Kind::Triangles { base }, _) => Part::Triangle(*base as u32 + local),
            (
                _,
                Input::User(UserInput {
                    splitter: Some(s), ..
                }),
            ) => Part::User(local, s.as_ref()),
            _ => Part::Box,
        }
    }
}

/// The two halves of `bounds` at the plane (empty where the box does not reach).
fn box_halves(axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
    let (mut l, mut r) = (*bounds, *bounds);
    l.max[axis] = l.max[axis].min(pos);
    r.min[axis] = r.min[axis].max(pos);
    let fix = |b: Aabb| if b.is_empty() { Aabb::EMPTY } else { b };
    (fix(l), fix(r))
}

impl SplitPrimitive for SceneSplitter<'_> {
    fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        match self.part(prim) {
            Part::Triangle(t) => self.triangles.split(t, axis, pos, bounds),
            Part::User(p, s) => s.split(p, axis, pos, bounds),
            Part::Box => box_halves(axis, pos, bounds),
        }
    }

    fn bin(
        &self,
        prim: u32,
        axis: Axis,
        bounds: &Aabb,
        map: &BinMap,
        bins: std::ops::RangeInclusive<usize>,
        f: &mut dyn FnMut(usize, &Aabb),
    ) {
        match self.part(prim) {
            Part::Triangle(t) => self.triangles.bin(t, axis, bounds, map, bins, f),
            Part::User(p, s) => s.bin(p, axis, bounds, map, bins, f),
            Part::Box => {
                let (first, last) = (*bins.start(), *bins.end());
                let mut rest = *bounds;
                for b in first..last {
                    let (l, r) = box_halves(axis, map.plane(b + 1), &rest);
                    if !l.is_empty() {
                        f(b, &l);
                    }
                    rest = r;
                    if rest.is_empty() {
                        return;
                    }
                }
                f(last, &rest);
            }
        }
    }

    fn estimate(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        match self.part(prim) {
            Part::Triangle(t) => self.triangles.estimate(t, axis, pos, bounds),
            Part::User(p, s) => s.estimate(p, axis, pos, bounds),
            Part::Box => box_halves(axis, pos, bounds),
        }
    }
}

/// The geometry holding global primitive `prim` (the last geometry starting at or before it;
/// empty geometries never hold one).
#[inline]
fn geometry_of(geometries: &[Geometry], prim: u32) -> usize {
    geometries.partition_point(|g| g.first <= prim) - 1
}

/// A ray-tracing scene of many geometries (triangle meshes and user primitives) under one
/// BVH, built by [`SceneBuilder`]. Each geometry has a [`GeometryId`] and a 32-bit mask; each
/// query takes a ray mask, and a geometry is tested only when `geometry mask & ray mask != 0`
/// (as Embree's `ray.mask`). The filtered queries take an any-hit filter (alpha testing).
///
/// **Exact.** Every answer equals [`Scene::brute_closest_hit`] / [`Scene::brute_any_hit`], a
/// loop over every primitive of every geometry, bit for bit (`t`, `u`, `v`, normal, ids). At
/// equal distance the lowest geometry index wins, then the lowest primitive index (one global
/// order: geometries in the order they were added, their primitives in order).
///
/// **Kernels.** A scene of triangles only is traced with the SIMD triangle kernels of
/// [`Accel`](crate::Accel) when no geometry's mask excludes the ray and no filter is given,
/// else with their filtered form (same packet test; the mask and the filter are applied to
/// each candidate that would change the answer). A scene with user primitives has one tree
/// over all primitives' boxes whose leaves hold the triangles' vertices
/// (`WideBvh::from_mixed`), traced by `WideBvh::closest_hit_mixed`: the same packet test on the
/// triangle lanes, the callbacks on the others.
///
/// ```
/// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
/// let quad = |z: f32| {
///     let (a, b, c, d) = (Vec3A::new(0.0, 0.0, z), Vec3A::new(1.0, 0.0, z), Vec3A::new(1.0, 1.0, z), Vec3A::new(0.0, 1.0, z));
///     [Triangle::new(a, b, c), Triangle::new(a, c, d)]
/// };
/// let mut b = SceneBuilder::new();
/// let leaves = b.add_triangles(&quad(1.0));
/// let ground = b.add_triangles(&quad(2.0));
/// let scene = b.build(Quality::Medium)?;
/// let ray = Ray::new(Vec3A::new(0.8, 0.1, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
/// assert_eq!(scene.closest_hit(&ray, ALL_MASK).unwrap().geometry, leaves);
/// // Alpha test: the leaves are transparent where u > 0.5.
/// let opaque = |h: &sahara::SceneHit| h.geometry != leaves || h.u <= 0.5;
/// assert_eq!(scene.closest_hit_filtered(&ray, ALL_MASK, opaque).unwrap().geometry, ground);
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone)]
pub struct Scene {
    tag: u64,
    geometries: Vec<Geometry>,
    /// Every triangle geometry's triangles, in geometry order.
    triangles: Vec<Triangle>,
    /// With user primitives: every primitive's box by global index (else empty).
    boxes: Vec<Aabb>,
    /// With user primitives: per global index, the triangle's index in `triangles`, or
    /// `u32::MAX` for a user primitive (else empty).
    triangle_of: Vec<u32>,
    bvh: Bvh,
    wide: Bvh8,
    quality: Quality,
    cost: CostModel,
    /// Some geometry holds user primitives: the tree is over boxes.
    mixed: bool,
    /// The distinct masks of the non-empty geometries, sorted.
    masks: Vec<u32>,
}

impl fmt::Debug for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scene")
            .field("geometries", &self.geometries.len())
            .field("primitives", &self.len())
            .field("quality", &self.quality)
            .field("user_primitives", &self.mixed)
            .finish_non_exhaustive()
    }
}

/// Which geometries a ray mask lets through.
#[derive(Clone, Copy, PartialEq)]
enum Pass {
    None,
    All,
    Some,
}

impl Scene {
    fn update_masks(&mut self) {
        let mut masks: Vec<u32> = self
            .geometries
            .iter()
            .filter(|g| g.len > 0)
            .map(|g| g.mask)
            .collect();
        masks.sort_unstable();
        masks.dedup();
        self.masks = masks;
    }

    fn pass(&self, mask: u32) -> Pass {
        let through = self.masks.iter().filter(|&&m| m & mask != 0).count();
        if through == 0 {
            Pass::None
        } else if through == self.masks.len() {
            Pass::All
        } else {
            Pass::Some
        }
    }

    fn index_of(&self, id: GeometryId) -> Result<usize, Error> {
        if id.scene == self.tag && (id.index as usize) < self.geometries.len() {
            Ok(id.index as usize)
        } else {
            Err(SceneError::UnknownGeometry(id).into())
        }
    }

    fn id(&self, g: usize) -> GeometryId {
        GeometryId {
            scene: self.tag,
            index: g as u32,
        }
    }

    /// The façade hit of a triangle hit at global index `hit.prim`.
    #[inline]
    fn triangle_hit(&self, g: usize, hit: &sahara_traverse::Hit) -> SceneHit {
        let geo = &self.geometries[g];
        let local = hit.prim - geo.first;
        let Kind::Triangles { base } = geo.kind else {
            unreachable!("a triangle hit on a user geometry")
        };
        SceneHit {
            geometry: self.id(g),
            primitive: local,
            t: hit.t,
            u: hit.u,
            v: hit.v,
            normal: self.triangles[base + local as usize].cross(),
        }
    }

    /// The primitives of a scene with user primitives, for the mixed traversal.
    fn mixed_prims(&self) -> MixedPrims<'_> {
        MixedPrims {
            boxes: &self.boxes,
            triangles: &self.triangles,
            triangle_of: &self.triangle_of,
        }
    }

    /// A triangle candidate of the mixed traversal (global index `hit.prim`): mask, then
    /// filter.
    #[inline]
    fn triangle_candidate(
        &self,
        hit: &sahara_traverse::Hit,
        mask: u32,
        filter: &SharedFilter<'_>,
    ) -> Option<SceneHit> {
        let g = geometry_of(&self.geometries, hit.prim);
        if self.geometries[g].mask & mask == 0 {
            return None;
        }
        let hit = self.triangle_hit(g, hit);
        Self::filtered(hit, filter)
    }

    /// A user-primitive candidate at global index `prim`: mask, the callback (given `tmax`)
    /// under the hit rule, filter.
    #[inline]
    fn user_candidate(
        &self,
        ray: &Ray,
        prim: u32,
        tmax: f32,
        mask: u32,
        filter: &SharedFilter<'_>,
    ) -> Option<SceneHit> {
        let g = geometry_of(&self.geometries, prim);
        let geo = &self.geometries[g];
        if geo.mask & mask == 0 {
            return None;
        }
        let Kind::User(intersect) = &geo.kind else {
            unreachable!("the mixed traversal tests triangles with the packet test")
        };
        let local = prim - geo.first;
        let i = intersect(ray, local, ray.tmin, tmax)?;
        let span = primitive_span(ray, &self.boxes[prim as usize]);
        let hit = SceneHit {
            geometry: self.id(g),
            primitive: local,
            t: accept_primitive_hit(ray, span, i.t)?,
            u: i.u,
            v: i.v,
            normal: i.normal,
        };
        Self::filtered(hit, filter)
    }

    #[inline]
    fn filtered(hit: SceneHit, filter: &SharedFilter<'_>) -> Option<SceneHit> {
        let keep = filter.borrow_mut().as_mut().is_none_or(|f| f(&hit));
        keep.then_some(hit)
    }

    // Inline, as `Accel`'s queries: the kernels are then instantiated in the caller's crate
    // like theirs (an instance compiled in this crate measured up to 20% slower in the test
    // profile).
    #[inline]
    fn closest(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&SceneHit) -> bool>,
    ) -> Option<SceneHit> {
        let pass = self.pass(mask);
        if pass == Pass::None {
            return None;
        }
        if self.mixed {
            // The two callbacks take turns with the filter, never at once.
            let filter = RefCell::new(filter);
            let hit = self.wide.closest_hit_mixed(
                self.mixed_prims(),
                ray,
                |h| self.triangle_candidate(h, mask, &filter),
                |ray: &Ray, p, _, tmax| {
                    self.user_candidate(ray, p, tmax, mask, &filter)
                        .map(|h| (h.t, h))
                },
                &mut NoStats,
            );
            return hit.map(|h| h.data);
        }
        let hit = if pass == Pass::All && filter.is_none() {
            self.wide.closest_hit(ray, &mut NoStats)
        } else {
            self.wide.closest_hit_filtered(
                ray,
                |h| self.accepts(h, mask, &mut filter),
                &mut NoStats,
            )
        };
        hit.is_hit()
            .then(|| self.triangle_hit(geometry_of(&self.geometries, hit.prim), &hit))
    }

    #[inline]
    fn any(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&SceneHit) -> bool>,
    ) -> bool {
        let pass = self.pass(mask);
        if pass == Pass::None {
            return false;
        }
        if self.mixed {
            let filter = RefCell::new(filter);
            return self.wide.any_hit_mixed(
                self.mixed_prims(),
                ray,
                |h| self.triangle_candidate(h, mask, &filter).map(|_| ()),
                |ray: &Ray, p, _, tmax| {
                    self.user_candidate(ray, p, tmax, mask, &filter)
                        .map(|h| (h.t, ()))
                },
                &mut NoStats,
            );
        }
        if pass == Pass::All && filter.is_none() {
            return self.wide.any_hit(ray, &mut NoStats);
        }
        self.wide
            .any_hit_filtered(ray, |h| self.accepts(h, mask, &mut filter), &mut NoStats)
    }

    /// Whether a triangle candidate of the triangles-only tree counts: its geometry's mask
    /// meets the ray's, and the filter, if any, accepts it (the rule of the closest and the
    /// any-hit queries alike).
    #[inline]
    fn accepts(
        &self,
        h: &sahara_traverse::Hit,
        mask: u32,
        filter: &mut Option<&mut dyn FnMut(&SceneHit) -> bool>,
    ) -> bool {
        let g = geometry_of(&self.geometries, h.prim);
        self.geometries[g].mask & mask != 0
            && filter.as_mut().is_none_or(|f| f(&self.triangle_hit(g, h)))
    }

    /// The closest hit in `[ray.tmin, ray.tmax]` on the geometries whose mask meets `mask`
    /// (`geometry mask & mask != 0`; [`ALL_MASK`] tests every geometry with a non-zero mask),
    /// or `None`. Ties: the lowest geometry index, then the lowest primitive index. Invalid
    /// rays miss.
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let mut b = SceneBuilder::new();
    /// let id = b.add_triangles(&[Triangle::new(Vec3A::new(-1.0, -1.0, 3.0), Vec3A::new(1.0, -1.0, 3.0), Vec3A::new(0.0, 1.0, 3.0))]);
    /// b.set_mask(id, 1)?;
    /// let scene = b.build(Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.t), Some(3.0));
    /// assert_eq!(scene.closest_hit(&ray, 2), None);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    #[inline]
    pub fn closest_hit(&self, ray: &Ray, mask: u32) -> Option<SceneHit> {
        self.closest(ray, mask, None)
    }

    /// [`Scene::closest_hit`] with an any-hit filter: `filter(&candidate)` keeps (`true`) or
    /// rejects (`false`) a candidate hit, and traversal goes on past rejected ones to the
    /// nearest kept hit. The filter is called only for candidates of geometries the mask lets
    /// through that would change the answer (nearer than the best kept hit, or as near on a
    /// lower index), in an order that depends on the tree, and possibly more than once for
    /// one primitive (spatial splits): it must be a pure function of the candidate. Then the
    /// answer equals [`Scene::brute_closest_hit`] with the same filter.
    ///
    /// **A panicking filter** aborts the query: the panic propagates to the caller (in the
    /// batch queries, out of the rayon call). The scene is only borrowed and has no interior
    /// mutability, so it stays valid: a caller may `catch_unwind(AssertUnwindSafe(|| ...))`
    /// and go on using it (a user geometry's callback makes `Scene` not `RefUnwindSafe` by
    /// type only).
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let tri = |z: f32| Triangle::new(Vec3A::new(-1.0, -1.0, z), Vec3A::new(1.0, -1.0, z), Vec3A::new(0.0, 1.0, z));
    /// let mut b = SceneBuilder::new();
    /// b.add_triangles(&[tri(1.0), tri(2.0), tri(3.0)]);
    /// let scene = b.build(Quality::Medium)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// // Triangles 0 and 1 are alpha-tested away.
    /// let hit = scene.closest_hit_filtered(&ray, ALL_MASK, |h| h.primitive == 2).unwrap();
    /// assert_eq!(hit.t, 3.0);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hit_filtered<F>(&self, ray: &Ray, mask: u32, mut filter: F) -> Option<SceneHit>
    where
        F: FnMut(&SceneHit) -> bool,
    {
        self.closest(ray, mask, Some(&mut filter))
    }

    /// True when some geometry the mask lets through is hit in `[ray.tmin, ray.tmax]`
    /// (occlusion; stops at the first hit found). Invalid rays miss.
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let mut b = SceneBuilder::new();
    /// b.add_triangles(&[Triangle::new(Vec3A::new(-1.0, -1.0, 3.0), Vec3A::new(1.0, -1.0, 3.0), Vec3A::new(0.0, 1.0, 3.0))]);
    /// let scene = b.build(Quality::Fast)?;
    /// assert!(scene.any_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 5.0), ALL_MASK));
    /// assert!(!scene.any_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 2.0), ALL_MASK));
    /// assert!(!scene.any_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 5.0), 0));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    #[inline]
    pub fn any_hit(&self, ray: &Ray, mask: u32) -> bool {
        self.any(ray, mask, None)
    }

    /// [`Scene::any_hit`] with an any-hit filter: true when some candidate is kept by
    /// `filter` (a shadow ray through alpha-tested leaves). The filter may be called for any
    /// candidate in `[tmin, tmax]`, in any order: it must be a pure function of the candidate.
    /// A panicking filter aborts the query as in [`Scene::closest_hit_filtered`].
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let mut b = SceneBuilder::new();
    /// let leaf = b.add_triangles(&[Triangle::new(Vec3A::new(-1.0, -1.0, 3.0), Vec3A::new(1.0, -1.0, 3.0), Vec3A::new(0.0, 1.0, 3.0))]);
    /// let scene = b.build(Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 5.0);
    /// assert!(!scene.any_hit_filtered(&ray, ALL_MASK, |h| h.geometry != leaf));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hit_filtered<F>(&self, ray: &Ray, mask: u32, mut filter: F) -> bool
    where
        F: FnMut(&SceneHit) -> bool,
    {
        self.any(ray, mask, Some(&mut filter))
    }

    /// [`Scene::closest_hit`] of every ray with one mask, in parallel on the current rayon
    /// pool, in the order of `rays`.
    ///
    /// ```
    /// # use sahara::{Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let scene = SceneBuilder::new().build(Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 1.0); 3];
    /// assert_eq!(scene.closest_hits(&rays, ALL_MASK), vec![None; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hits(&self, rays: &[Ray], mask: u32) -> Vec<Option<SceneHit>> {
        crate::batch(rays, |r| self.closest_hit(r, mask))
    }

    /// [`Scene::closest_hit_filtered`] of every ray, in parallel, in the order of `rays`
    /// (the filter is shared by the threads, hence `Fn + Sync`).
    ///
    /// ```
    /// # use sahara::{Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let scene = SceneBuilder::new().build(Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 1.0); 3];
    /// assert_eq!(scene.closest_hits_filtered(&rays, ALL_MASK, |_| true), vec![None; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hits_filtered<F>(
        &self,
        rays: &[Ray],
        mask: u32,
        filter: F,
    ) -> Vec<Option<SceneHit>>
    where
        F: Fn(&SceneHit) -> bool + Sync,
    {
        crate::batch(rays, |r| self.closest_hit_filtered(r, mask, &filter))
    }

    /// [`Scene::any_hit`] of every ray with one mask, in parallel, in the order of `rays`.
    ///
    /// ```
    /// # use sahara::{Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let scene = SceneBuilder::new().build(Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 1.0); 3];
    /// assert_eq!(scene.any_hits(&rays, ALL_MASK), vec![false; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hits(&self, rays: &[Ray], mask: u32) -> Vec<bool> {
        crate::batch(rays, |r| self.any_hit(r, mask))
    }

    /// [`Scene::any_hit_filtered`] of every ray, in parallel, in the order of `rays`.
    ///
    /// ```
    /// # use sahara::{Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let scene = SceneBuilder::new().build(Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 1.0); 3];
    /// assert_eq!(scene.any_hits_filtered(&rays, ALL_MASK, |_| true), vec![false; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hits_filtered<F>(&self, rays: &[Ray], mask: u32, filter: F) -> Vec<bool>
    where
        F: Fn(&SceneHit) -> bool + Sync,
    {
        crate::batch(rays, |r| self.any_hit_filtered(r, mask, &filter))
    }

    /// The brute-force reference of [`Scene::closest_hit_filtered`] (and, with `filter`
    /// `None`, of [`Scene::closest_hit`]): every geometry in index order whose mask meets
    /// `mask`, every primitive of it in order, the watertight triangle test
    /// (`sahara_geom::intersect::intersect_triangle`) or the user callback under the hit rule
    /// of `sahara_traverse::custom` (called with the ray's whole interval), the filter on each
    /// candidate that would change the answer. No tree is used. The queries equal it bit for
    /// bit.
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let mut b = SceneBuilder::new();
    /// b.add_triangles(&[Triangle::new(Vec3A::new(-1.0, -1.0, 3.0), Vec3A::new(1.0, -1.0, 3.0), Vec3A::new(0.0, 1.0, 3.0))]);
    /// let scene = b.build(Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 5.0);
    /// assert_eq!(scene.brute_closest_hit(&ray, ALL_MASK, None), scene.closest_hit(&ray, ALL_MASK));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_closest_hit(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&SceneHit) -> bool>,
    ) -> Option<SceneHit> {
        if !ray.is_valid() {
            return None;
        }
        let w = ray.watertight();
        let mut best: Option<SceneHit> = None;
        for g in 0..self.geometries.len() {
            self.brute_geometry(&w, ray, g, mask, &mut |hit| {
                // Geometries and primitives come in index order: only a nearer hit wins.
                if best.is_none_or(|b| hit.t < b.t) && filter.as_mut().is_none_or(|f| f(&hit)) {
                    best = Some(hit);
                }
                false
            });
        }
        best
    }

    /// The brute-force reference of [`Scene::any_hit_filtered`] and [`Scene::any_hit`]
    /// (`filter` `None`): true when some candidate of [`Scene::brute_closest_hit`]'s loop is
    /// kept by the filter.
    ///
    /// ```
    /// use sahara::{Quality, Ray, SceneBuilder, Vec3A, ALL_MASK};
    /// let scene = SceneBuilder::new().build(Quality::Fast)?;
    /// assert!(!scene.brute_any_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 5.0), ALL_MASK, None));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_any_hit(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&SceneHit) -> bool>,
    ) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let w = ray.watertight();
        let mut found = false;
        for g in 0..self.geometries.len() {
            found = self.brute_geometry(&w, ray, g, mask, &mut |hit| {
                filter.as_mut().is_none_or(|f| f(&hit))
            });
            if found {
                break;
            }
        }
        found
    }

    /// Offers every hit of geometry `g` (if the mask lets it through) to `offer`, in primitive
    /// order, until `offer` returns true; returns whether it did.
    fn brute_geometry(
        &self,
        w: &WatertightRay,
        ray: &Ray,
        g: usize,
        mask: u32,
        offer: &mut dyn FnMut(SceneHit) -> bool,
    ) -> bool {
        let geo = &self.geometries[g];
        if geo.mask & mask == 0 {
            return false;
        }
        let geometry = self.id(g);
        for local in 0..geo.len {
            let hit = match &geo.kind {
                Kind::Triangles { base } => {
                    let tri = &self.triangles[base + local as usize];
                    intersect_triangle(w, tri, ray.tmin, ray.tmax).map(|h| SceneHit {
                        geometry,
                        primitive: local,
                        t: h.t,
                        u: h.u,
                        v: h.v,
                        normal: tri.cross(),
                    })
                }
                Kind::User(intersect) => {
                    let bounds = &self.boxes[(geo.first + local) as usize];
                    intersect(ray, local, ray.tmin, ray.tmax).and_then(|i| {
                        let t = accept_primitive_hit(ray, primitive_span(ray, bounds), i.t)?;
                        Some(SceneHit {
                            geometry,
                            primitive: local,
                            t,
                            u: i.u,
                            v: i.v,
                            normal: i.normal,
                        })
                    })
                }
            };
            if let Some(hit) = hit {
                if offer(hit) {
                    return true;
                }
            }
        }
        false
    }

    /// Moves the triangles of geometry `id` to `triangles` (the same number, in the same
    /// order: triangle `i`'s new position; the same topology) and refits the scene's BVH and
    /// its 8-wide layout bottom-up instead of rebuilding, as [`Accel::refit`](crate::Accel::refit)
    /// does: exact (every answer equals [`Scene::brute_closest_hit`] over the moved
    /// triangles), the tree's quality decaying as the motion grows (`docs/refit.md`). Masks,
    /// ids and the other geometries are untouched; one call refits the whole tree, so move
    /// several geometries with [`Scene::refit_many`].
    ///
    /// * A scene of triangles only refits as an `Accel`: refitting to unmoved triangles is the
    ///   identity bit for bit at every level, and spatial-split trees ([`Quality::High`],
    ///   [`Quality::Best`]) clip the moved triangles again at their recorded cuts.
    /// * A scene with user primitives refits its tree over all primitives' boxes with the
    ///   moved triangles' whole boxes (the user primitives' boxes do not move) and collapses
    ///   the layout again: exact, and the identity for trees without spatial splits; after
    ///   spatial splits the refitted boxes are whole, not clipped (looser).
    ///
    /// Fails, leaving the scene unchanged, with [`SceneError::UnknownGeometry`] (an id of
    /// another scene or out of range), [`SceneError::NotTriangles`] (a geometry of user
    /// primitives), [`SceneError::RefitCount`] (another number of triangles) or
    /// [`SceneError::NonFinite`] (a NaN or infinite coordinate).
    ///
    /// ```
    /// use sahara::{Error, Quality, Ray, SceneBuilder, SceneError, Triangle, Vec3A, ALL_MASK};
    /// let tri = |z: f32| Triangle::new(Vec3A::new(-1.0, -1.0, z), Vec3A::new(1.0, -1.0, z), Vec3A::new(0.0, 1.0, z));
    /// let mut b = SceneBuilder::new();
    /// let door = b.add_triangles(&[tri(2.0)]);
    /// let wall = b.add_triangles(&[tri(4.0)]);
    /// let mut scene = b.build(Quality::High)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.geometry), Some(door));
    /// // The door slides away along x.
    /// let open = Triangle::new(tri(2.0).v[0] + Vec3A::X * 5.0, tri(2.0).v[1] + Vec3A::X * 5.0, tri(2.0).v[2] + Vec3A::X * 5.0);
    /// scene.refit(door, &[open])?;
    /// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.geometry), Some(wall));
    /// assert!(matches!(
    ///     scene.refit(door, &[]),
    ///     Err(Error::Scene(SceneError::RefitCount { geometry: 0, expected: 1, given: 0 }))
    /// ));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn refit(&mut self, id: GeometryId, triangles: &[Triangle]) -> Result<(), Error> {
        self.refit_many(&[(id, triangles)])
    }

    /// [`Scene::refit`] of several geometries with one refit of the tree: `(id, triangles)`
    /// pairs (a later pair for the same geometry wins). All or nothing: on an error (as
    /// [`Scene::refit`]'s) no geometry moves.
    ///
    /// ```
    /// use sahara::{Quality, SceneBuilder, Triangle, Vec3A};
    /// let t = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    /// let up = |t: Triangle| Triangle::new(t.v[0] + Vec3A::Z, t.v[1] + Vec3A::Z, t.v[2] + Vec3A::Z);
    /// let mut b = SceneBuilder::new();
    /// let (a, c) = (b.add_triangles(&[t]), b.add_triangles(&[t, t]));
    /// let mut scene = b.build(Quality::Medium)?;
    /// scene.refit_many(&[(a, &[up(t)]), (c, &[up(t), t])])?;
    /// assert_eq!(scene.triangles(c), Some(&[up(t), t][..]));
    /// // One bad pair: nothing moves.
    /// assert!(scene.refit_many(&[(a, &[t]), (c, &[t])]).is_err());
    /// assert_eq!(scene.triangles(a), Some(&[up(t)][..]));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn refit_many(&mut self, moves: &[(GeometryId, &[Triangle])]) -> Result<(), Error> {
        // Every move is checked before anything changes.
        let mut ranges = Vec::with_capacity(moves.len());
        for &(id, triangles) in moves {
            let g = self.index_of(id)?;
            let geo = &self.geometries[g];
            let Kind::Triangles { base } = geo.kind else {
                return Err(SceneError::NotTriangles(id).into());
            };
            if triangles.len() != geo.len as usize {
                return Err(SceneError::RefitCount {
                    geometry: id.index,
                    expected: geo.len as usize,
                    given: triangles.len(),
                }
                .into());
            }
            if let Some(p) = triangles.iter().position(|t| !t.is_finite()) {
                return Err(SceneError::NonFinite {
                    geometry: id.index,
                    primitive: p,
                }
                .into());
            }
            ranges.push((g, base));
        }
        let mut old = Vec::with_capacity(moves.len());
        for (&(_, triangles), &(g, base)) in moves.iter().zip(&ranges) {
            let range = base..base + triangles.len();
            old.push((g, base, self.triangles[range.clone()].to_vec()));
            self.set_triangles(g, base, triangles);
        }
        if let Err(e) = self.refit_tree() {
            // Unreachable after the checks above (finite triangles, a tree checked when it was
            // built); put the old triangles back all the same, latest move first.
            for (g, base, triangles) in old.iter().rev() {
                self.set_triangles(*g, *base, triangles);
            }
            let _ = self.refit_tree();
            return Err(e.into());
        }
        Ok(())
    }

    /// Writes the triangles of geometry `g` (its triangles start at `base`), and with user
    /// primitives their boxes.
    fn set_triangles(&mut self, g: usize, base: usize, triangles: &[Triangle]) {
        self.triangles[base..base + triangles.len()].copy_from_slice(triangles);
        if self.mixed {
            let first = self.geometries[g].first as usize;
            let boxes = &mut self.boxes[first..first + triangles.len()];
            for (b, t) in boxes.iter_mut().zip(triangles) {
                *b = t.bounds();
            }
        }
    }

    /// Refits the tree and the layout to the current triangles (and boxes).
    fn refit_tree(&mut self) -> Result<(), sahara_bvh::RefitError> {
        if self.mixed {
            self.bvh.refit(&self.boxes)?;
            self.wide = Bvh8::from_mixed(&self.bvh, self.mixed_prims());
            Ok(())
        } else {
            self.bvh.refit_triangles(&self.triangles)?;
            self.wide.refit_triangles(&self.triangles)
        }
    }

    /// The parts a scene file stores, or [`SceneError::UserPrimitives`] naming the first
    /// geometry of user primitives (their callbacks cannot be stored).
    pub(crate) fn saved_parts(&self) -> Result<SavedParts<'_>, SceneError> {
        if let Some(g) = self
            .geometries
            .iter()
            .position(|g| matches!(g.kind, Kind::User(_)))
        {
            return Err(SceneError::UserPrimitives(self.id(g)));
        }
        Ok(SavedParts {
            geometries: self.geometries.iter().map(|g| (g.mask, g.len)).collect(),
            triangles: &self.triangles,
            bvh: &self.bvh,
            quality: self.quality,
            cost: self.cost,
        })
    }

    /// A loaded triangles-only scene: `geometries` are `(mask, triangle count)` in index
    /// order, their counts summing to `triangles.len()` (below 2^32), and `bvh` a tree checked
    /// against `triangles`. It gets a tag of its own, like a built scene.
    pub(crate) fn from_saved(
        geometries: Vec<(u32, u32)>,
        triangles: Vec<Triangle>,
        bvh: Bvh,
        quality: Quality,
        cost: CostModel,
    ) -> Scene {
        let mut first = 0u32;
        let geometries = geometries
            .into_iter()
            .map(|(mask, len)| {
                let geo = Geometry {
                    kind: Kind::Triangles {
                        base: first as usize,
                    },
                    mask,
                    first,
                    len,
                };
                first += len;
                geo
            })
            .collect();
        let wide = Bvh8::from_bvh(&bvh, &triangles);
        let mut scene = Scene {
            tag: NEXT_SCENE.fetch_add(1, Ordering::Relaxed),
            geometries,
            triangles,
            boxes: Vec::new(),
            triangle_of: Vec::new(),
            bvh,
            wide,
            quality,
            cost,
            mixed: false,
            masks: Vec::new(),
        };
        scene.update_masks();
        scene
    }

    /// Writes a scene of triangle geometries: every geometry's mask and triangles, the tree
    /// and how it was built (format in [`crate::file`]); the 8-wide layout is rebuilt on load.
    ///
    /// A scene with user primitives cannot be saved (their callbacks are code): it fails with
    /// an [`std::io::Error`] of kind [`Unsupported`](std::io::ErrorKind::Unsupported) wrapping
    /// [`SceneError::UserPrimitives`] (get it with `err.get_ref()` and `downcast_ref`), and
    /// nothing is written.
    ///
    /// ```
    /// use sahara::{Aabb, Quality, Scene, SceneBuilder, SceneError, Triangle, Vec3A};
    /// let mut b = SceneBuilder::new();
    /// b.add_triangles(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)]);
    /// let scene = b.build(Quality::Fast)?;
    /// let mut file = Vec::new();
    /// scene.save(&mut file)?;
    /// assert_eq!(&file[..8], b"SAHARSCN");
    ///
    /// let mut b = SceneBuilder::new();
    /// let ball = b.add_primitives(&[Aabb::new(Vec3A::ZERO, Vec3A::ONE)], |_: &sahara::Ray, _, _, _| None);
    /// let err = b.build(Quality::Fast)?.save(&mut Vec::new()).unwrap_err();
    /// assert_eq!(err.kind(), std::io::ErrorKind::Unsupported);
    /// let inner = err.get_ref().and_then(|e| e.downcast_ref::<SceneError>());
    /// assert_eq!(inner, Some(&SceneError::UserPrimitives(ball)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn save<W: std::io::Write>(&self, w: &mut W) -> std::io::Result<()> {
        crate::file::save_scene(self, w)
    }

    /// Reads what [`Scene::save`] wrote: checks the magic, version, sizes and checksum, the
    /// quality code and cost model, that the geometries' counts add up, that every triangle is
    /// finite and that the tree fits the triangles, then rebuilds the 8-wide layout. The
    /// loaded scene equals the saved one (tree, layout, triangles, masks, quality, cost) but
    /// is a scene of its own: its [`GeometryId`]s have the same indices and a new tag (get them
    /// with [`Scene::geometries`] or [`Scene::geometry`]). Never panics on any bytes: a broken
    /// file is a [`LoadError`](crate::LoadError).
    ///
    /// ```
    /// use sahara::{LoadError, Quality, Ray, Scene, SceneBuilder, Triangle, Vec3A, ALL_MASK};
    /// let mut b = SceneBuilder::new();
    /// let wall = b.add_triangles(&[Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0))]);
    /// b.set_mask(wall, 0b10)?;
    /// let scene = b.build(Quality::High)?;
    /// let mut file = Vec::new();
    /// scene.save(&mut file)?;
    /// let loaded = Scene::load(&mut file.as_slice())?;
    /// assert!(loaded.bvh() == scene.bvh() && loaded.wide() == scene.wide());
    /// let wall = loaded.geometry(0).unwrap();
    /// assert_eq!(loaded.mask(wall), Some(0b10));
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 9.0);
    /// assert_eq!(loaded.closest_hit(&ray, ALL_MASK).map(|h| (h.geometry, h.t)), Some((wall, 2.0)));
    /// file[60] ^= 1;
    /// assert!(matches!(Scene::load(&mut file.as_slice()), Err(LoadError::Checksum)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn load<R: std::io::Read>(r: &mut R) -> Result<Scene, crate::LoadError> {
        crate::file::load_scene(r)
    }

    /// The id of the geometry at `index` (the position of its `add_*` call), or `None` past
    /// the last: how a loaded scene's ids are found again.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// let id = b.add_triangles(&[]);
    /// let scene = b.build(sahara::Quality::Fast)?;
    /// assert_eq!((scene.geometry(0), scene.geometry(1)), (Some(id), None));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn geometry(&self, index: u32) -> Option<GeometryId> {
        ((index as usize) < self.geometries.len()).then(|| self.id(index as usize))
    }

    /// Sets a geometry's mask without rebuilding (masks are not part of the tree). Fails with
    /// [`SceneError::UnknownGeometry`] for an id out of range or of another scene.
    ///
    /// ```
    /// use sahara::{Quality, SceneBuilder};
    /// let mut b = SceneBuilder::new();
    /// let id = b.add_triangles(&[]);
    /// let mut scene = b.build(Quality::Fast)?;
    /// scene.set_mask(id, 0)?;
    /// assert_eq!(scene.mask(id), Some(0));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn set_mask(&mut self, id: GeometryId, mask: u32) -> Result<(), Error> {
        let g = self.index_of(id)?;
        self.geometries[g].mask = mask;
        self.update_masks();
        Ok(())
    }

    /// A geometry's mask, or `None` for an id out of range or of another scene.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// let id = b.add_triangles(&[]);
    /// let scene = b.build(sahara::Quality::Fast)?;
    /// assert_eq!(scene.mask(id), Some(sahara::ALL_MASK));
    /// let other = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert_eq!(other.mask(id), None);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn mask(&self, id: GeometryId) -> Option<u32> {
        self.index_of(id).ok().map(|g| self.geometries[g].mask)
    }

    /// The number of primitives of a geometry, or `None` for an id out of range or of another
    /// scene.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// let id = b.add_triangles(&[]);
    /// assert_eq!(b.build(sahara::Quality::Fast)?.geometry_len(id), Some(0));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn geometry_len(&self, id: GeometryId) -> Option<usize> {
        self.index_of(id)
            .ok()
            .map(|g| self.geometries[g].len as usize)
    }

    /// The triangles of a triangle geometry (`None` for user primitives and unknown ids).
    ///
    /// ```
    /// use sahara::{SceneBuilder, Triangle, Vec3A};
    /// let t = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    /// let mut b = SceneBuilder::new();
    /// let id = b.add_triangles(&[t]);
    /// assert_eq!(b.build(sahara::Quality::Fast)?.triangles(id), Some(&[t][..]));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn triangles(&self, id: GeometryId) -> Option<&[Triangle]> {
        let geo = &self.geometries[self.index_of(id).ok()?];
        match geo.kind {
            Kind::Triangles { base } => Some(&self.triangles[base..base + geo.len as usize]),
            Kind::User(_) => None,
        }
    }

    /// The ids of all geometries, in index order.
    ///
    /// ```
    /// let mut b = sahara::SceneBuilder::new();
    /// let a = b.add_triangles(&[]);
    /// let c = b.add_triangles(&[]);
    /// let scene = b.build(sahara::Quality::Fast)?;
    /// assert_eq!(scene.geometries().collect::<Vec<_>>(), vec![a, c]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn geometries(&self) -> impl ExactSizeIterator<Item = GeometryId> + '_ {
        (0..self.geometries.len()).map(|g| self.id(g))
    }

    /// The number of primitives of all geometries.
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert_eq!(scene.len(), 0);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn len(&self) -> usize {
        self.geometries
            .last()
            .map_or(0, |g| (g.first + g.len) as usize)
    }

    /// True when the scene has no primitive (every ray misses).
    ///
    /// ```
    /// assert!(sahara::SceneBuilder::new().build(sahara::Quality::Fast)?.is_empty());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The quality level it was built at.
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::High)?;
    /// assert_eq!(scene.quality(), sahara::Quality::High);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn quality(&self) -> Quality {
        self.quality
    }

    /// The cost model it was built with.
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert_eq!(scene.cost(), sahara::CostModel::AILA);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn cost(&self) -> CostModel {
        self.cost
    }

    /// The binary tree over all primitives (global index: geometries in index order, their
    /// primitives in order).
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert!(scene.bvh().nodes.is_empty());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The 8-wide layout the queries run on (over triangles, or over the boxes of all
    /// primitives, with the triangles' vertices in the leaves, when the scene has user
    /// primitives).
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert_eq!(scene.wide().backend(), scene.backend());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn wide(&self) -> &Bvh8 {
        &self.wide
    }

    /// The SIMD backend of the triangle kernels on this CPU.
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// println!("{:?}", scene.backend());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn backend(&self) -> Backend {
        self.wide.backend()
    }

    /// Bounds of all primitives (empty when there are none).
    ///
    /// ```
    /// let scene = sahara::SceneBuilder::new().build(sahara::Quality::Fast)?;
    /// assert!(scene.bounds().is_empty());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn bounds(&self) -> Aabb {
        self.wide.bounds()
    }
}
