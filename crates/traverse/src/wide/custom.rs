//! The wide trees over any primitive: trees whose leaves hold primitive indices only
//! ([`WideBvh::from_boxes`]), traversed with a user intersection callback, filtered triangle
//! queries, and refitting.
//!
//! The traversal loop is the wide kernels' (the same node order, culling and box tests, lane
//! for lane), with the leaves handed to the callback under the hit rule of [`crate::custom`];
//! so the results equal the brute-force references of that module bit for bit, on every
//! backend. The box tests use the SSE2 backend on x86-64 (always present, inlined into the
//! loop) and the portable one elsewhere or when [`Backend::Portable`] is asked for: with a
//! user callback per primitive the box tests are not what limits the speed.

use super::collapse::{self, Source, WideCuts};
use super::kernel::{
    descend_any, descend_closest, enter, widen, FixedStack, Kernel, PacketHits, RayData, Stack,
    VecStack, FIXED_STACK,
};
use super::{decode_leaf, Backend, TriPacket, WideBvh, LEAF_BIT, NO_ROOT};
use crate::custom::{offer, MixedPrims, PrimHit, UserPrims};
use crate::{Hit, TraversalStats};
use sahara_bvh::{replay_cuts, Bvh, Cut, RefitError};
use sahara_geom::intersect::intersect_triangle;
use sahara_geom::{Aabb, Ray, Triangle};

/// What a traversal does at a leaf.
trait WideLeaf<const W: usize> {
    /// Tests the leaf's packets. Returns `None` to stop the traversal (an any-hit query found
    /// a hit), else the best distance so far (`+∞` for none), which closest-hit traversal culls
    /// with.
    ///
    /// # Safety
    /// The kernel's CPU features must be present.
    unsafe fn visit<K: Kernel<W>, S: TraversalStats, const NEG: bool>(
        &mut self,
        packets: &[TriPacket],
        kr: &K::Ray,
        rd: &RayData,
        tfar: f32,
        stats: &mut S,
    ) -> Option<f32>;
}

/// User primitives: the callback on every lane, under the hit rule.
struct UserLeaf<'a, F, D> {
    prims: UserPrims<'a, F>,
    ray: &'a Ray,
    any: bool,
    found: bool,
    best: Option<PrimHit<D>>,
}

impl<const W: usize, F, D> WideLeaf<W> for UserLeaf<'_, F, D>
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
{
    #[inline(always)]
    unsafe fn visit<K: Kernel<W>, S: TraversalStats, const NEG: bool>(
        &mut self,
        packets: &[TriPacket],
        _: &K::Ray,
        _: &RayData,
        _: f32,
        stats: &mut S,
    ) -> Option<f32> {
        for p in packets {
            stats.triangles(p.len());
            for &prim in p.prims.iter().filter(|&&q| q != u32::MAX) {
                if self.any {
                    if self.prims.any(self.ray, prim) {
                        self.found = true;
                        return None;
                    }
                    continue;
                }
                let bt = self.best.as_ref().map_or(f32::INFINITY, |h| h.t);
                if let Some((t, d)) = self.prims.closest(self.ray, prim, bt) {
                    offer(&mut self.best, t, prim, d);
                }
            }
        }
        Some(self.best.as_ref().map_or(f32::INFINITY, |h| h.t))
    }
}

/// Any-hit with a yes/no callback per primitive (the caller applies its own rule).
struct OccluderLeaf<F> {
    accept: F,
    found: bool,
}

impl<const W: usize, F: FnMut(u32) -> bool> WideLeaf<W> for OccluderLeaf<F> {
    #[inline(always)]
    unsafe fn visit<K: Kernel<W>, S: TraversalStats, const NEG: bool>(
        &mut self,
        packets: &[TriPacket],
        _: &K::Ray,
        _: &RayData,
        _: f32,
        stats: &mut S,
    ) -> Option<f32> {
        for p in packets {
            stats.triangles(p.len());
            for &prim in p.prims.iter().filter(|&&q| q != u32::MAX) {
                if (self.accept)(prim) {
                    self.found = true;
                    return None;
                }
            }
        }
        Some(f32::INFINITY)
    }
}

/// Triangles with a filter: the backend's packet test, then the filter on each hit lane.
struct FilterLeaf<'a, G> {
    filter: G,
    ray: &'a Ray,
    any: bool,
    found: bool,
    best: Hit,
}

impl<G: FnMut(&Hit) -> bool> FilterLeaf<'_, G> {
    /// Offers one candidate; true when an any-hit query is done.
    #[inline(always)]
    fn candidate(&mut self, h: Hit) -> bool {
        if self.any {
            if (self.filter)(&h) {
                self.found = true;
                return true;
            }
        } else if self.best.is_improved_by(h.t, h.prim) && (self.filter)(&h) {
            self.best = h;
        }
        false
    }
}

impl<const W: usize, G: FnMut(&Hit) -> bool> WideLeaf<W> for FilterLeaf<'_, G> {
    #[inline(always)]
    unsafe fn visit<K: Kernel<W>, S: TraversalStats, const NEG: bool>(
        &mut self,
        packets: &[TriPacket],
        kr: &K::Ray,
        rd: &RayData,
        tfar: f32,
        stats: &mut S,
    ) -> Option<f32> {
        let mut out = PacketHits {
            t: [0.0; 4],
            u: [0.0; 4],
            v: [0.0; 4],
        };
        let mut tfar = tfar;
        for p in packets {
            stats.triangles(p.len());
            // SAFETY: forwarded from the caller.
            let stopped = unsafe {
                packet_candidates::<W, K, NEG>(p, kr, rd, self.ray, tfar, &mut out, |h| {
                    self.candidate(h)
                })
            };
            if stopped {
                return None;
            }
            if !self.any {
                tfar = widen(self.best.t.min(rd.tmax));
            }
        }
        Some(self.best.t)
    }
}

/// Every triangle candidate of one packet, offered to `offer` in lane order: first the lanes
/// the backend's packet test hit, then the lanes it left to the scalar watertight test (see
/// `Kernel::intersect_packet`). Returns true as soon as `offer` does (an any-hit query is
/// done). The filtered and the mixed leaves share it, so both see the candidates of the plain
/// kernels in the same order.
///
/// # Safety
/// The kernel's CPU features must be present.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn packet_candidates<const W: usize, K: Kernel<W>, const NEG: bool>(
    p: &TriPacket,
    kr: &K::Ray,
    rd: &RayData,
    ray: &Ray,
    tfar: f32,
    out: &mut PacketHits,
    mut offer: impl FnMut(Hit) -> bool,
) -> bool {
    // SAFETY: forwarded from the caller.
    let (mut hits, mut fallback) = unsafe { K::intersect_packet::<NEG>(p, kr, rd, tfar, out) };
    while hits != 0 {
        let l = hits.trailing_zeros() as usize & 3;
        hits &= hits - 1;
        let h = Hit {
            t: out.t[l],
            prim: p.prims[l],
            u: out.u[l],
            v: out.v[l],
        };
        if offer(h) {
            return true;
        }
    }
    while fallback != 0 {
        let l = fallback.trailing_zeros() as usize & 3;
        fallback &= fallback - 1;
        let tri = p.triangle(l);
        if let Some(h) = intersect_triangle(&rd.w, &tri, ray.tmin, ray.tmax) {
            let h = Hit {
                t: h.t,
                prim: p.prims[l],
                u: h.u,
                v: h.v,
            };
            if offer(h) {
                return true;
            }
        }
    }
    false
}

/// Triangles and user primitives in one tree: the backend's packet test on the triangle lanes
/// (user primitives have NaN vertices, never hit), `accept` on each triangle candidate that
/// would change the answer, and the callback under the hit rule on the user lanes.
struct MixedLeaf<'a, F, G, D> {
    prims: UserPrims<'a, F>,
    triangle_of: &'a [u32],
    accept: G,
    ray: &'a Ray,
    any: bool,
    found: bool,
    best: Option<PrimHit<D>>,
}

impl<F, G: FnMut(&Hit) -> Option<D>, D> MixedLeaf<'_, F, G, D> {
    #[inline(always)]
    fn best_t(&self) -> f32 {
        self.best.as_ref().map_or(f32::INFINITY, |h| h.t)
    }

    /// Offers one triangle candidate; true when an any-hit query is done.
    #[inline(always)]
    fn triangle(&mut self, h: Hit) -> bool {
        if self.any {
            if (self.accept)(&h).is_some() {
                self.found = true;
                return true;
            }
            return false;
        }
        let better = match &self.best {
            None => true,
            Some(b) => h.t < b.t || (h.t == b.t && h.prim < b.prim),
        };
        if better {
            if let Some(data) = (self.accept)(&h) {
                self.best = Some(PrimHit {
                    t: h.t,
                    prim: h.prim,
                    data,
                });
            }
        }
        false
    }
}

impl<const W: usize, F, G, D> WideLeaf<W> for MixedLeaf<'_, F, G, D>
where
    F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
    G: FnMut(&Hit) -> Option<D>,
{
    #[inline(always)]
    unsafe fn visit<K: Kernel<W>, S: TraversalStats, const NEG: bool>(
        &mut self,
        packets: &[TriPacket],
        kr: &K::Ray,
        rd: &RayData,
        tfar: f32,
        stats: &mut S,
    ) -> Option<f32> {
        let mut out = PacketHits {
            t: [0.0; 4],
            u: [0.0; 4],
            v: [0.0; 4],
        };
        let mut tfar = tfar;
        for p in packets {
            stats.triangles(p.len());
            // SAFETY: forwarded from the caller.
            let stopped = unsafe {
                packet_candidates::<W, K, NEG>(p, kr, rd, self.ray, tfar, &mut out, |h| {
                    self.triangle(h)
                })
            };
            if stopped {
                return None;
            }
            for &prim in &p.prims {
                if prim == u32::MAX || self.triangle_of[prim as usize] != u32::MAX {
                    continue;
                }
                if self.any {
                    if self.prims.any(self.ray, prim) {
                        self.found = true;
                        return None;
                    }
                    continue;
                }
                if let Some((t, d)) = self.prims.closest(self.ray, prim, self.best_t()) {
                    offer(&mut self.best, t, prim, d);
                }
            }
            if !self.any {
                tfar = widen(self.best_t().min(rd.tmax));
            }
        }
        Some(self.best_t())
    }
}

/// The wide traversal loop with leaves handled by `leaf` (closest hit: near to far, culled
/// with the best distance; any hit: until `leaf` stops it).
///
/// # Safety
/// The kernel's CPU features must be present; `St` must hold `bvh.max_stack` entries.
#[inline(always)]
unsafe fn traverse<
    K: Kernel<W>,
    const W: usize,
    S: TraversalStats,
    St: Stack,
    const NEG: bool,
    L: WideLeaf<W>,
>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    closest: bool,
    stats: &mut S,
    stack: &mut St,
    leaf: &mut L,
) {
    if bvh.root == NO_ROOT || !ray.is_valid() {
        return;
    }
    let mut rd = RayData::new(ray);
    let mut tfar = widen(rd.tmax);
    // SAFETY: forwarded from the caller.
    let Some(mut cur) =
        (unsafe { enter::<K, W, S, St, NEG>(bvh, ray, &rd, tfar, closest, stats, stack) })
    else {
        return;
    };
    rd.finish(ray);
    // SAFETY: forwarded from the caller.
    let kr = unsafe { K::prepare(&rd) };
    let mut dist = [0.0f32; W];
    loop {
        if cur & LEAF_BIT != 0 {
            stats.leaf();
            let (first, n) = decode_leaf(cur);
            let packets = &bvh.packets[first..first + n];
            // SAFETY: forwarded.
            match unsafe { leaf.visit::<K, S, NEG>(packets, &kr, &rd, tfar, stats) } {
                None => return,
                Some(b) => {
                    if closest {
                        tfar = widen(b.min(rd.tmax));
                    }
                }
            }
        } else {
            stats.inner();
            let node = &bvh.nodes[cur as usize];
            // SAFETY: forwarded.
            let mask = unsafe { K::intersect_node::<NEG>(node, &kr, &rd, tfar, &mut dist) };
            let next = if closest {
                descend_closest(node, mask, &dist, stack)
            } else {
                descend_any(node, mask, stack)
            };
            if let Some(next) = next {
                cur = next;
                continue;
            }
        }
        loop {
            match stack.pop() {
                None => return,
                Some(e) => {
                    if !closest || e.dist <= tfar {
                        cur = e.child;
                        break;
                    }
                }
            }
        }
    }
}

/// [`traverse`] with the stack and the `tmin < 0` variant chosen for the ray.
///
/// # Safety
/// The kernel's CPU features must be present.
unsafe fn run_kernel<K: Kernel<W>, const W: usize, S: TraversalStats, L: WideLeaf<W>>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    closest: bool,
    stats: &mut S,
    leaf: &mut L,
) {
    let neg = ray.tmin < 0.0;
    // SAFETY: forwarded; `FixedStack` only when the bound fits.
    unsafe {
        if bvh.max_stack <= FIXED_STACK {
            let mut buf = FixedStack::buffer();
            let st = &mut FixedStack::new(&mut buf);
            if neg {
                traverse::<K, W, S, _, true, L>(bvh, ray, closest, stats, st, leaf)
            } else {
                traverse::<K, W, S, _, false, L>(bvh, ray, closest, stats, st, leaf)
            }
        } else {
            let st = &mut VecStack(Vec::with_capacity(bvh.max_stack));
            if neg {
                traverse::<K, W, S, _, true, L>(bvh, ray, closest, stats, st, leaf)
            } else {
                traverse::<K, W, S, _, false, L>(bvh, ray, closest, stats, st, leaf)
            }
        }
    }
}

/// Runs a query with the box tests of `backend` (SSE2 for every x86 backend, portable
/// otherwise).
fn run<const W: usize, S: TraversalStats, L: WideLeaf<W>>(
    bvh: &WideBvh<W>,
    backend: Backend,
    ray: &Ray,
    closest: bool,
    stats: &mut S,
    leaf: &mut L,
) {
    match backend {
        #[cfg(target_arch = "x86_64")]
        Backend::Sse2 | Backend::Avx2 | Backend::Avx512 => {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { run_kernel::<super::x86::Sse, W, S, L>(bvh, ray, closest, stats, leaf) }
        }
        _ => {
            // SAFETY: the portable kernel needs no CPU feature.
            unsafe {
                run_kernel::<super::portable::Portable, W, S, L>(bvh, ray, closest, stats, leaf)
            }
        }
    }
}

impl<const W: usize> WideBvh<W> {
    /// Collapses a binary BVH built over primitive boxes (`BuildInput::from_boxes`) into a
    /// `W`-wide tree whose leaves hold the primitives' indices only (their packets have NaN
    /// vertices, so the triangle queries never hit): the tree of
    /// [`WideBvh::closest_hit_custom`] and [`WideBvh::any_hit_custom`]. The collapse is the
    /// one of [`WideBvh::from_bvh`] (big leaves are sorted by box centres).
    ///
    /// # Panics
    ///
    /// As [`WideBvh::from_bvh`] (a leaf references a primitive outside `boxes`).
    pub fn from_boxes(bvh: &Bvh, boxes: &[Aabb]) -> Self {
        collapse::collapse(bvh, Source::Boxes(boxes))
    }

    /// Closest hit on user primitives (see [`crate::custom`] for the callback's contract and
    /// the hit rule): `boxes` are the primitives' boxes the tree was built from. Equal to
    /// [`crate::custom::brute_closest_hit`] bit for bit. Invalid rays miss.
    ///
    /// # Panics
    ///
    /// If a leaf references a primitive outside `boxes`.
    pub fn closest_hit_custom<D, F, S>(
        &self,
        boxes: &[Aabb],
        ray: &Ray,
        intersect: F,
        stats: &mut S,
    ) -> Option<PrimHit<D>>
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        S: TraversalStats,
    {
        self.closest_hit_custom_with(self.backend, boxes, ray, intersect, stats)
    }

    /// [`WideBvh::closest_hit_custom`] with the box tests of a chosen backend (every x86
    /// backend uses the SSE2 box test here; all give the same result).
    pub fn closest_hit_custom_with<D, F, S>(
        &self,
        backend: Backend,
        boxes: &[Aabb],
        ray: &Ray,
        intersect: F,
        stats: &mut S,
    ) -> Option<PrimHit<D>>
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        S: TraversalStats,
    {
        let mut leaf = UserLeaf {
            prims: UserPrims { boxes, intersect },
            ray,
            any: false,
            found: false,
            best: None,
        };
        run(self, backend, ray, true, stats, &mut leaf);
        leaf.best
    }

    /// Any hit on user primitives: true when some primitive has a hit under the hit rule
    /// (exactly when [`WideBvh::closest_hit_custom`] finds one).
    ///
    /// # Panics
    ///
    /// As [`WideBvh::closest_hit_custom`].
    pub fn any_hit_custom<D, F, S>(
        &self,
        boxes: &[Aabb],
        ray: &Ray,
        intersect: F,
        stats: &mut S,
    ) -> bool
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        S: TraversalStats,
    {
        self.any_hit_custom_with(self.backend, boxes, ray, intersect, stats)
    }

    /// [`WideBvh::any_hit_custom`] with the box tests of a chosen backend.
    pub fn any_hit_custom_with<D, F, S>(
        &self,
        backend: Backend,
        boxes: &[Aabb],
        ray: &Ray,
        intersect: F,
        stats: &mut S,
    ) -> bool
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        S: TraversalStats,
    {
        let mut leaf = UserLeaf {
            prims: UserPrims { boxes, intersect },
            ray,
            any: true,
            found: false,
            best: None::<PrimHit<D>>,
        };
        run(self, backend, ray, false, stats, &mut leaf);
        leaf.found
    }

    /// Collapses a binary BVH built over the boxes of triangles and user primitives together
    /// (`BuildInput::from_boxes`, each triangle's box its bounds) into a `W`-wide tree whose
    /// leaves hold the triangles' vertices (user primitives get NaN vertices): the tree of
    /// [`WideBvh::closest_hit_mixed`] and [`WideBvh::any_hit_mixed`].
    ///
    /// # Panics
    ///
    /// If `prims.triangle_of` is not as long as `prims.boxes`, names a triangle outside
    /// `prims.triangles`, or a leaf references a primitive outside `prims.boxes`.
    pub fn from_mixed(bvh: &Bvh, prims: MixedPrims<'_>) -> Self {
        assert_eq!(
            prims.triangle_of.len(),
            prims.boxes.len(),
            "one entry per primitive"
        );
        collapse::collapse(bvh, Source::Mixed(prims))
    }

    /// Closest hit in a tree of triangles and user primitives ([`WideBvh::from_mixed`]):
    /// triangles by the backend's packet test (the watertight test), each triangle
    /// candidate that would change the answer (nearer than the best, or as near on a lower
    /// index) passed to `accept`, which returns its data or `None` to reject it (a filter);
    /// user primitives by `intersect` under the hit rule of [`crate::custom`] (with the same
    /// contract). Ties: the lowest primitive index. Equal, bit for bit, to a loop over all
    /// primitives in index order applying the watertight test and `accept` to triangles and
    /// the hit rule to the others. Invalid rays miss.
    ///
    /// # Panics
    ///
    /// If `prims` is not the tree's (a leaf references a primitive outside it).
    pub fn closest_hit_mixed<D, F, G, S>(
        &self,
        prims: MixedPrims<'_>,
        ray: &Ray,
        accept: G,
        intersect: F,
        stats: &mut S,
    ) -> Option<PrimHit<D>>
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        G: FnMut(&Hit) -> Option<D>,
        S: TraversalStats,
    {
        self.closest_hit_mixed_with(self.backend, prims, ray, accept, intersect, stats)
    }

    /// [`WideBvh::closest_hit_mixed`] with the box and packet tests of a chosen backend
    /// (every x86 backend uses the SSE2 tests here; all give the same result).
    pub fn closest_hit_mixed_with<D, F, G, S>(
        &self,
        backend: Backend,
        prims: MixedPrims<'_>,
        ray: &Ray,
        accept: G,
        intersect: F,
        stats: &mut S,
    ) -> Option<PrimHit<D>>
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        G: FnMut(&Hit) -> Option<D>,
        S: TraversalStats,
    {
        let mut leaf = MixedLeaf {
            prims: UserPrims {
                boxes: prims.boxes,
                intersect,
            },
            triangle_of: prims.triangle_of,
            accept,
            ray,
            any: false,
            found: false,
            best: None,
        };
        run(self, backend, ray, true, stats, &mut leaf);
        leaf.best
    }

    /// Any hit in a tree of triangles and user primitives: true when a triangle hit in `[tmin,
    /// tmax]` is accepted by `accept`, or a user primitive has a hit under the hit rule.
    ///
    /// # Panics
    ///
    /// As [`WideBvh::closest_hit_mixed`].
    pub fn any_hit_mixed<D, F, G, S>(
        &self,
        prims: MixedPrims<'_>,
        ray: &Ray,
        accept: G,
        intersect: F,
        stats: &mut S,
    ) -> bool
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        G: FnMut(&Hit) -> Option<D>,
        S: TraversalStats,
    {
        self.any_hit_mixed_with(self.backend, prims, ray, accept, intersect, stats)
    }

    /// [`WideBvh::any_hit_mixed`] with the box and packet tests of a chosen backend.
    pub fn any_hit_mixed_with<D, F, G, S>(
        &self,
        backend: Backend,
        prims: MixedPrims<'_>,
        ray: &Ray,
        accept: G,
        intersect: F,
        stats: &mut S,
    ) -> bool
    where
        F: FnMut(&Ray, u32, f32, f32) -> Option<(f32, D)>,
        G: FnMut(&Hit) -> Option<D>,
        S: TraversalStats,
    {
        let mut leaf = MixedLeaf {
            prims: UserPrims {
                boxes: prims.boxes,
                intersect,
            },
            triangle_of: prims.triangle_of,
            accept,
            ray,
            any: true,
            found: false,
            best: None,
        };
        run(self, backend, ray, false, stats, &mut leaf);
        leaf.found
    }

    /// Any-hit traversal that asks `accept(prim)` about every primitive of every leaf the ray
    /// reaches (boxes tested over `[lower_distance(tmin), cull_distance(tmax)]`), until one
    /// says yes. Exact against a brute-force loop over all primitives when `accept` itself
    /// rejects primitives whose box fails that box test (the instances' any-hit rule).
    pub(crate) fn any_hit_occluders<F, S>(&self, ray: &Ray, accept: F, stats: &mut S) -> bool
    where
        F: FnMut(u32) -> bool,
        S: TraversalStats,
    {
        let mut leaf = OccluderLeaf {
            accept,
            found: false,
        };
        run(self, self.backend, ray, false, stats, &mut leaf);
        leaf.found
    }

    /// Closest hit on the tree's triangles with an any-hit filter (see
    /// [`crate::custom`]'s filters): the backend's packet test, then `filter` on each
    /// candidate that would change the answer. Equal to
    /// [`crate::custom::brute_closest_hit_filtered`] bit for bit.
    pub fn closest_hit_filtered<G, S>(&self, ray: &Ray, filter: G, stats: &mut S) -> Hit
    where
        G: FnMut(&Hit) -> bool,
        S: TraversalStats,
    {
        self.closest_hit_filtered_with(self.backend, ray, filter, stats)
    }

    /// [`WideBvh::closest_hit_filtered`] with a chosen backend.
    pub fn closest_hit_filtered_with<G, S>(
        &self,
        backend: Backend,
        ray: &Ray,
        filter: G,
        stats: &mut S,
    ) -> Hit
    where
        G: FnMut(&Hit) -> bool,
        S: TraversalStats,
    {
        let mut leaf = FilterLeaf {
            filter,
            ray,
            any: false,
            found: false,
            best: Hit::MISS,
        };
        run(self, backend, ray, true, stats, &mut leaf);
        leaf.best
    }

    /// Any hit on the tree's triangles with an any-hit filter: true when a hit in `[tmin,
    /// tmax]` is kept by `filter`.
    pub fn any_hit_filtered<G, S>(&self, ray: &Ray, filter: G, stats: &mut S) -> bool
    where
        G: FnMut(&Hit) -> bool,
        S: TraversalStats,
    {
        self.any_hit_filtered_with(self.backend, ray, filter, stats)
    }

    /// [`WideBvh::any_hit_filtered`] with a chosen backend.
    pub fn any_hit_filtered_with<G, S>(
        &self,
        backend: Backend,
        ray: &Ray,
        filter: G,
        stats: &mut S,
    ) -> bool
    where
        G: FnMut(&Hit) -> bool,
        S: TraversalStats,
    {
        let mut leaf = FilterLeaf {
            filter,
            ray,
            any: true,
            found: false,
            best: Hit::MISS,
        };
        run(self, backend, ray, false, stats, &mut leaf);
        leaf.found
    }

    /// Refits the tree to moved triangles (the same triangles, by index, as at build time):
    /// every child box becomes the union of its subtree's triangle bounds, bottom-up, and the
    /// leaf packets get the new vertices (a triangle that became degenerate is stored as NaN
    /// lanes, as by the collapse). The topology (nodes, children, which triangle is in which
    /// lane) is kept.
    ///
    /// Refitting with unchanged triangles is the identity, bit for bit, for trees collapsed
    /// from any builder's binary tree. With spatial splits, a leaf's box is the union of its
    /// binary references' boxes, each its triangle clipped again by the reference's recorded
    /// cuts ([`Bvh::refit_triangles`], [`Bvh::ref_cuts`]): unmoved triangles give the clipped
    /// boxes of the build, moved ones boxes that still hold every part of the triangle a ray
    /// can hit there (a leaf may become [`Aabb::EMPTY`], which no ray reaches). Trees
    /// collapsed from spatial-split trees without cut records (loaded from version-1 files),
    /// and binary leaves of more than 32 references, refit with the triangles' whole bounds
    /// (correct, looser). On error the tree is left unchanged.
    pub fn refit_triangles(&mut self, tris: &[Triangle]) -> Result<(), RefitError> {
        for (i, t) in tris.iter().enumerate() {
            if !t.is_finite() && self.references(i as u32) {
                return Err(RefitError::InvalidBox { prim: i as u32 });
            }
        }
        self.refit_source(Source::Triangles(tris))
    }

    /// Refits a tree over primitive boxes ([`WideBvh::from_boxes`]) to the primitives' new
    /// boxes, as [`WideBvh::refit_triangles`] does for triangles. A tree over triangles refitted
    /// with boxes holds boxes only afterwards (its packets get NaN vertices).
    pub fn refit_boxes(&mut self, boxes: &[Aabb]) -> Result<(), RefitError> {
        for (i, b) in boxes.iter().enumerate() {
            let bad = !(b.min.is_finite() && b.max.is_finite()) || b.min.cmpgt(b.max).any();
            if bad && self.references(i as u32) {
                return Err(RefitError::InvalidBox { prim: i as u32 });
            }
        }
        self.refit_source(Source::Boxes(boxes))
    }

    fn references(&self, prim: u32) -> bool {
        self.packets.iter().any(|p| p.prims.contains(&prim))
    }

    fn refit_source(&mut self, src: Source<'_>) -> Result<(), RefitError> {
        let len = src.len();
        for p in self.packets.iter() {
            for &prim in p.prims.iter().filter(|&&q| q != u32::MAX) {
                if prim as usize >= len {
                    return Err(RefitError::MissingPrimitive { prim, len });
                }
            }
        }
        if self.root == NO_ROOT {
            return Ok(());
        }
        let own = match (&self.cuts, &src) {
            (Some(c), Source::Triangles(t)) => Some(self.cut_boxes(c, t)),
            _ => None,
        };
        // A leaf slot's box: its records' (with them), else its primitives' whole boxes; an
        // inner slot's: its children's and what the records add.
        let slot_box = |own: &Option<Vec<Option<Aabb>>>, slot: usize, children: Aabb| match own {
            Some(o) => o[slot].map_or(children, |b| children.union(&b)),
            None => children,
        };
        // Children have larger indices than their parents (they are allocated while the
        // parent is filled): a reverse sweep sees every child first.
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let mut out = node;
            for s in 0..W {
                if node.valid & (1 << s) == 0 {
                    continue;
                }
                let c = node.children[s];
                let b = if c & LEAF_BIT != 0 {
                    let whole = self.refit_leaf(c, &src);
                    match own.as_ref().and_then(|o| o[i * W + s]) {
                        Some(b) => b,
                        None => whole,
                    }
                } else {
                    let child = &self.nodes[c as usize];
                    let mut b = Aabb::EMPTY;
                    for k in 0..W {
                        if child.valid & (1 << k) != 0 {
                            b.grow_aabb(&child.child_bounds(k));
                        }
                    }
                    slot_box(&own, i * W + s, b)
                };
                let rows = [b.min.x, b.max.x, b.min.y, b.max.y, b.min.z, b.max.z];
                for (row, v) in out.bounds.iter_mut().zip(rows) {
                    row[s] = v;
                }
            }
            out.set_order();
            self.nodes[i] = out;
        }
        let root_slot = self.nodes.len() * W;
        self.root_bounds = if self.root & LEAF_BIT != 0 {
            let whole = self.refit_leaf(self.root, &src);
            match own.as_ref().and_then(|o| o[root_slot]) {
                Some(b) => b,
                None => whole,
            }
        } else {
            let root = &self.nodes[self.root as usize];
            let mut b = Aabb::EMPTY;
            for k in 0..W {
                if root.valid & (1 << k) != 0 {
                    b.grow_aabb(&root.child_bounds(k));
                }
            }
            slot_box(&own, root_slot, b)
        };
        Ok(())
    }

    /// Rewrites the packets of leaf reference `leaf` from `src` and returns their bounds
    /// (from the cut records, when the tree has them and `src` is triangles).
    fn refit_leaf(&mut self, leaf: u32, src: &Source<'_>) -> Aabb {
        let (first, n) = decode_leaf(leaf);
        let mut b = Aabb::EMPTY;
        for p in &mut self.packets[first..first + n] {
            for lane in 0..4 {
                let prim = p.prims[lane];
                if prim != u32::MAX {
                    b.grow_aabb(&src.bounds(prim));
                    src.fill_lane(p, lane, prim);
                }
            }
        }
        b
    }

    /// With cut records: the box each slot (`i * W + k`, the root's last) gets besides its
    /// children's: a leaf with records its references' replayed boxes, and every slot the boxes
    /// that cuts made at its binary node or between it and its wide children were applied to
    /// ([`WideCuts`]); `None` for a leaf slot without records.
    fn cut_boxes(&self, cuts: &WideCuts, tris: &[Triangle]) -> Vec<Option<Aabb>> {
        let root_slot = self.nodes.len() * W;
        let mut own = vec![Some(Aabb::EMPTY); root_slot + 1];
        if self.root == NO_ROOT {
            return own;
        }
        // (binary depth, slot) of the slots from the root to the current one.
        let mut path: Vec<(u32, usize)> = Vec::new();
        let mut stack = vec![(self.root, root_slot, 0usize)];
        while let Some((c, slot, plen)) = stack.pop() {
            path.truncate(plen);
            let d = cuts.depth[slot];
            if d != Cut::NO_DEPTH {
                path.push((d, slot));
            }
            if c & LEAF_BIT == 0 {
                let node = &self.nodes[c as usize];
                for k in 0..W {
                    if node.valid & (1 << k) != 0 {
                        stack.push((node.children[k], c as usize * W + k, path.len()));
                    }
                }
                continue;
            }
            let (first, n) = decode_leaf(c);
            let refs = cuts.leaf_refs(first, n);
            if refs.is_empty() {
                own[slot] = None;
                continue;
            }
            let mut b = Aabb::EMPTY;
            for k in refs {
                let tri = &tris[cuts.prims[k] as usize];
                b.grow_aabb(&replay_cuts(cuts.cuts.get(k), tri, |cut, before| {
                    if cut.depth == Cut::NO_DEPTH {
                        return;
                    }
                    if let Some(&(_, s)) = path.iter().rev().find(|(d, _)| *d <= cut.depth) {
                        if let Some(o) = &mut own[s] {
                            o.grow_aabb(before);
                        }
                    }
                }));
            }
            if let Some(o) = &mut own[slot] {
                o.grow_aabb(&b);
            }
        }
        own
    }
}
