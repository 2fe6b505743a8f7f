//! Collapsing a binary [`Bvh`] into a [`WideBvh`]: the SAH-optimal collapse of Ylitie, Karras
//! and Laine (2017) by dynamic programming over the binary tree ([`Plan`]), then the wide
//! nodes and the leaf packets are laid out depth first ([`Layout`]): a counting pass gives
//! every wide node's block its final range, so that the blocks are written straight into the
//! final arrays, in parallel, with no copy.

use super::memory::HugeSlice;
use super::{
    encode_leaf, Backend, TriPacket, WideBvh, WideNode, LEAF_BIT, LEAF_FIRST_MASK,
    MAX_LEAF_PACKETS, NO_ROOT,
};
use crate::custom::MixedPrims;
use crate::Precision;
use sahara_bvh::Bvh;
use sahara_geom::intersect::is_degenerate;
use sahara_geom::{Aabb, Triangle};
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Most references in one wide leaf.
const LEAF_MAX: usize = 4 * MAX_LEAF_PACKETS;

/// SAH cost of testing the child boxes of one wide inner node (the unit of the cost model).
const C_NODE: f32 = 1.0;
/// SAH cost of visiting a leaf, on top of its packets: decoding it and reaching its first
/// packet in memory (the fixed part of a leaf's cost).
const C_LEAF: f32 = 0.5;
/// SAH cost of testing one packet of 4 triangles. With [`C_LEAF`], a one-packet leaf costs as
/// much as an inner node and each further packet half as much (the next packet's cache lines
/// follow the first). Chosen by interleaved measurements on the shared scenes (2026-11-25):
/// against `C_LEAF = 0` and `C_PACKET = 1` (plain per-packet SAH) it trades 1–4% more speed on
/// diffuse rays for up to 1.5% on some primary rays, with a third fewer nodes.
const C_PACKET: f32 = 0.5;

/// What the leaves of a wide tree hold: triangles (copied into the packets) or primitives known
/// only by their boxes (packets of indices with NaN vertices, for the callback traversals of
/// [`super::custom`]).
#[derive(Clone, Copy)]
pub(crate) enum Source<'a> {
    Triangles(&'a [Triangle]),
    Boxes(&'a [Aabb]),
    /// Boxes, some of which are triangles ([`WideBvh::from_mixed`](super::WideBvh::from_mixed)).
    Mixed(MixedPrims<'a>),
}

impl Source<'_> {
    pub(crate) fn len(&self) -> usize {
        match self {
            Source::Triangles(t) => t.len(),
            Source::Boxes(b) => b.len(),
            Source::Mixed(m) => m.boxes.len(),
        }
    }

    pub(crate) fn bounds(&self, p: u32) -> Aabb {
        match self {
            Source::Triangles(t) => t[p as usize].bounds(),
            Source::Boxes(b) => b[p as usize],
            Source::Mixed(m) => m.boxes[p as usize],
        }
    }

    fn centroid(&self, p: u32) -> sahara_geom::Vec3A {
        match self {
            Source::Triangles(t) => t[p as usize].centroid(),
            Source::Boxes(b) => b[p as usize].centroid(),
            Source::Mixed(m) => m.boxes[p as usize].centroid(),
        }
    }

    /// Starts loading primitive `p` into the cache (a hint: the collapse reads the primitives
    /// of a leaf in index order, scattered over the whole array, so their cache misses are
    /// overlapped by asking for all of them first). Out-of-range indices are harmless here.
    #[inline]
    fn prefetch(&self, p: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (start, size) = match self {
                Source::Triangles(t) => (
                    t.as_ptr().wrapping_add(p as usize).cast::<i8>(),
                    std::mem::size_of::<Triangle>(),
                ),
                Source::Boxes(b) | Source::Mixed(MixedPrims { boxes: b, .. }) => (
                    b.as_ptr().wrapping_add(p as usize).cast::<i8>(),
                    std::mem::size_of::<Aabb>(),
                ),
            };
            // SAFETY: SSE is part of x86-64, and a prefetch never faults, whatever the
            // address.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(start);
                _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(size - 1));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = p;
    }

    /// Writes primitive `prim` into lane `lane` of a packet: its vertices (NaN for a
    /// degenerate triangle, which never hits, and for a box primitive) and its index.
    pub(crate) fn fill_lane(&self, p: &mut TriPacket, lane: usize, prim: u32) {
        p.prims[lane] = prim;
        // Never hit (`accept_hit`): NaN vertices for a degenerate triangle, which the packet
        // tests never hit, so the SIMD tests need not check for degenerate triangles; NaN for
        // a box primitive too.
        let tri = match self {
            Source::Triangles(tris) => Some(&tris[prim as usize]).filter(|t| !is_degenerate(t)),
            Source::Boxes(_) => None,
            Source::Mixed(m) => m
                .triangle(prim)
                .map(|i| &m.triangles[i as usize])
                .filter(|t| !is_degenerate(t)),
        };
        for k in 0..3 {
            for a in 0..3 {
                p.v[k][a][lane] = tri.map_or(f32::NAN, |t| t.v[k][a]);
            }
        }
    }
}

/// SAH cost (per unit of the node's area) of a wide leaf over `refs` references: packets of
/// 4, or, beyond [`LEAF_MAX`] references (binary leaves only), the small subtree of leaves of
/// `Collapser::big_leaf` (roughly).
fn leaf_cost(refs: u64) -> f32 {
    let packets = refs.div_ceil(4);
    if packets as usize <= MAX_LEAF_PACKETS {
        C_LEAF + C_PACKET * packets as f32
    } else {
        C_NODE
            + C_LEAF * packets.div_ceil(MAX_LEAF_PACKETS as u64) as f32
            + C_PACKET * packets as f32
    }
}

/// Choice for a binary node standing for one wide child: a leaf over its whole subtree.
const AS_LEAF: u8 = 0;
/// Choice for a binary node standing for one wide child: a wide inner node.
const AS_NODE: u8 = 1;

/// The SAH-optimal collapse of a binary tree into a `W`-wide one (Ylitie, Karras and Laine
/// 2017): for every binary node `n` and every `i` in `1..=W`, `cost(n, i)` is the least SAH
/// cost of the subtree of `n` when it may take up to `i` child slots of its wide parent:
///
/// * `cost(n, 1) = min(leaf(n), area(n) · c_node + distribute(n, W))`: a leaf over the whole
///   subtree (at most [`LEAF_MAX`] references), or a wide node whose children are the
///   subtree's best distribution over `W` slots;
/// * `cost(n, i) = min(cost(n, i - 1), distribute(n, i))` for `i > 1`, where
///   `distribute(n, i) = min over 0 < k < i of cost(left, k) + cost(right, i - k)`.
///
/// Binary leaves can only be leaves. Costs are computed bottom-up (children follow their
/// parent in the depth-first node order), ties go to the first choice in a fixed order, so the
/// plan is deterministic.
struct Plan {
    width: usize,
    /// `cost(root, 1)`: the least SAH cost of the whole tree (not normalised by the root's
    /// area; checked against the built tree by the tests).
    #[cfg_attr(not(test), allow(dead_code))]
    root_cost: f64,
    /// At `n * width + i - 1`: for `i = 1`, [`AS_LEAF`] or [`AS_NODE`]; for `i > 1`, 0 when
    /// `cost(n, i) = cost(n, i - 1)`, else the slots `k` given to the left child.
    choice: Vec<u8>,
    /// For an inner node that becomes a wide node: the slots given to its left child in
    /// `distribute(n, W)`.
    split: Vec<u8>,
}

impl Plan {
    /// The plan for `bvh`; fills `refs[n]` with the references of subtree `n`. Where the
    /// layout is depth first with every subtree a contiguous node range (what the builders
    /// make), large subtrees are planned with both children at once; the plan is the same bit
    /// for bit (every node's row depends on its children's rows only).
    fn new(bvh: &Bvh, refs: &mut [u64], width: usize, par: Par) -> Self {
        let n = bvh.nodes.len();
        // Areas relative to the root's, so that `f32` costs (half the memory of `f64`; the plan
        // has `width` of them per binary node) neither overflow nor lose precision.
        let root_area = half_area(&bvh.nodes[0].bounds());
        let scale = if root_area > 0.0 {
            1.0 / root_area
        } else {
            1.0
        };
        let mut cost = vec![0.0f32; n * width];
        let mut choice = vec![0u8; n * width];
        let mut split = vec![0u8; n];
        let rows = PlanRows {
            bvh,
            width,
            scale,
            par_nodes: par.plan_nodes,
        };
        let mut slices = RowSlices {
            refs,
            cost: &mut cost,
            choice: &mut choice,
            split: &mut split,
        };
        let done = n > par.plan_nodes && rows.subtree(0, n, slices.reborrow());
        if !done {
            // One range in node order: right for any layout (children follow their parent).
            let all = rows.range(0, n, slices.reborrow());
            assert!(all, "a child precedes its parent or lies outside the tree");
        }
        Self {
            width,
            root_cost: cost[0] as f64 * root_area,
            choice,
            split,
        }
    }

    /// True when binary node `n`, standing for one wide child, becomes a leaf.
    fn is_leaf(&self, n: usize) -> bool {
        self.choice[n * self.width] == AS_LEAF
    }

    /// Appends to `out` the binary nodes that stand for the (at most `slots`) wide children of
    /// the subtree of `n`, in order.
    fn gather(&self, bvh: &Bvh, n: usize, mut slots: usize, out: &mut Kids) {
        let row = n * self.width;
        while slots > 1 && self.choice[row + slots - 1] == 0 {
            slots -= 1;
        }
        if slots == 1 {
            out.list[out.len] = n;
            out.len += 1;
            return;
        }
        let k = self.choice[row + slots - 1] as usize;
        self.gather(bvh, n + 1, k, out);
        self.gather(bvh, bvh.nodes[n].index as usize, slots - k, out);
    }
}

/// Where the collapse runs in parallel (it changes the speed, never a bit of the result).
#[derive(Clone, Copy)]
struct Par {
    /// Subtrees of more binary nodes than this are planned with both children at once.
    plan_nodes: usize,
    /// Wide nodes over at least this many references count and write their children's
    /// blocks at once.
    refs: u64,
}

impl Par {
    /// 4096 for both: at 16 384 the collapse of scenes of a few ten thousand triangles (the
    /// teapot: 16k) ran on one thread even when two were there; 4096 cut the teapot's two-thread
    /// collapse by a quarter and was no slower at one thread or on larger scenes
    /// (docs/results/2026-12-04-zen5).
    ///
    /// Under Miri both are 16, so that the small trees Miri can afford take the parallel
    /// paths (the same code; only where it starts differs).
    const DEFAULT: Par = if cfg!(miri) {
        Par {
            plan_nodes: 16,
            refs: 16,
        }
    } else {
        Par {
            plan_nodes: 1 << 12,
            refs: 1 << 12,
        }
    };
}

/// The dynamic programme of [`Plan`], row by row: a row holds, for one binary node, its `width`
/// costs and choices (`cost` and `choice` slices start at the row of some node `base`).
struct PlanRows<'a> {
    bvh: &'a Bvh,
    width: usize,
    scale: f64,
    par_nodes: usize,
}

/// The plan's arrays for a range of binary nodes (each starting at the range's first node):
/// reference counts, costs and choices (`width` per node), and splits.
struct RowSlices<'s> {
    refs: &'s mut [u64],
    cost: &'s mut [f32],
    choice: &'s mut [u8],
    split: &'s mut [u8],
}

impl<'s> RowSlices<'s> {
    fn reborrow(&mut self) -> RowSlices<'_> {
        RowSlices {
            refs: self.refs,
            cost: self.cost,
            choice: self.choice,
            split: self.split,
        }
    }

    /// The first `nodes` nodes' slices, and the rest (`w` costs and choices per node).
    fn split_at(self, nodes: usize, w: usize) -> (RowSlices<'s>, RowSlices<'s>) {
        let (refs, r_refs) = self.refs.split_at_mut(nodes);
        let (cost, r_cost) = self.cost.split_at_mut(nodes * w);
        let (choice, r_choice) = self.choice.split_at_mut(nodes * w);
        let (split, r_split) = self.split.split_at_mut(nodes);
        (
            RowSlices {
                refs,
                cost,
                choice,
                split,
            },
            RowSlices {
                refs: r_refs,
                cost: r_cost,
                choice: r_choice,
                split: r_split,
            },
        )
    }
}

impl PlanRows<'_> {
    /// Rows and reference counts of the nodes `a..b` (slices starting at node `a`), last node
    /// first. `false` when a node's child lies outside the range: then the range is not a
    /// closed part of the tree (the layout is not depth first) and its rows are incomplete.
    fn range(&self, a: usize, b: usize, s: RowSlices<'_>) -> bool {
        let RowSlices {
            refs,
            cost,
            choice,
            split,
        } = s;
        let w = self.width;
        for i in (a..b).rev() {
            let node = &self.bvh.nodes[i];
            let row = (i - a) * w;
            let (head, tail) = cost.split_at_mut(row + w);
            let kids = if node.is_leaf() {
                refs[i - a] = node.count as u64;
                None
            } else {
                let (l, r) = (i + 1, node.index as usize);
                if r >= b || l >= b {
                    return false;
                }
                refs[i - a] = refs[l - a].saturating_add(refs[r - a]);
                let l = &tail[(l - i - 1) * w..][..w];
                let r = &tail[(r - i - 1) * w..][..w];
                Some((l, r))
            };
            split[i - a] = self.row(
                i,
                refs[i - a],
                kids,
                &mut head[row..],
                &mut choice[row..row + w],
            );
        }
        true
    }

    /// Rows of the subtree of `i`, taken to be the node range `i..end` (slices starting at
    /// node `i`): in a depth-first layout its left child's subtree is `i + 1..r` and its right
    /// child's `r..end`, planned in parallel when the subtree is large. `false` when the layout
    /// is not depth first (a child outside its range); the rows are then incomplete.
    fn subtree(&self, i: usize, end: usize, s: RowSlices<'_>) -> bool {
        let node = &self.bvh.nodes[i];
        if end - i <= self.par_nodes || node.is_leaf() {
            return self.range(i, end, s);
        }
        let r = node.index as usize;
        if r <= i + 1 || r >= end {
            return false;
        }
        let w = self.width;
        // Layout: row `i`, then the left subtree `i + 1..r`, then the right one `r..end`.
        let (own, kids) = s.split_at(1, w);
        let (mut left, mut right) = kids.split_at(r - i - 1, w);
        let (left_ok, right_ok) = rayon::join(
            || self.subtree(i + 1, r, left.reborrow()),
            || self.subtree(r, end, right.reborrow()),
        );
        if !(left_ok && right_ok) {
            return false;
        }
        own.refs[0] = left.refs[0].saturating_add(right.refs[0]);
        own.split[0] = self.row(
            i,
            own.refs[0],
            Some((&left.cost[..w], &right.cost[..w])),
            own.cost,
            own.choice,
        );
        true
    }

    /// Fills the row of node `i` (`cost` and `choice` start at it) from its children's rows
    /// (`None` for a leaf); returns the slots given to the left child in `distribute(i, W)`.
    fn row(
        &self,
        i: usize,
        refs: u64,
        kids: Option<(&[f32], &[f32])>,
        cost: &mut [f32],
        choice: &mut [u8],
    ) -> u8 {
        let width = self.width;
        let node = &self.bvh.nodes[i];
        let area = (half_area(&node.bounds()) * self.scale) as f32;
        let Some((l, r)) = kids else {
            let c = area * leaf_cost(refs);
            cost[..width].fill(c);
            choice[0] = AS_LEAF;
            return 0;
        };
        let mut dist = [0.0f32; 9];
        let mut dist_k = [0u8; 9];
        let nodes = &self.bvh.nodes;
        if nodes[i + 1].is_leaf() {
            distribute_left_leaf(l[0], r, &mut dist[..=width], &mut dist_k[..=width]);
        } else if nodes[node.index as usize].is_leaf() {
            distribute_right_leaf(l, r[0], &mut dist[..=width], &mut dist_k[..=width]);
        } else {
            distribute(l, r, &mut dist[..=width], &mut dist_k[..=width]);
        }
        let inner = area * C_NODE + dist[width];
        let leaf = if refs <= LEAF_MAX as u64 {
            area * leaf_cost(refs)
        } else {
            f32::INFINITY
        };
        if leaf <= inner {
            cost[0] = leaf;
            choice[0] = AS_LEAF;
        } else {
            cost[0] = inner;
            choice[0] = AS_NODE;
        }
        for j in 2..=width {
            // Ties distribute (more slots used, never a worse cost).
            if dist[j] <= cost[j - 2] {
                cost[j - 1] = dist[j];
                choice[j - 1] = dist_k[j];
            } else {
                cost[j - 1] = cost[j - 2];
                choice[j - 1] = 0;
            }
        }
        dist_k[width]
    }
}

/// `distribute(n, j)` for `j` in `2..dist.len()` from the rows `l` and `r` of `n`'s children:
/// `dist[j]` is the least `l[k - 1] + r[j - k - 1]` over `0 < k < j`, and `dist_k[j]` the first
/// `k` that reaches it. `O(W²)` additions.
#[inline]
fn distribute(l: &[f32], r: &[f32], dist: &mut [f32], dist_k: &mut [u8]) {
    for j in 2..dist.len() {
        let mut best = f32::INFINITY;
        let mut best_k = 1;
        for k in 1..j {
            let c = l[k - 1] + r[j - k - 1];
            if c < best {
                best = c;
                best_k = k;
            }
        }
        dist[j] = best;
        dist_k[j] = best_k as u8;
    }
}

/// [`distribute`] where the left child is a binary leaf, whose row is the constant `l0`, in
/// `O(W)`. The same values bit for bit: every row is non-increasing (`cost(n, i)` is a minimum
/// over more choices as `i` grows) and free of NaN (areas are finite and non-negative, and
/// the scale is finite), so `l0 + r[j - k - 1]` (rounding is monotonic) is least at `k = 1`,
/// the first `k` [`distribute`] would keep.
#[inline]
fn distribute_left_leaf(l0: f32, r: &[f32], dist: &mut [f32], dist_k: &mut [u8]) {
    for j in 2..dist.len() {
        dist[j] = l0 + r[j - 2];
        dist_k[j] = 1;
    }
}

/// [`distribute`] where the right child is a binary leaf, whose row is the constant `r0`, in
/// `O(W)`. The candidates `l[k - 1] + r0` then do not depend on `j`, so [`distribute`]'s scan
/// for `j` is its scan for `j - 1` followed by the one new candidate `k = j - 1`: one running
/// scan gives the same values and the same `k`, bit for bit, whatever the rows hold.
#[inline]
fn distribute_right_leaf(l: &[f32], r0: f32, dist: &mut [f32], dist_k: &mut [u8]) {
    let mut best = f32::INFINITY;
    let mut best_k = 1;
    for j in 2..dist.len() {
        let c = l[j - 2] + r0;
        if c < best {
            best = c;
            best_k = j - 1;
        }
        dist[j] = best;
        dist_k[j] = best_k as u8;
    }
}

/// Half the surface area of a box, in `f64` (no overflow for huge finite boxes).
fn half_area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let e = [
        b.max.x as f64 - b.min.x as f64,
        b.max.y as f64 - b.min.y as f64,
        b.max.z as f64 - b.min.z as f64,
    ];
    e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
}

pub(crate) fn collapse<const W: usize>(bvh: &Bvh, tris: Source<'_>) -> WideBvh<W> {
    collapse_with(bvh, tris, Par::DEFAULT)
}

/// [`collapse`] with the parallel thresholds `par`.
fn collapse_with<const W: usize>(bvh: &Bvh, tris: Source<'_>, par: Par) -> WideBvh<W> {
    assert!(
        W == 4 || W == 8,
        "wide BVHs have 4 or 8 children per node, not {W}"
    );
    let backend = Backend::best();
    if bvh.nodes.is_empty() {
        return WideBvh {
            nodes: HugeSlice::empty(),
            packets: HugeSlice::empty(),
            root: NO_ROOT,
            root_bounds: Aabb::EMPTY,
            max_stack: 1,
            backend,
            precision: Precision::Exact,
            cuts: None,
        };
    }
    let n = bvh.nodes.len();
    // The plan also counts every subtree's references.
    let mut refs = vec![0u64; n];
    let plan = Plan::new(bvh, &mut refs, W, par);
    let layout = Layout::<W> {
        bvh,
        tris,
        plan: &plan,
        refs: &refs,
        par_refs: par.refs,
        blocks: (0..n).map(|_| AtomicU64::new(0)).collect(),
        leaves: None,
        inner: None,
    };
    let layout = match (&bvh.ref_cuts, &tris) {
        (Some(_), Source::Triangles(_)) => Layout {
            leaves: Some(Mutex::default()),
            inner: Some(Mutex::default()),
            ..layout
        },
        _ => layout,
    };
    let (nodes, packets, root) = layout.write();
    let cuts = layout.cut_records(packets.len(), nodes.len(), root);
    assert!(
        nodes.len() < LEAF_BIT as usize,
        "too many wide nodes ({})",
        nodes.len()
    );
    let max_stack = stack_bound(&nodes, root);
    WideBvh {
        nodes,
        packets,
        root,
        root_bounds: bvh.nodes[0].bounds(),
        max_stack,
        backend,
        precision: Precision::Exact,
        cuts,
    }
}

/// The cut records of a wide tree ([`Bvh::ref_cuts`] carried through the collapse), so that
/// a refit gives every child box of the binary node it stands for, clipped as the builder
/// clipped it: the binary references each wide leaf stands for (a wide leaf is a binary
/// subtree whose references were deduplicated into its packets) and the depth of the binary
/// node behind every slot (a binary node's box also holds the boxes its split cut, which a
/// refit adds to the deepest slot whose binary node is that node or an ancestor of it).
#[derive(Clone, Debug)]
pub(crate) struct WideCuts {
    /// The references of the leaf whose packets are `first..first + n` are
    /// `start[first]..start[first + n]` (only a leaf's first packet has any; a leaf without
    /// any, the part of a binary leaf of more than [`LEAF_MAX`] references, refits with whole
    /// triangle bounds).
    pub start: Vec<u32>,
    /// The references' triangles.
    pub prims: Vec<u32>,
    /// The references' cuts.
    pub cuts: sahara_bvh::RefCuts,
    /// The binary depth of the node behind slot `k` of wide node `i`, at `i * W + k`
    /// ([`Cut::NO_DEPTH`](sahara_bvh::Cut::NO_DEPTH) for the slots of the nodes that split
    /// oversized leaves); the last entry is the root's (0).
    pub depth: Vec<u32>,
}

impl WideCuts {
    /// The references of the leaf whose packets are `first..first + n`.
    pub fn leaf_refs(&self, first: usize, n: usize) -> std::ops::Range<usize> {
        self.start[first] as usize..self.start[first + n] as usize
    }

    /// Bytes of the records.
    pub fn memory_bytes(&self) -> usize {
        (self.start.len() + self.prims.len() + self.depth.len()) * 4 + self.cuts.memory_bytes()
    }
}

/// How many wide nodes and leaf packets something becomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Shape {
    nodes: usize,
    packets: usize,
}

impl Shape {
    const ONE_NODE: Shape = Shape {
        nodes: 1,
        packets: 0,
    };

    fn plus(self, o: Shape) -> Shape {
        Shape {
            nodes: self.nodes + o.nodes,
            packets: self.packets + o.packets,
        }
    }

    /// The shape of a wide leaf over `prims` distinct references: its packets of 4, or the
    /// small subtree of [`Layout::big_leaf`] (`W` parts of a multiple of 4 references each).
    fn leaf<const W: usize>(prims: usize) -> Shape {
        if prims <= LEAF_MAX {
            return Shape {
                nodes: 0,
                packets: prims.div_ceil(4),
            };
        }
        let per = prims.div_ceil(W).div_ceil(4) * 4;
        let (full, rest) = (prims / per, prims % per);
        let mut s = Shape::ONE_NODE;
        let part = Shape::leaf::<W>(per);
        for _ in 0..full {
            s = s.plus(part);
        }
        if rest > 0 {
            s = s.plus(Shape::leaf::<W>(rest));
        }
        s
    }

    /// Packed into one word (both parts are below 2³², or the tree could not be encoded).
    fn pack(self) -> u64 {
        let (n, p) = (
            u32::try_from(self.nodes).expect("too many wide nodes"),
            u32::try_from(self.packets).expect("too many triangle packets"),
        );
        (n as u64) << 32 | p as u64
    }

    fn unpack(w: u64) -> Shape {
        Shape {
            nodes: (w >> 32) as usize,
            packets: (w & 0xffff_ffff) as usize,
        }
    }
}

/// The binary nodes standing for the wide children of one wide node, in slot order.
#[derive(Clone, Copy)]
struct Kids {
    list: [usize; 8],
    len: usize,
}

impl Kids {
    fn as_slice(&self) -> &[usize] {
        &self.list[..self.len]
    }
}

/// Reused buffers: the references of a leaf and the binary nodes still to visit.
#[derive(Default)]
struct Scratch {
    prims: Vec<u32>,
    todo: Vec<usize>,
    /// The references of a wide node's leaf children, one after the other.
    node_prims: Vec<u32>,
}

/// Sorts at most [`LEAF_MAX`] values by rank, without a branch on the data: the value at `i`
/// goes to the number of values below it plus the number of equal values before it (a
/// comparison sort's branches mispredict on leaf-sized arrays, which made it a sixth of the
/// collapse's time on the dragon).
fn sort_small(v: &mut [u32]) {
    let n = v.len();
    assert!(n <= LEAF_MAX);
    let mut out = [0u32; LEAF_MAX];
    for (i, &x) in v.iter().enumerate() {
        let below: usize = v.iter().map(|&y| (y < x) as usize).sum();
        let equal_before: usize = v[..i].iter().map(|&y| (y == x) as usize).sum();
        out[below + equal_before] = x;
    }
    v.copy_from_slice(&out[..n]);
}

/// Nested parallel sections deeper than this run sequentially (bounds the recursion on
/// degenerate, list-like trees).
const MAX_PAR_DEPTH: usize = 48;

/// The layout of the wide tree, written straight into its final memory in two passes:
///
/// 1. [`count`](Layout::count) records, for every binary node that becomes a wide inner
///    node, the [`Shape`] of its *block* (every wide node below it and every packet of its
///    subtree);
/// 2. [`place`](Layout::place) writes every wide node and packet at its final index.
///
/// The order is the depth-first one of a sequential collapse with a work stack: a wide node's
/// block holds its children's slots (inner children and the nodes of oversized leaves, in
/// slot order), then the blocks of its inner children from the last to the first; its
/// packets are those of its leaf children in slot order, then those of its inner children's
/// subtrees from the last to the first. Every block's range is known before it is written, so
/// blocks are written in parallel (disjoint ranges) and the result does not depend on the
/// thread count.
struct Layout<'a, const W: usize> {
    bvh: &'a Bvh,
    tris: Source<'a>,
    plan: &'a Plan,
    refs: &'a [u64],
    /// Wide nodes over at least this many references count and place their children's
    /// blocks in parallel.
    par_refs: u64,
    /// [`Shape::pack`]ed block shapes, by binary node (set by [`Layout::count`]).
    blocks: Vec<AtomicU64>,
    /// With cut records: `(first packet, binary node)` of every wide leaf written.
    leaves: Option<Mutex<Vec<(u32, u32)>>>,
    /// With cut records: `(wide node, binary node)` of every wide node but the root (which
    /// stands for binary node 0) and those that split oversized leaves.
    inner: Option<Mutex<Vec<(u32, u32)>>>,
}

/// One wide inner node still to write: its binary node, its slot, and exactly the memory of
/// its block and its packets.
struct Job<'o, const W: usize> {
    bin: usize,
    slot: &'o mut MaybeUninit<WideNode<W>>,
    out: Out<'o, W>,
}

/// A range of the final node and packet arrays, written from its start.
struct Out<'o, const W: usize> {
    nodes: &'o mut [MaybeUninit<WideNode<W>>],
    /// Global index of `nodes[0]`.
    base: usize,
    packets: &'o mut [MaybeUninit<TriPacket>],
    /// Global index of `packets[0]`.
    pbase: usize,
}

impl<'o, const W: usize> Out<'o, W> {
    /// The next node: its global index and its slot.
    fn node(&mut self) -> (u32, &'o mut MaybeUninit<WideNode<W>>) {
        let (first, rest) = std::mem::take(&mut self.nodes)
            .split_first_mut()
            .expect("the counted block has room for this node");
        let i = self.base;
        self.nodes = rest;
        self.base += 1;
        (i as u32, first)
    }

    /// The next packet's slot (the caller writes it).
    fn packet(&mut self) -> &'o mut MaybeUninit<TriPacket> {
        let (first, rest) = std::mem::take(&mut self.packets)
            .split_first_mut()
            .expect("the counted block has room for this packet");
        self.packets = rest;
        self.pbase += 1;
        first
    }

    /// Splits off the first `s.nodes` nodes and `s.packets` packets.
    fn take(&mut self, s: Shape) -> Out<'o, W> {
        let (nodes, rest) = std::mem::take(&mut self.nodes).split_at_mut(s.nodes);
        let (packets, prest) = std::mem::take(&mut self.packets).split_at_mut(s.packets);
        let out = Out {
            nodes,
            base: self.base,
            packets,
            pbase: self.pbase,
        };
        self.nodes = rest;
        self.packets = prest;
        self.base += s.nodes;
        self.pbase += s.packets;
        out
    }

    fn is_used_up(&self) -> bool {
        self.nodes.is_empty() && self.packets.is_empty()
    }
}

impl<const W: usize> Layout<'_, W> {
    /// Writes the whole tree; returns the nodes, the packets and the root.
    fn write(&self) -> (HugeSlice<WideNode<W>>, HugeSlice<TriPacket>, u32) {
        let mut s = Scratch::default();
        let shape = if self.plan.is_leaf(0) {
            Shape::leaf::<W>(self.leaf_size(0, &mut s))
        } else {
            self.count(0, 0);
            Shape::ONE_NODE.plus(self.block(0))
        };
        let mut root = NO_ROOT;
        let mut nodes = None;
        // SAFETY: both closures write every element of the slices they are given: the counted
        // shapes are exactly what the writers consume, which `Layout::place` asserts for every
        // block (and `write_root` for the whole tree).
        let packets = unsafe {
            HugeSlice::from_init(shape.packets, |packets| {
                nodes = Some(HugeSlice::from_init(shape.nodes, |nodes| {
                    root = self.write_root(nodes, packets, &mut s);
                }));
            })
        };
        (nodes.expect("written above"), packets, root)
    }

    /// The wide tree's cut records (`None` without [`Layout::leaves`]), for a tree of
    /// `packets` packets and `nodes` nodes whose root is `root`: each recorded leaf's binary
    /// references in depth-first order, and the binary depth behind every slot.
    fn cut_records(&self, packets: usize, nodes: usize, root: u32) -> Option<WideCuts> {
        let from = self.bvh.ref_cuts.as_ref()?;
        let mut leaves = std::mem::take(&mut *self.leaves.as_ref()?.lock().expect("leaves"));
        leaves.sort_unstable();
        let mut inner = std::mem::take(&mut *self.inner.as_ref()?.lock().expect("inner"));
        if root & LEAF_BIT == 0 {
            inner.push((root, 0));
        }
        // Children come after their parent: one forward pass gives every binary depth.
        let mut bdepth = vec![0u32; self.bvh.nodes.len()];
        for (i, n) in self.bvh.nodes.iter().enumerate() {
            if !n.is_leaf() {
                bdepth[i + 1] = bdepth[i] + 1;
                bdepth[n.index as usize] = bdepth[i] + 1;
            }
        }
        let mut depth = vec![sahara_bvh::Cut::NO_DEPTH; nodes * W + 1];
        depth[nodes * W] = 0;
        for &(i, bin) in &inner {
            for (k, &c) in self.kids(bin as usize).as_slice().iter().enumerate() {
                depth[i as usize * W + k] = bdepth[c];
            }
        }
        let mut out = WideCuts {
            start: Vec::with_capacity(packets + 1),
            prims: Vec::new(),
            cuts: sahara_bvh::RefCuts::new(),
            depth,
        };
        let mut todo = Vec::new();
        let mut next = leaves.iter().peekable();
        for p in 0..packets {
            out.start.push(out.prims.len() as u32);
            let Some(&(_, bin)) = next.next_if(|l| l.0 as usize == p) else {
                continue;
            };
            todo.push(bin as usize);
            while let Some(i) = todo.pop() {
                let node = &self.bvh.nodes[i];
                if node.is_leaf() {
                    let first = node.index as usize;
                    for slot in first..first + node.count as usize {
                        out.prims.push(self.bvh.prim_indices[slot]);
                        out.cuts.push(from.get(slot));
                    }
                } else {
                    todo.push(node.index as usize);
                    todo.push(i + 1);
                }
            }
        }
        out.start.push(out.prims.len() as u32);
        Some(out)
    }

    fn write_root(
        &self,
        nodes: &mut [MaybeUninit<WideNode<W>>],
        packets: &mut [MaybeUninit<TriPacket>],
        s: &mut Scratch,
    ) -> u32 {
        if self.plan.is_leaf(0) {
            let mut out = Out {
                nodes,
                base: 0,
                packets,
                pbase: 0,
            };
            self.leaf_prims(0, s);
            let mut prims = std::mem::take(&mut s.prims);
            let root = self.leaf(0, &mut prims, &mut out);
            assert!(out.is_used_up(), "the root leaf's shape was miscounted");
            return root;
        }
        // The root is node 0, its block starts at node 1.
        let (slot, nodes) = nodes.split_first_mut().expect("the root's node");
        let out = Out {
            nodes,
            base: 1,
            packets,
            pbase: 0,
        };
        self.place(Job { bin: 0, slot, out }, 0);
        0
    }

    /// The binary nodes standing for the wide children of binary inner node `bin` (planned
    /// as a wide node): the plan's best distribution of its subtree over `W` slots.
    fn kids(&self, bin: usize) -> Kids {
        let mut k = Kids {
            list: [0; 8],
            len: 0,
        };
        let left = self.plan.split[bin] as usize;
        self.plan.gather(self.bvh, bin + 1, left, &mut k);
        let right = self.bvh.nodes[bin].index as usize;
        self.plan.gather(self.bvh, right, W - left, &mut k);
        k
    }

    fn block(&self, bin: usize) -> Shape {
        Shape::unpack(self.blocks[bin].load(Ordering::Relaxed))
    }

    /// The references of the wide leaf standing for binary node `bin`, into `s.prims`:
    /// sorted by index, without duplicates (a tree without spatial splits has none, so the
    /// dedup is skipped there: a primitive that such a tree references twice is stored twice,
    /// which changes no answer).
    fn leaf_prims(&self, bin: usize, s: &mut Scratch) {
        let Scratch { prims, todo, .. } = s;
        prims.clear();
        todo.clear();
        todo.push(bin);
        while let Some(i) = todo.pop() {
            let node = &self.bvh.nodes[i];
            if node.is_leaf() {
                prims.extend_from_slice(self.bvh.leaf_prims(node));
            } else {
                todo.push(node.index as usize);
                todo.push(i + 1);
            }
        }
        if prims.len() <= LEAF_MAX {
            sort_small(prims);
        } else {
            prims.sort_unstable();
        }
        if self.bvh.spatial_splits {
            prims.dedup();
        }
    }

    /// The number of references of the wide leaf standing for binary node `bin`.
    fn leaf_size(&self, bin: usize, s: &mut Scratch) -> usize {
        if self.bvh.spatial_splits {
            self.leaf_prims(bin, s);
            s.prims.len()
        } else {
            self.refs[bin] as usize
        }
    }

    /// Pass 1: the block shapes of `root` (a binary node planned as a wide inner node) and of
    /// every wide inner node below it, children before parents (an explicit stack: the depth
    /// of the tree is not bounded).
    fn count(&self, root: usize, par_depth: usize) {
        let mut s = Scratch::default();
        // A node is pushed twice: without its children (to expand it), then with them (to sum
        // their shapes once they are counted).
        let mut stack: Vec<(usize, Option<Kids>)> = vec![(root, None)];
        while let Some((bin, kids)) = stack.pop() {
            if let Some(kids) = kids {
                let mut shape = Shape::default();
                for &c in kids.as_slice() {
                    shape = shape.plus(if self.plan.is_leaf(c) {
                        Shape::leaf::<W>(self.leaf_size(c, &mut s))
                    } else {
                        Shape::ONE_NODE.plus(self.block(c))
                    });
                }
                self.blocks[bin].store(shape.pack(), Ordering::Relaxed);
                continue;
            }
            let kids = self.kids(bin);
            stack.push((bin, Some(kids)));
            let inner = kids
                .as_slice()
                .iter()
                .copied()
                .filter(|&c| !self.plan.is_leaf(c));
            if self.refs[bin] >= self.par_refs && par_depth < MAX_PAR_DEPTH {
                use rayon::prelude::*;
                let inner: Vec<usize> = inner.collect();
                inner
                    .into_par_iter()
                    .for_each(|c| self.count(c, par_depth + 1));
            } else {
                stack.extend(inner.map(|c| (c, None)));
            }
        }
    }

    /// Pass 2: writes the wide node of `job` and its whole block (an explicit stack; the blocks
    /// of large nodes' children in parallel).
    fn place<'o>(&self, job: Job<'o, W>, par_depth: usize) {
        let mut s = Scratch::default();
        let mut stack = vec![job];
        let mut next = Vec::with_capacity(W);
        while let Some(job) = stack.pop() {
            let big = self.refs[job.bin] >= self.par_refs && par_depth < MAX_PAR_DEPTH;
            self.fill(job, &mut s, &mut next);
            if big {
                use rayon::prelude::*;
                let jobs = std::mem::take(&mut next);
                jobs.into_par_iter()
                    .for_each(|j| self.place(j, par_depth + 1));
            } else {
                stack.append(&mut next);
            }
        }
    }

    /// Writes the wide node of `job` (its leaf children's packets and oversized leaves'
    /// nodes included); pushes onto `next` the jobs of its inner children, each with its
    /// block's range.
    fn fill<'o>(&self, job: Job<'o, W>, s: &mut Scratch, next: &mut Vec<Job<'o, W>>) {
        let Job { bin, slot, mut out } = job;
        let nodes = &self.bvh.nodes;
        let kids = self.kids(bin);
        let mut node = WideNode::<W>::EMPTY;
        let mut inner: [(usize, Option<&'o mut MaybeUninit<WideNode<W>>>); W] =
            std::array::from_fn(|_| (0, None));
        let mut m = 0;
        // The references of every leaf child first, their primitives asked for all at once:
        // they lie scattered over the whole primitive array, and the node's leaves then wait
        // for memory together rather than one after the other.
        s.node_prims.clear();
        let mut ends = [0usize; W];
        for (k, &c) in kids.as_slice().iter().enumerate() {
            if self.plan.is_leaf(c) {
                self.leaf_prims(c, s);
                for &p in &s.prims {
                    self.tris.prefetch(p);
                }
                s.node_prims.extend_from_slice(&s.prims);
            }
            ends[k] = s.node_prims.len();
        }
        for (k, &c) in kids.as_slice().iter().enumerate() {
            for (row, v) in node.bounds.iter_mut().zip(rows(&nodes[c].bounds())) {
                row[k] = v;
            }
            node.children[k] = if self.plan.is_leaf(c) {
                let start = if k == 0 { 0 } else { ends[k - 1] };
                self.leaf(c, &mut s.node_prims[start..ends[k]], &mut out)
            } else {
                let (i, child_slot) = out.node();
                if let Some(l) = &self.inner {
                    l.lock().expect("inner").push((i, c as u32));
                }
                inner[m] = (c, Some(child_slot));
                m += 1;
                i
            };
            node.valid |= 1 << k;
        }
        node.set_order();
        slot.write(node);
        for (c, child_slot) in inner[..m].iter_mut().rev() {
            let child_out = out.take(self.block(*c));
            next.push(Job {
                bin: *c,
                slot: child_slot.take().expect("set above"),
                out: child_out,
            });
        }
        assert!(out.is_used_up(), "a block's shape was miscounted");
    }

    /// Writes the wide leaf standing for binary node `bin`, whose references
    /// ([`Layout::leaf_prims`]) are `prims` (its packets, and its nodes when it holds more than
    /// [`LEAF_MAX`] references); returns the child reference.
    fn leaf(&self, bin: usize, prims: &mut [u32], out: &mut Out<'_, W>) -> u32 {
        for &p in prims.iter() {
            assert!(
                (p as usize) < self.tris.len(),
                "the BVH references triangle {p}, but there are only {}",
                self.tris.len()
            );
        }
        let bounds = self.bvh.nodes[bin].bounds();
        if let (Some(leaves), true) = (&self.leaves, prims.len() <= LEAF_MAX) {
            let mut l = leaves.lock().expect("leaves");
            l.push((out.pbase as u32, bin as u32));
        }
        if prims.len() > LEAF_MAX {
            // Sort along the longest axis so that the sub-leaves have tight boxes.
            let axis = bounds.largest_axis();
            let key = |p: u32| self.tris.centroid(p)[axis];
            prims.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        }
        self.big_leaf(prims, &bounds, out)
    }

    fn big_leaf(&self, prims: &[u32], bounds: &Aabb, out: &mut Out<'_, W>) -> u32 {
        if prims.len() <= LEAF_MAX {
            let first = out.pbase;
            assert!(
                first + MAX_LEAF_PACKETS <= LEAF_FIRST_MASK as usize,
                "too many triangle packets"
            );
            for chunk in prims.chunks(4) {
                self.packet(chunk, out.packet());
            }
            return encode_leaf(first, prims.len().div_ceil(4));
        }
        // `W` children of (a multiple of 4) references each.
        let per = prims.len().div_ceil(W).div_ceil(4) * 4;
        let (k, slot) = out.node();
        let mut node = WideNode::<W>::EMPTY;
        for (s, part) in prims.chunks(per).enumerate() {
            let mut b = Aabb::EMPTY;
            for &p in part {
                b.grow_aabb(&self.tris.bounds(p));
            }
            // With spatial splits the triangles may stick out of the leaf: clip the box.
            let mut b = b.intersection(bounds);
            if b.is_empty() {
                b = *bounds;
            }
            for (row, v) in node.bounds.iter_mut().zip(rows(&b)) {
                row[s] = v;
            }
            node.children[s] = self.big_leaf(part, &b, out);
            node.valid |= 1 << s;
        }
        node.set_order();
        slot.write(node);
        k
    }

    /// Writes the packet of (at most 4) `prims` into `slot`, in place.
    fn packet(&self, prims: &[u32], slot: &mut MaybeUninit<TriPacket>) {
        let p = slot.write(TriPacket {
            v: [[[f32::NAN; 4]; 3]; 3],
            prims: [u32::MAX; 4],
        });
        for (lane, &prim) in prims.iter().enumerate() {
            self.tris.fill_lane(p, lane, prim);
        }
    }
}

/// Most entries the traversal stack can hold, plus `W`: at an inner node `n` it holds the
/// pending siblings of `n`'s ancestors (at most `Σ (children - 1)` over them) plus, briefly,
/// all of `n`'s children; the branch-free pushes (`Stack::push_if`, `Stack::spare`) write up
/// to `W` entries above the pending ones.
fn stack_bound<const W: usize>(nodes: &[WideNode<W>], root: u32) -> usize {
    let mut bound = 1;
    if root & LEAF_BIT != 0 {
        return bound;
    }
    let mut todo = vec![(root as usize, 0usize)];
    while let Some((i, pending)) = todo.pop() {
        let node = &nodes[i];
        let c = node.child_count();
        bound = bound.max(pending + c);
        for s in 0..W {
            let ch = node.children[s];
            if node.valid & (1 << s) != 0 && ch & LEAF_BIT == 0 {
                todo.push((ch as usize, pending + c - 1));
            }
        }
    }
    bound + W
}

fn rows(b: &Aabb) -> [f32; 6] {
    [b.min.x, b.max.x, b.min.y, b.max.y, b.min.z, b.max.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_builders::{registry, BuildInput, CostModel};
    use sahara_geom::{rng::Pcg32, Vec3A};

    fn soup(n: usize, seed: u64) -> Vec<Triangle> {
        let mut r = Pcg32::new(seed, 3);
        let mut p = |s: f32| Vec3A::new(r.range_f32(-s, s), r.range_f32(-s, s), r.range_f32(-s, s));
        (0..n)
            .map(|_| {
                let c = p(1.0);
                Triangle::new(c + p(0.05), c + p(0.05), c + p(0.05))
            })
            .collect()
    }

    fn build(name: &str, tris: &[Triangle]) -> Bvh {
        let input = BuildInput::new(tris, CostModel::default()).unwrap();
        registry::by_name(name).unwrap().build(&input).unwrap()
    }

    fn refs(bvh: &Bvh) -> Vec<u64> {
        let n = bvh.nodes.len();
        let mut refs = vec![0u64; n];
        for i in (0..n).rev() {
            let node = &bvh.nodes[i];
            refs[i] = if node.is_leaf() {
                node.count as u64
            } else {
                refs[i + 1] + refs[node.index as usize]
            };
        }
        refs
    }

    /// The SAH cost of a wide tree under the collapse's cost model.
    fn wide_cost<const W: usize>(w: &WideBvh<W>) -> f64 {
        let mut cost = half_area(&w.root_bounds)
            * if w.root & LEAF_BIT == 0 {
                C_NODE as f64
            } else {
                (C_LEAF + C_PACKET * super::super::decode_leaf(w.root).1 as f32) as f64
            };
        for node in &w.nodes {
            for s in 0..W {
                if node.valid & (1 << s) == 0 {
                    continue;
                }
                let a = half_area(&node.child_bounds(s));
                let c = node.children[s];
                cost += if c & LEAF_BIT != 0 {
                    let (_, packets) = super::super::decode_leaf(c);
                    a * (C_LEAF + C_PACKET * packets as f32) as f64
                } else {
                    a * C_NODE as f64
                };
            }
        }
        cost
    }

    fn check<const W: usize>(bvh: &Bvh, tris: &[Triangle]) {
        let refs = refs(bvh);
        let plan = Plan::new(bvh, &mut refs.clone(), W, Par::DEFAULT);
        let w = collapse::<W>(bvh, Source::Triangles(tris));
        // The built tree is the planned one (no leaf exceeds 32 references here).
        let (planned, built) = (plan.root_cost, wide_cost(&w));
        assert!(
            (planned - built).abs() <= 1e-4 * planned,
            "plan {planned}, tree {built}"
        );
        // No worse than the trivial collapse (every binary node kept, leaves as they are).
        let trivial: f64 = bvh
            .nodes
            .iter()
            .zip(&refs)
            .map(|(n, &r)| {
                let c = if n.is_leaf() { leaf_cost(r) } else { C_NODE };
                half_area(&n.bounds()) * c as f64
            })
            .sum();
        assert!(planned <= trivial * (1.0 + 1e-4), "{planned} > {trivial}");
        // Every node has 2..=W children; every triangle is in exactly one lane.
        let mut seen = vec![0u32; tris.len()];
        for n in &w.nodes {
            assert!((2..=W).contains(&n.child_count()));
        }
        for p in &w.packets {
            for &prim in p.prims.iter().filter(|&&p| p != u32::MAX) {
                seen[prim as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        // Deterministic, bit for bit.
        let again = collapse::<W>(bvh, Source::Triangles(tris));
        assert_eq!(bits(&w), bits(&again));
        same_bits_in_parallel(bvh, tris, &w);
    }

    /// Every bit of a wide tree.
    fn bits<const W: usize>(w: &WideBvh<W>) -> Vec<u32> {
        w.nodes
            .iter()
            .flat_map(|n| {
                n.bounds
                    .iter()
                    .flatten()
                    .map(|f| f.to_bits())
                    .chain(n.children)
                    .chain([n.valid])
                    .chain(n.order.map(u32::from))
                    .collect::<Vec<_>>()
            })
            .chain(w.packets.iter().flat_map(|p| {
                p.v.iter()
                    .flatten()
                    .flatten()
                    .map(|f| f.to_bits())
                    .chain(p.prims)
                    .collect::<Vec<_>>()
            }))
            .chain([w.root, w.max_stack as u32])
            .collect()
    }

    /// Whatever runs in parallel (every subtree, some, or none), the collapse gives `w`'s bits.
    fn same_bits_in_parallel<const W: usize>(bvh: &Bvh, tris: &[Triangle], w: &WideBvh<W>) {
        for par in [
            Par {
                plan_nodes: 1,
                refs: 1,
            },
            Par {
                plan_nodes: 3,
                refs: 40,
            },
            Par {
                plan_nodes: usize::MAX,
                refs: u64::MAX,
            },
        ] {
            let p = collapse_with::<W>(bvh, Source::Triangles(tris), par);
            assert_eq!(bits(w), bits(&p));
        }
    }

    #[test]
    fn the_plan_is_the_tree_and_beats_the_trivial_collapse() {
        for (n, seed) in [(1, 1), (7, 2), (300, 3), (3000, 4)] {
            let tris = soup(n, seed);
            for builder in ["sweep", "binned"] {
                let bvh = build(builder, &tris);
                check::<4>(&bvh, &tris);
                check::<8>(&bvh, &tris);
            }
        }
    }

    /// Every node's stored child order, for every octant class, is a permutation of the slots
    /// with the used slots first, sorted by the centre's projection on the octant's diagonal.
    fn check_orders<const W: usize>(w: &WideBvh<W>) {
        for node in w.nodes.iter() {
            for q in 0..4 {
                let p = node.order_bits(q);
                let slots: Vec<usize> = (0..W).map(|k| (p >> (3 * k)) as usize & 7).collect();
                let mut sorted = slots.clone();
                sorted.sort_unstable();
                assert_eq!(
                    sorted,
                    (0..W).collect::<Vec<_>>(),
                    "not a permutation: {slots:?}"
                );
                let used = node.child_count();
                assert!(slots[..used].iter().all(|&s| node.valid & (1 << s) != 0));
                let sign = [1.0 - 2.0 * (q & 1) as f64, 1.0 - (q & 2) as f64, 1.0];
                let key = |s: usize| {
                    let b = node.child_bounds(s);
                    (0..3)
                        .map(|a| sign[a] * (b.min[a] as f64 + b.max[a] as f64))
                        .sum::<f64>()
                };
                assert!(slots[..used].windows(2).all(|x| key(x[0]) <= key(x[1])));
            }
        }
    }

    #[test]
    fn child_orders_follow_the_octants() {
        let tris = soup(3000, 6);
        let bvh = build("sweep", &tris);
        check_orders(&collapse::<4>(&bvh, Source::Triangles(&tris)));
        check_orders(&collapse::<8>(&bvh, Source::Triangles(&tris)));
    }

    #[test]
    fn parallel_collapse_is_bit_identical_with_spatial_splits_and_on_any_thread_count() {
        let tris = soup(400, 6);
        let bvh = build("sbvh", &tris);
        assert!(bvh.spatial_splits);
        let w = collapse::<8>(&bvh, Source::Triangles(&tris));
        same_bits_in_parallel(&bvh, &tris, &w);
        let tris = soup(20_000, 7);
        let bvh = build("binned", &tris);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let w = one.install(|| collapse::<8>(&bvh, Source::Triangles(&tris)));
        assert_eq!(
            bits(&w),
            bits(&collapse::<8>(&bvh, Source::Triangles(&tris)))
        );
        same_bits_in_parallel(&bvh, &tris, &w);
    }

    /// The `O(W)` distributions for a leaf child equal the full scan bit for bit, on rows as
    /// the plan makes them (non-increasing, a leaf's constant), with ties and infinities.
    #[test]
    fn leaf_child_distributions_equal_the_full_scan() {
        let mut rng = Pcg32::new(5, 9);
        // A non-increasing row of `w` costs from a few values (so that ties are common).
        let row = |rng: &mut Pcg32, w: usize| -> Vec<f32> {
            let vals = [f32::INFINITY, 9.0, 4.5, 3.0, 3.0, 1.25, 0.1, 0.0];
            let mut r: Vec<f32> = (0..w)
                .map(|_| vals[(rng.next_u32() % vals.len() as u32) as usize])
                .collect();
            r.sort_by(|a, b| b.total_cmp(a));
            r
        };
        for w in [4usize, 8] {
            for case in 0..5000 {
                let (l, r) = (row(&mut rng, w), row(&mut rng, w));
                let leaf = [0.75f32, f32::INFINITY, 3.0][case % 3];
                let mut want = ([0.0f32; 9], [0u8; 9]);
                let mut got = ([0.0f32; 9], [0u8; 9]);
                distribute(&[leaf; 8][..w], &r, &mut want.0[..=w], &mut want.1[..=w]);
                distribute_left_leaf(leaf, &r, &mut got.0[..=w], &mut got.1[..=w]);
                assert_eq!(want.0.map(f32::to_bits), got.0.map(f32::to_bits), "{r:?}");
                assert_eq!(want.1, got.1, "left leaf {leaf}, right row {r:?}");
                distribute(&l, &[leaf; 8][..w], &mut want.0[..=w], &mut want.1[..=w]);
                distribute_right_leaf(&l, leaf, &mut got.0[..=w], &mut got.1[..=w]);
                assert_eq!(want.0.map(f32::to_bits), got.0.map(f32::to_bits), "{l:?}");
                assert_eq!(want.1, got.1, "left row {l:?}, right leaf {leaf}");
            }
        }
    }

    #[test]
    fn the_rank_sort_sorts_with_duplicates() {
        let mut r = Pcg32::new(9, 1);
        for n in 0..=LEAF_MAX {
            for range in [4, 1000] {
                let mut v: Vec<u32> = (0..n).map(|_| r.next_u32() % range).collect();
                let mut expected = v.clone();
                expected.sort_unstable();
                sort_small(&mut v);
                assert_eq!(v, expected);
            }
        }
    }

    /// `bvh` laid out so that subtrees are not contiguous: each node is followed by its left
    /// child (as the format requires), but right children are deferred to a queue.
    fn deferred_right_children(bvh: &Bvh) -> Bvh {
        let mut order = Vec::with_capacity(bvh.nodes.len());
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(mut n) = queue.pop_front() {
            loop {
                order.push(n);
                let node = &bvh.nodes[n];
                if node.is_leaf() {
                    break;
                }
                queue.push_back(node.index as usize);
                n += 1;
            }
        }
        let mut new_index = vec![0u32; bvh.nodes.len()];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new as u32;
        }
        let nodes = order
            .iter()
            .map(|&old| {
                let mut node = bvh.nodes[old];
                if !node.is_leaf() {
                    node.index = new_index[node.index as usize];
                }
                node
            })
            .collect();
        Bvh {
            nodes,
            prim_indices: bvh.prim_indices.clone(),
            spatial_splits: bvh.spatial_splits,
            ref_cuts: None,
        }
    }

    #[test]
    fn layouts_that_are_not_depth_first_collapse_to_the_same_tree() {
        let tris = soup(3000, 8);
        let bvh = build("binned", &tris);
        let moved = deferred_right_children(&bvh);
        moved.validate(&tris).unwrap();
        // Not depth first any more: some right child does not follow its left subtree.
        let n = moved.nodes.len();
        let mut size = vec![1usize; n];
        for i in (0..n).rev() {
            let node = &moved.nodes[i];
            if !node.is_leaf() {
                size[i] += size[i + 1] + size[node.index as usize];
            }
        }
        assert!(moved
            .nodes
            .iter()
            .enumerate()
            .any(|(i, node)| !node.is_leaf() && node.index as usize != i + 1 + size[i + 1]));
        let w = collapse::<8>(&bvh, Source::Triangles(&tris));
        assert_eq!(
            bits(&w),
            bits(&collapse::<8>(&moved, Source::Triangles(&tris)))
        );
        same_bits_in_parallel(&moved, &tris, &w);
    }

    #[test]
    fn degenerate_triangles_are_nan_lanes() {
        let mut tris = soup(10, 5);
        tris[3] = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0);
        let bvh = build("sweep", &tris);
        let w = collapse::<8>(&bvh, Source::Triangles(&tris));
        let mut found = false;
        for p in &w.packets {
            for lane in 0..4 {
                if p.prims[lane] == 3 {
                    found = true;
                    assert!(p.v.iter().flatten().all(|row| row[lane].is_nan()));
                } else if p.prims[lane] != u32::MAX {
                    assert_eq!(p.triangle(lane), tris[p.prims[lane] as usize]);
                }
            }
        }
        assert!(found);
    }
}
