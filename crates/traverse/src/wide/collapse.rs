//! Collapsing a binary [`Bvh`] into a [`WideBvh`].

use super::{
    encode_leaf, Backend, TriPacket, WideBvh, WideNode, LEAF_BIT, LEAF_FIRST_MASK,
    MAX_LEAF_PACKETS, NO_ROOT,
};
use sahara_bvh::Bvh;
use sahara_geom::{Aabb, Triangle};

/// Binary subtrees with at most this many references become a single leaf packet.
const MERGE_MAX: u64 = 4;
/// Most references in one wide leaf.
const LEAF_MAX: usize = 4 * MAX_LEAF_PACKETS;

struct Collapser<'a, const W: usize> {
    bvh: &'a Bvh,
    tris: &'a [Triangle],
    /// References in each binary subtree.
    refs: Vec<u64>,
    nodes: Vec<WideNode<W>>,
    packets: Vec<TriPacket>,
    /// Wide nodes allocated but not filled yet: `(binary node, wide node)`.
    work: Vec<(usize, usize)>,
}

pub(crate) fn collapse<const W: usize>(bvh: &Bvh, tris: &[Triangle]) -> WideBvh<W> {
    assert!(
        W == 4 || W == 8,
        "wide BVHs have 4 or 8 children per node, not {W}"
    );
    let backend = Backend::best();
    if bvh.nodes.is_empty() {
        return WideBvh {
            nodes: Vec::new(),
            packets: Vec::new(),
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
        refs,
        nodes: Vec::new(),
        packets: Vec::new(),
        work: Vec::new(),
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
        nodes: c.nodes,
        packets: c.packets,
        root,
        root_bounds: bvh.nodes[0].bounds(),
        max_stack,
        backend,
    }
}

/// Most entries the traversal stack can hold: at an inner node `n` it holds the pending
/// siblings of `n`'s ancestors (at most `Σ (children - 1)` over them) plus, briefly, all of
/// `n`'s children.
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
    bound
}

fn rows(b: &Aabb) -> [f32; 6] {
    [b.min.x, b.max.x, b.min.y, b.max.y, b.min.z, b.max.z]
}

impl<const W: usize> Collapser<'_, W> {
    /// The wide child standing for binary node `bin`: a leaf when `bin` is a leaf or a small
    /// subtree, else a (not yet filled) wide node.
    fn child(&mut self, bin: usize) -> u32 {
        let node = self.bvh.nodes[bin];
        if node.is_leaf() || self.refs[bin] <= MERGE_MAX {
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

    /// Fills wide node `wide` from binary inner node `bin`: greedily opens the inner child
    /// with the largest surface area until there are `W` children or only leaves (and small
    /// subtrees) remain.
    fn fill(&mut self, bin: usize, wide: usize) {
        let bvh = self.bvh;
        let nodes = &bvh.nodes;
        let mut list: Vec<usize> = vec![bin + 1, nodes[bin].index as usize];
        while list.len() < W {
            let mut pick: Option<(usize, f32)> = None;
            for (slot, &c) in list.iter().enumerate() {
                if nodes[c].is_leaf() || self.refs[c] <= MERGE_MAX {
                    continue;
                }
                let area = nodes[c].bounds().surface_area();
                if pick.is_none_or(|(_, a)| area > a) {
                    pick = Some((slot, area));
                }
            }
            let Some((slot, _)) = pick else { break };
            let c = list[slot];
            list[slot] = c + 1;
            list.insert(slot + 1, nodes[c].index as usize);
        }
        let mut out = WideNode::<W>::EMPTY;
        for (s, &c) in list.iter().enumerate() {
            let r = rows(&nodes[c].bounds());
            for (row, v) in out.bounds.iter_mut().zip(r) {
                row[s] = v;
            }
            out.children[s] = self.child(c);
            out.valid |= 1 << s;
        }
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
            let key = |p: u32| self.tris[p as usize].centroid()[axis];
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
                b.grow_aabb(&self.tris[p as usize].bounds());
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
        self.nodes[k] = out;
        k as u32
    }

    fn packet(&self, prims: &[u32]) -> TriPacket {
        let mut p = TriPacket {
            v: [[[f32::NAN; 4]; 3]; 3],
            prims: [u32::MAX; 4],
        };
        for (lane, &prim) in prims.iter().enumerate() {
            let t = &self.tris[prim as usize];
            for k in 0..3 {
                for a in 0..3 {
                    p.v[k][a][lane] = t.v[k][a];
                }
            }
            p.prims[lane] = prim;
        }
        p
    }
}
