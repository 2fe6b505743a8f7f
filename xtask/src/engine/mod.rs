//! The tracing engines the commands dispatch on: sahara's layouts (`bvh2`, `bvh4`, `bvh8`)
//! and, behind their cargo features, the foreign engines (Embree, tinybvh, obvhs), as one type,
//! [`Engine`]; one timed and counted trace of an engine ([`measure_trace`], [`TraceReport`],
//! `report.rs`) and the ray sets of a scene ([`ray_set`], `rays.rs`). Not a command: `trace`,
//! `eval`, `study`, `measure` and `reinsert-rays` use it.
//!
//! The foreign engines' modules: `embree.rs` (Intel Embree 3 as a tracer), `embree_tree.rs`
//! (Embree's trees converted to a `Bvh`, the builders `embree-medium` and `embree-high`),
//! `tinybvh.rs`, `obvhs.rs` (obvhs's tracer and its PLOC tree as the builder `obvhs-ploc`) and
//! `peers.rs` (how far a foreign engine's hits agree with sahara's reference).

#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "embree")]
pub mod embree_tree;
#[cfg(feature = "obvhs")]
pub mod obvhs;
pub mod peers;
mod rays;
mod report;
#[cfg(feature = "tinybvh")]
pub mod tinybvh;

pub use rays::ray_set;
pub use report::{measure_trace, report, TraceReport};

use anyhow::{bail, Result};
use sahara_geom::Triangle;
use sahara_trace::{Backend, Bvh2Tracer, Tracer};
use sahara_traverse::Precision;
use std::fmt;
use std::str::FromStr;

/// A tracing engine: one of sahara's layouts of the builder's tree, or a foreign engine that
/// builds and traces its own tree from the triangles (the builder's tree is unused), with the
/// cargo feature that enables it. Written and parsed as its name (`bvh8`, `tinybvh-hq`, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Engine {
    /// sahara's binary tree and its scalar kernel.
    Bvh2,
    /// sahara's 4-wide layout and its SIMD kernels.
    Bvh4,
    /// sahara's 8-wide layout and its SIMD kernels.
    Bvh8,
    /// Intel Embree 3 over its own MEDIUM-quality BVH (feature `embree`, docs/embree.md).
    Embree,
    /// tinybvh's `BVH8_CPU` over its `Build` tree (feature `tinybvh`, docs/peers.md).
    Tinybvh,
    /// tinybvh's `BVH8_CPU` over its `BuildHQ` tree (feature `tinybvh`).
    TinybvhHq,
    /// obvhs's CWBVH over its medium_build tree (feature `obvhs`, docs/peers.md).
    Obvhs,
}

impl Engine {
    /// Every engine, sahara's layouts first, in the order reports list them.
    pub const ALL: [Engine; 7] = [
        Engine::Bvh2,
        Engine::Bvh4,
        Engine::Bvh8,
        Engine::Embree,
        Engine::Tinybvh,
        Engine::TinybvhHq,
        Engine::Obvhs,
    ];

    /// The engine's name, as the command line and the reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            Engine::Bvh2 => "bvh2",
            Engine::Bvh4 => "bvh4",
            Engine::Bvh8 => "bvh8",
            Engine::Embree => "embree",
            Engine::Tinybvh => "tinybvh",
            Engine::TinybvhHq => "tinybvh-hq",
            Engine::Obvhs => "obvhs",
        }
    }

    /// The cargo feature a foreign engine needs; `None` for sahara's layouts.
    pub fn feature(self) -> Option<&'static str> {
        match self {
            Engine::Bvh2 | Engine::Bvh4 | Engine::Bvh8 => None,
            Engine::Embree => Some("embree"),
            Engine::Tinybvh | Engine::TinybvhHq => Some("tinybvh"),
            Engine::Obvhs => Some("obvhs"),
        }
    }

    /// True for the engines other than sahara's layouts (they ignore the builder's tree).
    pub fn is_foreign(self) -> bool {
        self.feature().is_some()
    }

    /// Whether this build can trace with the engine (sahara's layouts always can, a foreign
    /// engine with its feature).
    pub fn is_built(self) -> bool {
        match self.feature() {
            None => true,
            Some("embree") => cfg!(feature = "embree"),
            Some("tinybvh") => cfg!(feature = "tinybvh"),
            Some("obvhs") => cfg!(feature = "obvhs"),
            Some(_) => false,
        }
    }

    /// The engines of this build: sahara's layouts and the foreign engines whose feature is on.
    pub fn built() -> Vec<Engine> {
        Engine::ALL.into_iter().filter(|e| e.is_built()).collect()
    }

    /// A tracer of this engine over `bvh` whose bvh4/bvh8 kernels run `backend` (an error when
    /// this CPU cannot); Embree gets the matching ISA. Foreign engines ignore `bvh`; one whose
    /// feature is off is an error saying how to turn it on.
    pub fn tracer<'a>(
        self,
        bvh: &'a sahara_bvh::Bvh,
        tris: &'a [Triangle],
        backend: Backend,
    ) -> Result<Box<dyn Tracer + 'a>> {
        self.tracer_at(bvh, tris, backend, Precision::Exact)
    }

    /// [`Engine::tracer`] whose bvh4/bvh8 kernels run the triangle test of `precision`
    /// (`docs/precision.md`). The binary layout has only the exact test (an error for
    /// `Fast`); foreign engines run their own test whatever `precision` says (see
    /// [`Engine::precision_name`]).
    pub fn tracer_at<'a>(
        self,
        bvh: &'a sahara_bvh::Bvh,
        tris: &'a [Triangle],
        backend: Backend,
        precision: Precision,
    ) -> Result<Box<dyn Tracer + 'a>> {
        let _ = backend; // unused by some feature combinations
        match self {
            Engine::Bvh2 => {
                anyhow::ensure!(
                    precision == Precision::Exact,
                    "bvh2 (the scalar reference) has only the exact triangle test; \
                     --precision {precision} needs bvh4 or bvh8"
                );
                Ok(Box::new(Bvh2Tracer::new(bvh, tris)))
            }
            Engine::Bvh4 => {
                let mut t = sahara_trace::WideTracer::<4>::with_backend(bvh, tris, backend)?;
                t.wide.set_precision(precision);
                Ok(Box::new(t))
            }
            Engine::Bvh8 => {
                let mut t = sahara_trace::WideTracer::<8>::with_backend(bvh, tris, backend)?;
                t.wide.set_precision(precision);
                Ok(Box::new(t))
            }
            // Embree builds (once per triangle slice) and traces its own BVH; `bvh` is unused.
            #[cfg(feature = "embree")]
            Engine::Embree => Ok(Box::new(embree::EmbreeTracer::with_backend(tris, backend)?)),
            #[cfg(feature = "tinybvh")]
            Engine::Tinybvh => Ok(Box::new(tinybvh::TinyTracer::new(
                tris,
                tinybvh::Quality::Build,
            )?)),
            #[cfg(feature = "tinybvh")]
            Engine::TinybvhHq => Ok(Box::new(tinybvh::TinyTracer::new(
                tris,
                tinybvh::Quality::BuildHq,
            )?)),
            #[cfg(feature = "obvhs")]
            Engine::Obvhs => Ok(Box::new(obvhs::ObvhsTracer::new(tris)?)),
            #[allow(unreachable_patterns)] // every feature on: each engine has its arm above
            other => {
                let feature = other.feature().unwrap_or("?");
                bail!(
                    "built without the `{feature}` feature: run `cargo run --release -p xtask \
                     --features {feature} -- trace ...` (docs/embree.md, docs/peers.md)"
                )
            }
        }
    }

    /// The `precision` field of a report of this engine traced at sahara's `precision`:
    /// `exact` or `fast` for sahara's layouts, `native` for a foreign engine (its own,
    /// non-watertight test).
    pub fn precision_name(self, precision: Precision) -> &'static str {
        if self.is_foreign() {
            "native"
        } else {
            precision.name()
        }
    }

    /// The `backend` field of a report of this engine traced with sahara's `backend`:
    /// `scalar` for bvh2, the backend for bvh4/bvh8, the ISA asked of Embree, `avx2` for
    /// tinybvh, `default` for obvhs.
    pub fn backend_name(self, backend: Backend) -> String {
        match self {
            Engine::Bvh2 => "scalar".into(),
            Engine::Bvh4 | Engine::Bvh8 => backend.name().into(),
            #[cfg(feature = "embree")]
            Engine::Embree => embree::reported_isa(backend),
            #[cfg(not(feature = "embree"))]
            Engine::Embree => "default".into(),
            Engine::Tinybvh | Engine::TinybvhHq => "avx2".into(),
            Engine::Obvhs => "default".into(),
        }
    }
}

impl fmt::Display for Engine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Engine {
    type Err = String;

    /// Any engine's name, built or not (tracing with an engine whose feature is off is the
    /// error, with the way to turn it on).
    fn from_str(s: &str) -> Result<Engine, String> {
        Engine::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| {
                let known: Vec<&str> = Engine::built().into_iter().map(Engine::name).collect();
                format!("unknown layout '{s}' (known: {})", known.join(", "))
            })
    }
}

impl serde::Serialize for Engine {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// `--backend`'s parser: the name checked against this CPU ([`sahara_trace::parse_backend`]).
pub fn parse_backend_arg(name: &str) -> Result<Backend, sahara_trace::BackendError> {
    sahara_trace::parse_backend(name, Backend::is_available)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util;
    use sahara_trace::trace_set;

    #[test]
    fn backend_names_parse_and_unavailable_ones_are_typed_errors() {
        // What `--backend` accepts on this CPU.
        for b in Backend::ALL {
            assert_eq!(parse_backend_arg(b.name()).is_ok(), b.is_available(), "{b}");
        }
        // A CPU without AVX-512, simulated.
        let no_avx512 = |b: Backend| b != Backend::Avx512;
        assert!(matches!(
            sahara_trace::parse_backend("avx512", no_avx512),
            Err(sahara_trace::BackendError::Unavailable {
                wanted: Backend::Avx512,
                ..
            })
        ));
        assert!(parse_backend_arg("sse4").is_err());
    }

    #[test]
    fn engines_and_backends_of_reports() {
        assert!(Engine::built().starts_with(&[Engine::Bvh2, Engine::Bvh4, Engine::Bvh8]));
        for e in Engine::ALL {
            assert_eq!(e.name().parse::<Engine>(), Ok(e));
            assert_eq!(e.to_string(), e.name());
            assert_eq!(e.is_foreign(), !e.name().starts_with("bvh"));
            assert_eq!(Engine::built().contains(&e), e.is_built());
        }
        assert!("optix".parse::<Engine>().is_err());
        assert!(!Engine::Bvh8.is_foreign());
        assert_eq!(Engine::Bvh2.backend_name(Backend::Sse2), "scalar");
        assert_eq!(Engine::Bvh8.backend_name(Backend::Sse2), "sse2");
        assert_eq!(Engine::Bvh4.backend_name(Backend::Portable), "portable");
        assert_eq!(Engine::Tinybvh.backend_name(Backend::Sse2), "avx2");
    }

    #[test]
    fn every_available_backend_traces_a_procedural_scene_alike() {
        let scene = util::load_scene("sphere_in_box:2000").unwrap();
        let input = sahara_builders::BuildInput::new(
            &scene.triangles,
            sahara_builders::CostModel::default(),
        )
        .unwrap();
        let bvh = util::builder("sweep").unwrap().build(&input).unwrap();
        let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
        for kind in ["primary", "diffuse", "ao"] {
            let set = ray_set(kind, &scene, &reference, 48, 32, 3).unwrap();
            let want = trace_set(&reference, &set).checksum();
            for engine in [Engine::Bvh4, Engine::Bvh8] {
                for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
                    let t = engine.tracer(&bvh, &scene.triangles, b).unwrap();
                    let (_, counted) = measure_trace(t.as_ref(), &set, Some(1), 1).unwrap();
                    let r = report(
                        &scene.name,
                        scene.triangles.len(),
                        "sweep",
                        engine,
                        &engine.backend_name(b),
                        Precision::Exact,
                        &set,
                        Some(1),
                        sahara_trace::Timing::from_samples(&[1e-3]),
                        &counted,
                    );
                    assert_eq!(r.checksum, format!("{want:016x}"), "{engine} {b} {kind}");
                    assert_eq!(
                        (r.backend.as_str(), r.precision.as_str()),
                        (b.name(), "exact")
                    );
                }
            }
        }
        for b in Backend::ALL.into_iter().filter(|b| !b.is_available()) {
            assert!(Engine::Bvh8.tracer(&bvh, &scene.triangles, b).is_err());
        }
        // The fast precision: bvh4 and bvh8 give the same answers; bvh2 refuses it; reports say it.
        let set = ray_set("diffuse", &scene, &reference, 48, 32, 3).unwrap();
        let fast = |e: Engine| {
            let t = e
                .tracer_at(&bvh, &scene.triangles, Backend::best(), Precision::Fast)
                .unwrap();
            trace_set(t.as_ref(), &set).checksum()
        };
        assert_eq!(fast(Engine::Bvh4), fast(Engine::Bvh8));
        assert!(Engine::Bvh2
            .tracer_at(&bvh, &scene.triangles, Backend::best(), Precision::Fast)
            .is_err());
        assert_eq!(Engine::Bvh8.precision_name(Precision::Fast), "fast");
        assert_eq!(Engine::Embree.precision_name(Precision::Fast), "native");
    }
}
