//! Hard cases for sahara: a suite that tries to break every builder, metric and kernel.
//!
//! The suite is organised as a list of [`Case`]s (a scene, a ray set and what must hold) that
//! [`run_case`] checks against every registered builder ([`sahara_builders::registry`]) and every
//! traversal [`Kernel`] (the binary tree with the scalar reference kernels, and the 4- and
//! 8-wide layouts with each SIMD backend this CPU has, plus the portable fallback):
//!
//! * **watertightness** ([`Category::Watertight`]): closed tessellated spheres and boxes, at
//!   the origin and offset by 10^4 to 10^7, rays from inside in random directions and rays
//!   aimed exactly at vertices, edge midpoints and along the axes: zero misses allowed;
//! * **bad rays** ([`Category::BadRays`]): NaN and infinities in every field, zero, negative
//!   zero and denormal directions, empty and reversed intervals: every kernel answers exactly
//!   what brute force answers, and invalid rays ([`Ray::is_valid`]) miss;
//! * **bad geometry** ([`Category::BadGeometry`], [`Category::NonFinite`],
//!   [`Category::Huge`]): degenerate, duplicated, collinear and coincident triangles, huge,
//!   tiny and mixed coordinates, flat, single-triangle and empty scenes, NaN/Inf input, and
//!   (in [`Level::Full`]) more than 2^24 triangles: every builder terminates with a tree that
//!   [`Bvh::validate`](sahara_bvh::Bvh::validate)s and a finite SAH cost, or a typed error;
//! * **determinism**: every builder gives a bit-identical tree on 1 and 2 threads and across
//!   repeated runs (compared byte by byte in the BVH file format);
//! * **equality**: every kernel returns exactly the hit of [`sahara_traverse::brute`] ray by
//!   ray (distance, primitive and barycentrics, compared bit for bit) on every case, closest
//!   hit and any hit.
//!
//! Bad files are covered by [`corpus`] (deterministic mutations of small valid OBJ, glTF, GLB
//! and BVH files) and [`fuzzing`] (the checks the cargo-fuzz targets of `fuzz/` and the
//! corpus replay share).
//!
//! Every builder run happens in its own thread under [`std::panic::catch_unwind`] and a time
//! limit, so one failure is reported and the others still run.
//!
//! ```no_run
//! use sahara_hardcases::{cases, kernels, run_case, Level};
//!
//! let builders = sahara_builders::registry::entries();
//! for case in cases(Level::Fast) {
//!     for o in run_case(&case, &builders, &kernels()) {
//!         assert!(o.passed || o.known_bug.is_some(), "{} / {}: {}", o.case, o.subject, o.detail);
//!     }
//! }
//! ```
#![warn(missing_docs)]

mod cases;
pub mod corpus;
pub mod expand;
pub mod floors;
pub mod fuzzing;
mod guard;
pub mod pinning;
mod rays;
pub mod report;
mod runner;
pub mod timing;

use std::fmt;
use std::sync::Arc;

pub use cases::{camera_rays, cases};
pub use guard::catch_quiet;
pub use runner::{run_case, run_case_with, Options};

use sahara_geom::{Ray, Triangle};
use sahara_traverse::Backend;

/// How much of the suite to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Level {
    /// The CI subset: every kind of case at small sizes (well under two minutes on two cores
    /// in the optimised test profile).
    Fast,
    /// Everything: meshes up to 10^6 triangles, more rays, and more than 2^24 triangles of a
    /// procedural scene (`cargo xtask hardcases --full`).
    Full,
}

/// What kind of hard case a [`Case`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Category {
    /// A closed mesh and rays starting inside it: the first [`Case::must_hit`] rays must hit.
    Watertight,
    /// Rays with NaN, infinities, zero or denormal directions, empty or reversed intervals.
    BadRays,
    /// Degenerate or numerically extreme (but finite) triangles.
    BadGeometry,
    /// A NaN or infinite coordinate: [`sahara_builders::BuildInput::new`] must reject it with
    /// [`sahara_builders::BuildError::NonFinite`] naming the triangle.
    NonFinite,
    /// The procedural scenes of the catalog (ordinary inputs, for determinism and equality).
    Procedural,
    /// Axis-aligned floors and walls ([`floors`]): large flat triangles near and far from the
    /// origin at 1 to 10^4 units, grazing rays and secondary rays leaving a surface. Besides
    /// equality, brute force is pinned by the exact oracle ([`Case::oracle`]).
    FlatFloors,
    /// More than 2^24 triangles (float counters lose integers there); [`Level::Full`] only.
    Huge,
}

impl Category {
    /// A short lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Category::Watertight => "watertight",
            Category::BadRays => "bad-rays",
            Category::BadGeometry => "bad-geometry",
            Category::NonFinite => "non-finite",
            Category::Procedural => "procedural",
            Category::FlatFloors => "flat-floors",
            Category::Huge => "huge",
        }
    }
}

/// One hard case: a scene, rays, and what must hold.
#[derive(Clone, Debug)]
pub struct Case {
    /// Unique name, `category/what` (for example `watertight/icosphere-s3@1e7`).
    pub name: String,
    /// What kind of case it is.
    pub category: Category,
    /// What the case is about, one line.
    pub note: String,
    /// The scene (shared with the builder threads).
    pub triangles: Arc<Vec<Triangle>>,
    /// The rays every kernel traces, closest hit and any hit.
    pub rays: Vec<Ray>,
    /// The first `must_hit` rays start strictly inside a closed mesh: every kernel (and brute
    /// force) must report a hit for each of them.
    pub must_hit: usize,
    /// `Some(i)`: the input has a non-finite coordinate and the first one is in triangle `i`.
    pub expect_non_finite: Option<usize>,
    /// Check that every builder gives bit-identical trees on 1 and 2 threads and on a second
    /// run.
    pub check_determinism: bool,
    /// Builders to run (`None`: every registered builder).
    pub only_builders: Option<Vec<String>>,
    /// Also judge brute force (closest hit and any hit) against the exact oracle of
    /// `sahara-oracle`, which shares no code with the kernels (subject `oracle`): no ray may
    /// miss, or hit farther than, a hit the oracle finds away from edges, and no reported hit
    /// may be one the oracle rejects (rays on an edge, or whose candidates `f32` cannot order,
    /// are counted apart).
    pub oracle: bool,
}

impl Case {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
}

/// A traversal kernel: a layout with the backend that traces it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// The binary tree with [`sahara_traverse::scalar`].
    Bvh2,
    /// The 4-wide tree with a backend.
    Bvh4(Backend),
    /// The 8-wide tree with a backend.
    Bvh8(Backend),
}

impl Kernel {
    /// `bvh2`, or `bvh4-sse2`, `bvh8-avx2`, `bvh8-portable`, ...
    pub fn name(self) -> String {
        match self {
            Kernel::Bvh2 => "bvh2".to_string(),
            Kernel::Bvh4(b) => format!("bvh4-{}", b.name()),
            Kernel::Bvh8(b) => format!("bvh8-{}", b.name()),
        }
    }
}

impl fmt::Display for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// Every kernel this machine can run: `bvh2`, then `bvh4` and `bvh8` with each available
/// backend (the portable fallback always, SSE2 and AVX2 where the CPU has them).
pub fn kernels() -> Vec<Kernel> {
    let backends: Vec<Backend> = Backend::ALL
        .into_iter()
        .filter(|b| b.is_available())
        .collect();
    let mut v = vec![Kernel::Bvh2];
    v.extend(backends.iter().map(|&b| Kernel::Bvh4(b)));
    v.extend(backends.iter().map(|&b| Kernel::Bvh8(b)));
    v
}

/// The result of one check: a case against one subject.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Outcome {
    /// The case name.
    pub case: String,
    /// What was checked: `input`, `brute`, a builder name (`sweep`: build, validation, SAH,
    /// file round trip, determinism), or `builder/kernel` (`sweep/bvh8-avx2`: equality with
    /// brute force and watertightness).
    pub subject: String,
    /// The builder, when the subject is about one.
    pub builder: Option<String>,
    /// The kernel, when the subject is about one.
    pub kernel: Option<String>,
    /// True when everything held (or the check was skipped).
    pub passed: bool,
    /// True when the check did not run (for example a `small_inputs_only` builder on a large
    /// input).
    pub skipped: bool,
    /// `ok`, or what failed (first failing ray, error, panic message, `timeout ...`).
    pub detail: String,
    /// Set when the failure matches an entry of [`KNOWN_BUGS`] (reported, routed to the
    /// crate's owner, and not counted as a regression by the CI tests).
    pub known_bug: Option<String>,
    /// Wall time of the check, seconds (for a builder: the build on two threads).
    pub seconds: f64,
}

impl Outcome {
    /// True when the outcome is a failure not explained by [`KNOWN_BUGS`].
    pub fn is_regression(&self) -> bool {
        !self.passed && self.known_bug.is_none()
    }
}

/// A failure the suite found in a crate it does not own, reported for routing.
#[derive(Clone, Copy, Debug)]
pub struct KnownBug {
    /// Short identifier used in the table.
    pub id: &'static str,
    /// Case names containing one of these strings are affected.
    pub cases: &'static [&'static str],
    /// Subjects containing this string are affected (`""`: every subject).
    pub subject_contains: &'static str,
    /// Details containing this string are affected (`""`: every failure).
    pub detail_contains: &'static str,
    /// What is wrong and where.
    pub description: &'static str,
}

/// Failures found by the suite in crates it does not own, not yet fixed there. The CI tests
/// accept exactly these (each also has a minimal `#[ignore]`d test in
/// `crates/hardcases/tests/known_bugs.rs` that fails until the owner fixes it).
pub const KNOWN_BUGS: &[KnownBug] = &[
    // Empty: the four bugs found so far were fixed in sahara-geom and the kernels on
    // 2026-11-25 (`false-hit`, `slab-rounding`, `inf-t`, `denormal-slow`; their minimal tests
    // stay in tests/known_bugs.rs as regression tests, see docs/hardcases.md).
];

/// The [`KnownBug`] explaining a failure, if any.
pub fn known_bug_for(case: &str, subject: &str, detail: &str) -> Option<&'static KnownBug> {
    KNOWN_BUGS.iter().find(|b| {
        b.cases.iter().any(|c| case.contains(c))
            && subject.contains(b.subject_contains)
            && detail.contains(b.detail_contains)
    })
}

/// The README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
