//! Wide BVHs (4 and 8 children per node) and their SIMD traversal kernels.
//!
//! [`WideBvh::from_bvh`] collapses a binary [`Bvh`] into a tree whose nodes hold the bounds of
//! up to `W` children as structure-of-arrays (`min_x[W]`, `max_x[W]`, … so that one SIMD pass
//! tests all children), and whose leaves hold triangles in packets of 4 (vertices stored SoA,
//! padded with NaN lanes that never hit). [`Bvh4`] and [`Bvh8`] are the two supported widths.
//!
//! **Collapse.** The SAH-optimal collapse of Ylitie, Karras and Laine (2017, "Efficient
//! incoherent ray traversal on GPUs through compressed wide BVHs"): a dynamic program over the
//! binary tree computes, for every binary node and every number of child slots `1..=W` it may
//! take in its wide parent, the least SAH cost of its subtree — as one leaf over the whole
//! subtree (at most 8 packets), as a wide node, or distributed over several slots — and the
//! wide tree is read off the optimum. The cost model counts a wide node test as 1, a leaf
//! visit as 0.5 plus 0.5 per packet of 4 triangles. It is deterministic (fixed tie-breaks), and
//! the wide tree depends on the binary tree only (not on the CPU). A binary leaf with more
//! than 32 references becomes a small subtree of leaves (sorted along the leaf's longest
//! axis). Every triangle keeps its original index, and spatial-split trees (a triangle in
//! several leaves) are supported.
//!
//! **Kernels.** Closest hit and any hit, stack-based. Closest-hit traversal visits the hit
//! children near to far in an order fixed per ray octant (Fuetterling et al. 2017, as in
//! tinybvh's `BVH8_CPU` and Ylitie et al.'s CWBVH): the collapse stores in each node the order
//! of its children's centres along the diagonals of four octants (the other four read them
//! backwards), so the descent needs no distance sort: two hit children are ordered by their
//! entry distances, three or more are pushed in the stored order (branch-free; with AVX2 a lane
//! permutation and two 256-bit stores). Any-hit traversal visits them in slot order. Four backends share the traversal code
//! ([`Backend`]): AVX-512 (the AVX2 kernels with AVX-512F/VL enabled: 256-bit vectors, mask
//! registers, 32 vector registers), AVX2 (8-wide `f32` box tests with 256-bit registers), SSE2
//! (4-wide; an 8-wide node is tested in two halves) and a portable scalar implementation of the
//! same layout, used where no SIMD path exists. The best one available is chosen once, at run time, with
//! `is_x86_feature_detected!` ([`simd_backend`]).
//!
//! **Exactness.** Every backend returns bit-identical results:
//!
//! * the box test is the robust slab test of [`intersect_aabb`] (far planes use the reciprocal
//!   direction scaled by [`ROBUST_FAR_SCALE`], precomputed per ray with [`far_factors`]; NaN
//!   slab distances ignored), evaluated with the same operations in the same order; the near and far planes are picked by the sign of the reciprocal direction,
//!   which gives the same distances as `min`/`max` of the two slab distances but keeps a NaN
//!   slab distance (origin on a slab plane, zero direction component) out of both the near and
//!   the far distance, so such rays are never culled;
//! * the triangle test evaluates the watertight test of [`intersect_triangle`] lane by lane
//!   with the same `f32` operations in the same order (no FMA contraction), and hands any lane
//!   where an edge function is exactly zero (the case where the reference falls back to `f64`)
//!   to [`intersect_triangle`] itself. So `t`, `u`, `v` and the primitive are those of the
//!   reference kernel [`crate::scalar::closest_hit`];
//! * candidate triangles are accepted against the ray's own `[tmin, tmax]`, must pass
//!   [`accept_hit`] (the SIMD backends evaluate its bounds test on all lanes of a packet with
//!   the operations of [`intersect_aabb`]; degenerate triangles, which it always rejects, are
//!   stored as NaN lanes that never hit), and are then compared with [`Hit::is_improved_by`],
//!   so the result does not depend on the order in which leaves are visited (equal distances:
//!   lowest primitive index);
//! * boxes are tested against `[lower_distance(tmin), cull_distance(min(best t, tmax))]` (the
//!   interval widened by 2^-16 of itself at both ends), and rays with `tmin < 0` also make
//!   negative far distances conservative (`× (1 - 2γ(3))`). Because [`accept_hit`] only admits
//!   a hit whose triangle's own bounds pass that same slab test, and the computed slab
//!   distances are monotonic in the box, no box containing a hit triangle is ever culled.
//!
//! So every kernel, the scalar reference included, returns the brute-force result
//! ([`crate::brute`]) bit for bit.
//!
//! Invalid rays ([`Ray::is_valid`]) miss.
//!
//! [`intersect_aabb`]: sahara_geom::intersect::intersect_aabb
//! [`intersect_triangle`]: sahara_geom::intersect::intersect_triangle
//! [`accept_hit`]: sahara_geom::intersect::accept_hit
//! [`ROBUST_FAR_SCALE`]: sahara_geom::intersect::ROBUST_FAR_SCALE
//! [`far_factors`]: sahara_geom::intersect::far_factors
//!
//! ```
//! use sahara_bvh::{Bvh, Node};
//! use sahara_geom::{Ray, Triangle, Vec3A};
//! use sahara_traverse::{scalar, Backend, Bvh8, NoStats};
//!
//! let tris = [Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0))];
//! let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
//! let wide = Bvh8::from_bvh(&bvh, &tris);
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, f32::INFINITY);
//! let hit = wide.closest_hit(&ray, &mut NoStats);
//! assert_eq!(hit, scalar::closest_hit(&bvh, &tris, &ray, &mut NoStats));
//! assert_eq!(hit, wide.closest_hit_with(Backend::Portable, &ray, &mut NoStats));
//! assert!(wide.any_hit(&ray, &mut NoStats));
//! ```

mod collapse;
mod custom;
#[macro_use]
mod kernel;
mod memory;
mod portable;
#[cfg(target_arch = "x86_64")]
mod x86;

use crate::{Hit, Precision, TraversalStats};
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Ray, Triangle};
use std::fmt;

/// A 4-wide BVH (SSE2 kernels on x86-64).
pub type Bvh4 = WideBvh<4>;
/// An 8-wide BVH (AVX2 kernels when the CPU has AVX2 and FMA).
pub type Bvh8 = WideBvh<8>;

/// Marks a leaf in a child reference: `1 << 31 | (packets - 1) << 28 | first packet`.
pub(crate) const LEAF_BIT: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 28;
const LEAF_FIRST_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
/// Most packets (of 4 triangles) in one leaf.
pub(crate) const MAX_LEAF_PACKETS: usize = 8;

#[inline(always)]
pub(crate) fn encode_leaf(first: usize, packets: usize) -> u32 {
    debug_assert!((1..=MAX_LEAF_PACKETS).contains(&packets));
    debug_assert!(first <= LEAF_FIRST_MASK as usize);
    LEAF_BIT | ((packets as u32 - 1) << LEAF_COUNT_SHIFT) | first as u32
}

/// `(first packet, number of packets)` of a leaf reference.
#[inline(always)]
pub(crate) fn decode_leaf(child: u32) -> (usize, usize) {
    (
        (child & LEAF_FIRST_MASK) as usize,
        (((child >> LEAF_COUNT_SHIFT) & 7) + 1) as usize,
    )
}

/// An inner node of a [`WideBvh`]: the bounds of up to `W` children as structure of arrays
/// (rows `min_x, max_x, min_y, max_y, min_z, max_z`, `W` lanes each) and the children.
///
/// A child is either an inner node (its index) or a leaf (`1 << 31`, the number of packets
/// minus one in bits 28–30, the first packet in bits 0–27). Slots whose bit is clear in
/// `valid` are unused; they hold an empty box (minimum `+∞`, maximum `-∞`), whose near slab
/// distance is `+∞` and far slab distance `-∞` on every axis for every valid ray, so the box
/// tests reject them without a mask. `order` holds the near-to-far order of the slots for four
/// ray octants (`WideNode::order_bits`), in what was padding. 64-byte aligned: 128 bytes for
/// `W = 4`, 256 bytes for `W = 8`.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode<const W: usize> {
    pub(crate) bounds: [[f32; W]; 6],
    pub(crate) children: [u32; W],
    pub(crate) valid: u32,
    pub(crate) order: [u16; W],
}

const _: () = assert!(std::mem::size_of::<WideNode<4>>() == 128);
const _: () = assert!(std::mem::size_of::<WideNode<8>>() == 256);

/// An integer whose order is [`f64::total_cmp`]'s: negative values (sign bit set) have their
/// other bits flipped, so that larger magnitudes come first.
fn total_order(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

impl<const W: usize> WideNode<W> {
    pub(crate) const EMPTY: Self = Self {
        bounds: [
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        children: [u32::MAX; W],
        valid: 0,
        order: [0; W],
    };

    /// The near-to-far order of the slots for the rays of octant class `q` (`0..4`: the sign
    /// bits of the direction's x and y components, z non-negative), as `W` slot numbers of 3
    /// bits, nearest in the lowest bits. The octant with all three signs flipped uses the
    /// same order backwards. Used slots come first; the order is that of the child boxes'
    /// centres projected on the octant's diagonal `(±1, ±1, 1)` (ties: lower slot first), so it
    /// is only a guess of the entry order, and only the speed of traversal depends on it.
    #[inline(always)]
    pub(crate) fn order_bits(&self, q: usize) -> u32 {
        if W == 8 {
            u32::from(self.order[(2 * q) & (W - 1)])
                | u32::from(self.order[(2 * q + 1) & (W - 1)]) << 16
        } else {
            u32::from(self.order[q & (W - 1)])
        }
    }

    /// Computes [`WideNode::order_bits`] from the bounds (after the collapse or a refit).
    pub(crate) fn set_order(&mut self) {
        // Octant class `q` takes bits `4 W q ..` of the `16 W`-bit field.
        let mut bits: u128 = 0;
        for q in 0..4 {
            let sign = [
                if q & 1 != 0 { -1.0 } else { 1.0 },
                if q & 2 != 0 { -1.0 } else { 1.0 },
                1.0f64,
            ];
            let key = |s: usize| -> f64 {
                if self.valid & (1 << s) == 0 {
                    return f64::INFINITY;
                }
                (0..3)
                    .map(|a| {
                        sign[a] * (self.bounds[2 * a][s] as f64 + self.bounds[2 * a + 1][s] as f64)
                    })
                    .sum()
            };
            // The slots sorted by `(key.total_cmp, slot)`, by rank and without a branch on the
            // keys (a comparison sort of 8 keys, recomputing them, cost a tenth of the
            // collapse): `total_order` maps `total_cmp` to the integers' order.
            let keys: [i64; W] = std::array::from_fn(|s| total_order(key(s)));
            let mut p = 0u128;
            for (s, &k) in keys.iter().enumerate() {
                let rank: usize = keys
                    .iter()
                    .enumerate()
                    .map(|(t, &o)| ((o < k) | ((o == k) & (t < s))) as usize)
                    .sum();
                p |= (s as u128) << (3 * rank);
            }
            bits |= p << (4 * W * q);
        }
        for (i, o) in self.order.iter_mut().enumerate() {
            *o = (bits >> (16 * i)) as u16;
        }
    }

    /// Number of used child slots.
    #[inline]
    pub fn child_count(&self) -> usize {
        self.valid.count_ones() as usize
    }

    /// Bounds of child slot `i` (meaningless for an unused slot).
    pub fn child_bounds(&self, i: usize) -> Aabb {
        let b = &self.bounds;
        Aabb::new(
            sahara_geom::Vec3A::new(b[0][i], b[2][i], b[4][i]),
            sahara_geom::Vec3A::new(b[1][i], b[3][i], b[5][i]),
        )
    }
}

/// Four triangles prepared for a SIMD watertight test: vertices as `v[vertex][axis][lane]`
/// and the original primitive index of each lane (`u32::MAX` and NaN vertices in padding
/// lanes, which never hit).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TriPacket {
    pub(crate) v: [[[f32; 4]; 3]; 3],
    pub(crate) prims: [u32; 4],
}

impl TriPacket {
    /// The triangle of lane `lane`, exactly as given to the builder.
    #[inline]
    pub(crate) fn triangle(&self, lane: usize) -> Triangle {
        let p = |k: usize| {
            sahara_geom::Vec3A::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane])
        };
        Triangle::new(p(0), p(1), p(2))
    }

    /// Number of real (non-padding) triangles.
    #[inline(always)]
    pub(crate) fn len(&self) -> u32 {
        self.prims.iter().filter(|&&p| p != u32::MAX).count() as u32
    }
}

/// A BVH with `W` children per inner node (`W` = 4 or 8) and leaves of SIMD triangle packets.
///
/// Built from a binary [`Bvh`] with [`WideBvh::from_bvh`]; traversed with
/// [`WideBvh::closest_hit`] and [`WideBvh::any_hit`], which give exactly the results of the
/// scalar reference kernels (see the [module documentation](self)).
#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize> {
    pub(crate) nodes: memory::HugeSlice<WideNode<W>>,
    pub(crate) packets: memory::HugeSlice<TriPacket>,
    /// The root: a node index, a leaf reference, or `u32::MAX` for an empty tree.
    pub(crate) root: u32,
    pub(crate) root_bounds: Aabb,
    /// Upper bound of the traversal stack depth.
    pub(crate) max_stack: usize,
    pub(crate) backend: Backend,
    /// The triangle test of the queries ([`WideBvh::set_precision`]).
    pub(crate) precision: Precision,
    /// The leaves' cut records, for trees collapsed from binary trees with
    /// [`Bvh::ref_cuts`] (refitting clips moved triangles as the builder did).
    pub(crate) cuts: Option<collapse::WideCuts>,
}

/// Empty-tree root marker.
pub(crate) const NO_ROOT: u32 = u32::MAX;

/// The body of [`WideBvh::closest_hit_with`] and [`WideBvh::any_hit_with`]: the entry point of
/// `backend` at the tree's precision (`[exact, fast]` per x86 backend, then the portable
/// function), falling back to the portable kernels when the CPU lacks the backend.
macro_rules! dispatch {
    ($bvh:expr, $backend:expr, $ray:expr, $stats:expr,
     [$avx512:ident, $avx512_fast:ident], [$avx2:ident, $avx2_fast:ident],
     [$sse2:ident, $sse2_fast:ident], $portable:ident) => {{
        let bvh = $bvh;
        let backend = $backend;
        let fast = bvh.precision == Precision::Fast;
        match backend {
            #[cfg(target_arch = "x86_64")]
            Backend::Avx512 if backend == bvh.backend || Backend::Avx512.is_available() => {
                // SAFETY: AVX2, FMA, AVX-512F and AVX-512VL are present (checked above or when
                // `bvh.backend` was chosen).
                unsafe {
                    if fast {
                        x86::$avx512_fast(bvh, $ray, $stats)
                    } else {
                        x86::$avx512(bvh, $ray, $stats)
                    }
                }
            }
            #[cfg(target_arch = "x86_64")]
            Backend::Avx2 if backend == bvh.backend || Backend::Avx2.is_available() => {
                // SAFETY: AVX2 and FMA are present (checked above or when `bvh.backend` was
                // chosen).
                unsafe {
                    if fast {
                        x86::$avx2_fast(bvh, $ray, $stats)
                    } else {
                        x86::$avx2(bvh, $ray, $stats)
                    }
                }
            }
            #[cfg(target_arch = "x86_64")]
            // SAFETY: SSE2 is part of x86-64.
            Backend::Sse2 => unsafe {
                if fast {
                    x86::$sse2_fast(bvh, $ray, $stats)
                } else {
                    x86::$sse2(bvh, $ray, $stats)
                }
            },
            _ if fast => portable::$portable::<W, S, true>(bvh, $ray, $stats),
            _ => portable::$portable::<W, S, false>(bvh, $ray, $stats),
        }
    }};
}

impl<const W: usize> WideBvh<W> {
    /// Collapses a binary BVH built over `tris` into a `W`-wide one (see the
    /// [module documentation](self) for the strategy). The triangles are copied into the leaf
    /// packets, so the wide tree does not borrow them; hits report indices into `tris`.
    ///
    /// # Panics
    ///
    /// If `W` is not 4 or 8, if `bvh` fails [`Bvh::validate_structure`], or if a leaf of
    /// `bvh` references a triangle outside `tris`.
    pub fn from_bvh(bvh: &Bvh, tris: &[Triangle]) -> Self {
        collapse::collapse(bvh, collapse::Source::Triangles(tris))
    }

    /// Closest hit with the fastest backend available for this width (see
    /// [`WideBvh::backend`]). Invalid rays miss.
    #[inline]
    pub fn closest_hit<S: TraversalStats>(&self, ray: &Ray, stats: &mut S) -> Hit {
        self.closest_hit_with(self.backend, ray, stats)
    }

    /// The triangle of the hit a closest-hit query of this tree recorded in `at` (passed as
    /// its statistics), read from the tree's leaf packets, which hold the vertices exactly as
    /// given: equal to the input triangle of [`Hit::prim`]. `None` when the query recorded no
    /// hit (a miss, or a query that does not record: the custom-primitive, filtered and
    /// instance traversals), or when `at` indexes past this tree's packets (a location from
    /// another tree is the caller's error; it can give another triangle of this one).
    #[inline]
    pub fn located_triangle(&self, at: &crate::HitLocation) -> Option<Triangle> {
        let (packet, lane) = at.get()?;
        Some(self.packets.get(packet)?.triangle(lane))
    }

    /// Any hit (occlusion): true when a triangle is hit in `[tmin, tmax]`, with the fastest
    /// backend available. Invalid rays miss.
    #[inline]
    pub fn any_hit<S: TraversalStats>(&self, ray: &Ray, stats: &mut S) -> bool {
        self.any_hit_with(self.backend, ray, stats)
    }

    /// Closest hit with a chosen backend; a backend this CPU lacks falls back to
    /// [`Backend::Portable`]. All backends give bit-identical results.
    #[inline]
    pub fn closest_hit_with<S: TraversalStats>(
        &self,
        backend: Backend,
        ray: &Ray,
        stats: &mut S,
    ) -> Hit {
        dispatch!(
            self,
            backend,
            ray,
            stats,
            [closest_hit_avx512, closest_hit_avx512_fast],
            [closest_hit_avx2, closest_hit_avx2_fast],
            [closest_hit_sse2, closest_hit_sse2_fast],
            closest_hit
        )
    }

    /// Any hit with a chosen backend; a backend this CPU lacks falls back to
    /// [`Backend::Portable`].
    #[inline]
    pub fn any_hit_with<S: TraversalStats>(
        &self,
        backend: Backend,
        ray: &Ray,
        stats: &mut S,
    ) -> bool {
        dispatch!(
            self,
            backend,
            ray,
            stats,
            [any_hit_avx512, any_hit_avx512_fast],
            [any_hit_avx2, any_hit_avx2_fast],
            [any_hit_sse2, any_hit_sse2_fast],
            any_hit
        )
    }

    /// The backend [`WideBvh::closest_hit`] and [`WideBvh::any_hit`] use:
    /// [`Backend::Avx512`] when the CPU has AVX2, FMA, AVX-512F and AVX-512VL, else
    /// [`Backend::Avx2`] when it has AVX2 and FMA, else [`Backend::Sse2`] on x86-64, else
    /// [`Backend::Portable`].
    #[inline]
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The triangle test of every query of this tree ([`Precision::Exact`] unless
    /// [`WideBvh::set_precision`] chose another).
    #[inline]
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// Chooses the triangle test of every query of this tree (a setting of the traced
    /// structure, as Embree's robust scene flag is of a scene). Each precision returns exactly
    /// the hits of its brute-force twin ([`crate::brute::closest_hit_at`]); the filtered and
    /// custom-primitive queries always use the exact test.
    ///
    /// ```
    /// use sahara_bvh::{Bvh, Node};
    /// use sahara_geom::{Ray, Triangle, Vec3A};
    /// use sahara_traverse::{brute, Bvh8, NoStats, Precision};
    ///
    /// let tris = [Triangle::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(1.0, -1.0, 2.0), Vec3A::new(0.0, 1.0, 2.0))];
    /// let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
    /// let mut wide = Bvh8::from_bvh(&bvh, &tris);
    /// wide.set_precision(Precision::Fast);
    /// let ray = Ray::new(Vec3A::new(0.1, 0.2, 0.0), Vec3A::Z, 0.0, f32::INFINITY);
    /// let hit = wide.closest_hit(&ray, &mut NoStats);
    /// assert_eq!(hit, brute::closest_hit_at(&tris, &ray, Precision::Fast));
    /// assert_eq!(hit.t, 2.0);
    /// ```
    #[inline]
    pub fn set_precision(&mut self, precision: Precision) {
        self.precision = precision;
    }

    /// The same tree with another [`WideBvh::set_precision`].
    #[inline]
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        self
    }

    /// Number of inner nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of leaf packets (of up to 4 triangles each).
    pub fn packet_count(&self) -> usize {
        self.packets.len()
    }

    /// Number of triangle references stored in the leaves (more than the number of triangles
    /// when the binary tree has spatial splits).
    pub fn reference_count(&self) -> usize {
        self.packets.iter().map(|p| p.len() as usize).sum()
    }

    /// The inner nodes (index 0 is the root unless the whole tree is one leaf).
    pub fn nodes(&self) -> &[WideNode<W>] {
        &self.nodes
    }

    /// Bytes used by the nodes and the packets.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode<W>>()
            + self.packets.len() * std::mem::size_of::<TriPacket>()
    }

    /// Bytes of the cut records a tree collapsed from a spatial-split tree keeps for refitting
    /// ([`Bvh::ref_cuts`]; traversal never reads them); 0 for other trees.
    ///
    /// ```
    /// use sahara_builders::{registry, BuildInput, CostModel};
    /// use sahara_geom::{Triangle, Vec3A};
    /// use sahara_traverse::Bvh8;
    ///
    /// // Long thin diagonal triangles: spatial splits cut them.
    /// let tris: Vec<Triangle> = (0..64)
    ///     .map(|i| {
    ///         let o = Vec3A::new(0.0, i as f32 * 0.1, 0.0);
    ///         Triangle::new(o, o + Vec3A::new(50.0, 50.0, 0.0), o + Vec3A::new(50.0, 50.05, 0.1))
    ///     })
    ///     .collect();
    /// let input = BuildInput::new(&tris, CostModel::default()).unwrap();
    /// let sbvh = registry::by_name("sbvh").unwrap().build(&input).unwrap();
    /// let binned = registry::by_name("binned").unwrap().build(&input).unwrap();
    /// assert!(Bvh8::from_bvh(&sbvh, &tris).cut_record_bytes() > 0);
    /// assert_eq!(Bvh8::from_bvh(&binned, &tris).cut_record_bytes(), 0);
    /// ```
    pub fn cut_record_bytes(&self) -> usize {
        self.cuts.as_ref().map_or(0, |c| c.memory_bytes())
    }

    /// Bounds of the whole tree (empty for an empty tree).
    pub fn bounds(&self) -> Aabb {
        self.root_bounds
    }

    /// A 64-bit fingerprint of the whole tree (FNV-1a over the bits of every node, packet,
    /// the root and its bounds), as [`Bvh::fingerprint`]: equal trees give equal
    /// fingerprints, and a change of any bound's or vertex's bit changes it with overwhelming
    /// probability (used to check that refitting unchanged triangles is the identity).
    pub fn fingerprint(&self) -> u64 {
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        self.for_each_word(|x| {
            for b in x.to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(PRIME);
            }
        });
        h
    }

    /// Every bit of the tree as 32-bit words, in a fixed order: the node count, each node's
    /// bounds, children, valid mask and orders, the packet count, each packet's vertices and
    /// primitive indices, the root and its bounds. What [`WideBvh::fingerprint`] hashes and
    /// `==` compares.
    fn for_each_word(&self, mut eat: impl FnMut(u32)) {
        eat(self.nodes.len() as u32);
        for n in self.nodes.iter() {
            n.bounds.iter().flatten().for_each(|f| eat(f.to_bits()));
            n.children.iter().for_each(|&c| eat(c));
            eat(n.valid);
            n.order.iter().for_each(|&o| eat(o.into()));
        }
        eat(self.packets.len() as u32);
        for p in self.packets.iter() {
            p.v.iter()
                .flatten()
                .flatten()
                .for_each(|f| eat(f.to_bits()));
            p.prims.iter().for_each(|&q| eat(q));
        }
        eat(self.root);
        let (lo, hi) = self.root_bounds.to_arrays();
        lo.iter().chain(&hi).for_each(|f| eat(f.to_bits()));
    }
}

/// Two layouts are equal when they are the same tree bit for bit: every node, packet (the NaN
/// vertices of padding lanes compared by their bits), the root and its bounds, what
/// [`WideBvh::fingerprint`] hashes. The backend and the precision are settings of the queries,
/// not of the tree, and are left out: a tree saved and loaded on another CPU equals the one
/// built here.
impl<const W: usize> PartialEq for WideBvh<W> {
    fn eq(&self, other: &Self) -> bool {
        let mut a = Vec::new();
        self.for_each_word(|x| a.push(x));
        let mut b = Vec::with_capacity(a.len());
        other.for_each_word(|x| b.push(x));
        a == b
    }
}

impl<const W: usize> Eq for WideBvh<W> {}

/// A traversal implementation of the wide layouts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Backend {
    /// Scalar code over the same layout; available everywhere.
    Portable,
    /// 128-bit SSE2 (every x86-64 CPU).
    Sse2,
    /// 256-bit AVX2 with FMA enabled (x86-64 CPUs that have both).
    Avx2,
    /// The AVX2 kernels compiled with AVX-512F and AVX-512VL as well (x86-64 CPUs that have
    /// all four): still 256-bit vectors, but box-test masks come straight from mask registers
    /// and the compiler has 32 vector registers, which removes the spills of the ray's
    /// constants.
    Avx512,
}

impl Backend {
    /// All backends, slowest first.
    pub const ALL: [Backend; 4] = [
        Backend::Portable,
        Backend::Sse2,
        Backend::Avx2,
        Backend::Avx512,
    ];

    /// True when this CPU can run the backend.
    pub fn is_available(self) -> bool {
        match self {
            Backend::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Backend::Sse2 => true,
            #[cfg(target_arch = "x86_64")]
            Backend::Avx2 => {
                std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            Backend::Avx512 => {
                Backend::Avx2.is_available()
                    && std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The fastest available backend.
    pub fn best() -> Backend {
        if Backend::Avx512.is_available() {
            Backend::Avx512
        } else if Backend::Avx2.is_available() {
            Backend::Avx2
        } else if Backend::Sse2.is_available() {
            Backend::Sse2
        } else {
            Backend::Portable
        }
    }

    /// `"portable"`, `"sse2"`, `"avx2"` or `"avx512"`.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Portable => "portable",
            Backend::Sse2 => "sse2",
            Backend::Avx2 => "avx2",
            Backend::Avx512 => "avx512",
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The SIMD path the wide kernels use on this machine: `"avx512"`, `"avx2"`, `"sse2"` or
/// `"portable"` (the name of [`Backend::best`]).
pub fn simd_backend() -> &'static str {
    Backend::best().name()
}

#[cfg(test)]
mod order_tests {
    use super::{total_order, WideNode};
    use sahara_geom::rng::Pcg32;

    /// The slot order of octant class `q` by a comparison sort on `(key.total_cmp, slot)`.
    fn sorted_slots<const W: usize>(node: &WideNode<W>, q: usize) -> Vec<usize> {
        let sign = [
            if q & 1 != 0 { -1.0 } else { 1.0 },
            if q & 2 != 0 { -1.0 } else { 1.0 },
            1.0f64,
        ];
        let key = |s: usize| -> f64 {
            if node.valid & (1 << s) == 0 {
                return f64::INFINITY;
            }
            (0..3)
                .map(|a| {
                    sign[a] * (node.bounds[2 * a][s] as f64 + node.bounds[2 * a + 1][s] as f64)
                })
                .sum()
        };
        let mut slots: Vec<usize> = (0..W).collect();
        slots.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        slots
    }

    fn check<const W: usize>(r: &mut Pcg32) {
        for _ in 0..2000 {
            let mut node = WideNode::<W>::EMPTY;
            node.valid = r.next_u32() & ((1 << W) - 1);
            // Few distinct coordinates, so that keys tie often (also +0 against -0).
            let coords = [-1.0f32, -0.0, 0.0, 1.0, 2.0];
            for row in node.bounds.iter_mut() {
                for v in row.iter_mut() {
                    *v = coords[r.below(coords.len() as u32) as usize];
                }
            }
            node.set_order();
            for q in 0..4 {
                let p = node.order_bits(q);
                let got: Vec<usize> = (0..W).map(|k| (p >> (3 * k)) as usize & 7).collect();
                assert_eq!(got, sorted_slots(&node, q), "octant class {q}");
            }
        }
    }

    #[test]
    fn child_orders_are_those_of_a_comparison_sort_ties_included() {
        let mut r = Pcg32::new(17, 3);
        check::<4>(&mut r);
        check::<8>(&mut r);
    }

    #[test]
    fn total_order_is_the_order_of_total_cmp() {
        let xs = [
            -f64::NAN,
            f64::NEG_INFINITY,
            -f64::MAX,
            -1.5,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            1.0,
            1.5,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
        ];
        for a in xs {
            for b in xs {
                assert_eq!(
                    total_order(a).cmp(&total_order(b)),
                    a.total_cmp(&b),
                    "{a} against {b}"
                );
            }
        }
    }
}
