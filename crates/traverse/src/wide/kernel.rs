//! The traversal loops shared by every backend, generic over a [`Kernel`] (the box and
//! triangle tests) and a [`Stack`].

// The planted bug (`--cfg sahara_planted_bug`, issue 46) is for fuzzing builds only: cargo fuzz
// sets `--cfg fuzzing`; any other build with it fails here.
#[cfg(all(
    any(sahara_planted_bug = "kernel", sahara_planted_bug = "builder"),
    not(fuzzing)
))]
compile_error!("sahara_planted_bug plants a wrong answer: only with --cfg fuzzing (cargo fuzz)");

use super::{decode_leaf, TriPacket, WideBvh, WideNode, LEAF_BIT, NO_ROOT};
use crate::{Hit, TraversalStats};
use sahara_geom::intersect::{far_factors, intersect_triangle, lower_distance, WatertightRay};
use sahara_geom::Ray;
use std::mem::MaybeUninit;

/// Widens a culling distance by 2^-16 of its magnitude, so that a box whose computed entry
/// distance rounds just above the distance of a triangle it holds (a tie at a vertex on the
/// box boundary) is still visited. Only culling uses it; hits are compared exactly.
#[inline(always)]
pub(crate) fn widen(t: f32) -> f32 {
    t + t.abs() * (1.0 / 65536.0)
}

/// The body of a backend's entry point for the rays and trees its fast path does not take (the
/// x86 backends' out-of-line paths, the portable entry points): `$traverse` (closest or any hit) with the inline stack when the tree's stack bound fits it, else a heap stack, and
/// the conservative far distances of rays with `tmin < 0` when the ray has one.
macro_rules! slow_path {
    ($($traverse:ident)::+, $kernel:ty, $bvh:expr, $ray:expr, $stats:expr) => {{
        let (bvh, ray, stats) = ($bvh, $ray, $stats);
        let neg = ray.tmin < 0.0;
        // SAFETY: the caller guarantees the CPU features; `FixedStack` only when the bound
        // fits.
        #[allow(unused_unsafe)]
        unsafe {
            if bvh.max_stack <= FIXED_STACK {
                let mut buf = FixedStack::buffer();
                let st = &mut FixedStack::new(&mut buf);
                return if neg {
                    $($traverse)::+::<$kernel, W, S, _, true>(bvh, ray, stats, st)
                } else {
                    $($traverse)::+::<$kernel, W, S, _, false>(bvh, ray, stats, st)
                };
            }
            let st = &mut VecStack(Vec::with_capacity(bvh.max_stack));
            if neg {
                $($traverse)::+::<$kernel, W, S, _, true>(bvh, ray, stats, st)
            } else {
                $($traverse)::+::<$kernel, W, S, _, false>(bvh, ray, stats, st)
            }
        }
    }};
}

/// Per-ray constants shared by every backend.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayData {
    pub(crate) origin: [f32; 3],
    pub(crate) inv: [f32; 3],
    /// The reciprocal direction scaled for far planes, for positive and for negative far
    /// distances ([`far_factors`]).
    pub(crate) inv_far: [f32; 3],
    pub(crate) inv_far_neg: [f32; 3],
    /// The ray's interval, for triangles.
    pub(crate) tmin: f32,
    pub(crate) tmax: f32,
    /// `tmin` lowered by 2^-16 of its magnitude, for boxes (see [`widen`]).
    pub(crate) box_tmin: f32,
    /// Bounds row (of `min_x, max_x, min_y, …`) of the near plane on each axis: the minimum
    /// when the reciprocal direction is positive (sign bit clear), else the maximum.
    pub(crate) near_row: [usize; 3],
    /// Row of the far plane.
    pub(crate) far_row: [usize; 3],
    /// The watertight test's constants; filled in by [`RayData::finish`] after the root test.
    pub(crate) w: WatertightRay,
    /// The ray's octant class: which of a node's four stored child orders
    /// ([`WideNode::order_bits`]) applies (the octant's, or the opposite octant's when the
    /// direction's z component is negative), and how [`descend_ordered`] reads it: `7` when
    /// it is this ray's near-to-far order (read from the last position, far first), `0` when
    /// it is the opposite octant's, i.e. this ray's far-to-near order (read from the first).
    pub(crate) order_q: usize,
    pub(crate) order_xor: usize,
    /// The direction (for the `Fast` precision's Möller–Trumbore test).
    pub(crate) dir: [f32; 3],
}

impl RayData {
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> Self {
        let inv = ray.inv_direction().to_array();
        let (far_pos, far_neg) = far_factors(ray.inv_direction());
        let mut near_row = [0; 3];
        let mut far_row = [0; 3];
        let mut octant = 0;
        for a in 0..3 {
            let neg = inv[a].is_sign_negative() as usize;
            near_row[a] = 2 * a + neg;
            far_row[a] = 2 * a + 1 - neg;
            octant |= neg << a;
        }
        // Octants with a negative z direction use the order of the opposite octant backwards.
        let flip = octant >> 2;
        let order_q = (octant ^ (flip * 3)) & 3;
        let order_xor = (1 - flip) * 7;
        Self {
            origin: ray.origin.to_array(),
            inv,
            inv_far: far_pos.to_array(),
            inv_far_neg: far_neg.to_array(),
            tmin: ray.tmin,
            tmax: ray.tmax,
            box_tmin: lower_distance(ray.tmin),
            near_row,
            far_row,
            // A placeholder with the ray's origin and reciprocal (the backends read those
            // before `finish`); the axes and shear are `finish`'s, for rays that enter the root.
            w: WatertightRay::with_inverse(ray.origin, sahara_geom::Vec3A::Z, ray.inv_direction()),
            order_q,
            order_xor,
            dir: ray.direction().to_array(),
        }
    }

    /// Computes the watertight test's constants (three divisions: done only for rays that
    /// enter the root box).
    #[inline(always)]
    pub(crate) fn finish(&mut self, ray: &Ray) {
        self.w = ray.watertight();
    }

    /// The robust slab test of one box given as `[min_x, max_x, min_y, max_y, min_z, max_z]`,
    /// against `[box_tmin, tfar]`: the scalar definition every SIMD box test reproduces lane
    /// by lane, and the operations of [`intersect_aabb`](sahara_geom::intersect::intersect_aabb).
    /// Returns the entry distance. `NEG` (rays with `tmin < 0`) also makes negative far
    /// distances conservative: `maxps(d · inv_far, d · inv_far_neg)`.
    #[inline(always)]
    pub(crate) fn slab<const NEG: bool>(&self, b: [f32; 6], tfar: f32) -> Option<f32> {
        let mut near = self.box_tmin;
        let mut far = tfar;
        for a in 0..3 {
            let tn = (b[self.near_row[a]] - self.origin[a]) * self.inv[a];
            let d = b[self.far_row[a]] - self.origin[a];
            let mut tf = d * self.inv_far[a];
            if NEG {
                // `maxps(tf, tf_neg)`.
                let tf_neg = d * self.inv_far_neg[a];
                tf = if tf > tf_neg { tf } else { tf_neg };
            }
            // `maxps(tn, near)` / `minps(tf, far)`: a NaN slab distance is ignored.
            near = if tn > near { tn } else { near };
            far = if tf < far { tf } else { far };
        }
        // Test-only (issue 46): `--cfg sahara_planted_bug="kernel"` flips this comparison
        // (boxes the ray only touches are missed), which the fuzzers must find. Normal builds
        // fold it away.
        let touches = if cfg!(sahara_planted_bug = "kernel") {
            near < far
        } else {
            near <= far
        };
        if touches {
            Some(near)
        } else {
            None
        }
    }
}

/// Hits of a 4-triangle packet found by a SIMD triangle test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PacketHits {
    pub(crate) t: [f32; 4],
    pub(crate) u: [f32; 4],
    pub(crate) v: [f32; 4],
}

/// Box and triangle tests of one backend.
pub(crate) trait Kernel<const W: usize> {
    /// The ray in the backend's registers.
    type Ray: Copy;

    /// The shape of the closest-hit loop ([`closest_hit`]), a code-generation choice only
    /// (both visit the same nodes in the same order): `true` nests a loop over inner nodes
    /// inside the loop over leaves, so the box test's constants, which the leaf test evicts
    /// from the registers, are reloaded only after a leaf (fewer instructions per ray with the
    /// 16 registers of AVX2); `false` is one flat loop (fewer with SSE2, measured).
    const NESTED_LOOPS: bool = false;

    /// Prepares the ray.
    ///
    /// # Safety
    /// The backend's CPU features must be present.
    unsafe fn prepare(r: &RayData) -> Self::Ray;

    /// Tests the `W` child boxes of `node` against `[box_tmin, tfar]` exactly as
    /// [`RayData::slab`] does; returns the mask of boxes hit (never an unused slot: its box is
    /// empty) and writes the entry distances to `dist`.
    ///
    /// # Safety
    /// As for [`Kernel::prepare`].
    unsafe fn intersect_node<const NEG: bool>(
        node: &WideNode<W>,
        r: &Self::Ray,
        rd: &RayData,
        tfar: f32,
        dist: &mut [f32; W],
    ) -> u32;

    /// Tests a packet against `[tmin, tmax]` of the ray, returning `(hit mask, fallback mask)`:
    /// lanes of the hit mask are the hits of [`intersect_triangle`] (its `f32` path,
    /// [`accept_hit`](sahara_geom::intersect::accept_hit)
    /// included) with `t <= tfar`, and their `t`, `u`, `v` (bit for bit those of
    /// [`intersect_triangle`]) are written to `out` when the mask is not zero; lanes of the
    /// fallback mask (an edge function exactly zero) must be tested with
    /// [`intersect_triangle`]. `NEG` as for [`Kernel::intersect_node`].
    ///
    /// # Safety
    /// As for [`Kernel::prepare`].
    unsafe fn intersect_packet<const NEG: bool>(
        p: &TriPacket,
        r: &Self::Ray,
        rd: &RayData,
        tfar: f32,
        out: &mut PacketHits,
    ) -> (u32, u32);

    /// [`descend_ordered`]: pushes the children in `mask` in the node's order for the ray's
    /// octant and returns the nearest (a backend may do it in SIMD registers).
    ///
    /// # Safety
    /// As for [`Kernel::prepare`].
    #[inline(always)]
    unsafe fn descend<St: Stack>(
        node: &WideNode<W>,
        mask: u32,
        dist: &[f32; W],
        rd: &RayData,
        stack: &mut St,
    ) -> Option<u32> {
        descend_ordered(node, mask, dist, rd, stack)
    }

    /// Any-hit version of [`Kernel::intersect_packet`]: `(hit mask, fallback mask)`.
    ///
    /// # Safety
    /// As for [`Kernel::prepare`].
    unsafe fn occlude_packet<const NEG: bool>(
        p: &TriPacket,
        r: &Self::Ray,
        rd: &RayData,
    ) -> (u32, u32);
}

/// A traversal stack entry: a child reference and its entry distance (`repr(C)`: the AVX2
/// descent writes entries as pairs of 32-bit lanes).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    pub(crate) child: u32,
    pub(crate) dist: f32,
}

/// The traversal stack.
pub(crate) trait Stack {
    fn push(&mut self, e: Entry);
    /// Writes `e` above the top and keeps it when `keep` (branch-free for [`FixedStack`]: the
    /// entry is written either way and overwritten by the next push when not kept; the tree's
    /// stack bound counts that extra slot).
    fn push_if(&mut self, e: Entry, keep: bool);
    /// Room for `n` entries above the top: where to write them (then [`Stack::grow`]).
    fn spare(&mut self, n: usize) -> *mut Entry;
    /// Keeps `n` entries written above the top after [`Stack::spare`].
    ///
    /// # Safety
    /// `spare(m)` with `m >= n` was called since the last change of the stack, and the `n`
    /// entries were written.
    unsafe fn grow(&mut self, n: usize);
    fn pop(&mut self) -> Option<Entry>;
    /// The last `n` entries, mutable (for sorting them).
    fn top_mut(&mut self, n: usize) -> &mut [Entry];
}

/// Capacity of [`FixedStack`].
pub(crate) const FIXED_STACK: usize = 256;

/// Storage of a [`FixedStack`]: declare it as a separate local (`FixedStack::buffer()`); a
/// `MaybeUninit` field built inside an aggregate gets zero-filled by rustc, 2 KiB per ray.
pub(crate) type StackBuffer = MaybeUninit<[Entry; FIXED_STACK]>;

/// A stack in an uninitialised array on the call stack, used for trees whose stack bound
/// fits.
pub(crate) struct FixedStack<'a> {
    data: &'a mut StackBuffer,
    len: usize,
}

impl<'a> FixedStack<'a> {
    #[inline(always)]
    pub(crate) fn buffer() -> StackBuffer {
        MaybeUninit::uninit()
    }

    #[inline(always)]
    pub(crate) fn new(data: &'a mut StackBuffer) -> Self {
        Self { data, len: 0 }
    }

    #[inline(always)]
    fn ptr(&mut self) -> *mut Entry {
        self.data.as_mut_ptr().cast::<Entry>()
    }
}

impl Stack for FixedStack<'_> {
    #[inline(always)]
    fn push(&mut self, e: Entry) {
        // The tree's stack bound was checked against the capacity before choosing this stack;
        // the check stays as a (predictable, never taken) guard for memory safety.
        if self.len >= FIXED_STACK {
            overflow();
        }
        // SAFETY: `len < FIXED_STACK`.
        unsafe { self.ptr().add(self.len).write(e) };
        self.len += 1;
    }

    #[inline(always)]
    fn push_if(&mut self, e: Entry, keep: bool) {
        if self.len >= FIXED_STACK {
            overflow();
        }
        // SAFETY: `len < FIXED_STACK`.
        unsafe { self.ptr().add(self.len).write(e) };
        self.len += keep as usize;
    }

    #[inline(always)]
    fn spare(&mut self, n: usize) -> *mut Entry {
        if self.len + n > FIXED_STACK {
            overflow();
        }
        // SAFETY: `len + n <= FIXED_STACK`.
        unsafe { self.ptr().add(self.len) }
    }

    #[inline(always)]
    unsafe fn grow(&mut self, n: usize) {
        self.len += n;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push`.
        Some(unsafe { self.ptr().add(self.len).read() })
    }

    #[inline(always)]
    fn top_mut(&mut self, n: usize) -> &mut [Entry] {
        assert!(n <= self.len);
        let start = self.len - n;
        // SAFETY: entries below `len` are initialised, and `start..len` is in bounds.
        unsafe { std::slice::from_raw_parts_mut(self.ptr().add(start), n) }
    }
}

#[cold]
#[inline(never)]
fn overflow() -> ! {
    panic!("wide BVH traversal stack overflow (stack bound computed wrongly)")
}

/// A heap stack for trees too deep for [`FixedStack`].
pub(crate) struct VecStack(pub(crate) Vec<Entry>);

impl Stack for VecStack {
    #[inline]
    fn push(&mut self, e: Entry) {
        self.0.push(e);
    }
    #[inline]
    fn push_if(&mut self, e: Entry, keep: bool) {
        if keep {
            self.0.push(e);
        }
    }
    #[inline]
    fn spare(&mut self, n: usize) -> *mut Entry {
        self.0.reserve(n);
        // SAFETY: the capacity is at least `len + n`.
        unsafe { self.0.as_mut_ptr().add(self.0.len()) }
    }
    #[inline]
    unsafe fn grow(&mut self, n: usize) {
        // SAFETY: the caller wrote `n` entries within the reserved capacity.
        unsafe { self.0.set_len(self.0.len() + n) };
    }
    #[inline]
    fn pop(&mut self) -> Option<Entry> {
        self.0.pop()
    }
    #[inline]
    fn top_mut(&mut self, n: usize) -> &mut [Entry] {
        let len = self.0.len();
        &mut self.0[len - n..]
    }
}

/// The lowest set lane of a non-zero mask of `W` lanes (`W` a power of two), masked so that
/// indexing `[_; W]` arrays needs no bounds check.
#[inline(always)]
fn lane<const W: usize>(mask: u32) -> usize {
    mask.trailing_zeros() as usize & (W - 1)
}

/// Sorts `e` by decreasing distance (insertion sort; at most `W` entries), so that the
/// nearest child ends on top of the stack.
#[inline(always)]
fn sort_far_to_near(e: &mut [Entry]) {
    for i in 1..e.len() {
        let x = e[i];
        let mut j = i;
        while j > 0 && e[j - 1].dist < x.dist {
            e[j] = e[j - 1];
            j -= 1;
        }
        e[j] = x;
    }
}

/// Tests the packets of a leaf, updating `best` and the culling distance `tfar`.
#[inline(always)]
unsafe fn leaf_closest<K: Kernel<W>, const W: usize, S: TraversalStats, const NEG: bool>(
    bvh: &WideBvh<W>,
    child: u32,
    kr: &K::Ray,
    rd: &RayData,
    best: &mut Hit,
    tfar: &mut f32,
    stats: &mut S,
) {
    stats.leaf();
    let (first, n) = decode_leaf(child);
    debug_assert!(first + n <= bvh.packets.len());
    // SAFETY: leaf references are built in bounds of `packets`.
    let packets = unsafe { bvh.packets.get_unchecked(first..first + n) };
    let mut out = PacketHits {
        t: [0.0; 4],
        u: [0.0; 4],
        v: [0.0; 4],
    };
    for (i, p) in packets.iter().enumerate() {
        stats.triangles(p.len());
        // SAFETY: forwarded from the caller.
        let (mut hits, mut fallback) =
            unsafe { K::intersect_packet::<NEG>(p, kr, rd, *tfar, &mut out) };
        while hits != 0 {
            let l = hits.trailing_zeros() as usize & 3;
            hits &= hits - 1;
            let prim = p.prims[l];
            if best.is_improved_by(out.t[l], prim) {
                *best = Hit {
                    t: out.t[l],
                    prim,
                    u: out.u[l],
                    v: out.v[l],
                };
                stats.closest_in_packet((first + i) as u32, l as u32);
                // The culling distance follows the best hit only (an accepted `t` is at most
                // `tmax`, so this is `widen(min(best.t, tmax))`), and only when it changes.
                debug_assert!(best.t <= rd.tmax);
                *tfar = widen(best.t);
            }
        }
        if fallback != 0 {
            while fallback != 0 {
                let l = fallback.trailing_zeros() as usize & 3;
                fallback &= fallback - 1;
                if scalar_lane(p, l, rd, best) {
                    stats.closest_in_packet((first + i) as u32, l as u32);
                }
            }
            *tfar = widen(best.t.min(rd.tmax));
        }
    }
}

/// The exact scalar test of one lane (for lanes with an edge function exactly zero); true
/// when it improved `best`.
#[cold]
#[inline(never)]
fn scalar_lane(p: &TriPacket, l: usize, rd: &RayData, best: &mut Hit) -> bool {
    let prim = p.prims[l];
    if let Some(h) = intersect_triangle(&rd.w, &p.triangle(l), rd.tmin, rd.tmax) {
        if best.is_improved_by(h.t, prim) {
            *best = Hit {
                t: h.t,
                prim,
                u: h.u,
                v: h.v,
            };
            return true;
        }
    }
    false
}

#[cold]
#[inline(never)]
fn scalar_lane_occluded(p: &TriPacket, l: usize, rd: &RayData) -> bool {
    intersect_triangle(&rd.w, &p.triangle(l), rd.tmin, rd.tmax).is_some()
}

/// The test of the root box (an early exit for rays that miss the scene): the vectorised
/// reference slab test [`intersect_aabb`](sahara_geom::intersect::intersect_aabb), which treats
/// negative far distances as the `NEG` kernels do (and for `tmin >= 0` they fail either way).
#[inline(always)]
fn enters_root<const W: usize>(bvh: &WideBvh<W>, ray: &Ray, rd: &RayData, tfar: f32) -> bool {
    sahara_geom::intersect::intersect_aabb(
        ray.origin,
        ray.inv_direction(),
        rd.box_tmin,
        tfar,
        &bvh.root_bounds,
    )
    .is_some()
}

/// Pushes the children of `node` in `mask` (their entry distances in `dist`) so that they are
/// popped near to far, and returns the nearest one, which is visited next (not pushed); `None`
/// for an empty mask.
#[inline(always)]
pub(crate) fn descend_closest<const W: usize, St: Stack>(
    node: &WideNode<W>,
    mut mask: u32,
    dist: &[f32; W],
    stack: &mut St,
) -> Option<u32> {
    debug_assert_eq!(mask & !node.valid, 0, "an unused slot's empty box was hit");
    if mask == 0 {
        return None;
    }
    let i0 = lane::<W>(mask);
    mask &= mask - 1;
    if mask == 0 {
        return Some(node.children[i0]);
    }
    let i1 = lane::<W>(mask);
    mask &= mask - 1;
    let e0 = Entry {
        child: node.children[i0],
        dist: dist[i0],
    };
    let e1 = Entry {
        child: node.children[i1],
        dist: dist[i1],
    };
    if mask == 0 {
        let (near, far) = if e1.dist < e0.dist {
            (e1, e0)
        } else {
            (e0, e1)
        };
        stack.push(far);
        return Some(near.child);
    }
    stack.push(e0);
    stack.push(e1);
    let mut n = 2;
    while mask != 0 {
        let i = lane::<W>(mask);
        mask &= mask - 1;
        stack.push(Entry {
            child: node.children[i],
            dist: dist[i],
        });
        n += 1;
    }
    sort_far_to_near(stack.top_mut(n));
    stack.pop().map(|e| e.child)
}

/// Pushes the children of `node` in `mask` so that they are popped near to far in the node's
/// stored order for the ray's octant (Fuetterling et al. 2017: the order of the child boxes'
/// centres along the octant's diagonal, precomputed by the collapse), and returns the nearest,
/// which is visited next (not pushed); `None` for an empty mask. Unlike [`descend_closest`] it
/// does not sort by entry distance: the push is a branch-free pass over the `W` slots. The
/// order only changes the speed: closest-hit culling still uses each child's own entry
/// distance, and hits are compared with `Hit::is_improved_by`.
#[inline(always)]
pub(crate) fn descend_ordered<const W: usize, St: Stack>(
    node: &WideNode<W>,
    mask: u32,
    dist: &[f32; W],
    rd: &RayData,
    stack: &mut St,
) -> Option<u32> {
    debug_assert_eq!(mask & !node.valid, 0, "an unused slot's empty box was hit");
    if mask == 0 {
        return None;
    }
    let i0 = lane::<W>(mask);
    let rest = mask & (mask - 1);
    if rest == 0 {
        return Some(node.children[i0]);
    }
    if rest & (rest - 1) == 0 {
        // Two children: the nearer by entry distance (one comparison, no pass over the slots).
        let i1 = lane::<W>(rest);
        let (near, far) = if dist[i1] < dist[i0] {
            (i1, i0)
        } else {
            (i0, i1)
        };
        stack.push(Entry {
            child: node.children[far],
            dist: dist[far],
        });
        return Some(node.children[near]);
    }
    let p = node.order_bits(rd.order_q);
    let x = rd.order_xor & (W - 1);
    for i in 0..W {
        let s = (p >> (3 * (i ^ x))) as usize & (W - 1);
        stack.push_if(
            Entry {
                child: node.children[s],
                dist: dist[s],
            },
            (mask >> s) & 1 != 0,
        );
    }
    stack.pop().map(|e| e.child)
}

/// Pushes the children of `node` in `mask` but the first, which is returned (any-hit
/// traversal: no order).
#[inline(always)]
pub(crate) fn descend_any<const W: usize, St: Stack>(
    node: &WideNode<W>,
    mut mask: u32,
    stack: &mut St,
) -> Option<u32> {
    debug_assert_eq!(mask & !node.valid, 0, "an unused slot's empty box was hit");
    if mask == 0 {
        return None;
    }
    let i = lane::<W>(mask);
    mask &= mask - 1;
    while mask != 0 {
        let j = lane::<W>(mask);
        mask &= mask - 1;
        stack.push(Entry {
            child: node.children[j],
            dist: 0.0,
        });
    }
    Some(node.children[i])
}

/// The first step of a traversal: the test of the root node's children (or, for a tree that
/// is a single leaf, of the root box). Returns the node to visit next (children to visit later
/// are pushed), or `None` when the ray misses the scene. It runs before the watertight
/// constants are computed ([`RayData::finish`]), which rays that miss the scene never need.
///
/// # Safety
/// As for [`closest_hit`].
#[inline(always)]
pub(crate) unsafe fn enter<
    K: Kernel<W>,
    const W: usize,
    S: TraversalStats,
    St: Stack,
    const NEG: bool,
>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    rd: &RayData,
    tfar: f32,
    closest: bool,
    stats: &mut S,
    stack: &mut St,
) -> Option<u32> {
    let root = bvh.root;
    if root & LEAF_BIT != 0 {
        return enters_root(bvh, ray, rd, tfar).then_some(root);
    }
    stats.inner();
    debug_assert!((root as usize) < bvh.nodes.len());
    // SAFETY: inner references are built in bounds of `nodes`.
    let node = unsafe { bvh.nodes.get_unchecked(root as usize) };
    let mut dist = [0.0f32; W];
    // SAFETY: forwarded from the caller; the box tests need only the box constants of `rd`.
    let mask = unsafe {
        let kr = K::prepare(rd);
        K::intersect_node::<NEG>(node, &kr, rd, tfar, &mut dist)
    };
    if closest {
        // SAFETY: forwarded from the caller.
        unsafe { K::descend(node, mask, &dist, rd, stack) }
    } else {
        descend_any(node, mask, stack)
    }
}

/// Closest-hit traversal.
///
/// # Safety
/// The kernel's CPU features must be present; `St` must hold `bvh.max_stack` entries.
#[inline(always)]
pub(crate) unsafe fn closest_hit<
    K: Kernel<W>,
    const W: usize,
    S: TraversalStats,
    St: Stack,
    const NEG: bool,
>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
    stack: &mut St,
) -> Hit {
    let mut best = Hit::MISS;
    if bvh.root == NO_ROOT || !ray.is_valid() {
        return best;
    }
    let mut rd = RayData::new(ray);
    // Culling distance: the nearest hit so far (or tmax), widened.
    let mut tfar = widen(rd.tmax);
    // SAFETY: forwarded from the caller.
    let Some(mut cur) =
        (unsafe { enter::<K, W, S, St, NEG>(bvh, ray, &rd, tfar, true, stats, stack) })
    else {
        return best;
    };
    rd.finish(ray);
    // SAFETY: forwarded from the caller.
    let kr = unsafe { K::prepare(&rd) };
    let mut dist = [0.0f32; W];
    if !K::NESTED_LOOPS {
        loop {
            if cur & LEAF_BIT != 0 {
                // SAFETY: forwarded.
                unsafe {
                    leaf_closest::<K, W, S, NEG>(bvh, cur, &kr, &rd, &mut best, &mut tfar, stats)
                };
            } else {
                stats.inner();
                debug_assert!((cur as usize) < bvh.nodes.len());
                // SAFETY: inner references are built in bounds of `nodes`.
                let node = unsafe { bvh.nodes.get_unchecked(cur as usize) };
                // SAFETY: forwarded.
                let mask = unsafe { K::intersect_node::<NEG>(node, &kr, &rd, tfar, &mut dist) };
                // SAFETY: forwarded.
                if let Some(next) = unsafe { K::descend(node, mask, &dist, &rd, stack) } {
                    cur = next;
                    continue;
                }
            }
            match pop_closest(stack, tfar) {
                Some(next) => cur = next,
                None => return best,
            }
        }
    }
    // Two nested loops: the inner one descends through inner nodes (popping after a node
    // without a hit child), the outer one tests a leaf and pops. So the node loop is a loop of
    // its own, and the box test's constants, which the leaf test's registers evict, are
    // reloaded only when a leaf was tested, not after every pop.
    loop {
        while cur & LEAF_BIT == 0 {
            stats.inner();
            debug_assert!((cur as usize) < bvh.nodes.len());
            // SAFETY: inner references are built in bounds of `nodes`.
            let node = unsafe { bvh.nodes.get_unchecked(cur as usize) };
            // SAFETY: forwarded.
            let mask = unsafe { K::intersect_node::<NEG>(node, &kr, &rd, tfar, &mut dist) };
            // SAFETY: forwarded.
            cur = match unsafe { K::descend(node, mask, &dist, &rd, stack) } {
                Some(next) => next,
                None => match pop_closest(stack, tfar) {
                    Some(next) => next,
                    None => return best,
                },
            };
        }
        // SAFETY: forwarded.
        unsafe { leaf_closest::<K, W, S, NEG>(bvh, cur, &kr, &rd, &mut best, &mut tfar, stats) };
        match pop_closest(stack, tfar) {
            Some(next) => cur = next,
            None => return best,
        }
    }
}

/// Pops the next child that may still hold a nearer hit (entry distance at most `tfar`);
/// `None` when the stack is empty.
#[inline(always)]
fn pop_closest<St: Stack>(stack: &mut St, tfar: f32) -> Option<u32> {
    loop {
        let e = stack.pop()?;
        if e.dist <= tfar {
            return Some(e.child);
        }
    }
}

/// Any-hit traversal.
///
/// # Safety
/// As for [`closest_hit`].
#[inline(always)]
pub(crate) unsafe fn any_hit<
    K: Kernel<W>,
    const W: usize,
    S: TraversalStats,
    St: Stack,
    const NEG: bool,
>(
    bvh: &WideBvh<W>,
    ray: &Ray,
    stats: &mut S,
    stack: &mut St,
) -> bool {
    if bvh.root == NO_ROOT || !ray.is_valid() {
        return false;
    }
    let mut rd = RayData::new(ray);
    let tfar = widen(rd.tmax);
    // SAFETY: forwarded from the caller.
    let Some(mut cur) =
        (unsafe { enter::<K, W, S, St, NEG>(bvh, ray, &rd, tfar, false, stats, stack) })
    else {
        return false;
    };
    rd.finish(ray);
    // SAFETY: forwarded from the caller.
    let kr = unsafe { K::prepare(&rd) };
    let mut dist = [0.0f32; W];
    loop {
        if cur & LEAF_BIT != 0 {
            stats.leaf();
            let (first, n) = decode_leaf(cur);
            debug_assert!(first + n <= bvh.packets.len());
            // SAFETY: leaf references are built in bounds of `packets`.
            let packets = unsafe { bvh.packets.get_unchecked(first..first + n) };
            for p in packets {
                stats.triangles(p.len());
                // SAFETY: forwarded.
                let (hits, mut fallback) = unsafe { K::occlude_packet::<NEG>(p, &kr, &rd) };
                if hits != 0 {
                    return true;
                }
                while fallback != 0 {
                    let l = fallback.trailing_zeros() as usize & 3;
                    fallback &= fallback - 1;
                    if scalar_lane_occluded(p, l, &rd) {
                        return true;
                    }
                }
            }
        } else {
            stats.inner();
            debug_assert!((cur as usize) < bvh.nodes.len());
            // SAFETY: inner references are built in bounds of `nodes`.
            let node = unsafe { bvh.nodes.get_unchecked(cur as usize) };
            // SAFETY: forwarded.
            let mask = unsafe { K::intersect_node::<NEG>(node, &kr, &rd, tfar, &mut dist) };
            if let Some(next) = descend_any(node, mask, stack) {
                cur = next;
                continue;
            }
        }
        match stack.pop() {
            None => return false,
            Some(e) => cur = e.child,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    /// A node whose 8 children are unit boxes on a diagonal line, in a shuffled slot order:
    /// for every octant, the ordered descent visits them nearest first along the ray.
    #[test]
    fn ordered_descent_is_near_to_far_in_every_octant() {
        let mut node = WideNode::<8>::EMPTY;
        let place = [3usize, 7, 0, 5, 1, 6, 2, 4];
        for (s, &k) in place.iter().enumerate() {
            let c = k as f32 * 2.0;
            let rows = [c, c + 1.0, c, c + 1.0, c, c + 1.0];
            for (row, v) in node.bounds.iter_mut().zip(rows) {
                row[s] = v;
            }
            node.children[s] = s as u32;
            node.valid |= 1 << s;
        }
        node.set_order();
        for oct in 0..8u32 {
            let d = Vec3A::new(
                if oct & 1 != 0 { -1.0 } else { 1.0 },
                if oct & 2 != 0 { -1.0 } else { 1.0 },
                if oct & 4 != 0 { -1.0 } else { 1.0 },
            );
            let ray = Ray::new(Vec3A::ZERO, d, 0.0, f32::INFINITY);
            let rd = RayData::new(&ray);
            let key = |s: u32| place[s as usize] as f32 * d.dot(Vec3A::ONE);
            // Entry distances consistent with the geometry (two hits are ordered by them).
            let dist: [f32; 8] = std::array::from_fn(|s| 100.0 + key(s as u32));
            for mask in [0xffu32, 0b1010_0110, 0b0001_1000] {
                let mut buf = FixedStack::buffer();
                let mut st = FixedStack::new(&mut buf);
                let mut seen = vec![descend_ordered(&node, mask, &dist, &rd, &mut st).unwrap()];
                while let Some(e) = st.pop() {
                    seen.push(e.child);
                }
                assert_eq!(seen.len(), mask.count_ones() as usize, "octant {oct}");
                assert!(seen.iter().all(|&s| mask & (1 << s) != 0));
                assert!(
                    seen.windows(2).all(|w| key(w[0]) <= key(w[1])),
                    "octant {oct}, mask {mask:#x}: {seen:?}"
                );
            }
        }
    }
}
