//! The oracle's own acceleration structure: a median-split BVH over triangle
//! centroids with f64 boxes, and a provably conservative slab test.
//!
//! Box bounds are vertex coordinates converted f32 -> f64 (exact). Each node also
//! stores, per axis, the largest extent of any one of its triangles: a point of
//! a triangle's plane whose barycentrics are all `>= -band` lies within
//! `2 * band * extent` of that triangle's box on every axis (write the weights as
//! `-band + w'` with `w' >= 0`, `Σw' = 1 + 3 band`: `x - max_x = Σ w_i (x_i - max_x)
//! <= band Σ (max_x - x_i) <= 2 band extent`), so widening a node box by
//! `2 band maxextent` keeps every band candidate inside it.

/// Largest leaf.
const LEAF: usize = 4;

/// Relative widening of slab parameters. Each slab parameter
/// `(bound - o) * (1/d)` carries three roundings (relative error < 3.4e-16);
/// 2^-30 ≈ 9.3e-10 is far above that.
const SLAB_REL: f64 = 1.0 / (1u64 << 30) as f64;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// Largest per-axis extent of a single triangle below this node.
    pub ext: [f64; 3],
    /// Inner (`count == 0`): children at `first` and `first + 1`.
    /// Leaf: triangles `first .. first + count` in leaf order.
    pub first: u32,
    pub count: u32,
}

/// A triangle while building: prim, centroid, box (f32 values are exact).
#[derive(Clone, Copy)]
struct Item {
    prim: u32,
    c: [f32; 3],
    lo: [f32; 3],
    hi: [f32; 3],
}

/// Build over the triangles `prims` (all finite, non-degenerate). Returns the
/// nodes (root at 0; empty when `prims` is empty) and the prims in leaf order.
pub(crate) fn build(tris: &[[[f32; 3]; 3]], prims: Vec<u32>) -> (Vec<Node>, Vec<u32>) {
    if prims.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let mut items: Vec<Item> = prims
        .into_iter()
        .map(|prim| {
            let t = &tris[prim as usize];
            Item {
                prim,
                c: std::array::from_fn(|a| {
                    ((t[0][a] as f64 + t[1][a] as f64 + t[2][a] as f64) / 3.0) as f32
                }),
                lo: std::array::from_fn(|a| t[0][a].min(t[1][a]).min(t[2][a])),
                hi: std::array::from_fn(|a| t[0][a].max(t[1][a]).max(t[2][a])),
            }
        })
        .collect();
    let mut nodes = Vec::with_capacity(items.len() / 2 + 1);
    nodes.push(Node {
        lo: [0.0; 3],
        hi: [0.0; 3],
        ext: [0.0; 3],
        first: 0,
        count: 0,
    });
    rec(&mut nodes, &mut items, 0, 0);
    (nodes, items.into_iter().map(|it| it.prim).collect())
}

fn rec(nodes: &mut Vec<Node>, items: &mut [Item], base: usize, ni: usize) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut ext = [0.0f64; 3];
    let mut clo = [f32::INFINITY; 3];
    let mut chi = [f32::NEG_INFINITY; 3];
    for it in items.iter() {
        for a in 0..3 {
            lo[a] = lo[a].min(it.lo[a]);
            hi[a] = hi[a].max(it.hi[a]);
            ext[a] = ext[a].max(it.hi[a] as f64 - it.lo[a] as f64);
            clo[a] = clo[a].min(it.c[a]);
            chi[a] = chi[a].max(it.c[a]);
        }
    }
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    // The extent only widens boxes; round it up (the f64 difference of two f32
    // values is within half an ulp) to stay conservative.
    let ext = ext.map(|e| if e > 0.0 { e.next_up() } else { 0.0 });
    if items.len() <= LEAF {
        nodes[ni] = Node {
            lo,
            hi,
            ext,
            first: base as u32,
            count: items.len() as u32,
        };
        return;
    }
    let spread = [0, 1, 2].map(|a| chi[a] as f64 - clo[a] as f64);
    let axis = if spread[0] >= spread[1] && spread[0] >= spread[2] {
        0
    } else if spread[1] >= spread[2] {
        1
    } else {
        2
    };
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |x, y| x.c[axis].total_cmp(&y.c[axis]));
    let c = nodes.len();
    let blank = nodes[ni];
    nodes.push(blank);
    nodes.push(blank);
    nodes[ni] = Node {
        lo,
        hi,
        ext,
        first: c as u32,
        count: 0,
    };
    let (left, right) = items.split_at_mut(mid);
    rec(nodes, left, base, c);
    rec(nodes, right, base + mid, c + 1);
}

/// Ray data for slab tests (f64, exact conversions of the f32 inputs).
pub(crate) struct SlabRay {
    pub o: [f64; 3],
    pub d: [f64; 3],
    pub inv: [f64; 3],
    /// `2 * band * (1 + 1e-6)` (0 when band <= 0).
    pub wband: f64,
}

/// Conservative ray/box test: returns a lower bound of the entry parameter when
/// the line `o + t d`, `t` in `[lo, hi]`, may meet the (band-widened) box.
/// Never rejects a box the exact line meets within `[lo, hi]`.
#[inline]
pub(crate) fn slab(n: &Node, r: &SlabRay, lo: f64, hi: f64) -> Option<f64> {
    let mut tn = f64::NEG_INFINITY;
    let mut tf = f64::INFINITY;
    for a in 0..3 {
        let (bl, bh) = if r.wband > 0.0 {
            let w = if n.ext[a] > 0.0 {
                r.wband * n.ext[a]
            } else {
                0.0
            };
            // round outwards: one ulp covers the half-ulp rounding of the
            // subtraction; the (1 + 1e-6) in wband covers the product's.
            ((n.lo[a] - w).next_down(), (n.hi[a] + w).next_up())
        } else {
            (n.lo[a], n.hi[a])
        };
        if r.d[a] == 0.0 {
            // exact: the line stays at o[a]
            if r.o[a] < bl || r.o[a] > bh {
                return None;
            }
            continue;
        }
        let t1 = (bl - r.o[a]) * r.inv[a];
        let t2 = (bh - r.o[a]) * r.inv[a];
        let (a1, a2) = if t1 <= t2 { (t1, t2) } else { (t2, t1) };
        tn = tn.max(a1 - a1.abs() * SLAB_REL);
        tf = tf.min(a2 + a2.abs() * SLAB_REL);
    }
    if tn > tf || tf < lo || tn > hi {
        None
    } else {
        Some(tn)
    }
}
