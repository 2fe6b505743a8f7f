//! Criterion benchmarks for the sahara workspace: `cargo bench -p sahara-benches`.
//!
//! * `builders`: every registered builder on two procedural scene sizes;
//! * `traversal`: closest-hit and any-hit kernels on primary and diffuse rays.
//!
//! This library only holds the scene setup the benchmarks share.

use sahara_geom::Triangle;
use sahara_scene::Procedural;

/// The triangles of a procedural scene of about `size` triangles (fixed seed).
pub fn procedural(p: Procedural, size: usize) -> Vec<Triangle> {
    p.scene(size, sahara_scene::DEFAULT_SEED).triangles()
}
