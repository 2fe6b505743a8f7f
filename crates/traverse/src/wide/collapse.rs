//! Collapsing a binary [`Bvh`] into a [`WideBvh`]: the SAH-optimal collapse of Ylitie, Karras
//! and Laine (2017) by dynamic programming over the binary tree ([`Plan`]), then the wide
//! nodes and the leaf packets are laid out depth first.

use super::memory::HugeSlice;
use super::{
    encode_leaf, Backend, TriPacket, WideBvh, WideNode, LEAF_BIT, LEAF_FIRST_MASK,
    MAX_LEAF_PACKETS, NO_ROOT,
};
use sahara_bvh::Bvh;
use sahara_geom::intersect::is_degenerate;
use sahara_geom::{Aabb, Triangle};

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
    plan: Plan,
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
    /// The plan for `bvh`, whose subtree `n` holds `refs[n]` references.
    fn new(bvh: &Bvh, refs: &[u64], width: usize) -> Self {
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
        let mut dist = vec![0.0f32; width + 1];
        let mut dist_k = vec![0u8; width + 1];
        for i in (0..n).rev() {
            let node = &bvh.nodes[i];
            let area = (half_area(&node.bounds()) * scale) as f32;
            let row = i * width;
            if node.is_leaf() {
                let c = area * leaf_cost(refs[i]);
                cost[row..row + width].fill(c);
                choice[row] = AS_LEAF;
                continue;
            }
            let (l, r) = (i + 1, node.index as usize);
            for (j, (d, dk)) in dist.iter_mut().zip(dist_k.iter_mut()).enumerate().skip(2) {
                let mut best = f32::INFINITY;
                let mut best_k = 1;
                for k in 1..j {
                    let c = cost[l * width + k - 1] + cost[r * width + j - k - 1];
                    if c < best {
                        best = c;
                        best_k = k;
                    }
                }
                *d = best;
                *dk = best_k as u8;
            }
            let inner = area * C_NODE + dist[width];
            let leaf = if refs[i] <= LEAF_MAX as u64 {
                area * leaf_cost(refs[i])
            } else {
                f32::INFINITY
            };
            split[i] = dist_k[width];
            if leaf <= inner {
                cost[row] = leaf;
                choice[row] = AS_LEAF;
            } else {
                cost[row] = inner;
                choice[row] = AS_NODE;
            }
            for j in 2..=width {
                // Ties distribute (more slots used, never a worse cost).
                if dist[j] <= cost[row + j - 2] {
                    cost[row + j - 1] = dist[j];
                    choice[row + j - 1] = dist_k[j];
                } else {
                    cost[row + j - 1] = cost[row + j - 2];
                    choice[row + j - 1] = 0;
                }
            }
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
    let mut refs = vec![0u64; n];
    for i in (0..n).rev() {
        let node = &bvh.nodes[i];
        refs[i] = if node.is_leaf() {
            node.count as u64
        } else {
            refs[i + 1].saturating_add(refs[node.index as usize])
        };
    }
    let mut c = Collapser::<W> {
        bvh,
        tris,
        nodes: Vec::new(),
        packets: Vec::new(),
        work: Vec::new(),
        plan: Plan::new(bvh, &refs, W),
    };
    let root = c.child(0);
    while let Some((bin, wide)) = c.work.pop() {
        c.fill(bin, wide);
    }
    assert!(
        c.nodes.len() < LEAF_BIT as usize,
        "too many wide nodes ({})",
        c.nodes.len()
    );
    let max_stack = stack_bound(&c.nodes, root);
    WideBvh {
        nodes: c.nodes.into(),
        packets: c.packets.into(),
        root,
        root_bounds: bvh.nodes[0].bounds(),
        max_stack,
        backend,
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

impl<const W: usize> Collapser<'_, W> {
    /// The wide child standing for binary node `bin`: a leaf over its subtree or a (not yet
    /// filled) wide node, as planned.
    fn child(&mut self, bin: usize) -> u32 {
        let node = self.bvh.nodes[bin];
        if self.plan.is_leaf(bin) {
            let prims = self.subtree_prims(bin);
            return self.leaf(prims, &node.bounds());
        }
        let k = self.nodes.len();
        self.nodes.push(WideNode::EMPTY);
        self.work.push((bin, k));
        k as u32
    }

    /// The distinct references of a binary subtree.
    fn subtree_prims(&self, bin: usize) -> Vec<u32> {
        let mut prims = Vec::new();
        let mut todo = vec![bin];
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
        prims
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
    fn leaf(&mut self, mut prims: Vec<u32>, bounds: &Aabb) -> u32 {
        for &p in &prims {
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
        self.big_leaf(&prims, bounds)
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
        let plan = Plan::new(bvh, &refs, W);
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
        let bits = |w: &WideBvh<W>| -> Vec<u32> {
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
        };
        assert_eq!(bits(&w), bits(&again));
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
