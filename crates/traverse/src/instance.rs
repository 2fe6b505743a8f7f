//! Instances: a two-level structure, a top-level tree over instances of bottom-level trees.
//!
//! An [`Instance`] is a bottom-level tree (an index into the set's [`BottomLevel`] trees, for
//! example [`Bvh8`]s over triangles) placed in the world by an affine transform. Its world box
//! is the box of the eight transformed corners of the bottom-level tree's box, widened by a
//! relative 2^-20 of the transformed coordinates' magnitude to cover the rounding of the
//! transform. The top-level tree is built over these boxes by any builder (the caller builds
//! it, typically with `BuildInput::from_boxes` of `sahara-builders`, which this crate does not
//! depend on) and collapsed into a [`Bvh8`] over boxes ([`WideBvh::from_boxes`]).
//!
//! **Tracing.** For an instance reached by the top-level traversal, the ray is taken into
//! object space with the inverse affine transform (computed once, in `f32`, by glam): origin
//! and direction are transformed, the direction is **not renormalised** and `tmin`, `tmax`
//! are kept. So the object-space `t` of a hit is its world-space `t` (up to the rounding of
//! the inverse transform), and distances of different instances compare directly: the
//! closest hit over all instances is the nearest of their closest hits.
//!
//! **Exactness.** The top level is the user-primitive traversal of [`crate::custom`]: an
//! instance is a primitive whose box is its world box and whose intersection callback is the
//! bottom-level closest hit of the object-space ray (which finds the same hit for any `tmax` at
//! least its distance, as the callbacks must). Hits therefore pass the hit rule of
//! [`crate::custom::accept_primitive_hit`] (the bottom level's `t` clamped into the instance's
//! world-box span: with the padding above this almost never changes it), and ties go to the
//! lowest instance index, then (inside the bottom level) to the lowest primitive index. The
//! result equals, bit for bit, the brute-force loop over all instances that applies the same
//! transforms and the same rule ([`InstanceSet::object_ray`], [`InstanceSet::world_boxes`]).
//! Any-hit queries accept an instance when its bottom level reports a hit for the object-space
//! ray and its world box passes the box test of the culling interval, `[lower_distance(tmin),
//! cull_distance(tmax)]`.
//!
//! Against flattening the instances into one mesh (transforming the vertices instead of the
//! rays) the answers agree up to rounding: the two round differently, so hits on or near shared
//! edges can change triangle, and distances differ in the last bits (the tests state the
//! tolerance).
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
//! use sahara_traverse::instance::{Instance, InstanceSet};
//! use sahara_traverse::{Bvh8, NoStats};
//! use glam::{Affine3A, Vec3};
//!
//! let tris = [Triangle::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, -1.0, 0.0), Vec3A::new(0.0, 1.0, 0.0))];
//! let blas_tree = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let blas = Bvh8::from_bvh(&blas_tree, &tris);
//! let instances = vec![
//!     Instance { blas: 0, transform: Affine3A::from_translation(Vec3::new(0.0, 0.0, 5.0)) },
//!     Instance { blas: 0, transform: Affine3A::from_translation(Vec3::new(0.0, 0.0, 2.0)) },
//! ];
//! // A top-level tree over the two world boxes (any builder would do).
//! let top = |boxes: &[Aabb]| Bvh {
//!     nodes: vec![Node::inner(&boxes[0].union(&boxes[1]), 2), Node::leaf(&boxes[0], 0, 1), Node::leaf(&boxes[1], 1, 1)],
//!     prim_indices: vec![0, 1],
//!     spatial_splits: false,
//!     ref_cuts: None,
//! };
//! let set = InstanceSet::new(vec![blas], instances, top).unwrap();
//! let hit = set.closest_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY), &mut NoStats).unwrap();
//! assert_eq!((hit.instance, hit.prim, hit.t), (1, 0, 2.0));
//! ```

use crate::custom::{primitive_span, PrimHit};
use crate::{Bvh8, Hit, NoStats, TraversalStats, WideBvh};
use glam::{Affine3A, Vec3A};
use sahara_bvh::{Bvh, ValidationError};
use sahara_geom::intersect::{cull_distance, intersect_aabb, lower_distance};
use sahara_geom::{Aabb, Ray};

/// A bottom-level tree an [`InstanceSet`] can place: closest and any hit of an object-space
/// ray, and its object-space bounds.
///
/// `closest_hit` must return the closest hit in `[tmin, tmax]` (lowest primitive index on
/// ties), so that for any `tmax` at least that hit's distance the answer is the same: the
/// contract of [`crate::custom`]'s callbacks, which every kernel of this crate meets.
pub trait BottomLevel {
    /// Closest hit of an object-space ray ([`Hit::MISS`] for none).
    fn closest_hit(&self, ray: &Ray) -> Hit;
    /// True when the object-space ray hits something in `[tmin, tmax]`.
    fn any_hit(&self, ray: &Ray) -> bool;
    /// Object-space bounds (empty for an empty tree).
    fn bounds(&self) -> Aabb;
}

impl<const W: usize> BottomLevel for WideBvh<W> {
    #[inline]
    fn closest_hit(&self, ray: &Ray) -> Hit {
        WideBvh::closest_hit(self, ray, &mut NoStats)
    }
    #[inline]
    fn any_hit(&self, ray: &Ray) -> bool {
        WideBvh::any_hit(self, ray, &mut NoStats)
    }
    fn bounds(&self) -> Aabb {
        WideBvh::bounds(self)
    }
}

/// A shared bottom-level tree: many [`InstanceSet`]s (or a renderer and a set) can hold the
/// same tree without copying it.
///
/// ```
/// use std::sync::Arc;
/// use sahara_bvh::{Bvh, Node};
/// use sahara_geom::{Ray, Triangle, Vec3A};
/// use sahara_traverse::instance::BottomLevel;
/// use sahara_traverse::Bvh8;
///
/// let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
/// let tree = Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
/// let shared = Arc::new(Bvh8::from_bvh(&tree, &[tri]));
/// let ray = Ray::new(Vec3A::new(0.25, 0.25, -1.0), Vec3A::Z, 0.0, 10.0);
/// assert_eq!(BottomLevel::closest_hit(&shared, &ray).t, 1.0);
/// assert_eq!(BottomLevel::bounds(&shared), tri.bounds());
/// ```
impl<B: BottomLevel + ?Sized> BottomLevel for std::sync::Arc<B> {
    #[inline]
    fn closest_hit(&self, ray: &Ray) -> Hit {
        (**self).closest_hit(ray)
    }
    #[inline]
    fn any_hit(&self, ray: &Ray) -> bool {
        (**self).any_hit(ray)
    }
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
}

/// One placed copy of a bottom-level tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index of the bottom-level tree in the set.
    pub blas: u32,
    /// Object to world.
    pub transform: Affine3A,
}

/// A closest hit through instances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceHit {
    /// Ray parameter (world and object space alike: directions are not renormalised).
    pub t: f32,
    /// The instance hit.
    pub instance: u32,
    /// The primitive hit in the instance's bottom-level tree.
    pub prim: u32,
    /// Barycentric weight of vertex 1 (as [`Hit::u`]).
    pub u: f32,
    /// Barycentric weight of vertex 2 (as [`Hit::v`]).
    pub v: f32,
}

/// Why [`InstanceSet::new`] refused its input.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InstanceError {
    /// An instance names a bottom-level tree that does not exist.
    #[error("instance {instance} uses bottom-level tree {blas}, but there are only {count}")]
    UnknownBlas {
        /// The instance.
        instance: usize,
        /// The tree it names.
        blas: u32,
        /// How many trees there are.
        count: usize,
    },
    /// An instance's transform has a NaN or infinite entry, or cannot be inverted (its inverse
    /// is not finite).
    #[error("instance {instance} has a non-finite or singular transform")]
    BadTransform {
        /// The instance.
        instance: usize,
    },
    /// The top-level tree given by the builder is broken.
    #[error("the top-level tree is invalid: {0}")]
    TopLevel(#[from] ValidationError),
    /// The top-level tree references an instance that does not exist, or misses one.
    #[error("the top-level tree does not reference each of the {0} instances")]
    TopLevelCoverage(usize),
    /// An update ([`InstanceSet::set_transforms`], [`InstanceSet::set_mask`]) names an
    /// instance that does not exist.
    #[error("there is no instance {instance}: there are only {count}")]
    UnknownInstance {
        /// The instance named.
        instance: usize,
        /// How many instances there are.
        count: usize,
    },
}

/// A two-level scene: bottom-level trees, their instances and a top-level [`Bvh8`] over the
/// instances' world boxes (see the [module documentation](self)).
#[derive(Clone, Debug)]
pub struct InstanceSet<B: BottomLevel = Bvh8> {
    blases: Vec<B>,
    instances: Vec<Instance>,
    masks: Vec<u32>,
    inverse: Vec<Affine3A>,
    boxes: Vec<Aabb>,
    top: Bvh,
    top_wide: Bvh8,
}

/// The world box of `local` under `m`: the box of the transformed corners, widened by 2^-20 of
/// the magnitude of the transform's terms on each axis (`|M| · max(|min|, |max|) + |t|`).
fn world_box(m: &Affine3A, local: &Aabb) -> Aabb {
    if local.is_empty() {
        let t = m.translation;
        return Aabb::new(t, t);
    }
    let mut b = Aabb::EMPTY;
    for c in 0..8 {
        let p = Vec3A::new(
            if c & 1 == 0 { local.min.x } else { local.max.x },
            if c & 2 == 0 { local.min.y } else { local.max.y },
            if c & 4 == 0 { local.min.z } else { local.max.z },
        );
        b.grow(m.transform_point3a(p));
    }
    let mag = local.min.abs().max(local.max.abs());
    let abs = glam::Mat3A::from_cols(
        m.matrix3.x_axis.abs(),
        m.matrix3.y_axis.abs(),
        m.matrix3.z_axis.abs(),
    );
    let pad = (abs * mag + m.translation.abs()) * (1.0 / 1_048_576.0);
    Aabb::new(b.min - pad, b.max + pad)
}

/// Checks instance `i` and computes its inverse transform and world box.
fn place<B: BottomLevel>(
    blases: &[B],
    i: usize,
    inst: &Instance,
) -> Result<(Affine3A, Aabb), InstanceError> {
    let Some(blas) = blases.get(inst.blas as usize) else {
        return Err(InstanceError::UnknownBlas {
            instance: i,
            blas: inst.blas,
            count: blases.len(),
        });
    };
    let inv = inst.transform.inverse();
    let b = world_box(&inst.transform, &blas.bounds());
    let finite =
        inst.transform.is_finite() && inv.is_finite() && b.min.is_finite() && b.max.is_finite();
    if !finite {
        return Err(InstanceError::BadTransform { instance: i });
    }
    Ok((inv, b))
}

/// Builds, checks and collapses the top-level tree over the world boxes.
fn top_level(
    boxes: &[Aabb],
    build_top: impl FnOnce(&[Aabb]) -> Bvh,
) -> Result<(Bvh, Bvh8), InstanceError> {
    let top = build_top(boxes);
    top.validate_structure()?;
    let mut seen = vec![false; boxes.len()];
    for &p in &top.prim_indices {
        match seen.get_mut(p as usize) {
            Some(s) => *s = true,
            None => return Err(InstanceError::TopLevelCoverage(boxes.len())),
        }
    }
    if seen.iter().any(|&s| !s) {
        return Err(InstanceError::TopLevelCoverage(boxes.len()));
    }
    let top_wide = Bvh8::from_boxes(&top, boxes);
    Ok((top, top_wide))
}

impl<B: BottomLevel> InstanceSet<B> {
    /// Places `instances` of the bottom-level trees `blases` and builds the top-level tree:
    /// `build_top(world_boxes)` returns a binary tree over the instances' world boxes (one
    /// primitive per instance, in order), for example a registered builder run on
    /// `BuildInput::from_boxes(world_boxes, cost)`; it is checked and collapsed into a
    /// [`Bvh8`]. An instance of an empty tree gets the point box at its translation (it is
    /// never hit).
    pub fn new(
        blases: Vec<B>,
        instances: Vec<Instance>,
        build_top: impl FnOnce(&[Aabb]) -> Bvh,
    ) -> Result<Self, InstanceError> {
        let mut inverse = Vec::with_capacity(instances.len());
        let mut boxes = Vec::with_capacity(instances.len());
        for (i, inst) in instances.iter().enumerate() {
            let (inv, b) = place(&blases, i, inst)?;
            inverse.push(inv);
            boxes.push(b);
        }
        let (top, top_wide) = top_level(&boxes, build_top)?;
        Ok(Self {
            blases,
            masks: vec![u32::MAX; instances.len()],
            instances,
            inverse,
            boxes,
            top,
            top_wide,
        })
    }

    /// Moves instances: each `(instance, transform)` of `updates` gives an instance its new
    /// object-to-world transform (a later update of the same instance wins). Their inverses
    /// and world boxes are recomputed, and the **top level only** is rebuilt by `build_top`
    /// over all the world boxes, as in [`InstanceSet::new`]; the bottom-level trees are not
    /// touched. With the same deterministic `build_top`, the result is the set
    /// [`InstanceSet::new`] would build from the moved instances (the same top-level tree).
    ///
    /// Fails, leaving the set unchanged, with [`InstanceError::UnknownInstance`] for an
    /// index out of range, [`InstanceError::BadTransform`] for a non-finite or singular
    /// transform, or the errors of a broken top-level tree.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
    /// use sahara_traverse::instance::{Instance, InstanceError, InstanceSet};
    /// use sahara_traverse::{Bvh8, NoStats};
    /// use glam::{Affine3A, Vec3};
    ///
    /// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, -1.0, 0.0), Vec3A::new(0.0, 1.0, 0.0));
    /// let blas = Bvh8::from_bvh(&Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None }, &[tri]);
    /// let one = |b: &[Aabb]| Bvh { nodes: vec![Node::leaf(&b[0], 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
    /// let mut set = InstanceSet::new(vec![blas], vec![Instance { blas: 0, transform: Affine3A::IDENTITY }], one).unwrap();
    /// set.set_transforms(&[(0, Affine3A::from_translation(Vec3::new(0.0, 0.0, 4.0)))], one)?;
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// assert_eq!(set.closest_hit(&ray, &mut NoStats).unwrap().t, 4.0);
    /// // A singular transform or a missing instance changes nothing.
    /// assert!(set.set_transforms(&[(0, Affine3A::from_scale(Vec3::ZERO))], one).is_err());
    /// assert_eq!(set.set_transforms(&[(1, Affine3A::IDENTITY)], one), Err(InstanceError::UnknownInstance { instance: 1, count: 1 }));
    /// assert_eq!(set.closest_hit(&ray, &mut NoStats).unwrap().t, 4.0);
    /// # Ok::<(), InstanceError>(())
    /// ```
    pub fn set_transforms(
        &mut self,
        updates: &[(usize, Affine3A)],
        build_top: impl FnOnce(&[Aabb]) -> Bvh,
    ) -> Result<(), InstanceError> {
        let mut boxes = self.boxes.clone();
        let mut placed = Vec::with_capacity(updates.len());
        for &(i, transform) in updates {
            let Some(old) = self.instances.get(i) else {
                return Err(InstanceError::UnknownInstance {
                    instance: i,
                    count: self.instances.len(),
                });
            };
            let inst = Instance {
                blas: old.blas,
                transform,
            };
            let (inv, b) = place(&self.blases, i, &inst)?;
            boxes[i] = b;
            placed.push((i, inst, inv));
        }
        let (top, top_wide) = top_level(&boxes, build_top)?;
        for (i, inst, inv) in placed {
            self.instances[i] = inst;
            self.inverse[i] = inv;
        }
        self.boxes = boxes;
        self.top = top;
        self.top_wide = top_wide;
        Ok(())
    }

    /// Sets instance `instance`'s 32-bit mask (every instance starts with all bits set): the
    /// masked queries ([`InstanceSet::closest_hit_masked`], [`InstanceSet::any_hit_masked`])
    /// skip an instance whose mask shares no bit with the ray's. Nothing is rebuilt. Fails
    /// with [`InstanceError::UnknownInstance`] for an index out of range.
    ///
    /// ```
    /// use sahara_bvh::Bvh;
    /// use sahara_traverse::instance::{InstanceError, InstanceSet};
    /// use sahara_traverse::Bvh8;
    /// let mut set = InstanceSet::<Bvh8>::new(vec![], vec![], |_| Bvh::empty()).unwrap();
    /// assert_eq!(set.set_mask(0, 1), Err(InstanceError::UnknownInstance { instance: 0, count: 0 }));
    /// assert!(set.masks().is_empty());
    /// ```
    pub fn set_mask(&mut self, instance: usize, mask: u32) -> Result<(), InstanceError> {
        let count = self.masks.len();
        let slot = self
            .masks
            .get_mut(instance)
            .ok_or(InstanceError::UnknownInstance { instance, count })?;
        *slot = mask;
        Ok(())
    }

    /// The instances' masks, in instance order (see [`InstanceSet::set_mask`]).
    pub fn masks(&self) -> &[u32] {
        &self.masks
    }

    /// The inverses of the instances' transforms (world to object), as every query uses
    /// them (computed once by glam in `f32`).
    pub fn inverse_transforms(&self) -> &[Affine3A] {
        &self.inverse
    }

    /// The instances.
    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// The bottom-level trees.
    pub fn blases(&self) -> &[B] {
        &self.blases
    }

    /// The instances' world boxes (the top level's primitive boxes).
    pub fn world_boxes(&self) -> &[Aabb] {
        &self.boxes
    }

    /// The binary top-level tree (before its collapse into a [`Bvh8`]).
    pub fn top_level(&self) -> &Bvh {
        &self.top
    }

    /// The world-space ray `ray` in the object space of instance `instance`, with interval
    /// `[ray.tmin, tmax]`: origin and direction through the inverse transform, the direction
    /// not renormalised. Every query uses exactly this ray.
    #[inline]
    pub fn object_ray(&self, instance: u32, ray: &Ray, tmax: f32) -> Ray {
        let inv = &self.inverse[instance as usize];
        Ray::new(
            inv.transform_point3a(ray.origin),
            inv.transform_vector3a(ray.direction()),
            ray.tmin,
            tmax,
        )
    }

    /// The bottom-level closest hit of instance `i` for a world ray with interval `[ray.tmin,
    /// tmax]`: the top level's intersection callback.
    #[inline]
    fn instance_closest(&self, ray: &Ray, i: u32, tmax: f32) -> Option<(f32, (u32, f32, f32))> {
        let blas = &self.blases[self.instances[i as usize].blas as usize];
        let h = blas.closest_hit(&self.object_ray(i, ray, tmax));
        h.is_hit().then_some((h.t, (h.prim, h.u, h.v)))
    }

    /// Closest hit through the instances; `stats` counts the top level's work (nodes visited,
    /// instances tested). Invalid rays miss. Every instance is tested whatever its mask (as
    /// [`InstanceSet::closest_hit_masked`] with the ray mask `u32::MAX` when no mask is zero).
    pub fn closest_hit<S: TraversalStats>(&self, ray: &Ray, stats: &mut S) -> Option<InstanceHit> {
        let h = self.top_wide.closest_hit_custom(
            &self.boxes,
            ray,
            |r: &Ray, i, _tmin, tmax| self.instance_closest(r, i, tmax),
            stats,
        )?;
        Some(to_instance_hit(h))
    }

    /// [`InstanceSet::closest_hit`] over the instances whose mask shares a bit with `mask`
    /// (`instance mask & mask != 0`); the others are skipped as if absent.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
    /// use sahara_traverse::instance::{Instance, InstanceSet};
    /// use sahara_traverse::{Bvh8, NoStats};
    /// use glam::Affine3A;
    ///
    /// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0));
    /// let blas = Bvh8::from_bvh(&Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None }, &[tri]);
    /// let one = |b: &[Aabb]| Bvh { nodes: vec![Node::leaf(&b[0], 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
    /// let mut set = InstanceSet::new(vec![blas], vec![Instance { blas: 0, transform: Affine3A::IDENTITY }], one).unwrap();
    /// set.set_mask(0, 0b10).unwrap();
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// assert!(set.closest_hit_masked(&ray, 0b10, &mut NoStats).is_some());
    /// assert!(set.closest_hit_masked(&ray, 0b01, &mut NoStats).is_none());
    /// assert!(!set.any_hit_masked(&ray, 0b01, &mut NoStats));
    /// ```
    pub fn closest_hit_masked<S: TraversalStats>(
        &self,
        ray: &Ray,
        mask: u32,
        stats: &mut S,
    ) -> Option<InstanceHit> {
        let h = self.top_wide.closest_hit_custom(
            &self.boxes,
            ray,
            |r: &Ray, i, _tmin, tmax| {
                if self.masks[i as usize] & mask == 0 {
                    return None;
                }
                self.instance_closest(r, i, tmax)
            },
            stats,
        )?;
        Some(to_instance_hit(h))
    }

    /// Any hit through the instances: true when some instance's bottom level reports a hit of
    /// the object-space ray and the instance's world box passes the culling box test (see the
    /// [module documentation](self)). Invalid rays miss. Masks are not looked at.
    pub fn any_hit<S: TraversalStats>(&self, ray: &Ray, stats: &mut S) -> bool {
        self.top_wide
            .any_hit_occluders(ray, |i| self.instance_any(ray, i), stats)
    }

    /// [`InstanceSet::any_hit`] over the instances whose mask shares a bit with `mask` (see
    /// [`InstanceSet::closest_hit_masked`]).
    pub fn any_hit_masked<S: TraversalStats>(&self, ray: &Ray, mask: u32, stats: &mut S) -> bool {
        self.top_wide.any_hit_occluders(
            ray,
            |i| self.masks[i as usize] & mask != 0 && self.instance_any(ray, i),
            stats,
        )
    }

    /// The any-hit acceptance of instance `i`.
    #[inline]
    fn instance_any(&self, ray: &Ray, i: u32) -> bool {
        self.passes_box(ray, i) && {
            let blas = &self.blases[self.instances[i as usize].blas as usize];
            blas.any_hit(&self.object_ray(i, ray, ray.tmax))
        }
    }

    /// The any-hit queries' culling test of instance `i`'s world box.
    #[inline]
    fn passes_box(&self, ray: &Ray, i: u32) -> bool {
        let b = &self.boxes[i as usize];
        let (lo, hi) = (lower_distance(ray.tmin), cull_distance(ray.tmax));
        intersect_aabb(ray.origin, ray.inv_direction(), lo, hi, b).is_some()
    }

    /// [`InstanceSet::closest_hit_masked`] with the bottom-level query given by the caller:
    /// `closest(instance, object_ray)` answers for instance `instance` (its index, not its
    /// tree's) and the ray in its object space ([`InstanceSet::object_ray`]), for example a
    /// filtered query of the instance's tree. With `closest` the tree's own closest hit it is
    /// [`InstanceSet::closest_hit_masked`]. The same top-level traversal, hit rule and ties.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
    /// use sahara_traverse::instance::{Instance, InstanceSet};
    /// use sahara_traverse::{Bvh8, Hit, NoStats};
    /// use glam::{Affine3A, Vec3};
    ///
    /// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0));
    /// let blas = Bvh8::from_bvh(&Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None }, &[tri]);
    /// let both = |b: &[Aabb]| Bvh { nodes: vec![Node::leaf(&b[0].union(&b[1]), 0, 2)], prim_indices: vec![0, 1], spatial_splits: false, ref_cuts: None };
    /// let placed = vec![
    ///     Instance { blas: 0, transform: Affine3A::IDENTITY },
    ///     Instance { blas: 0, transform: Affine3A::from_translation(Vec3::Z) },
    /// ];
    /// let set = InstanceSet::new(vec![blas], placed, both).unwrap();
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// // Instance 0 is see-through: the hit is instance 1's, one unit further.
    /// let hit = set.closest_hit_with(&ray, u32::MAX, |i, o| {
    ///     if i == 0 { Hit::MISS } else { set.blases()[0].closest_hit(o, &mut NoStats) }
    /// }, &mut NoStats);
    /// assert_eq!(hit.map(|h| (h.instance, h.t)), Some((1, 3.0)));
    /// ```
    pub fn closest_hit_with<S: TraversalStats>(
        &self,
        ray: &Ray,
        mask: u32,
        mut closest: impl FnMut(u32, &Ray) -> Hit,
        stats: &mut S,
    ) -> Option<InstanceHit> {
        let h = self.top_wide.closest_hit_custom(
            &self.boxes,
            ray,
            |r: &Ray, i, _tmin, tmax| {
                if self.masks[i as usize] & mask == 0 {
                    return None;
                }
                let h = closest(i, &self.object_ray(i, r, tmax));
                h.is_hit().then_some((h.t, (h.prim, h.u, h.v)))
            },
            stats,
        )?;
        Some(to_instance_hit(h))
    }

    /// [`InstanceSet::any_hit_masked`] with the bottom-level query given by the caller:
    /// `any(instance, object_ray)` (see [`InstanceSet::closest_hit_with`]) is asked for the
    /// instances whose mask meets `mask` and whose world box the ray passes.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
    /// use sahara_traverse::instance::{Instance, InstanceSet};
    /// use sahara_traverse::{Bvh8, NoStats};
    /// use glam::Affine3A;
    ///
    /// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0));
    /// let blas = Bvh8::from_bvh(&Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None }, &[tri]);
    /// let one = |b: &[Aabb]| Bvh { nodes: vec![Node::leaf(&b[0], 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
    /// let set = InstanceSet::new(vec![blas], vec![Instance { blas: 0, transform: Affine3A::IDENTITY }], one).unwrap();
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// assert!(set.any_hit_with(&ray, u32::MAX, |_, o| set.blases()[0].any_hit(o, &mut NoStats), &mut NoStats));
    /// assert!(!set.any_hit_with(&ray, u32::MAX, |_, _| false, &mut NoStats));
    /// ```
    pub fn any_hit_with<S: TraversalStats>(
        &self,
        ray: &Ray,
        mask: u32,
        mut any: impl FnMut(u32, &Ray) -> bool,
        stats: &mut S,
    ) -> bool {
        self.top_wide.any_hit_occluders(
            ray,
            |i| {
                self.masks[i as usize] & mask != 0
                    && self.passes_box(ray, i)
                    && any(i, &self.object_ray(i, ray, ray.tmax))
            },
            stats,
        )
    }

    /// The two-level brute-force reference of [`InstanceSet::closest_hit`]: every instance in
    /// index order, the ray taken into its object space by [`InstanceSet::object_ray`],
    /// `closest(blas, object_ray)` (for example brute force over the bottom level's
    /// triangles), the same hit rule and tie-break.
    pub fn brute_closest_hit(
        &self,
        ray: &Ray,
        mut closest: impl FnMut(u32, &Ray) -> Hit,
    ) -> Option<InstanceHit> {
        self.brute_closest(ray, None, |i, o| {
            closest(self.instances[i as usize].blas, o)
        })
    }

    /// The brute-force reference of [`InstanceSet::closest_hit_masked`]: the loop of
    /// [`InstanceSet::brute_closest_hit`] over the instances whose mask shares a bit with
    /// `mask` only.
    pub fn brute_closest_hit_masked(
        &self,
        ray: &Ray,
        mask: u32,
        mut closest: impl FnMut(u32, &Ray) -> Hit,
    ) -> Option<InstanceHit> {
        self.brute_closest(ray, Some(mask), |i, o| {
            closest(self.instances[i as usize].blas, o)
        })
    }

    /// The brute-force reference of [`InstanceSet::closest_hit_with`]: the loop of
    /// [`InstanceSet::brute_closest_hit_masked`] with `closest(instance, object_ray)` (the
    /// instance's index, not its tree's). The example shows
    /// [`InstanceSet::brute_any_hit_with`] too.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Aabb, Ray, Triangle, Vec3A};
    /// use sahara_traverse::instance::{Instance, InstanceSet};
    /// use sahara_traverse::{brute, Bvh8, NoStats};
    /// use glam::Affine3A;
    ///
    /// let tri = Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0));
    /// let blas = Bvh8::from_bvh(&Bvh { nodes: vec![Node::leaf(&tri.bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None }, &[tri]);
    /// let one = |b: &[Aabb]| Bvh { nodes: vec![Node::leaf(&b[0], 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
    /// let set = InstanceSet::new(vec![blas], vec![Instance { blas: 0, transform: Affine3A::IDENTITY }], one).unwrap();
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
    /// let brute = set.brute_closest_hit_with(&ray, u32::MAX, |_, o| brute::closest_hit(&[tri], o));
    /// assert_eq!(brute, set.closest_hit(&ray, &mut NoStats));
    /// // The any-hit reference, with every mask and with none.
    /// assert!(set.brute_any_hit_with(&ray, u32::MAX, |_, o| brute::any_hit(&[tri], o)));
    /// assert!(!set.brute_any_hit_with(&ray, 0, |_, o| brute::any_hit(&[tri], o)));
    /// ```
    pub fn brute_closest_hit_with(
        &self,
        ray: &Ray,
        mask: u32,
        closest: impl FnMut(u32, &Ray) -> Hit,
    ) -> Option<InstanceHit> {
        self.brute_closest(ray, Some(mask), closest)
    }

    /// The closest-hit brute force: `closest(instance, object_ray)` for every instance in
    /// index order whose mask meets `mask` (every instance when `None`), under the hit rule
    /// and tie-break of `custom::brute_closest_hit`.
    fn brute_closest(
        &self,
        ray: &Ray,
        mask: Option<u32>,
        mut closest: impl FnMut(u32, &Ray) -> Hit,
    ) -> Option<InstanceHit> {
        crate::custom::brute_closest_hit(&self.boxes, ray, |r: &Ray, i, _tmin, tmax| {
            if mask.is_some_and(|m| self.masks[i as usize] & m == 0) {
                return None;
            }
            let h = closest(i, &self.object_ray(i, r, tmax));
            h.is_hit().then_some((h.t, (h.prim, h.u, h.v)))
        })
        .map(to_instance_hit)
    }

    /// The brute-force reference of [`InstanceSet::any_hit_masked`].
    pub fn brute_any_hit_masked(
        &self,
        ray: &Ray,
        mask: u32,
        mut any: impl FnMut(u32, &Ray) -> bool,
    ) -> bool {
        self.brute_any(ray, Some(mask), |i, o| {
            any(self.instances[i as usize].blas, o)
        })
    }

    /// The brute-force reference of [`InstanceSet::any_hit_with`]: every instance in index
    /// order whose mask meets `mask` and whose world box the ray passes (the query's culling
    /// test), `any(instance, object_ray)`. The example of
    /// [`InstanceSet::brute_closest_hit_with`] uses both.
    pub fn brute_any_hit_with(
        &self,
        ray: &Ray,
        mask: u32,
        any: impl FnMut(u32, &Ray) -> bool,
    ) -> bool {
        self.brute_any(ray, Some(mask), any)
    }

    /// The brute-force reference of [`InstanceSet::any_hit`], with `any(blas, object_ray)` the
    /// bottom-level any-hit query.
    pub fn brute_any_hit(&self, ray: &Ray, mut any: impl FnMut(u32, &Ray) -> bool) -> bool {
        self.brute_any(ray, None, |i, o| any(self.instances[i as usize].blas, o))
    }

    /// The any-hit brute force: `any(instance, object_ray)` for every instance in order that
    /// the mask and the culling box test let through.
    fn brute_any(
        &self,
        ray: &Ray,
        mask: Option<u32>,
        mut any: impl FnMut(u32, &Ray) -> bool,
    ) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let (lo, hi) = (lower_distance(ray.tmin), cull_distance(ray.tmax));
        (0..self.instances.len() as u32).any(|i| {
            mask.is_none_or(|m| self.masks[i as usize] & m != 0)
                && intersect_aabb(
                    ray.origin,
                    ray.inv_direction(),
                    lo,
                    hi,
                    &self.boxes[i as usize],
                )
                .is_some()
                && any(i, &self.object_ray(i, ray, ray.tmax))
        })
    }

    /// The computed span of the ray through instance `i`'s world box (see
    /// [`crate::custom::primitive_span`]).
    pub fn world_span(&self, ray: &Ray, i: u32) -> (f32, f32) {
        primitive_span(ray, &self.boxes[i as usize])
    }
}

fn to_instance_hit(h: PrimHit<(u32, f32, f32)>) -> InstanceHit {
    InstanceHit {
        t: h.t,
        instance: h.prim,
        prim: h.data.0,
        u: h.data.1,
        v: h.data.2,
    }
}
