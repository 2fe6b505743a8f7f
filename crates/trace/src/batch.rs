//! Batch tracing on rayon, work counters, checksums.

use crate::{RaySet, Tracer};
use rayon::prelude::*;
use sahara_geom::Ray;
use sahara_traverse::{Hit, WorkCounters};
use serde::{Deserialize, Serialize};

/// Rays per rayon task at least: enough to amortise scheduling, few enough to balance the
/// very uneven cost of rays.
const MIN_RAYS_PER_TASK: usize = 64;

/// The closest hit of every ray, in parallel (fast path: no counters). `result[i]` belongs to
/// `rays[i]` whatever the number of threads.
pub fn trace_closest<T: Tracer + ?Sized>(tracer: &T, rays: &[Ray]) -> Vec<Hit> {
    uncounted(rays, |r| tracer.closest_hit_fast(r))
}

/// [`trace_closest`] into a reused buffer (cleared, then filled with one hit per ray), so
/// that timed passes do not allocate.
pub fn trace_closest_into<T: Tracer + ?Sized>(tracer: &T, rays: &[Ray], out: &mut Vec<Hit>) {
    uncounted_into(rays, out, |r| tracer.closest_hit_fast(r))
}

/// The occlusion of every ray (any hit in `[tmin, tmax]`), in parallel, without counters.
/// `result[i]` belongs to `rays[i]`.
pub fn trace_any<T: Tracer + ?Sized>(tracer: &T, rays: &[Ray]) -> Vec<bool> {
    uncounted(rays, |r| tracer.any_hit_fast(r))
}

/// [`trace_any`] into a reused buffer (cleared, then filled with one result per ray).
pub fn trace_any_into<T: Tracer + ?Sized>(tracer: &T, rays: &[Ray], out: &mut Vec<bool>) {
    uncounted_into(rays, out, |r| tracer.any_hit_fast(r))
}

/// `f` of every ray, in parallel, in the order of the rays.
fn uncounted<R: Send>(rays: &[Ray], f: impl Fn(&Ray) -> R + Sync) -> Vec<R> {
    let mut out = Vec::new();
    uncounted_into(rays, &mut out, f);
    out
}

/// [`uncounted`] into a reused buffer (cleared, then filled with one result per ray).
fn uncounted_into<R: Send>(rays: &[Ray], out: &mut Vec<R>, f: impl Fn(&Ray) -> R + Sync) {
    rays.par_iter()
        .with_min_len(MIN_RAYS_PER_TASK)
        .map(&f)
        .collect_into_vec(out);
}

/// Results of a counting trace: per-ray results (`R` is `Vec<Hit>`, `Vec<bool>` or
/// [`TraceResults`]) and work, and the total work.
#[derive(Clone, Debug, PartialEq)]
pub struct CountedTrace<R> {
    /// One result per ray, in the order of the rays.
    pub results: R,
    /// The work of each ray, in the order of the rays.
    pub work: Vec<WorkCounters>,
    /// The sum of `work`.
    pub total: WorkCounters,
}

impl<R> CountedTrace<R> {
    /// The average work per ray of the batch.
    pub fn per_ray(&self) -> WorkPerRay {
        WorkPerRay::new(&self.total, self.work.len())
    }
}

fn counted<R: Send, F>(rays: &[Ray], f: F) -> CountedTrace<Vec<R>>
where
    F: Fn(&Ray, &mut WorkCounters) -> R + Sync,
{
    let (results, work): (Vec<R>, Vec<WorkCounters>) = rays
        .par_iter()
        .with_min_len(MIN_RAYS_PER_TASK)
        .map(|r| {
            let mut c = WorkCounters::default();
            let res = f(r, &mut c);
            (res, c)
        })
        .unzip();
    let mut total = WorkCounters::default();
    for w in &work {
        total += *w;
    }
    CountedTrace {
        results,
        work,
        total,
    }
}

/// [`trace_closest`] through the counting path ([`Tracer::closest_hit`]): the same hits, plus
/// the work of each ray and of the batch.
pub fn trace_closest_counted<T: Tracer + ?Sized>(
    tracer: &T,
    rays: &[Ray],
) -> CountedTrace<Vec<Hit>> {
    counted(rays, |r, c| tracer.closest_hit(r, c))
}

/// [`trace_any`] through the counting path ([`Tracer::any_hit`]).
pub fn trace_any_counted<T: Tracer + ?Sized>(tracer: &T, rays: &[Ray]) -> CountedTrace<Vec<bool>> {
    counted(rays, |r, c| tracer.any_hit(r, c))
}

/// The results of tracing a [`RaySet`] with the query its kind calls for.
#[derive(Clone, Debug, PartialEq)]
pub enum TraceResults {
    /// Closest hits (primary and diffuse rays).
    Closest(Vec<Hit>),
    /// Occlusion (ambient-occlusion rays).
    Any(Vec<bool>),
}

impl TraceResults {
    /// Number of rays.
    pub fn len(&self) -> usize {
        match self {
            TraceResults::Closest(h) => h.len(),
            TraceResults::Any(o) => o.len(),
        }
    }

    /// True for no ray.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of rays that hit something ([`hit_count`] or [`occluded_count`]).
    pub fn hit_count(&self) -> usize {
        match self {
            TraceResults::Closest(h) => hit_count(h),
            TraceResults::Any(o) => occluded_count(o),
        }
    }

    /// [`checksum`] of closest hits, or [`checksum_occlusion`] of occlusion results.
    pub fn checksum(&self) -> u64 {
        match self {
            TraceResults::Closest(h) => checksum(h),
            TraceResults::Any(o) => checksum_occlusion(o),
        }
    }
}

/// Traces `set` with the fast path: [`trace_any`] for ambient-occlusion sets,
/// [`trace_closest`] otherwise.
pub fn trace_set<T: Tracer + ?Sized>(tracer: &T, set: &RaySet) -> TraceResults {
    if set.kind.uses_any_hit() {
        TraceResults::Any(trace_any(tracer, &set.rays))
    } else {
        TraceResults::Closest(trace_closest(tracer, &set.rays))
    }
}

/// Traces `set` through the counting path, with the query its kind calls for: the same
/// results as [`trace_set`], plus the work of each ray and of the batch.
pub fn trace_set_counted<T: Tracer + ?Sized>(
    tracer: &T,
    set: &RaySet,
) -> CountedTrace<TraceResults> {
    if set.kind.uses_any_hit() {
        let c = trace_any_counted(tracer, &set.rays);
        CountedTrace {
            results: TraceResults::Any(c.results),
            work: c.work,
            total: c.total,
        }
    } else {
        let c = trace_closest_counted(tracer, &set.rays);
        CountedTrace {
            results: TraceResults::Closest(c.results),
            work: c.work,
            total: c.total,
        }
    }
}

/// Work per ray, averaged over a batch: what the JSON reports as inner/leaf/triangle visits
/// per ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorkPerRay {
    /// Inner nodes visited per ray.
    pub inner: f64,
    /// Leaves visited per ray.
    pub leaves: f64,
    /// Triangles tested per ray.
    pub triangles: f64,
}

impl WorkPerRay {
    /// The average of `total` over `rays` rays (all zero for no ray).
    pub fn new(total: &WorkCounters, rays: usize) -> Self {
        if rays == 0 {
            return Self::default();
        }
        let n = rays as f64;
        Self {
            inner: total.inner as f64 / n,
            leaves: total.leaves as f64 / n,
            triangles: total.triangles as f64 / n,
        }
    }

    /// `inner + leaves + triangles`.
    pub fn sum(&self) -> f64 {
        self.inner + self.leaves + self.triangles
    }
}

/// The total work of one ray, as the heat maps show it: `inner + leaves + triangles`.
#[inline]
pub fn work_total(w: &WorkCounters) -> u64 {
    w.inner + w.leaves + w.triangles
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

#[inline]
fn fnv_bytes(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(FNV_PRIME);
    }
    h
}

/// A checksum of closest hits, to compare kernels, layouts and builders on one ray set:
/// 64-bit FNV-1a over, for each hit in order, the 4 little-endian bytes of `prim` then the 4
/// little-endian bytes of `t.to_bits()`. Misses contribute `u32::MAX` and the bits of `+inf`.
///
/// Barycentrics are left out. Two tracers that follow the [`Tracer`] contract with the same
/// watertight triangle test agree exactly; a different tree over the same triangles gives the
/// same checksum too.
pub fn checksum(hits: &[Hit]) -> u64 {
    hits.iter().fold(FNV_OFFSET, |h, hit| {
        let h = fnv_bytes(h, &hit.prim.to_le_bytes());
        fnv_bytes(h, &hit.t.to_bits().to_le_bytes())
    })
}

/// A checksum of occlusion results: 64-bit FNV-1a over one byte per ray (1 occluded, 0 not).
pub fn checksum_occlusion(occluded: &[bool]) -> u64 {
    occluded
        .iter()
        .fold(FNV_OFFSET, |h, &o| fnv_bytes(h, &[u8::from(o)]))
}

/// Number of hits ([`Hit::is_hit`]).
pub fn hit_count(hits: &[Hit]) -> usize {
    hits.iter().filter(|h| h.is_hit()).count()
}

/// Number of occluded rays.
pub fn occluded_count(occluded: &[bool]) -> usize {
    occluded.iter().filter(|&&o| o).count()
}
