//! Instances: many placed copies of a few shared [`Accel`]s, traced as one scene, movable.

use std::sync::Arc;

use sahara_builders::BuildInput;
use sahara_traverse::instance::{BottomLevel, Instance, InstanceSet};
use sahara_traverse::{brute, NoStats};

use crate::{Aabb, Accel, BuildOptions, Bvh, Error, Hit, Ray, Vec3A};

pub use glam::Affine3A;

/// A closest hit through [`Instances`]: which instance, which mesh and triangle, where, and
/// the world-space geometric normal.
///
/// * `t`: the ray parameter, the same in world and object space (rays are taken into object
///   space without renormalising the direction);
/// * `u`, `v`: barycentric weights of the triangle's vertices 1 and 2 in object space (the
///   point is `(1 - u - v) · v0 + u · v1 + v · v2`, before the transform);
/// * `normal`: the object-space geometric normal `(v1 - v0) × (v2 - v0)` of the mesh's
///   triangle, transformed by the inverse-transpose of the linear part `M` of the instance's
///   transform (`M⁻ᵀ n`, with the inverse every query uses,
///   [`Instances::set`]`().inverse_transforms()`), **not normalised**. It is perpendicular to
///   the world-space triangle; in exact arithmetic it equals `(w1 - w0) × (w2 - w0) / det M` of
///   the transformed vertices, so under a mirroring transform (`det M < 0`) it keeps the
///   object-space orientation and points against the world-space winding.
///
/// ```
/// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
/// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
/// // The triangle stretched twice along x and lifted to z = 3.
/// let m = Affine3A::from_scale_rotation_translation(Vec3::new(2.0, 1.0, 1.0), Default::default(), Vec3::new(0.0, 0.0, 3.0));
/// let scene = Instances::build(vec![mesh], &[(0, m)], Quality::Fast)?;
/// let hit = scene.closest_hit(&Ray::new(Vec3A::new(0.5, 0.25, 0.0), Vec3A::Z, 0.0, 10.0), ALL_MASK).unwrap();
/// assert_eq!((hit.instance, hit.mesh, hit.prim, hit.t), (0, 0, 0, 3.0));
/// assert_eq!((hit.u, hit.v), (0.25, 0.25));
/// assert_eq!(hit.normal, Vec3A::Z); // M⁻ᵀ (0, 0, 1) = (0, 0, 1)
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceHit {
    /// Ray parameter (world and object space alike).
    pub t: f32,
    /// The instance hit: its index in the placements.
    pub instance: u32,
    /// The mesh of that instance: its index in [`Instances::meshes`].
    pub mesh: u32,
    /// The triangle hit, in the mesh's triangle order.
    pub prim: u32,
    /// Barycentric weight of vertex 1 (as [`Hit::u`]).
    pub u: f32,
    /// Barycentric weight of vertex 2 (as [`Hit::v`]).
    pub v: f32,
    /// World-space geometric normal, unnormalised: `M⁻ᵀ ((v1 - v0) × (v2 - v0))`.
    pub normal: Vec3A,
}

/// An [`Accel`] is a bottom-level tree of `sahara-traverse`'s two-level traversal (its 8-wide
/// layout's queries), so instance sets can hold shared `Arc<Accel>`s.
///
/// ```
/// use sahara::sahara_traverse::instance::BottomLevel;
/// use sahara::{Accel, Quality, Ray, Triangle, Vec3A};
/// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
/// let ray = Ray::new(Vec3A::new(0.25, 0.25, 1.0), -Vec3A::Z, 0.0, 5.0);
/// let hit = BottomLevel::closest_hit(&mesh, &ray);
/// assert_eq!(mesh.closest_hit(&ray).map(|h| (h.prim, h.t)), Some((hit.prim, hit.t)));
/// # Ok::<(), sahara::Error>(())
/// ```
impl BottomLevel for Accel {
    #[inline]
    fn closest_hit(&self, ray: &Ray) -> Hit {
        self.wide().closest_hit(ray, &mut NoStats)
    }
    #[inline]
    fn any_hit(&self, ray: &Ray) -> bool {
        self.wide().any_hit(ray, &mut NoStats)
    }
    fn bounds(&self) -> Aabb {
        self.wide().bounds()
    }
}

/// A two-level scene: the bottom-level meshes (shared [`Accel`]s, `Arc<Accel>`), their
/// placements (affine object-to-world transforms, one 32-bit mask each) and a top-level tree
/// over the placements' world boxes, built with the builder of a [`Quality`](crate::Quality)
/// level.
///
/// Rays are taken into each instance's object space without renormalising the direction, so
/// `t` means the same distance in world and object space. Every answer equals the brute force
/// [`Instances::brute_closest_hit`] (every instance, every triangle) bit for bit (see
/// `docs/primitives.md`).
///
/// **Moving instances.** [`Instances::set_transform`] and [`Instances::set_transforms`] move
/// instances without touching the meshes: they recompute the moved instances' world boxes and
/// **rebuild the top level** (one box per instance) with the same deterministic builder, rather
/// than refitting it. Rebuilding costs little (the top level has one primitive per instance,
/// not per triangle), keeps the top level's quality however far the instances travel (a refit
/// would keep a tree grouped for the old positions), and gives exactly the tree that
/// [`Instances::build`] or [`Instances::load`] would build for the new placements.
///
/// ```
/// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
///
/// let quad = [
///     Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y),
///     Triangle::new(Vec3A::X, Vec3A::X + Vec3A::Y, Vec3A::Y),
/// ];
/// let mesh = Accel::build(&quad, Quality::Medium)?;
/// // Ten copies of the quad in a row along x, at z = 5.
/// let placements: Vec<(usize, Affine3A)> = (0..10)
///     .map(|i| (0, Affine3A::from_translation(Vec3::new(2.0 * i as f32, 0.0, 5.0))))
///     .collect();
/// let mut scene = Instances::build(vec![mesh], &placements, Quality::Medium)?;
/// let ray = Ray::new(Vec3A::new(6.5, 0.5, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
/// let hit = scene.closest_hit(&ray, ALL_MASK).unwrap();
/// assert_eq!((hit.instance, hit.t), (3, 5.0));
/// // Move instance 3 nearer: only the top level is rebuilt.
/// scene.set_transform(3, Affine3A::from_translation(Vec3::new(6.0, 0.0, 2.0)))?;
/// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.t), Some(2.0));
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Instances {
    placements: Vec<(usize, Affine3A)>,
    options: BuildOptions,
    set: InstanceSet<Arc<Accel>>,
}

/// The top-level tree over the world boxes with `options`' builder.
fn build_top(options: &BuildOptions, boxes: &[Aabb]) -> Result<Bvh, Error> {
    let name = options.quality.builder_name();
    let builder = sahara_builders::registry::by_name(name).ok_or(Error::MissingBuilder(name))?;
    let input = BuildInput::from_boxes(boxes, options.cost)?;
    Ok(builder.build(&input)?)
}

impl Instances {
    /// Places the `meshes`: each `(mesh, transform)` of `placements` is one instance (its index
    /// in `placements` is [`InstanceHit::instance`]); the top level is built over the
    /// instances' world boxes with the builder of `options`' quality level. The meshes are
    /// moved into shared `Arc`s ([`Instances::build_shared`] takes `Arc`s you keep).
    ///
    /// Fails with [`Error::Instance`] when a placement names a missing mesh or its transform is
    /// not finite or not invertible.
    pub fn build(
        meshes: Vec<Accel>,
        placements: &[(usize, Affine3A)],
        options: impl Into<BuildOptions>,
    ) -> Result<Instances, Error> {
        Self::build_shared(
            meshes.into_iter().map(Arc::new).collect(),
            placements,
            options,
        )
    }

    /// [`Instances::build`] over shared meshes: the instance set holds the `Arc`s, so the
    /// same [`Accel`] can serve several sets (or the renderer) without a copy.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use sahara::{Accel, Affine3A, Instances, Quality, Triangle, Vec3A};
    /// let mesh = Arc::new(Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?);
    /// let a = Instances::build_shared(vec![mesh.clone()], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// let b = Instances::build_shared(vec![mesh.clone()], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// assert!(Arc::ptr_eq(&a.meshes()[0], &b.meshes()[0]));
    /// assert_eq!(Arc::strong_count(&mesh), 3);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn build_shared(
        meshes: Vec<Arc<Accel>>,
        placements: &[(usize, Affine3A)],
        options: impl Into<BuildOptions>,
    ) -> Result<Instances, Error> {
        let options = options.into();
        let instances = placements
            .iter()
            .map(|&(mesh, transform)| Instance {
                // Out-of-range indices (beyond u32 too) are refused by `InstanceSet::new`.
                blas: u32::try_from(mesh).unwrap_or(u32::MAX),
                transform,
            })
            .collect();
        let mut failure = None;
        let set = InstanceSet::new(meshes, instances, |boxes| {
            build_top(&options, boxes).unwrap_or_else(|e| {
                failure = Some(e);
                Bvh::empty()
            })
        });
        if let Some(e) = failure {
            return Err(e);
        }
        Ok(Instances {
            placements: placements.to_vec(),
            options: BuildOptions {
                threads: None,
                ..options
            },
            set: set?,
        })
    }

    /// Moves instance `instance` to the object-to-world `transform` and rebuilds the top level
    /// only (see [`Instances`]: why a rebuild and not a refit); the meshes are untouched.
    ///
    /// Fails, leaving everything unchanged, with [`Error::Instance`]: an index out of range
    /// (`InstanceError::UnknownInstance`), a transform with a NaN or infinite entry or that
    /// cannot be inverted (`InstanceError::BadTransform`).
    ///
    /// ```
    /// use sahara::sahara_traverse::instance::InstanceError;
    /// use sahara::{Accel, Affine3A, Error, Instances, Quality, Triangle, Vec3, Vec3A};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let mut scene = Instances::build(vec![mesh], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// let up = Affine3A::from_translation(Vec3::Z);
    /// scene.set_transform(0, up)?;
    /// assert_eq!(scene.placements()[0], (0, up));
    /// let flat = Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0));
    /// assert!(matches!(scene.set_transform(0, flat), Err(Error::Instance(InstanceError::BadTransform { instance: 0 }))));
    /// assert!(matches!(scene.set_transform(1, up), Err(Error::Instance(InstanceError::UnknownInstance { instance: 1, count: 1 }))));
    /// assert_eq!(scene.placements()[0], (0, up));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn set_transform(&mut self, instance: usize, transform: Affine3A) -> Result<(), Error> {
        self.set_transforms(&[(instance, transform)])
    }

    /// Moves several instances at once (`(instance, transform)` pairs; a later pair for the
    /// same instance wins) with one rebuild of the top level. All or nothing: on an error (as
    /// [`Instances::set_transform`]'s) no instance moves.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Triangle, Vec3, Vec3A};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let mut scene = Instances::build(vec![mesh], &[(0, Affine3A::IDENTITY); 3], Quality::Fast)?;
    /// let moves: Vec<(usize, Affine3A)> = (0..3).map(|i| (i, Affine3A::from_translation(Vec3::X * i as f32))).collect();
    /// scene.set_transforms(&moves)?;
    /// assert_eq!(scene.placements()[2].1, moves[2].1);
    /// // One bad transform: nothing moves.
    /// assert!(scene.set_transforms(&[(0, Affine3A::IDENTITY), (1, Affine3A::from_scale(Vec3::ZERO))]).is_err());
    /// assert_eq!(scene.placements()[0].1, moves[0].1);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn set_transforms(&mut self, updates: &[(usize, Affine3A)]) -> Result<(), Error> {
        let options = self.options;
        let mut failure = None;
        let moved = self.set.set_transforms(updates, |boxes| {
            build_top(&options, boxes).unwrap_or_else(|e| {
                failure = Some(e);
                Bvh::empty()
            })
        });
        if let Some(e) = failure {
            return Err(e);
        }
        moved?;
        for &(i, transform) in updates {
            self.placements[i].1 = transform;
        }
        Ok(())
    }

    /// Sets instance `instance`'s 32-bit mask (every instance starts with [`ALL_MASK`]): a
    /// query with ray mask `mask` skips the instances with `instance mask & mask == 0`.
    /// Nothing is rebuilt. Fails with [`Error::Instance`] for an index out of range.
    ///
    /// [`ALL_MASK`]: crate::ALL_MASK
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let mut scene = Instances::build(vec![mesh], &[(0, Affine3A::from_translation(Vec3::Z))], Quality::Fast)?;
    /// scene.set_mask(0, 0b10)?;
    /// assert_eq!(scene.mask(0), Some(0b10));
    /// let ray = Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0);
    /// assert!(scene.any_hit(&ray, ALL_MASK));
    /// assert!(!scene.any_hit(&ray, 0b01));
    /// assert!(scene.set_mask(1, 0).is_err());
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn set_mask(&mut self, instance: usize, mask: u32) -> Result<(), Error> {
        Ok(self.set.set_mask(instance, mask)?)
    }

    /// Instance `instance`'s mask, or `None` for an index out of range.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, ALL_MASK};
    /// let scene = Instances::build(vec![Accel::build(&[], Quality::Fast)?], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// assert_eq!((scene.mask(0), scene.mask(1)), (Some(ALL_MASK), None));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn mask(&self, instance: usize) -> Option<u32> {
        self.set.masks().get(instance).copied()
    }

    /// The placements: `(mesh, transform)` as given to [`Instances::build`], with the moves of
    /// [`Instances::set_transform`] applied.
    pub fn placements(&self) -> &[(usize, Affine3A)] {
        &self.placements
    }

    /// The quality level and cost model of the top level (the build threads are not kept).
    pub fn options(&self) -> BuildOptions {
        self.options
    }

    /// Writes the instance set: every mesh (each as a complete [`Accel`] file), the
    /// placements and their masks. The top level is not stored: [`Instances::load`] rebuilds
    /// it with the same deterministic builder (it is over one box per instance, so this is
    /// cheap). Format in [`crate::file`]. A mesh shared by several sets is written into each
    /// set's file.
    pub fn save<W: std::io::Write>(&self, w: &mut W) -> std::io::Result<()> {
        crate::file::save_instances(self, w)
    }

    /// Reads what [`Instances::save`] wrote; every mesh is checked as [`Accel::load`] checks
    /// it, and the placements as [`Instances::build`] checks them. A broken, truncated or
    /// foreign file is a [`LoadError`](crate::LoadError), never a panic.
    pub fn load<R: std::io::Read>(r: &mut R) -> Result<Instances, crate::LoadError> {
        crate::file::load_instances(r)
    }

    /// The façade's hit from the traversal's: adds the mesh and the world-space normal.
    #[inline]
    fn hit(&self, h: sahara_traverse::instance::InstanceHit) -> InstanceHit {
        let i = h.instance as usize;
        let mesh = self.set.instances()[i].blas;
        let tri = &self.set.blases()[mesh as usize].triangles()[h.prim as usize];
        let inverse = &self.set.inverse_transforms()[i];
        InstanceHit {
            t: h.t,
            instance: h.instance,
            mesh,
            prim: h.prim,
            u: h.u,
            v: h.v,
            normal: inverse.matrix3.transpose() * tri.cross(),
        }
    }

    /// The closest hit in `[ray.tmin, ray.tmax]` through every instance whose mask shares a
    /// bit with `mask` ([`ALL_MASK`](crate::ALL_MASK): every instance with a non-zero mask),
    /// or `None`. Ties: the lowest instance index, then the lowest triangle index. Invalid
    /// rays miss.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let near_far = [(0, Affine3A::from_translation(Vec3::Z)), (0, Affine3A::from_translation(Vec3::Z * 2.0))];
    /// let mut scene = Instances::build(vec![mesh], &near_far, Quality::Fast)?;
    /// scene.set_mask(0, 0b01)?;
    /// scene.set_mask(1, 0b10)?;
    /// let ray = Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0);
    /// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.instance), Some(0));
    /// assert_eq!(scene.closest_hit(&ray, 0b10).map(|h| h.instance), Some(1));
    /// assert_eq!(scene.closest_hit(&ray, 0), None);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hit(&self, ray: &Ray, mask: u32) -> Option<InstanceHit> {
        self.set
            .closest_hit_masked(ray, mask, &mut NoStats)
            .map(|h| self.hit(h))
    }

    /// True when some instance whose mask shares a bit with `mask` is hit in
    /// `[ray.tmin, ray.tmax]` (occlusion). Invalid rays miss.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![mesh], &[(0, Affine3A::from_translation(Vec3::Z))], Quality::Fast)?;
    /// assert!(scene.any_hit(&Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0), ALL_MASK));
    /// assert!(!scene.any_hit(&Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 0.5), ALL_MASK));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hit(&self, ray: &Ray, mask: u32) -> bool {
        self.set.any_hit_masked(ray, mask, &mut NoStats)
    }

    /// [`Instances::closest_hit`] of every ray, in parallel, in the order of `rays`.
    pub fn closest_hits(&self, rays: &[Ray], mask: u32) -> Vec<Option<InstanceHit>> {
        crate::batch(rays, |r| self.closest_hit(r, mask))
    }

    /// [`Instances::any_hit`] of every ray, in parallel, in the order of `rays`.
    pub fn any_hits(&self, rays: &[Ray], mask: u32) -> Vec<bool> {
        crate::batch(rays, |r| self.any_hit(r, mask))
    }

    /// The brute-force twin of [`Instances::closest_hit`]: every instance in index order whose
    /// mask shares a bit with `mask`, the ray taken into its object space exactly as the
    /// queries take it (`InstanceSet::object_ray`: the stored inverse transform, the direction
    /// not renormalised), every triangle of its mesh with the exact watertight test
    /// (`sahara_traverse::brute::closest_hit`), the same hit rule and ties. No tree is used.
    /// The query equals it bit for bit, normal included.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![mesh], &[(0, Affine3A::from_rotation_x(0.3))], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z, 0.0, 5.0);
    /// assert_eq!(scene.brute_closest_hit(&ray, ALL_MASK), scene.closest_hit(&ray, ALL_MASK));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_closest_hit(&self, ray: &Ray, mask: u32) -> Option<InstanceHit> {
        let meshes = self.set.blases();
        self.set
            .brute_closest_hit_masked(ray, mask, |mesh, o| {
                brute::closest_hit(meshes[mesh as usize].triangles(), o)
            })
            .map(|h| self.hit(h))
    }

    /// The brute-force twin of [`Instances::any_hit`] (the loop of
    /// [`Instances::brute_closest_hit`], `sahara_traverse::brute::any_hit` per instance).
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3A};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![mesh], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z, 0.0, 5.0);
    /// assert!(scene.brute_any_hit(&ray, 1) && scene.any_hit(&ray, 1));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_any_hit(&self, ray: &Ray, mask: u32) -> bool {
        let meshes = self.set.blases();
        self.set.brute_any_hit_masked(ray, mask, |mesh, o| {
            brute::any_hit(meshes[mesh as usize].triangles(), o)
        })
    }

    /// The façade's hit of a kernel hit `h` on instance `instance`.
    #[inline]
    fn hit_on(&self, instance: u32, h: &Hit) -> InstanceHit {
        self.hit(sahara_traverse::instance::InstanceHit {
            t: h.t,
            instance,
            prim: h.prim,
            u: h.u,
            v: h.v,
        })
    }

    /// [`Instances::closest_hit`] with an any-hit filter, as [`Scene::closest_hit_filtered`]
    /// has: `filter(&candidate)` keeps (`true`) or rejects (`false`) a candidate hit (an
    /// [`InstanceHit`], world-space normal included), and the traversal goes on past rejected
    /// ones to the nearest kept hit. The filter sees only candidates of instances the mask lets
    /// through that would change the answer, in an order that depends on the trees, possibly
    /// more than once for one triangle (spatial splits): it must be a pure function of the
    /// candidate. Then the answer equals [`Instances::brute_closest_hit_filtered`] bit for bit.
    ///
    /// **A panicking filter** aborts the query: the panic propagates to the caller (out of
    /// rayon in the batch forms). The instance set is only borrowed and has no interior
    /// mutability, so it stays valid: `catch_unwind(AssertUnwindSafe(|| ...))` and go on
    /// using it.
    ///
    /// [`Scene::closest_hit_filtered`]: crate::Scene::closest_hit_filtered
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let leaf = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let rows = [(0, Affine3A::from_translation(Vec3::Z)), (0, Affine3A::from_translation(Vec3::Z * 2.0))];
    /// let scene = Instances::build(vec![leaf], &rows, Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.6, 0.1, 0.0), Vec3A::Z, 0.0, 5.0);
    /// // Alpha test: the leaves are transparent where u > 0.5 on instance 0.
    /// let opaque = |h: &sahara::InstanceHit| h.instance != 0 || h.u <= 0.5;
    /// assert_eq!(scene.closest_hit(&ray, ALL_MASK).map(|h| h.instance), Some(0));
    /// assert_eq!(scene.closest_hit_filtered(&ray, ALL_MASK, opaque).map(|h| h.instance), Some(1));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hit_filtered<F>(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: F,
    ) -> Option<InstanceHit>
    where
        F: FnMut(&InstanceHit) -> bool,
    {
        let meshes = self.set.blases();
        let instances = self.set.instances();
        self.set
            .closest_hit_with(
                ray,
                mask,
                |i, o| {
                    let mesh = &meshes[instances[i as usize].blas as usize];
                    mesh.wide().closest_hit_filtered(
                        o,
                        |h| filter(&self.hit_on(i, h)),
                        &mut NoStats,
                    )
                },
                &mut NoStats,
            )
            .map(|h| self.hit(h))
    }

    /// [`Instances::any_hit`] with an any-hit filter: true when some candidate of an instance
    /// the mask lets through is kept by `filter` (a shadow ray through alpha-tested leaves).
    /// The filter may be called for any candidate in `[tmin, tmax]`, in any order: it must be
    /// a pure function of the candidate. A panicking filter aborts the query as in
    /// [`Instances::closest_hit_filtered`].
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let leaf = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![leaf], &[(0, Affine3A::from_translation(Vec3::Z))], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0);
    /// assert!(scene.any_hit_filtered(&ray, ALL_MASK, |_| true));
    /// assert!(!scene.any_hit_filtered(&ray, ALL_MASK, |h| h.instance != 0));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hit_filtered<F>(&self, ray: &Ray, mask: u32, mut filter: F) -> bool
    where
        F: FnMut(&InstanceHit) -> bool,
    {
        let meshes = self.set.blases();
        let instances = self.set.instances();
        self.set.any_hit_with(
            ray,
            mask,
            |i, o| {
                let mesh = &meshes[instances[i as usize].blas as usize];
                mesh.wide()
                    .any_hit_filtered(o, |h| filter(&self.hit_on(i, h)), &mut NoStats)
            },
            &mut NoStats,
        )
    }

    /// [`Instances::closest_hit_filtered`] of every ray, in parallel on the current rayon
    /// pool, in the order of `rays` (the filter is shared by the threads, hence `Fn + Sync`).
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let leaf = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![leaf], &[(0, Affine3A::from_translation(Vec3::Z))], Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0); 3];
    /// assert_eq!(scene.closest_hits_filtered(&rays, ALL_MASK, |_| false), vec![None; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn closest_hits_filtered<F>(
        &self,
        rays: &[Ray],
        mask: u32,
        filter: F,
    ) -> Vec<Option<InstanceHit>>
    where
        F: Fn(&InstanceHit) -> bool + Sync,
    {
        crate::batch(rays, |r| self.closest_hit_filtered(r, mask, &filter))
    }

    /// [`Instances::any_hit_filtered`] of every ray, in parallel, in the order of `rays`.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A, ALL_MASK};
    /// let leaf = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![leaf], &[(0, Affine3A::from_translation(Vec3::Z))], Quality::Fast)?;
    /// let rays = vec![Ray::new(Vec3A::new(0.25, 0.25, 0.0), Vec3A::Z, 0.0, 5.0); 3];
    /// assert_eq!(scene.any_hits_filtered(&rays, ALL_MASK, |_| true), vec![true; 3]);
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn any_hits_filtered<F>(&self, rays: &[Ray], mask: u32, filter: F) -> Vec<bool>
    where
        F: Fn(&InstanceHit) -> bool + Sync,
    {
        crate::batch(rays, |r| self.any_hit_filtered(r, mask, &filter))
    }

    /// The brute-force twin of [`Instances::closest_hit_filtered`] (and, with `filter` `None`,
    /// of [`Instances::closest_hit`]): the loop of [`Instances::brute_closest_hit`], every
    /// triangle of each instance in order with the watertight test, the filter on each
    /// candidate nearer than the best kept one. No tree is used.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![mesh], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z, 0.0, 5.0);
    /// let keep = |h: &sahara::InstanceHit| h.u < 0.5;
    /// assert_eq!(scene.brute_closest_hit_filtered(&ray, ALL_MASK, Some(&mut { keep })), scene.closest_hit_filtered(&ray, ALL_MASK, keep));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_closest_hit_filtered(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&InstanceHit) -> bool>,
    ) -> Option<InstanceHit> {
        let meshes = self.set.blases();
        let instances = self.set.instances();
        self.set
            .brute_closest_hit_with(ray, mask, |i, o| {
                let tris = meshes[instances[i as usize].blas as usize].triangles();
                brute::closest_hit_filtered(
                    tris,
                    o,
                    &mut |h| filter.as_mut().is_none_or(|f| f(&self.hit_on(i, h))),
                    false,
                )
            })
            .map(|h| self.hit(h))
    }

    /// The brute-force twin of [`Instances::any_hit_filtered`] (and, with `filter` `None`, of
    /// [`Instances::any_hit`]): true when some candidate of
    /// [`Instances::brute_closest_hit_filtered`]'s loop (the instance's world box culled as the
    /// query culls it) is kept by the filter.
    ///
    /// ```
    /// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3A, ALL_MASK};
    /// let mesh = Accel::build(&[Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)], Quality::Fast)?;
    /// let scene = Instances::build(vec![mesh], &[(0, Affine3A::IDENTITY)], Quality::Fast)?;
    /// let ray = Ray::new(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z, 0.0, 5.0);
    /// assert!(!scene.brute_any_hit_filtered(&ray, ALL_MASK, Some(&mut |_: &sahara::InstanceHit| false)));
    /// # Ok::<(), sahara::Error>(())
    /// ```
    pub fn brute_any_hit_filtered(
        &self,
        ray: &Ray,
        mask: u32,
        mut filter: Option<&mut dyn FnMut(&InstanceHit) -> bool>,
    ) -> bool {
        let meshes = self.set.blases();
        let instances = self.set.instances();
        self.set.brute_any_hit_with(ray, mask, |i, o| {
            let tris = meshes[instances[i as usize].blas as usize].triangles();
            brute::closest_hit_filtered(
                tris,
                o,
                &mut |h| filter.as_mut().is_none_or(|f| f(&self.hit_on(i, h))),
                true,
            )
            .is_hit()
        })
    }

    /// The bottom-level meshes, shared (`Arc::ptr_eq` with the `Arc`s given to
    /// [`Instances::build_shared`]).
    pub fn meshes(&self) -> &[Arc<Accel>] {
        self.set.blases()
    }

    /// The underlying two-level structure of `sahara-traverse` (its brute-force references,
    /// world boxes, inverse transforms, masks, top-level tree, object rays).
    pub fn set(&self) -> &InstanceSet<Arc<Accel>> {
        &self.set
    }
}
