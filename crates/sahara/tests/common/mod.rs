//! Helpers shared by the façade's tests: hits as bits, the ray sets, and checksums forged over
//! edited files.
#![allow(dead_code)]

use sahara::{Aabb, Ray, SceneHit, Vec3A};
use sahara_fixtures::rays::segments_in;
use sahara_geom::rng::Pcg32;

/// Every bit of a scene hit: geometry index, primitive, t, u, v, normal.
pub type SceneBits = (u32, u32, u32, u32, u32, [u32; 3]);

/// A scene hit as bits, for exact comparisons.
pub fn scene_bits(h: Option<SceneHit>) -> Option<SceneBits> {
    h.map(|h| {
        (
            h.geometry.index(),
            h.primitive,
            h.t.to_bits(),
            h.u.to_bits(),
            h.v.to_bits(),
            h.normal.to_array().map(f32::to_bits),
        )
    })
}

/// `n` segments inside the cube `[-half, half]^3`, then `n` unbounded rays from the plane
/// `z = 4` towards the square `[-1, 1]^2` of the plane `z = 0` (generator `Pcg32::new(seed, 5)`).
pub fn segments_and_rays_from_above(n: usize, seed: u64, half: f32) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 5);
    let bounds = Aabb::new(Vec3A::splat(-half), Vec3A::splat(half));
    let mut rays = segments_in(&bounds, n, &mut rng);
    for _ in 0..n {
        let o = Vec3A::new(rng.range_f32(-3.0, 3.0), rng.range_f32(-3.0, 3.0), 4.0);
        let target = Vec3A::new(rng.range_f32(-1.0, 1.0), rng.range_f32(-1.0, 1.0), 0.0);
        rays.push(Ray::new(o, target - o, 0.0, f32::INFINITY));
    }
    rays
}

/// `n` segments through `b` (generator `Pcg32::new(seed, stream)`), every second one made
/// unbounded.
pub fn segments_and_unbounded_rays(b: &Aabb, n: usize, seed: u64, stream: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, stream);
    let mut v = segments_in(b, n, &mut rng);
    for r in v.iter_mut().skip(1).step_by(2) {
        *r = Ray::new(r.origin, r.direction(), 0.0, f32::INFINITY);
    }
    v
}

/// Writes at `at..at + 8` the FNV-1a 64 checksum of the bytes after the 8-byte magic, those of
/// the checksum itself excepted: a file edited after saving passes the checksum again.
pub fn reseal(file: &mut [u8], at: usize) {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in file[8..at].iter().chain(&file[at + 8..]) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    file[at..at + 8].copy_from_slice(&h.to_le_bytes());
}
