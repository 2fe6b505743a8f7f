//! Which SIMD instruction sets the builders use.
//!
//! A builder's output never depends on this choice: every SIMD path computes, lane by lane,
//! the operations of the baseline path in the same order, so trees are equal bit for bit on
//! every CPU (each path is tested against the baseline). The choice only changes build time.
//! By default the builders use the best set the CPU has ([`BuildSimd::detected`]); benchmarks
//! cap it with [`set_max`] to time each backend on one machine.
//!
//! ```
//! use sahara_builders::simd::{self, BuildSimd};
//!
//! let best = BuildSimd::detected();
//! simd::set_max(BuildSimd::Baseline);
//! assert_eq!(simd::active(), BuildSimd::Baseline);
//! simd::set_max(BuildSimd::Avx512);
//! assert_eq!(simd::active(), best);
//! ```

use std::sync::atomic::{AtomicU8, Ordering};

/// A SIMD level of the builders, in increasing order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BuildSimd {
    /// What every build of the crate runs: scalar code, plus SSE2 on x86-64 (part of the
    /// x86-64 baseline).
    Baseline,
    /// AVX2 (x86-64, detected at run time): the spatial binning eight slabs at a time.
    Avx2,
    /// AVX-512F (x86-64, detected at run time): the spatial binning sixteen slabs at a time.
    Avx512,
}

impl BuildSimd {
    /// Every level, in increasing order.
    pub const ALL: [BuildSimd; 3] = [BuildSimd::Baseline, BuildSimd::Avx2, BuildSimd::Avx512];

    /// The best level this CPU runs.
    pub fn detected() -> BuildSimd {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f") {
                return BuildSimd::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") {
                return BuildSimd::Avx2;
            }
        }
        BuildSimd::Baseline
    }

    /// The level's name: `baseline`, `avx2` or `avx512`.
    pub fn name(self) -> &'static str {
        match self {
            BuildSimd::Baseline => "baseline",
            BuildSimd::Avx2 => "avx2",
            BuildSimd::Avx512 => "avx512",
        }
    }

    /// The level of a [`name`](Self::name).
    pub fn from_name(name: &str) -> Option<BuildSimd> {
        BuildSimd::ALL.into_iter().find(|b| b.name() == name)
    }
}

impl std::fmt::Display for BuildSimd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The cap set by [`set_max`] (a `BuildSimd` as `u8`; no cap at first).
static MAX: AtomicU8 = AtomicU8::new(BuildSimd::Avx512 as u8);

/// Caps the level every builder of this process uses from now on (to time the backends on
/// one machine; trees do not change). A level above [`BuildSimd::detected`] means no cap.
pub fn set_max(level: BuildSimd) {
    MAX.store(level as u8, Ordering::Relaxed);
}

/// The cap set by [`set_max`].
pub fn max() -> BuildSimd {
    match MAX.load(Ordering::Relaxed) {
        0 => BuildSimd::Baseline,
        1 => BuildSimd::Avx2,
        _ => BuildSimd::Avx512,
    }
}

/// The level the builders use now: the CPU's best, capped by [`set_max`].
pub fn active() -> BuildSimd {
    BuildSimd::detected().min(max())
}
