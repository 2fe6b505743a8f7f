//! Collapsing a binary [`Bvh`] into a [`WideBvh`]: the SAH-optimal collapse of Ylitie, Karras
//! and Laine (2017) by dynamic programming over the binary tree ([`Plan`]), then the wide
//! nodes and the leaf packets are laid out depth first.

use super::memory::HugeSlice;
use super::{
    decode_leaf, encode_leaf, Backend, TriPacket, WideBvh, WideNode, LEAF_BIT, LEAF_FIRST_MASK,
    MAX_LEAF_PACKETS, NO_ROOT,
};
use sahara_bvh::Bvh;
use sahara_geom::intersect::is_degenerate;
use sahara_geom::{Aabb, Triangle};
use std::mem::MaybeUninit;

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
}

impl Source<'_> {
    pub(crate) fn len(&self) -> usize {
        match self {
            Source::Triangles(t) => t.len(),
            Source::Boxes(b) => b.len(),
        }
    }

    pub(crate) fn bounds(&self, p: u32) -> Aabb {
        match self {
            Source::Triangles(t) => t[p as usize].bounds(),
            Source::Boxes(b) => b[p as usize],
        }
    }

    fn centroid(&self, p: u32) -> sahara_geom::Vec3A {
        match self {
            Source::Triangles(t) => t[p as usize].centroid(),
            Source::Boxes(b) => b[p as usize].centroid(),
        }
    }

    /// Writes primitive `prim` into lane `lane` of a packet: its vertices (NaN for a
    /// degenerate triangle, which never hits, and for a box primitive) and its index.
    pub(crate) fn fill_lane(&self, p: &mut TriPacket, lane: usize, prim: u32) {
        p.prims[lane] = prim;
        for k in 0..3 {
            for a in 0..3 {
                p.v[k][a][lane] = f32::NAN;
            }
        }
        let Source::Triangles(tris) = self else {
            return;
        };
        let t = &tris[prim as usize];
        if is_degenerate(t) {
            // Never hit (`accept_hit`): NaN vertices, which the packet tests never hit, so
            // the SIMD tests need not check for degenerate triangles.
            return;
        }
        for k in 0..3 {
            for a in 0..3 {
                p.v[k][a][lane] = t.v[k][a];
            }
        }
    }
}

struct Collapser<'a, const W: usize> {
    bvh: &'a Bvh,
    tris: Source<'a>,
    nodes: Vec<WideNode<W>>,
    packets: Vec<TriPacket>,
    /// Wide nodes allocated but not filled yet: `(binary node, wide node)`.
    work: Vec<(usize, usize)>,
    /// What every binary node becomes.
    plan: &'a Plan,
    /// Reused buffers of [`Collapser::subtree_prims`] (the references of a leaf and the
    /// binary nodes still to visit), so that no leaf allocates.
    prims: Vec<u32>,
    todo: Vec<usize>,
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
    /// The plan for `bvh`, whose subtree `n` holds `refs[n]` references. `sizes`, when the
    /// layout is depth first with every subtree contiguous (subtree `n` is the node range
    /// `n..n + sizes[n]`), lets large subtrees be planned in parallel; the plan is the same
    /// bit for bit (every node's row depends on its children's rows only).
    fn new(bvh: &Bvh, refs: &[u64], width: usize, sizes: Option<&[u32]>, par: Par) -> Self {
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
            refs,
            width,
            scale,
            par_nodes: par.plan_nodes,
        };
        match sizes {
            Some(sizes) if n > par.plan_nodes => {
                rows.subtree(sizes, 0, &mut cost, &mut choice, &mut split);
            }
            _ => rows.range(0, n, &mut cost, &mut choice, &mut split),
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
    fn gather(&self, bvh: &Bvh, n: usize, mut slots: usize, out: &mut Vec<usize>) {
        let row = n * self.width;
        while slots > 1 && self.choice[row + slots - 1] == 0 {
            slots -= 1;
        }
        if slots == 1 {
            out.push(n);
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
    /// Subtrees of at least this many references collapse their children's subtrees as
    /// separate fragments at once.
    refs: u64,
}

impl Par {
    const DEFAULT: Par = Par {
        plan_nodes: 1 << 14,
        refs: 1 << 14,
    };
}

/// The dynamic programme of [`Plan`], row by row: a row holds, for one binary node, its `width`
/// costs and choices (`cost` and `choice` slices start at the row of some node `base`).
struct PlanRows<'a> {
    bvh: &'a Bvh,
    refs: &'a [u64],
    width: usize,
    scale: f64,
    par_nodes: usize,
}

impl PlanRows<'_> {
    /// Rows of the nodes `a..b` (slices starting at node `a`), last node first; the children
    /// of every node of the range are in the range after it.
    fn range(&self, a: usize, b: usize, cost: &mut [f32], choice: &mut [u8], split: &mut [u8]) {
        let w = self.width;
        for i in (a..b).rev() {
            let node = &self.bvh.nodes[i];
            let row = (i - a) * w;
            let (head, tail) = cost.split_at_mut(row + w);
            let kids = (!node.is_leaf()).then(|| {
                let (l, r) = (i + 1, node.index as usize);
                let l = &tail[(l - i - 1) * w..][..w];
                let r = &tail[(r - i - 1) * w..][..w];
                (l, r)
            });
            split[i - a] = self.row(i, kids, &mut head[row..], &mut choice[row..row + w]);
        }
    }

    /// Rows of the subtree of `i`, the node range `i..i + sizes[i]` (slices starting at node
    /// `i`), both children in parallel when the subtree is large.
    fn subtree(
        &self,
        sizes: &[u32],
        i: usize,
        cost: &mut [f32],
        choice: &mut [u8],
        split: &mut [u8],
    ) {
        let size = sizes[i] as usize;
        let node = &self.bvh.nodes[i];
        if size <= self.par_nodes || node.is_leaf() {
            self.range(i, i + size, cost, choice, split);
            return;
        }
        let w = self.width;
        // Layout: row `i`, then the left subtree `i + 1..r`, then the right one `r..`.
        let nl = sizes[i + 1] as usize;
        let (own_cost, kids_cost) = cost.split_at_mut(w);
        let (l_cost, r_cost) = kids_cost.split_at_mut(nl * w);
        let (own_choice, kids_choice) = choice.split_at_mut(w);
        let (l_choice, r_choice) = kids_choice.split_at_mut(nl * w);
        let (own_split, kids_split) = split.split_at_mut(1);
        let (l_split, r_split) = kids_split.split_at_mut(nl);
        rayon::join(
            || self.subtree(sizes, i + 1, l_cost, l_choice, l_split),
            || self.subtree(sizes, i + 1 + nl, r_cost, r_choice, r_split),
        );
        own_split[0] = self.row(i, Some((&l_cost[..w], &r_cost[..w])), own_cost, own_choice);
    }

    /// Fills the row of node `i` (`cost` and `choice` start at it) from its children's rows
    /// (`None` for a leaf); returns the slots given to the left child in `distribute(i, W)`.
    fn row(
        &self,
        i: usize,
        kids: Option<(&[f32], &[f32])>,
        cost: &mut [f32],
        choice: &mut [u8],
    ) -> u8 {
        let width = self.width;
        let node = &self.bvh.nodes[i];
        let refs = self.refs[i];
        let area = (half_area(&node.bounds()) * self.scale) as f32;
        let Some((l, r)) = kids else {
            let c = area * leaf_cost(refs);
            cost[..width].fill(c);
            choice[0] = AS_LEAF;
            return 0;
        };
        let mut dist = [0.0f32; 9];
        let mut dist_k = [0u8; 9];
        for (j, (d, dk)) in dist[..=width]
            .iter_mut()
            .zip(dist_k[..=width].iter_mut())
            .enumerate()
            .skip(2)
        {
            let mut best = f32::INFINITY;
            let mut best_k = 1;
            for k in 1..j {
                let c = l[k - 1] + r[j - k - 1];
                if c < best {
                    best = c;
                    best_k = k;
                }
            }
            *d = best;
            *dk = best_k as u8;
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
        };
    }
    let n = bvh.nodes.len();
    // References and binary nodes of every subtree, and whether every subtree is a contiguous
    // range of the layout (then large subtrees are planned in parallel).
    let mut refs = vec![0u64; n];
    let mut sizes = vec![0u32; n];
    let mut contiguous = true;
    for i in (0..n).rev() {
        let node = &bvh.nodes[i];
        if node.is_leaf() {
            refs[i] = node.count as u64;
            sizes[i] = 1;
        } else {
            let (l, r) = (i + 1, node.index as usize);
            refs[i] = refs[l].saturating_add(refs[r]);
            sizes[i] = sizes[l].saturating_add(sizes[r]).saturating_add(1);
            contiguous &= r == i + 1 + sizes[l] as usize;
        }
    }
    contiguous &= sizes[0] as usize == n;
    let plan = Plan::new(bvh, &refs, W, contiguous.then_some(&sizes[..]), par);
    drop(sizes);
    let (nodes, packets, root) = if plan.is_leaf(0) {
        let mut c = Collapser::<W>::new(bvh, tris, &plan, Vec::new());
        let root = c.child(0);
        debug_assert!(c.work.is_empty());
        (c.nodes.into(), c.packets.into(), root)
    } else {
        let frag = fragment::<W>(bvh, tris, &plan, &refs, par.refs, 0);
        let (nodes, packets) = flatten(frag);
        (nodes, packets, 0)
    };
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
    }
}

/// The wide subtree of one binary node that becomes a wide inner node, with indices local to
/// the fragment: node `0` is the subtree's own wide node, node `j >= 1` the `j`-th node of the
/// block that the depth-first collapse lays out for its descendants; leaves count packets
/// from the fragment's first. `subs` are the fragments of large child subtrees built
/// separately (in parallel), in the order the sequential collapse lays them out after
/// `nodes`, each with the local index of the slot its own node fills.
struct Frag<const W: usize> {
    nodes: Vec<WideNode<W>>,
    packets: Vec<TriPacket>,
    subs: Vec<(usize, Frag<W>)>,
}

/// The fragment of binary node `bin` (planned as a wide inner node). The sequential collapse
/// fills a wide node, allocating its inner children at the end of the node array (and the
/// packets of its leaf children), then fills those children from the last to the first, each
/// with its whole subtree: so every wide node's descendants are one contiguous block, laid out
/// as the node's children, then the blocks of its last child to its first. Subtrees of at
/// least `par_refs` references build the blocks of their inner children as
/// separate fragments in parallel; [`flatten`] joins them into exactly the sequential layout.
fn fragment<const W: usize>(
    bvh: &Bvh,
    tris: Source<'_>,
    plan: &Plan,
    refs: &[u64],
    par_refs: u64,
    bin: usize,
) -> Frag<W> {
    let mut c = Collapser::<W>::new(bvh, tris, plan, vec![WideNode::EMPTY]);
    c.fill(bin, 0);
    if refs[bin] < par_refs {
        while let Some((b, w)) = c.work.pop() {
            c.fill(b, w);
        }
        return Frag {
            nodes: c.nodes,
            packets: c.packets,
            subs: Vec::new(),
        };
    }
    use rayon::prelude::*;
    let work = std::mem::take(&mut c.work);
    // The sequential collapse pops its work stack: the last child first.
    let subs = work
        .into_par_iter()
        .rev()
        .map(|(b, w)| (w, fragment::<W>(bvh, tris, plan, refs, par_refs, b)))
        .collect();
    Frag {
        nodes: c.nodes,
        packets: c.packets,
        subs,
    }
}

/// The node and packet arrays of the whole tree from the root's fragment, written straight
/// into their final memory: every fragment's block goes to the range the sequential collapse
/// gives it, the fragments of large subtrees in parallel (disjoint ranges).
fn flatten<const W: usize>(root: Frag<W>) -> (HugeSlice<WideNode<W>>, HugeSlice<TriPacket>) {
    if root.subs.is_empty() {
        // Built in one piece: local indices are the global ones.
        return (root.nodes.into(), root.packets.into());
    }
    let (n_nodes, n_packets) = count(&root);
    // The root's own node is node 0, its block starts at node 1.
    let own = relocate(&root.nodes[0], 1, 0);
    // SAFETY: `place` writes every element of the slices it is given (`count` is the size of
    // a fragment's block and of its packets, checked in debug builds), and node 0 is written
    // here.
    unsafe {
        let mut packets = None;
        let nodes = HugeSlice::from_init(n_nodes, |nodes| {
            let (first, block) = nodes.split_at_mut(1);
            first[0].write(own);
            packets = Some(HugeSlice::from_init(n_packets, |packets| {
                place(&root, 1, 0, block, packets);
            }));
        });
        (nodes, packets.expect("written above"))
    }
}

/// Nodes (its own one included) and packets of a fragment and its sub-fragments.
fn count<const W: usize>(f: &Frag<W>) -> (usize, usize) {
    f.subs
        .iter()
        .fold((f.nodes.len(), f.packets.len()), |(n, p), (_, s)| {
            let (sn, sp) = count(s);
            // A sub-fragment's own node fills a slot of its parent.
            (n + sn - 1, p + sp)
        })
}

/// Writes the block of fragment `f` (every node but its own, which its parent writes) at
/// global node `base` and its packets at `pbase`, then its sub-fragments' blocks after it, in
/// the order of the sequential collapse; sub-fragments in parallel. `nodes` and `packets` are
/// exactly the ranges of the block and of the packets of `f` and its sub-fragments.
fn place<const W: usize>(
    f: &Frag<W>,
    base: usize,
    pbase: usize,
    nodes: &mut [MaybeUninit<WideNode<W>>],
    packets: &mut [MaybeUninit<TriPacket>],
) {
    debug_assert_eq!((nodes.len() + 1, packets.len()), count(f));
    let own = f.nodes.len() - 1;
    let (mine, mut rest) = nodes.split_at_mut(own);
    for (out, n) in mine.iter_mut().zip(&f.nodes[1..]) {
        out.write(relocate(n, base, pbase));
    }
    let (pmine, mut prest) = packets.split_at_mut(f.packets.len());
    for (out, p) in pmine.iter_mut().zip(&f.packets) {
        out.write(*p);
    }
    let (mut b, mut pb) = (base + own, pbase + f.packets.len());
    let mut jobs = Vec::with_capacity(f.subs.len());
    for (w, sub) in &f.subs {
        let (sn, sp) = count(sub);
        // The sub-fragment's own node fills slot `w` of this fragment's block.
        mine[w - 1].write(relocate(&sub.nodes[0], b, pb));
        let (sub_nodes, r) = std::mem::take(&mut rest).split_at_mut(sn - 1);
        let (sub_packets, pr) = std::mem::take(&mut prest).split_at_mut(sp);
        rest = r;
        prest = pr;
        jobs.push((sub, b, pb, sub_nodes, sub_packets));
        b += sn - 1;
        pb += sp;
    }
    use rayon::prelude::*;
    jobs.into_par_iter()
        .for_each(|(sub, b, pb, n, p)| place(sub, b, pb, n, p));
}

/// A fragment's node with global indices: local node `j >= 1` is node `base + j - 1` (no
/// child is the fragment's own node `0`), packets start at `pbase`.
fn relocate<const W: usize>(n: &WideNode<W>, base: usize, pbase: usize) -> WideNode<W> {
    let mut out = *n;
    for s in 0..W {
        if n.valid & (1 << s) == 0 {
            continue;
        }
        let c = n.children[s];
        out.children[s] = if c & LEAF_BIT != 0 {
            let (first, count) = decode_leaf(c);
            let first = first + pbase;
            assert!(
                first + MAX_LEAF_PACKETS <= LEAF_FIRST_MASK as usize,
                "too many triangle packets"
            );
            encode_leaf(first, count)
        } else {
            debug_assert!(c >= 1);
            (base + c as usize - 1) as u32
        };
    }
    out
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

impl<'a, const W: usize> Collapser<'a, W> {
    fn new(bvh: &'a Bvh, tris: Source<'a>, plan: &'a Plan, nodes: Vec<WideNode<W>>) -> Self {
        Self {
            bvh,
            tris,
            nodes,
            packets: Vec::new(),
            work: Vec::new(),
            plan,
            prims: Vec::new(),
            todo: Vec::new(),
        }
    }

    /// The wide child standing for binary node `bin`: a leaf over its subtree or a (not yet
    /// filled) wide node, as planned.
    fn child(&mut self, bin: usize) -> u32 {
        let node = self.bvh.nodes[bin];
        if self.plan.is_leaf(bin) {
            let mut prims = std::mem::take(&mut self.prims);
            self.subtree_prims(bin, &mut prims);
            let leaf = self.leaf(&mut prims, &node.bounds());
            self.prims = prims;
            return leaf;
        }
        let k = self.nodes.len();
        self.nodes.push(WideNode::EMPTY);
        self.work.push((bin, k));
        k as u32
    }

    /// The distinct references of a binary subtree, sorted, into `prims`.
    fn subtree_prims(&mut self, bin: usize, prims: &mut Vec<u32>) {
        prims.clear();
        let todo = &mut self.todo;
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
        prims.sort_unstable();
        prims.dedup();
    }

    /// Fills wide node `wide` from binary inner node `bin`: its children are the binary nodes
    /// of the plan's best distribution of `bin`'s subtree over `W` slots, in depth-first order.
    fn fill(&mut self, bin: usize, wide: usize) {
        let bvh = self.bvh;
        let nodes = &bvh.nodes;
        let mut list: Vec<usize> = Vec::with_capacity(W);
        let k = self.plan.split[bin] as usize;
        self.plan.gather(bvh, bin + 1, k, &mut list);
        self.plan
            .gather(bvh, nodes[bin].index as usize, W - k, &mut list);
        let mut out = WideNode::<W>::EMPTY;
        for (s, &c) in list.iter().enumerate() {
            let r = rows(&nodes[c].bounds());
            for (row, v) in out.bounds.iter_mut().zip(r) {
                row[s] = v;
            }
            out.children[s] = self.child(c);
            out.valid |= 1 << s;
        }
        out.set_order();
        self.nodes[wide] = out;
    }

    /// A leaf over `prims` (distinct) inside `bounds`: packets of 4, or a small subtree of
    /// leaves when there are more than [`LEAF_MAX`] references.
    fn leaf(&mut self, prims: &mut [u32], bounds: &Aabb) -> u32 {
        for &p in prims.iter() {
            assert!(
                (p as usize) < self.tris.len(),
                "the BVH references triangle {p}, but there are only {}",
                self.tris.len()
            );
        }
        if prims.len() > LEAF_MAX {
            // Sort along the longest axis so that the sub-leaves have tight boxes.
            let axis = bounds.largest_axis();
            let key = |p: u32| self.tris.centroid(p)[axis];
            prims.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        }
        self.big_leaf(prims, bounds)
    }

    fn big_leaf(&mut self, prims: &[u32], bounds: &Aabb) -> u32 {
        if prims.len() <= LEAF_MAX {
            let first = self.packets.len();
            assert!(
                first + MAX_LEAF_PACKETS <= LEAF_FIRST_MASK as usize,
                "too many triangle packets"
            );
            for chunk in prims.chunks(4) {
                self.packets.push(self.packet(chunk));
            }
            return encode_leaf(first, self.packets.len() - first);
        }
        // `W` children of (a multiple of 4) references each.
        let per = prims.len().div_ceil(W).div_ceil(4) * 4;
        let k = self.nodes.len();
        self.nodes.push(WideNode::EMPTY);
        let mut out = WideNode::<W>::EMPTY;
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
            for (row, v) in out.bounds.iter_mut().zip(rows(&b)) {
                row[s] = v;
            }
            out.children[s] = self.big_leaf(part, &b);
            out.valid |= 1 << s;
        }
        out.set_order();
        self.nodes[k] = out;
        k as u32
    }

    fn packet(&self, prims: &[u32]) -> TriPacket {
        let mut p = TriPacket {
            v: [[[f32::NAN; 4]; 3]; 3],
            prims: [u32::MAX; 4],
        };
        for (lane, &prim) in prims.iter().enumerate() {
            self.tris.fill_lane(&mut p, lane, prim);
        }
        p
    }
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
        let plan = Plan::new(bvh, &refs, W, None, Par::DEFAULT);
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
