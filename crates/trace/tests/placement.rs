//! Camera placement (`place_camera`): inside closed scenes and levels, outside objects.

use sahara_builders::{registry, BuildInput, CostModel};
use sahara_geom::{Aabb, Triangle, Vec3A};
use sahara_scene::{closed_box, sphere_in_box, tessellated_sphere, UpAxis};
use sahara_trace::{place_camera, Bvh2Tracer, Placement, PlacementKind};

fn place(tris: &[Triangle], up: Vec3A) -> Placement {
    let input = BuildInput::new(tris, CostModel::default()).unwrap();
    let bvh = registry::by_name("binned").unwrap().build(&input).unwrap();
    place_camera(&Bvh2Tracer::new(&bvh, tris), tris, up)
}

fn bounds(tris: &[Triangle]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()))
}

fn inside(b: &Aabb, p: Vec3A) -> bool {
    p.cmpge(b.min).all() && p.cmple(b.max).all()
}

/// A z-up level: a closed 40 × 30 × 4 hall (floor, ceiling, outer walls) with a partition
/// wall and a grid of crates and pillars inside.
fn z_up_level() -> Vec<Triangle> {
    let mut tris = closed_box(Vec3A::ZERO, Vec3A::new(40.0, 30.0, 4.0), 4).triangles();
    let mut add = |lo: Vec3A, hi: Vec3A| tris.extend(closed_box(lo, hi, 1).triangles());
    // A partition with a doorway.
    add(Vec3A::new(19.8, 0.0, 0.0), Vec3A::new(20.2, 12.0, 4.0));
    add(Vec3A::new(19.8, 16.0, 0.0), Vec3A::new(20.2, 30.0, 4.0));
    for i in 0..9 {
        for j in 0..7 {
            let (x, y) = (2.5 + 4.3 * i as f32, 2.0 + 4.2 * j as f32);
            let h = if (i + j) % 3 == 0 {
                4.0
            } else {
                1.2 + 0.3 * (j % 3) as f32
            };
            add(Vec3A::new(x, y, 0.0), Vec3A::new(x + 1.5, y + 1.5, h));
        }
    }
    tris
}

#[test]
fn closed_scene_is_seen_from_inside() {
    let tris = sphere_in_box(20_000, 1).triangles();
    let p = place(&tris, UpAxis::detect(&tris).vector());
    assert_eq!(p.kind, PlacementKind::Interior, "{p:?}");
    assert!(p.score >= 0.5, "{p:?}");
    assert!(inside(&bounds(&tris), p.camera.eye), "{p:?}");
}

#[test]
fn z_up_level_is_detected_and_seen_from_inside() {
    let tris = z_up_level();
    let up = UpAxis::detect(&tris);
    assert_eq!(up, UpAxis::Z);
    let p = place(&tris, up.vector());
    assert_eq!(p.kind, PlacementKind::Interior, "{p:?}");
    assert!(p.score >= 0.5, "{p:?}");
    assert_eq!(p.camera.up, Vec3A::Z);
    assert!(inside(&bounds(&tris), p.camera.eye), "{p:?}");
    // The same level turned y-up is detected y-up.
    let turned: Vec<Triangle> = tris
        .iter()
        .map(|t| Triangle {
            v: t.v.map(|q| Vec3A::new(q.x, q.z, -q.y)),
        })
        .collect();
    assert_eq!(UpAxis::detect(&turned), UpAxis::Y);
}

#[test]
fn open_object_is_seen_from_outside() {
    let tris = tessellated_sphere(Vec3A::new(3.0, -2.0, 1.0), 2.0, 4).triangles();
    let p = place(&tris, UpAxis::detect(&tris).vector());
    assert_eq!(p.kind, PlacementKind::Exterior, "{p:?}");
    assert!(p.score >= 0.5, "{p:?}");
    assert!(!inside(&bounds(&tris), p.camera.eye), "{p:?}");
    assert_eq!(p.camera.target, Vec3A::new(3.0, -2.0, 1.0));
}

#[test]
fn empty_scene_gets_a_finite_camera() {
    let p = place_camera(&sahara_trace::BruteTracer::new(&[]), &[], Vec3A::Y);
    assert!(p.camera.eye.is_finite() && p.score == 0.0);
}
