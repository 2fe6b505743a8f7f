//! A scene of several geometries rendered as ASCII art: a floor (an indexed mesh), an
//! alpha-tested fence (triangles with a checkerboard alpha, an any-hit filter), a sphere (a
//! user primitive) and a lamp seen by the camera but casting no shadow (ray masks). Primary
//! rays are closest-hit queries, shadow rays occlusion queries, both filtered; every pixel is
//! checked against the brute-force twin.
//!
//! ```sh
//! cargo run --release -p sahara --example scene
//! ```

use sahara::{Aabb, Intersection, Quality, Ray, SceneBuilder, SceneHit, Triangle, Vec3A};

/// Ray mask bits: camera rays and shadow rays.
const CAMERA: u32 = 1;
const SHADOW: u32 = 2;

/// A sphere as a user primitive: its box and intersection callback (the entry point, or the
/// exit point when the entry lies before `tmin`; outward normal).
fn sphere(c: Vec3A, r: f32) -> (Aabb, impl Fn(&Ray, u32, f32, f32) -> Option<Intersection>) {
    let intersect = move |ray: &Ray, _: u32, tmin: f32, tmax: f32| {
        let (oc, d) = (ray.origin - c, ray.direction());
        let (a, b, k) = (d.dot(d), oc.dot(d), oc.dot(oc) - r * r);
        let disc = b * b - a * k;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let near = (-b - disc.sqrt()) / a;
        let t = if near >= tmin {
            near
        } else {
            (-b + disc.sqrt()) / a
        };
        let normal = ray.at(t) - c;
        (t >= tmin && t <= tmax).then_some(Intersection {
            t,
            u: 0.0,
            v: 0.0,
            normal,
        })
    };
    (Aabb::new(c - r, c + r), intersect)
}

fn main() -> Result<(), sahara::Error> {
    let mut b = SceneBuilder::new();
    let floor_positions = [
        [-6.0f32, 0.0, -6.0],
        [6.0, 0.0, -6.0],
        [6.0, 0.0, 6.0],
        [-6.0, 0.0, 6.0],
    ];
    let floor = b.add_indexed(&floor_positions, &[[0, 2, 1], [0, 3, 2]])?;
    let (p, q, r, s) = (
        Vec3A::new(-4.0, 0.0, 2.5),
        Vec3A::new(4.0, 0.0, 2.5),
        Vec3A::new(4.0, 0.9, 2.5),
        Vec3A::new(-4.0, 0.9, 2.5),
    );
    let fence = b.add_triangles(&[Triangle::new(p, q, r), Triangle::new(p, r, s)]);
    let (ball_box, ball) = sphere(Vec3A::new(0.5, 1.2, -1.0), 1.2);
    let ball = b.add_primitives(&[ball_box], ball);
    let (lamp_box, lamp) = sphere(Vec3A::new(-3.0, 3.5, 0.5), 0.3);
    let lamp = b.add_primitives(&[lamp_box], lamp);
    b.set_mask(lamp, CAMERA)?; // seen, but no shadow
    let scene = b.build(Quality::High)?;

    // The fence's alpha: a checkerboard in its triangles' barycentric coordinates.
    let alpha =
        |h: &SceneHit| h.geometry != fence || ((h.u * 8.0) as i32 + (h.v * 8.0) as i32) % 2 == 0;
    let light = Vec3A::new(-3.0, 3.5, 0.5);
    let (w, h) = (72, 30);
    let eye = Vec3A::new(0.0, 2.5, 8.0);
    let mut image = String::new();
    let mut counts = [0usize; 4];
    for y in 0..h {
        for x in 0..w {
            let d = Vec3A::new(
                (x as f32 / w as f32 - 0.5) * 1.2,
                0.15 - y as f32 / h as f32,
                -1.0,
            );
            let ray = Ray::new(eye, d, 0.0, f32::INFINITY);
            let hit = scene.closest_hit_filtered(&ray, CAMERA, alpha);
            assert_eq!(
                hit,
                scene.brute_closest_hit(&ray, CAMERA, Some(&mut |h: &SceneHit| alpha(h)))
            );
            let c = match hit {
                None => ' ',
                Some(hit) if hit.geometry == lamp => '@',
                Some(hit) => {
                    counts[hit.geometry.index() as usize] += 1;
                    let p = ray.at(hit.t);
                    let n = hit.normal.normalize_or_zero();
                    let n = if n.dot(d) > 0.0 { -n } else { n };
                    let to_light = light - p;
                    let shadow = Ray::new(p + n * 1e-3, to_light, 0.0, 1.0);
                    let lit = !scene.any_hit_filtered(&shadow, SHADOW, alpha);
                    assert_eq!(
                        lit,
                        !scene.brute_any_hit(&shadow, SHADOW, Some(&mut |h: &SceneHit| alpha(h)))
                    );
                    let shade = if lit {
                        n.dot(to_light.normalize()).max(0.0)
                    } else {
                        0.0
                    };
                    let ramp = if hit.geometry == floor {
                        ".:-=+*"
                    } else {
                        ".,oO08"
                    };
                    ramp.as_bytes()[((shade * 5.99) as usize).min(5)] as char
                }
            };
            image.push(c);
        }
        image.push('\n');
    }
    println!("{image}");
    println!(
        "pixels: floor {}, fence {}, ball {} (every pixel and shadow ray equals the brute-force twin)",
        counts[floor.index() as usize],
        counts[fence.index() as usize],
        counts[ball.index() as usize]
    );
    Ok(())
}
