//! Instances: many placed copies of a few [`Accel`]s, traced as one scene.

use rayon::prelude::*;
use sahara_builders::BuildInput;
use sahara_traverse::instance::{Instance, InstanceSet};
use sahara_traverse::{Bvh8, NoStats};

use crate::{Accel, BuildOptions, Error, Ray};

pub use glam::Affine3A;
pub use sahara_traverse::instance::InstanceHit;

/// A two-level scene: the bottom-level meshes ([`Accel`]s), their placements (affine
/// object-to-world transforms) and a top-level tree over the placements' world boxes, built
/// with the builder of a [`Quality`](crate::Quality) level.
///
/// Rays are taken into each instance's object space without renormalising the direction, so
/// `t` means the same distance in world and object space. Every answer equals the two-level
/// brute force of `sahara_traverse::instance` bit for bit (see `docs/primitives.md`).
///
/// ```
/// use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A};
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
/// let scene = Instances::build(vec![mesh], &placements, Quality::Medium)?;
/// let ray = Ray::new(Vec3A::new(6.5, 0.5, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
/// let hit = scene.closest_hit(&ray).unwrap();
/// assert_eq!((hit.instance, hit.t), (3, 5.0));
/// # Ok::<(), sahara::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Instances {
    meshes: Vec<Accel>,
    placements: Vec<(usize, Affine3A)>,
    options: BuildOptions,
    set: InstanceSet<Bvh8>,
}

impl Instances {
    /// Places the `meshes`: each `(mesh, transform)` of `placements` is one instance (its index
    /// in `placements` is [`InstanceHit::instance`]); the top level is built over the
    /// instances' world boxes with the builder of `options`' quality level.
    ///
    /// Fails with [`Error::Instance`] when a placement names a missing mesh or its transform is
    /// not finite or not invertible.
    pub fn build(
        meshes: Vec<Accel>,
        placements: &[(usize, Affine3A)],
        options: impl Into<BuildOptions>,
    ) -> Result<Instances, Error> {
        let options = options.into();
        let name = options.quality.builder_name();
        let builder =
            sahara_builders::registry::by_name(name).ok_or(Error::MissingBuilder(name))?;
        let instances = placements
            .iter()
            .map(|&(mesh, transform)| Instance {
                // Out-of-range indices (beyond u32 too) are refused by `InstanceSet::new`.
                blas: u32::try_from(mesh).unwrap_or(u32::MAX),
                transform,
            })
            .collect();
        let blases = meshes.iter().map(|m| m.wide().clone()).collect();
        let mut failure = None;
        let set = InstanceSet::new(blases, instances, |boxes| {
            let built =
                BuildInput::from_boxes(boxes, options.cost).and_then(|input| builder.build(&input));
            built.unwrap_or_else(|e| {
                failure = Some(e);
                sahara_bvh::Bvh::empty()
            })
        });
        if let Some(e) = failure {
            return Err(e.into());
        }
        Ok(Instances {
            meshes,
            placements: placements.to_vec(),
            options: BuildOptions {
                threads: None,
                ..options
            },
            set: set?,
        })
    }

    /// The placements, as given to [`Instances::build`].
    pub fn placements(&self) -> &[(usize, Affine3A)] {
        &self.placements
    }

    /// The quality level and cost model of the top level (the build threads are not kept).
    pub fn options(&self) -> BuildOptions {
        self.options
    }

    /// Writes the instance set: every mesh (each as a complete [`Accel`] file) and the
    /// placements. The top level is not stored: [`Instances::load`] rebuilds it with the same
    /// deterministic builder (it is over one box per instance, so this is cheap). Format in
    /// [`crate::file`].
    pub fn save<W: std::io::Write>(&self, w: &mut W) -> std::io::Result<()> {
        crate::file::save_instances(self, w)
    }

    /// Reads what [`Instances::save`] wrote; every mesh is checked as [`Accel::load`] checks
    /// it, and the placements as [`Instances::build`] checks them. A broken, truncated or
    /// foreign file is a [`LoadError`](crate::LoadError), never a panic.
    pub fn load<R: std::io::Read>(r: &mut R) -> Result<Instances, crate::LoadError> {
        crate::file::load_instances(r)
    }

    /// The closest hit through every instance in `[ray.tmin, ray.tmax]`, or `None`. Invalid
    /// rays miss.
    pub fn closest_hit(&self, ray: &Ray) -> Option<InstanceHit> {
        self.set.closest_hit(ray, &mut NoStats)
    }

    /// True when some instance is hit in `[ray.tmin, ray.tmax]` (occlusion).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.set.any_hit(ray, &mut NoStats)
    }

    /// [`Instances::closest_hit`] of every ray, in parallel, in the order of `rays`.
    pub fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<InstanceHit>> {
        rays.par_iter()
            .with_min_len(64)
            .map(|r| self.closest_hit(r))
            .collect()
    }

    /// [`Instances::any_hit`] of every ray, in parallel, in the order of `rays`.
    pub fn any_hits(&self, rays: &[Ray]) -> Vec<bool> {
        rays.par_iter()
            .with_min_len(64)
            .map(|r| self.any_hit(r))
            .collect()
    }

    /// The bottom-level meshes.
    pub fn meshes(&self) -> &[Accel] {
        &self.meshes
    }

    /// The underlying two-level structure of `sahara-traverse` (its brute-force references,
    /// world boxes, top-level tree, object rays).
    pub fn set(&self) -> &InstanceSet<Bvh8> {
        &self.set
    }
}
