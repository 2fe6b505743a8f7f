//! tinybvh's 8-wide CPU traversal (`BVH8_CPU`) as a trace engine, for side-by-side figures.
//!
//! Only compiled with the cargo feature `tinybvh` (off by default). The `tinybvh-rs` crate
//! wraps the single C++ header of tinybvh (Jacco Bikker) and compiles it with the system C++
//! compiler and `-march=native`; its Rust side exposes `BVH8_CPU` traversal only when the
//! Rust code is compiled with AVX2, hence (docs/peers.md):
//!
//! ```text
//! RUSTFLAGS="-C target-feature=+avx2,+fma" cargo run --release -p xtask --features tinybvh \
//!     -- trace --scene sibenik --builder sweep --engine tinybvh --rays diffuse --threads 1
//! ```
//!
//! [`TinyTracer`] builds tinybvh's own binary tree from the triangles (`Build`, its binned
//! SAH builder, for `--engine tinybvh`; `BuildHQ`, its spatial-split builder, for
//! `--engine tinybvh-hq`), splits its leaves to at most 4 triangles (what `BVH8_CPU` needs),
//! converts it to `MBVH<8>` and then to `BVH8_CPU`, and answers every query with
//! `BVH8_CPU::Intersect` (the builder's tree is ignored). Departures from the `Tracer`
//! contract, inherent to tinybvh:
//!
//! * its triangle test is not watertight and its tie-break at equal distance is its own, so
//!   some rays hit another triangle than sahara's kernels (`peers::agreement` counts them);
//! * rays start at distance 0 (tinybvh has no `tmin`); a ray's `tmax` is the initial hit
//!   distance (tinybvh's "no hit" is `1e30`);
//! * any-hit queries are closest-hit queries tested against `tmax` (the wrapper exposes no
//!   occlusion query);
//! * the work counters stay zero.

#[cfg(not(target_feature = "avx2"))]
compile_error!(
    "the `tinybvh` feature needs AVX2 code generation (tinybvh-rs exposes BVH8_CPU traversal \
     only then): build with RUSTFLAGS=\"-C target-feature=+avx2,+fma\" (docs/peers.md)"
);

use anyhow::{ensure, Result};
use sahara_geom::{Ray, Triangle};
use sahara_trace::{Hit, Tracer, WorkCounters};
use tinybvh_rs::Intersector;

/// Which of tinybvh's builders makes the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// `BVH::Build`: binned SAH (`--engine tinybvh`).
    Build,
    /// `BVH::BuildHQ`: SAH with spatial splits (`--engine tinybvh-hq`).
    BuildHq,
}

/// A ray as tinybvh's C++ side lays it out. tinybvh 1.6.8's `struct Ray` is aligned to 64 bytes
/// and 128 bytes long (its `Intersection` ends in a pointer and 56 bytes of user data), while
/// `tinybvh_rs::Ray` (0.1.0-beta.3) declares only the first 64 bytes, aligned to 16. The C++
/// traversal, compiled with `-march=native`, reads and writes the whole struct, which
/// overwrote the Rust caller's stack (a segmentation fault on the first ray, seen on an AVX-512
/// Xeon). The ray is therefore passed inside this buffer of the C++ size and alignment.
#[repr(C, align(64))]
struct CppRay {
    ray: tinybvh_rs::Ray,
    _tail: [u8; 64],
}

impl CppRay {
    /// What tinybvh's `Ray(origin, direction)` constructor makes: the direction normalised,
    /// its safe reciprocal (`tinybvh_safercp`: ±1e30 for components within 1e-12 of 0), the
    /// instance mask `0xFFFF`, no hit. Built here because `tinybvh_rs::Ray::new` returns the
    /// C++ struct by value into the 64-byte Rust one (the overflow described above).
    fn new(origin: [f32; 3], direction: [f32; 3]) -> Self {
        let [x, y, z] = direction;
        let len = (x * x + y * y + z * z).sqrt();
        let dir = [x / len, y / len, z / len];
        let rcp = |v: f32| {
            if !(-1e-12..=1e-12).contains(&v) {
                1.0 / v
            } else if v >= 0.0 {
                tinybvh_rs::INFINITE
            } else {
                -tinybvh_rs::INFINITE
            }
        };
        let ray = tinybvh_rs::Ray {
            origin,
            padding_0: 0xFFFF,
            dir,
            padding_1: 0,
            r_d: dir.map(rcp),
            padding_2: 0,
            hit: tinybvh_rs::Intersection {
                t: tinybvh_rs::INFINITE,
                u: 0.0,
                v: 0.0,
                prim: 0,
            },
        };
        CppRay {
            ray,
            _tail: [0; 64],
        }
    }
}

const _: () = assert!(std::mem::size_of::<CppRay>() == 128);
const _: () = assert!(std::mem::size_of::<tinybvh_rs::Ray>() == 64);

/// tinybvh's `BVH8_CPU` over its own tree (see the module documentation).
pub struct TinyTracer {
    bvh: Option<tinybvh_rs::bvh8_cpu::BVH>,
    quality: Quality,
}

// SAFETY: after construction the tree is only read: `BVH8_CPU::Intersect` is a const member
// function that writes nothing but the ray passed to it (tinybvh's traversal keeps its stack
// on the C++ call stack), so concurrent queries from several threads are sound.
unsafe impl Sync for TinyTracer {}
// SAFETY: the tree owns its memory (no thread-local state); moving it between threads is sound.
unsafe impl Send for TinyTracer {}

impl TinyTracer {
    /// Builds tinybvh's tree over `tris` with `quality`.
    pub fn new(tris: &[Triangle], quality: Quality) -> Result<Self> {
        ensure!(
            tris.len() < (u32::MAX / 3) as usize,
            "{} triangles are too many for tinybvh",
            tris.len()
        );
        if tris.is_empty() {
            return Ok(Self { bvh: None, quality });
        }
        let verts: Vec<[f32; 4]> = tris
            .iter()
            .flat_map(|t| t.v.iter().map(|p| [p.x, p.y, p.z, 0.0]))
            .collect();
        let mut bvh = match quality {
            Quality::Build => tinybvh_rs::bvh::BVH::new(verts.as_slice().into()),
            Quality::BuildHq => tinybvh_rs::bvh::BVH::new_hq(verts.as_slice().into()),
        }
        .map_err(|e| anyhow::anyhow!("tinybvh build failed: {e:?}"))?;
        bvh.split_leaves(4);
        let mbvh = tinybvh_rs::mbvh::BVH::new(&bvh);
        let bvh8 = tinybvh_rs::bvh8_cpu::BVH::new(&mbvh)
            .map_err(|e| anyhow::anyhow!("tinybvh BVH8_CPU conversion failed: {e:?}"))?;
        Ok(Self {
            bvh: Some(bvh8),
            quality,
        })
    }
}

impl Tracer for TinyTracer {
    fn name(&self) -> &str {
        match self.quality {
            Quality::Build => "tinybvh",
            Quality::BuildHq => "tinybvh-hq",
        }
    }

    fn closest_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> Hit {
        self.closest_hit_fast(ray)
    }

    fn any_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> bool {
        self.any_hit_fast(ray)
    }

    #[inline]
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        let Some(bvh) = &self.bvh else {
            return Hit::MISS;
        };
        if !ray.is_valid() {
            return Hit::MISS;
        }
        let tmax = ray.tmax.min(tinybvh_rs::INFINITE);
        let mut c = CppRay::new(ray.origin.to_array(), ray.direction().to_array());
        let r = &mut c.ray;
        r.hit.t = tmax;
        bvh.intersect(r);
        if r.hit.t < tmax {
            Hit {
                t: r.hit.t,
                prim: r.hit.prim,
                u: r.hit.u,
                v: r.hit.v,
            }
        } else {
            Hit::MISS
        }
    }

    #[inline]
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        self.closest_hit_fast(ray).is_hit()
    }
}

#[cfg(test)]
mod tests {
    //! Only with `--features tinybvh`: tinybvh's hits against sahara's reference on the same
    //! rays. tinybvh is not watertight, so mismatches are counted and bounded, not forbidden.
    use super::*;
    use sahara_trace::{Bvh2Tracer, RayKind, RaySet};

    #[test]
    fn tinybvh_hits_agree_with_the_reference() {
        let scene = crate::util::load_scene("teapot_stadium:5000").unwrap();
        let input = sahara_builders::BuildInput::new(
            &scene.triangles,
            sahara_builders::CostModel::default(),
        )
        .unwrap();
        let bvh = crate::util::builder("sweep")
            .unwrap()
            .build(&input)
            .unwrap();
        let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
        let cam = scene.camera;
        for quality in [Quality::Build, Quality::BuildHq] {
            let engine = TinyTracer::new(&scene.triangles, quality).unwrap();
            for kind in RayKind::ALL {
                let set = RaySet::generate(kind, &cam, 64, 48, &reference, &scene.triangles, 1);
                let m = crate::engine::peers::agreement(&reference, &engine, &set);
                eprintln!("{}, {kind}: {m}", engine.name());
                assert!(m.rate() < 0.01, "{} {kind}: {m}", engine.name());
                assert!(m.rays > 100);
            }
        }
        let empty = TinyTracer::new(&[], Quality::Build).unwrap();
        let r = Ray::new(
            sahara_geom::Vec3A::ZERO,
            sahara_geom::Vec3A::X,
            0.0,
            f32::INFINITY,
        );
        assert_eq!(empty.closest_hit_fast(&r), Hit::MISS);
    }
}
