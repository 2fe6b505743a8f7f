//! The rays of a scene: a generated ray set (primary, diffuse, ao) from the scene's camera, or
//! a ray file.

use crate::util;
use anyhow::{Context, Result};
use sahara_trace::{RayKind, RaySet, Tracer};

/// The ray set named by `spec` (a kind or a ray file) for a scene, generated with `tracer`.
pub fn ray_set(
    spec: &str,
    scene: &util::LoadedScene,
    tracer: &dyn Tracer,
    width: u32,
    height: u32,
    seed: u64,
) -> Result<RaySet> {
    let camera = scene.camera;
    match spec.parse::<RayKind>() {
        Ok(kind) => Ok(RaySet::generate(
            kind,
            &camera,
            width,
            height,
            tracer,
            &scene.triangles,
            seed,
        )),
        Err(_) => {
            let rays = sahara_trace::read_rays(spec).with_context(|| {
                format!("'{spec}' is neither primary|diffuse|ao nor a ray file")
            })?;
            Ok(RaySet::from_rays(RayKind::Primary, rays))
        }
    }
}
