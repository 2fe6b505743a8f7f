//! Build time of every registered builder on two scene sizes.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use sahara_benches::procedural;
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_scene::Procedural;

fn builders(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for (scene, size) in [
        (Procedural::SphereInBox, 10_000),
        (Procedural::City, 100_000),
    ] {
        let tris = procedural(scene, size);
        let input = BuildInput::new(&tris, CostModel::default()).unwrap();
        for e in registry::entries()
            .into_iter()
            .filter(|e| !e.small_inputs_only)
        {
            let b = (e.make)();
            let id = BenchmarkId::new(e.name, format!("{}-{}", scene.name(), tris.len()));
            g.bench_function(id, |bench| bench.iter(|| b.build(&input).unwrap()));
        }
    }
    g.finish();
}

criterion_group!(benches, builders);
criterion_main!(benches);
