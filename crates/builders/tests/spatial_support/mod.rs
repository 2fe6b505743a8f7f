//! Scene generators shared by the builder tests (`binned.rs`, `sbvh.rs`, `tsah_spatial.rs`),
//! and the real scenes of the measurements (`sbvh_scenes.rs`, `tsah_scenes.rs`,
//! `tsah_spatial_scenes.rs`).
#![allow(dead_code)]

use sahara_builders::Bvh;
use sahara_geom::rng::Pcg32;
use sahara_geom::{Triangle, Vec3A};
use sahara_scene::Catalog;

pub fn rand_point(rng: &mut Pcg32, lo: f32, hi: f32) -> Vec3A {
    Vec3A::new(
        rng.range_f32(lo, hi),
        rng.range_f32(lo, hi),
        rng.range_f32(lo, hi),
    )
}

pub fn soup(n: usize, seed: u64, size: f32) -> Vec<Triangle> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| {
            let c = rand_point(&mut rng, 0.0, 100.0);
            let s = rng.range_f32(0.01, size);
            Triangle::new(
                c + rand_point(&mut rng, -s, s),
                c + rand_point(&mut rng, -s, s),
                c + rand_point(&mut rng, -s, s),
            )
        })
        .collect()
}

pub fn clustered(n: usize) -> Vec<Triangle> {
    let mut rng = Pcg32::new(7, 3);
    let c = Vec3A::splat(50.0);
    (0..n)
        .map(|i| {
            let s = rng.range_f32(0.1, 50.0);
            let j = if i % 2 == 0 {
                Vec3A::ZERO
            } else {
                rand_point(&mut rng, -1e-4, 1e-4)
            };
            Triangle::new(
                c + j + Vec3A::new(-s, -s, 0.0),
                c + j + Vec3A::new(s, 0.0, -s),
                c + j + Vec3A::new(0.0, s, s),
            )
        })
        .collect()
}

pub fn degenerate_mix(n_soup: usize, rounds: usize, dups: usize) -> Vec<Triangle> {
    let mut tris = soup(n_soup, 11, 20.0);
    let p = Vec3A::new(3.0, 4.0, 5.0);
    for i in 0..rounds {
        let o = Vec3A::splat(i as f32 * 0.1);
        tris.push(Triangle::new(o, o + Vec3A::X * 30.0, o + Vec3A::X * 60.0));
        tris.push(Triangle::new(o, o, o + Vec3A::new(20.0, 30.0, 40.0)));
        tris.push(Triangle::new(p, p, p));
    }
    let dup = tris[5];
    tris.extend(std::iter::repeat_n(dup, dups));
    tris
}

pub fn flat_scene(n: usize) -> Vec<Triangle> {
    let mut rng = Pcg32::new(5, 9);
    (0..n)
        .map(|_| {
            let c = Vec3A::new(rng.range_f32(0.0, 100.0), rng.range_f32(0.0, 100.0), 2.0);
            let a = Vec3A::new(rng.range_f32(-9.0, 9.0), rng.range_f32(-9.0, 9.0), 0.0);
            let b = Vec3A::new(rng.range_f32(-9.0, 9.0), rng.range_f32(-9.0, 9.0), 0.0);
            Triangle::new(c, c + a, c + b)
        })
        .collect()
}

/// Every bit of a tree, to compare trees for bit-identity.
pub fn bits(bvh: &Bvh) -> Vec<u32> {
    let mut v = Vec::new();
    for n in &bvh.nodes {
        v.extend(n.min.iter().chain(&n.max).map(|x| x.to_bits()));
        v.extend([n.index, n.count]);
    }
    v.extend(&bvh.prim_indices);
    v
}

/// The triangles of the scene file `name` of `catalog` (for [`Catalog::discover`]: a file of
/// `$SAHARA_SCENES` or `../shared/scenes`; procedural scenes of that name are not taken), or
/// `None` with a message when there is no such file. Panics when the file does not load.
pub fn scene_file_triangles(catalog: &Catalog, name: &str) -> Option<Vec<Triangle>> {
    let Some(entry) = catalog.get(name).filter(|e| e.path().is_some()) else {
        let dirs: Vec<String> = catalog
            .dirs()
            .iter()
            .map(|(d, _)| d.display().to_string())
            .collect();
        eprintln!(
            "{name}: no such scene file in [{}] ($SAHARA_SCENES, ../shared/scenes), skipped",
            dirs.join(", ")
        );
        return None;
    };
    let scene = catalog
        .load_entry(entry)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    Some(scene.triangles())
}
