//! The tracer abstraction, and its implementation on the binary BVH.

use sahara_bvh::Bvh;
use sahara_geom::{Ray, Triangle};
use sahara_traverse::{scalar, Backend, Hit, NoStats, WorkCounters};

/// Something that answers closest-hit and any-hit queries for single rays: one implementation
/// per BVH layout (binary, 4-wide, 8-wide, …).
///
/// Every function of this crate that traces takes `&T where T: Tracer + ?Sized`, so a new
/// layout plugs into ray generation, batch tracing, counting, images and timing by
/// implementing this trait (also usable as `&dyn Tracer`).
///
/// Contract, shared by every implementation so that results compare ray by ray:
///
/// * invalid rays ([`Ray::is_valid`]) miss;
/// * the closest hit in `[ray.tmin, ray.tmax]` is returned, and among hits at exactly the same
///   `t` the lowest primitive index wins ([`Hit::is_improved_by`]);
/// * `prim` indexes the scene's triangle slice as given by the caller (a layout that
///   reorders triangles internally maps back);
/// * the `_fast` methods return exactly what the counting methods return.
pub trait Tracer: Sync {
    /// A short name of the layout for reports (`"bvh2"`, `"bvh4"`, …).
    fn name(&self) -> &str {
        "tracer"
    }

    /// The closest hit, adding the work done to `stats` (counters are accumulated, not
    /// reset).
    fn closest_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> Hit;

    /// True when anything is hit in `[tmin, tmax]`, adding the work done to `stats`.
    fn any_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> bool;

    /// The closest hit without counting: the path that is timed. The default calls
    /// [`Tracer::closest_hit`] with scratch counters; implementations override it with a
    /// kernel compiled without counters.
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        self.closest_hit(ray, &mut WorkCounters::default())
    }

    /// Any hit without counting (see [`Tracer::closest_hit_fast`]).
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        self.any_hit(ray, &mut WorkCounters::default())
    }
}

/// The binary BVH traced by the scalar reference kernels of `sahara_traverse::scalar`
/// (compiled with `NoStats` for the fast path, `WorkCounters` for the counting path).
#[derive(Clone, Copy, Debug)]
pub struct Bvh2Tracer<'a> {
    /// The tree.
    pub bvh: &'a Bvh,
    /// The triangles it was built over (indexed by the tree's primitive references).
    pub tris: &'a [Triangle],
}

impl<'a> Bvh2Tracer<'a> {
    /// A tracer over `bvh` built on `tris`.
    pub fn new(bvh: &'a Bvh, tris: &'a [Triangle]) -> Self {
        Self { bvh, tris }
    }
}

impl Tracer for Bvh2Tracer<'_> {
    fn name(&self) -> &str {
        "bvh2"
    }

    #[inline]
    fn closest_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> Hit {
        scalar::closest_hit(self.bvh, self.tris, ray, stats)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> bool {
        scalar::any_hit(self.bvh, self.tris, ray, stats)
    }

    #[inline]
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        scalar::closest_hit(self.bvh, self.tris, ray, &mut NoStats)
    }

    #[inline]
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        scalar::any_hit(self.bvh, self.tris, ray, &mut NoStats)
    }
}

/// Brute force over a triangle slice (every triangle tested, `sahara_traverse::brute`): a
/// reference tracer for tests and tiny scenes. Its counters report one leaf and every
/// triangle per valid ray (an upper bound for any-hit, which stops at the first hit).
#[derive(Clone, Copy, Debug)]
pub struct BruteTracer<'a> {
    /// The triangles.
    pub tris: &'a [Triangle],
}

impl<'a> BruteTracer<'a> {
    /// A brute-force tracer over `tris`.
    pub fn new(tris: &'a [Triangle]) -> Self {
        Self { tris }
    }
}

impl Tracer for BruteTracer<'_> {
    fn name(&self) -> &str {
        "brute"
    }

    fn closest_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> Hit {
        if ray.is_valid() {
            stats.leaves += 1;
            stats.triangles += self.tris.len() as u64;
        }
        self.closest_hit_fast(ray)
    }

    fn any_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> bool {
        if ray.is_valid() {
            stats.leaves += 1;
            stats.triangles += self.tris.len() as u64;
        }
        self.any_hit_fast(ray)
    }

    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        sahara_traverse::brute::closest_hit(self.tris, ray)
    }

    fn any_hit_fast(&self, ray: &Ray) -> bool {
        sahara_traverse::brute::any_hit(self.tris, ray)
    }
}

/// A `--backend` choice that cannot be honoured: an unknown name, or a backend this CPU lacks
/// ([`parse_backend`], [`require_backend`], [`WideTracer::with_backend`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BackendError {
    /// Not one of `portable`, `sse2`, `avx2`, `avx512`.
    #[error("unknown backend {0:?} (expected portable, sse2, avx2 or avx512)")]
    Unknown(String),
    /// The CPU (or the target architecture) cannot run the backend.
    #[error(
        "backend {wanted} is not available on this CPU (it needs {}); this CPU runs: {}",
        requirement(*.wanted),
        names(.available)
    )]
    Unavailable {
        /// The backend asked for.
        wanted: Backend,
        /// The backends this CPU runs, slowest first.
        available: Vec<Backend>,
    },
}

/// What a backend needs of the CPU, for error messages.
fn requirement(b: Backend) -> &'static str {
    match b {
        Backend::Portable => "nothing",
        Backend::Sse2 => "x86-64",
        Backend::Avx2 => "x86-64 with AVX2 and FMA",
        Backend::Avx512 => "x86-64 with AVX2, FMA, AVX-512F and AVX-512VL",
    }
}

fn names(v: &[Backend]) -> String {
    v.iter().map(|b| b.name()).collect::<Vec<_>>().join(", ")
}

/// `backend` when `is_available` says the CPU runs it, else [`BackendError::Unavailable`]
/// (with the list of backends `is_available` admits). Pass [`Backend::is_available`] for this
/// CPU; tests pass other predicates to simulate other CPUs.
pub fn require_backend(
    backend: Backend,
    is_available: impl Fn(Backend) -> bool,
) -> Result<Backend, BackendError> {
    if is_available(backend) {
        Ok(backend)
    } else {
        Err(BackendError::Unavailable {
            wanted: backend,
            available: Backend::ALL
                .into_iter()
                .filter(|&b| is_available(b))
                .collect(),
        })
    }
}

/// Parses a backend name (`portable`, `sse2`, `avx2`, `avx512`, ASCII case-insensitive) and
/// checks it with [`require_backend`].
///
/// ```
/// use sahara_trace::{parse_backend, Backend, BackendError};
///
/// assert_eq!(parse_backend("sse2", Backend::is_available), Ok(Backend::Sse2));
/// // A CPU without AVX-512 (simulated):
/// let no_avx512 = |b: Backend| b != Backend::Avx512;
/// assert!(matches!(parse_backend("avx512", no_avx512), Err(BackendError::Unavailable { .. })));
/// assert!(matches!(parse_backend("neon", no_avx512), Err(BackendError::Unknown(_))));
/// ```
pub fn parse_backend(
    name: &str,
    is_available: impl Fn(Backend) -> bool,
) -> Result<Backend, BackendError> {
    let b = Backend::ALL
        .into_iter()
        .find(|b| name.eq_ignore_ascii_case(b.name()))
        .ok_or_else(|| BackendError::Unknown(name.to_string()))?;
    require_backend(b, is_available)
}

/// A wide BVH (4- or 8-wide, collapsed from a binary [`Bvh`]) traced by the SIMD kernels of
/// `sahara_traverse::wide`: with the CPU's best backend chosen at run time ([`WideTracer::new`])
/// or with a chosen one ([`WideTracer::with_backend`]). Every backend gives the same hits.
#[derive(Clone, Debug)]
pub struct WideTracer<const W: usize> {
    /// The collapsed tree (it owns a copy of the triangle data it needs).
    pub wide: sahara_traverse::WideBvh<W>,
    backend: Backend,
}

impl<const W: usize> WideTracer<W> {
    /// Collapses `bvh` (built over `tris`) into a `W`-wide tree, traced with the best backend
    /// of this CPU.
    pub fn new(bvh: &Bvh, tris: &[Triangle]) -> Self {
        let wide = sahara_traverse::WideBvh::<W>::from_bvh(bvh, tris);
        let backend = wide.backend();
        Self { wide, backend }
    }

    /// As [`WideTracer::new`], traced with `backend`; [`BackendError::Unavailable`] when this
    /// CPU cannot run it (checked before the tree is collapsed, never a silent fallback).
    pub fn with_backend(
        bvh: &Bvh,
        tris: &[Triangle],
        backend: Backend,
    ) -> Result<Self, BackendError> {
        require_backend(backend, Backend::is_available)?;
        let wide = sahara_traverse::WideBvh::<W>::from_bvh(bvh, tris);
        Ok(Self { wide, backend })
    }

    /// The backend the queries run.
    pub fn backend(&self) -> Backend {
        self.backend
    }
}

impl<const W: usize> Tracer for WideTracer<W> {
    fn name(&self) -> &str {
        if W == 4 {
            "bvh4"
        } else {
            "bvh8"
        }
    }

    #[inline]
    fn closest_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> Hit {
        self.wide.closest_hit_with(self.backend, ray, stats)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray, stats: &mut WorkCounters) -> bool {
        self.wide.any_hit_with(self.backend, ray, stats)
    }

    #[inline]
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        self.wide.closest_hit_with(self.backend, ray, &mut NoStats)
    }

    #[inline]
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        self.wide.any_hit_with(self.backend, ray, &mut NoStats)
    }
}
