use crate::Bvh;

/// Shape statistics of a [`Bvh`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BvhStats {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of inner nodes.
    pub inner: usize,
    /// Number of leaves.
    pub leaves: usize,
    /// Number of primitive references (greater than the primitive count with spatial splits).
    pub references: usize,
    /// Number of levels (a single leaf has depth 1, an empty tree 0).
    pub depth: usize,
    /// The largest leaf.
    pub max_leaf: usize,
    /// `leaf_histogram[k]` = number of leaves with `k` references.
    pub leaf_histogram: Vec<usize>,
}

impl Bvh {
    /// Computes node, leaf, reference and depth statistics (iteratively, no recursion).
    pub fn stats(&self) -> BvhStats {
        let mut s = BvhStats {
            nodes: self.nodes.len(),
            references: self.prim_indices.len(),
            ..Default::default()
        };
        if self.nodes.is_empty() {
            return s;
        }
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            s.depth = s.depth.max(d);
            let n = &self.nodes[i];
            if n.is_leaf() {
                let c = n.count as usize;
                s.leaves += 1;
                s.max_leaf = s.max_leaf.max(c);
                if s.leaf_histogram.len() <= c {
                    s.leaf_histogram.resize(c + 1, 0);
                }
                s.leaf_histogram[c] += 1;
            } else {
                s.inner += 1;
                let (l, r) = self.children(i);
                stack.push((r, d + 1));
                stack.push((l, d + 1));
            }
        }
        s
    }
}
