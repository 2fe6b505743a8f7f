//! The quality knob: which registered builder each level runs, and why.

use std::num::NonZeroUsize;

use sahara_metrics::CostModel;

/// How much build time to spend for faster tracing. Each level runs one registered builder
/// of `sahara-builders` ([`Quality::builder_name`]); the levels were chosen on 2026-12-02 from
/// the evaluation's measurements on the ten shared scenes (see `docs/facade.md`).
///
/// Factors are geometric means over the ten scenes, relative to [`Quality::Medium`] (the
/// full-sweep SAH). "Work" is the exact work per ray in SAH units
/// (`c_t · inner nodes + c_i · triangles`), given as `medium's work / this level's work`, so
/// above 1 means less work; machine noise cannot touch it. Wall-clock trace speed moves the
/// same way but single cells are noisy on the shared two-core machine.
///
/// | level | builder | build time | work per ray, primary / diffuse / AO rays |
/// |---|---|---:|---|
/// | [`Fast`](Quality::Fast) | `cluster-binned` (binned SAH over Morton clusters) | ≈0.5× | 0.924 / 0.917 / 0.919 (bvh8) |
/// | [`Medium`](Quality::Medium) | `sweep` (full-sweep SAH) | 1× | 1 / 1 / 1 |
/// | [`High`](Quality::High) | `spatial-binned` (binned SAH with spatial splits, in place) | 1.9× | 1.083 / 1.083 / 1.074 (bvh8) |
/// | [`Best`](Quality::Best) | `tsah-sbvh` (temporary-subtree SAH with spatial splits) | 142× | 1.230 / 1.209 / – |
///
/// `Fast` was `binned` (0.88× the build time, 0.985 / 0.988 / 0.987) until 2026-12-07, when
/// `cluster-binned` replaced it (issue 44, item 3): 0.37× `Medium`'s build instructions on
/// Sponza and Sibenik (callgrind, one thread), its build alone 1.8–2.3× faster and with the
/// collapse to bvh8 1.65–1.74× (two loaded Xeon cores, interleaved), for 8–9% more work per
/// ray (geomean of nine scenes, at most 20% on any); `docs/builders-frontier.md`.
///
/// `High` was `sbvh` (14.8× the build time, 1.166 / 1.160 / 1.134) until 2026-12-07, when the
/// in-place spatial-split builder replaced it: on the ten scenes in one run over the 8-wide
/// layout, `spatial-binned` does 7–8% less work than `Medium` where `sbvh` does 12–14% less,
/// at an eighth of `sbvh`'s build time (1.9× `Medium`'s) and below Embree HIGH's (`docs/builders-classic.md`,
/// "Spatial splits in place"), so a renderer can rebuild at `High`; `sbvh` stays registered
/// for trees built once.
///
/// For scale, on two Zen 4 cores: sponza (66 450 triangles) builds in 29 ms (`Fast`), 31 ms
/// (`Medium`), 534 ms (`sbvh`) and 4.7 s (`Best`); the Stanford dragon (871 414 triangles)
/// in 0.45 s, 0.64 s, 4.0 s and about 70 s. `High`'s `spatial-binned`, on two loaded Xeon
/// cores in the run that gave `sbvh` 798 ms and 17 s: 108 ms and 2.6 s.
///
/// The tree of a level depends on the triangles and the cost model only: it is bit-identical
/// whatever the number of threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Quality {
    /// Binned SAH over Morton clusters: the quickest build (about half [`Quality::Medium`]'s
    /// time, 1.7× faster with the collapse to the 8-wide layout), about 8–9% more work per ray.
    Fast,
    /// Full-sweep SAH: the classic object-split tree. The default.
    #[default]
    Medium,
    /// Spatial splits (in place, with a 30% replication budget): cuts large and long
    /// triangles; about 8% less work per ray than [`Quality::Medium`] (up to 30% on scenes of
    /// long thin triangles) for 1.9× its build time, faster than Embree's spatial-split
    /// builder. Triangles may be referenced by several leaves.
    High,
    /// The temporary-subtree SAH builder with spatial splits: 4–5% less work than `sbvh`
    /// (about 10% less than [`Quality::High`]), for about 10× `sbvh`'s build time. For
    /// scenes built once and traced for long (cache the result with
    /// [`Accel::save`](crate::Accel::save)).
    Best,
}

impl Quality {
    /// Every level, fastest build first.
    pub const ALL: [Quality; 4] = [Quality::Fast, Quality::Medium, Quality::High, Quality::Best];

    /// The registry name of the builder this level runs (`sahara_builders::registry`).
    pub const fn builder_name(self) -> &'static str {
        match self {
            Quality::Fast => "cluster-binned",
            Quality::Medium => "sweep",
            Quality::High => "spatial-binned",
            Quality::Best => "tsah-sbvh",
        }
    }

    /// `"fast"`, `"medium"`, `"high"` or `"best"`.
    pub const fn name(self) -> &'static str {
        match self {
            Quality::Fast => "fast",
            Quality::Medium => "medium",
            Quality::High => "high",
            Quality::Best => "best",
        }
    }

    /// The level's code in saved files (0 to 3, in the order of [`Quality::ALL`]).
    pub(crate) const fn code(self) -> u32 {
        match self {
            Quality::Fast => 0,
            Quality::Medium => 1,
            Quality::High => 2,
            Quality::Best => 3,
        }
    }

    /// The level of a code written by [`Quality::code`].
    pub(crate) fn from_code(code: u32) -> Option<Quality> {
        Quality::ALL.into_iter().find(|q| q.code() == code)
    }
}

impl std::fmt::Display for Quality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How to build: the quality level, the SAH cost model the builder optimises for, and the
/// number of build threads. A [`Quality`] converts into options with the defaults.
///
/// ```
/// use sahara::{BuildOptions, Quality};
/// let options = BuildOptions::new(Quality::High).with_threads(1);
/// assert_eq!(options.quality, Quality::High);
/// assert_eq!(BuildOptions::from(Quality::Fast).threads, None);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildOptions {
    /// Which builder runs.
    pub quality: Quality,
    /// The SAH constants: the fields `traversal` (the paper's `c_t`, default 1.2) and
    /// `intersection` (`c_i`, default 1), [`CostModel::AILA`]; both must be finite,
    /// `traversal >= 0` and `intersection > 0`.
    pub cost: CostModel,
    /// Build on a rayon pool of this many threads (`None`: the current pool). The tree is the
    /// same whatever the count.
    pub threads: Option<NonZeroUsize>,
}

impl BuildOptions {
    /// The options of `quality` with the default cost model, on the current rayon pool.
    pub const fn new(quality: Quality) -> Self {
        Self {
            quality,
            cost: CostModel::AILA,
            threads: None,
        }
    }

    /// These options with another cost model.
    #[must_use]
    pub const fn with_cost(mut self, cost: CostModel) -> Self {
        self.cost = cost;
        self
    }

    /// These options building on `threads` threads (0 means the current pool).
    #[must_use]
    pub const fn with_threads(mut self, threads: usize) -> Self {
        self.threads = NonZeroUsize::new(threads);
        self
    }
}

impl From<Quality> for BuildOptions {
    fn from(quality: Quality) -> Self {
        Self::new(quality)
    }
}
