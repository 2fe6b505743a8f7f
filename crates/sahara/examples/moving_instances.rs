//! Moving instances rendered as ASCII art: a ring of copies of one shared mesh (a tetrahedron,
//! every other copy mirrored and stretched) turns around a floor, one `set_transforms` per frame (the top
//! level is rebuilt, the meshes are not); the floor is an instance with a mask that camera rays
//! see and shadow rays do not test. Shading uses the world-space normal of `InstanceHit`. Every
//! pixel of every frame is checked against the brute-force twin.
//!
//! ```sh
//! cargo run --release -p sahara --example moving_instances
//! ```

use std::sync::Arc;

use sahara::{Accel, Affine3A, Instances, Quality, Ray, Triangle, Vec3, Vec3A};

/// Ray mask bits: camera rays and shadow rays.
const CAMERA: u32 = 1;
const SHADOW: u32 = 2;
const RING: usize = 6;

fn ring(frame: usize) -> Vec<(usize, Affine3A)> {
    (0..RING)
        .map(|k| {
            let a = 0.25 * frame as f32 + k as f32 * std::f32::consts::TAU / RING as f32;
            let spin = glam::Quat::from_rotation_y(2.0 * a);
            let scale = if k % 2 == 0 {
                Vec3::ONE
            } else {
                Vec3::new(-0.7, 1.3, 0.7)
            };
            let at = Vec3::new(2.2 * a.cos(), 0.0, 6.0 + 2.2 * a.sin());
            (
                1,
                Affine3A::from_scale_rotation_translation(scale, spin, at),
            )
        })
        .collect()
}

fn main() -> Result<(), sahara::Error> {
    let (a, b, c, d) = (
        Vec3A::new(-0.6, 0.0, -0.6),
        Vec3A::new(0.6, 0.0, -0.6),
        Vec3A::new(0.0, 0.0, 0.6),
        Vec3A::new(0.0, 1.2, 0.0),
    );
    let tetra = [
        Triangle::new(a, c, b),
        Triangle::new(a, b, d),
        Triangle::new(b, c, d),
        Triangle::new(c, a, d),
    ];
    let floor = [
        Triangle::new(
            Vec3A::new(-5.0, 0.0, 0.0),
            Vec3A::new(-5.0, 0.0, 12.0),
            Vec3A::new(5.0, 0.0, 0.0),
        ),
        Triangle::new(
            Vec3A::new(5.0, 0.0, 0.0),
            Vec3A::new(-5.0, 0.0, 12.0),
            Vec3A::new(5.0, 0.0, 12.0),
        ),
    ];
    let meshes = vec![
        Arc::new(Accel::build(&floor, Quality::Fast)?),
        Arc::new(Accel::build(&tetra, Quality::Medium)?),
    ];
    let mut placements = vec![(0, Affine3A::from_translation(Vec3::new(0.0, -0.01, 0.0)))];
    placements.extend(ring(0));
    let mut scene = Instances::build_shared(meshes.clone(), &placements, Quality::Medium)?;
    // The floor is seen by the camera and casts no shadow (shadow rays skip it).
    scene.set_mask(0, CAMERA)?;
    for k in 1..=RING {
        scene.set_mask(k, CAMERA | SHADOW)?;
    }
    let light = Vec3A::new(-3.0, 6.0, 2.0);
    let eye = Vec3A::new(0.0, 2.5, -2.0);
    for frame in 0..3 {
        let moves: Vec<(usize, Affine3A)> = ring(frame)
            .into_iter()
            .enumerate()
            .map(|(k, (_, m))| (k + 1, m))
            .collect();
        scene.set_transforms(&moves)?;
        assert!(
            Arc::ptr_eq(&scene.meshes()[1], &meshes[1]),
            "moving rebuilt a mesh"
        );
        println!("frame {frame}");
        for y in 0..20 {
            let mut line = String::new();
            for x in 0..60 {
                let dir = Vec3A::new(
                    (x as f32 - 30.0) / 30.0,
                    (8.0 - y as f32) / 20.0 - 0.15,
                    1.0,
                );
                let ray = Ray::new(eye, dir, 0.0, f32::INFINITY);
                let hit = scene.closest_hit(&ray, CAMERA);
                assert_eq!(hit, scene.brute_closest_hit(&ray, CAMERA), "pixel {x}, {y}");
                line.push(match hit {
                    None => ' ',
                    Some(h) => {
                        let p = ray.at(h.t);
                        let to_light = light - p;
                        let shadow = Ray::new(p, to_light, 1e-3, 1.0);
                        let lit = !scene.any_hit(&shadow, SHADOW);
                        assert_eq!(lit, !scene.brute_any_hit(&shadow, SHADOW));
                        // Face the camera whatever the winding (mirrored copies flip it).
                        let n = h.normal.normalize_or_zero();
                        let n = if n.dot(dir) > 0.0 { -n } else { n };
                        let shade = if lit {
                            n.dot(to_light.normalize()).max(0.0)
                        } else {
                            0.0
                        };
                        b".:-=+*#%@"[((shade * 8.0) as usize).min(8)] as char
                    }
                });
            }
            println!("{}", line.trim_end());
        }
    }
    Ok(())
}
