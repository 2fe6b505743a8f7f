//! The triangle test a wide tree's kernels run: exact (the default) or fast.

use std::fmt;
use std::str::FromStr;

/// Which ray/triangle test the wide kernels run (`docs/precision.md`).
///
/// Both levels agree bit for bit with their own brute-force twin ([`crate::brute::closest_hit_at`]
/// and [`crate::brute::any_hit_at`]) on every backend, and both report distances through the
/// same hit rule ([`sahara_geom::intersect::accept_hit_at`]). They differ in which triangles a
/// ray hits on edges and vertices:
///
/// * [`Precision::Exact`] is the watertight test of Woop et al. (2013) with an `f64` fallback
///   on zero edge functions: a ray through a shared edge or vertex of a closed mesh always
///   hits one of its triangles, and the exact oracle (`sahara-oracle`) finds no real hit
///   missed;
/// * [`Precision::Fast`] is Möller–Trumbore with the division deferred
///   ([`sahara_geom::intersect::intersect_triangle_fast`]), the contract of Embree's and
///   tinybvh's default kernels: rays through shared edges can slip between triangles, and
///   hits near edges can go to the neighbour.
///
/// ```
/// use sahara_traverse::Precision;
/// assert_eq!(Precision::default(), Precision::Exact);
/// assert_eq!("fast".parse::<Precision>(), Ok(Precision::Fast));
/// assert_eq!(Precision::Fast.to_string(), "fast");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Precision {
    /// The watertight test: no hit slips through a shared edge or vertex.
    #[default]
    Exact,
    /// Möller–Trumbore with the division deferred: not watertight.
    Fast,
}

impl Precision {
    /// Both levels, the default first.
    pub const ALL: [Precision; 2] = [Precision::Exact, Precision::Fast];

    /// `"exact"` or `"fast"`.
    pub fn name(self) -> &'static str {
        match self {
            Precision::Exact => "exact",
            Precision::Fast => "fast",
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A precision name that is not `exact` or `fast`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown precision {0:?} (expected exact or fast)")]
pub struct ParsePrecisionError(pub String);

impl FromStr for Precision {
    type Err = ParsePrecisionError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Precision::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| ParsePrecisionError(s.to_string()))
    }
}
