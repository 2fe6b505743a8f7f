//! Trace throughput of the traversal layouts on primary and diffuse rays, one thread.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_scene::Procedural;
use sahara_trace::{Bvh2Tracer, Camera, RayKind, RaySet, Tracer, WideTracer};

fn traversal(c: &mut Criterion) {
    let scene = Procedural::TeapotStadium.scene(30_000, sahara_scene::DEFAULT_SEED);
    let tris = scene.triangles();
    let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    let bvh = registry::by_name("sweep").unwrap().build(&input).unwrap();
    let cam = &scene.camera;
    let camera = Camera::new(cam.eye, cam.target, cam.up, cam.fov_y_degrees);
    let tracers: Vec<Box<dyn Tracer + '_>> = vec![
        Box::new(Bvh2Tracer::new(&bvh, &tris)),
        Box::new(WideTracer::<4>::new(&bvh, &tris)),
        Box::new(WideTracer::<8>::new(&bvh, &tris)),
    ];
    let mut g = c.benchmark_group("trace");
    g.sample_size(10);
    for kind in [
        RayKind::Primary,
        RayKind::Diffuse,
        RayKind::AmbientOcclusion,
    ] {
        let set = RaySet::generate(kind, &camera, 256, 192, tracers[0].as_ref(), &tris, 1);
        g.throughput(Throughput::Elements(set.len() as u64));
        for t in &tracers {
            g.bench_function(format!("{}/{}", t.name(), kind.name()), |b| {
                b.iter(|| {
                    if kind.uses_any_hit() {
                        set.rays.iter().filter(|r| t.any_hit_fast(r)).count()
                    } else {
                        set.rays
                            .iter()
                            .filter(|r| t.closest_hit_fast(r).is_hit())
                            .count()
                    }
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, traversal);
criterion_main!(benches);
