//! A small cost-only binned SAH build (Wald 2007, "On fast construction of SAH-based bounding
//! volume hierarchies") for the binned temporaries of the paper's builder: `K` equal-width bins
//! over the node's centroid bounds on each axis, Eq. 2 at the `K - 1` planes, the same leaf rule
//! as the sweep builder, and `c(T)` computed bottom-up without allocating a node.

use sahara_geom::{Aabb, Vec3A};
use sahara_metrics::CostModel;

use crate::sweep::SubtreeCost;
use crate::tsah::engine::BinMap;

/// Reusable buffers of [`binned_cost`].
#[derive(Debug, Default)]
pub(crate) struct BinnedScratch {
    tasks: Vec<Task>,
    values: Vec<SubtreeCost>,
    counts: Vec<u32>,
    boxes: Vec<Aabb>,
    right_areas: Vec<f32>,
}

#[derive(Clone, Copy, Debug)]
enum Task {
    Visit(usize, usize),
    Combine(f64),
}

/// The best plane found so far: (cost, imbalance, axis, plane).
#[derive(Clone, Copy)]
struct Best {
    cost: f64,
    imbalance: usize,
    axis: usize,
    plane: usize,
}

impl Best {
    fn better_than(&self, o: &Best) -> bool {
        match self.cost.total_cmp(&o.cost) {
            std::cmp::Ordering::Less => true,
            std::cmp::Ordering::Greater => false,
            std::cmp::Ordering::Equal => {
                (self.imbalance, self.axis, self.plane) < (o.imbalance, o.axis, o.plane)
            }
        }
    }
}

/// `c(T)` of the binned SAH tree over `ids` (permuted in place), relative to its bounds.
pub(crate) fn binned_cost(
    bounds: &[Aabb],
    centroids: &[Vec3A],
    ids: &mut [u32],
    bins: usize,
    cost: &CostModel,
    max_leaf: usize,
    scratch: &mut BinnedScratch,
) -> SubtreeCost {
    let n = ids.len();
    if n == 0 {
        return SubtreeCost {
            cost: 0.0,
            area: 0.0,
        };
    }
    let bins = bins.max(2);
    let max_leaf = max_leaf.max(1);
    let BinnedScratch {
        tasks,
        values,
        counts,
        boxes,
        right_areas,
    } = scratch;
    counts.clear();
    counts.resize(3 * bins, 0);
    boxes.clear();
    boxes.resize(3 * bins, Aabb::EMPTY);
    right_areas.clear();
    right_areas.resize(bins, 0.0);
    tasks.clear();
    values.clear();
    tasks.push(Task::Visit(0, n));
    while let Some(task) = tasks.pop() {
        let (s, e) = match task {
            Task::Combine(area) => {
                let r = values.pop().expect("right cost");
                let l = values.pop().expect("left cost");
                values.push(SubtreeCost {
                    cost: cost.inner_cost(area, l.area, l.cost, r.area, r.cost),
                    area,
                });
                continue;
            }
            Task::Visit(s, e) => (s, e),
        };
        let seg = &mut ids[s..e];
        let m = seg.len();
        let mut node = Aabb::EMPTY;
        let mut cb = Aabb::EMPTY;
        for &id in seg.iter() {
            node.grow_aabb(&bounds[id as usize]);
            cb.grow(centroids[id as usize]);
        }
        let area = node.half_area() as f64;
        if m == 1 {
            values.push(SubtreeCost {
                cost: cost.leaf_cost(1),
                area,
            });
            continue;
        }
        let maps: [Option<BinMap>; 3] =
            std::array::from_fn(|a| BinMap::new(cb.min[a], cb.max[a], bins));
        counts.fill(0);
        boxes.fill(Aabb::EMPTY);
        for &id in seg.iter() {
            let c = centroids[id as usize];
            for (a, map) in maps.iter().enumerate() {
                if let Some(map) = map {
                    let b = a * bins + map.bin(c[a]);
                    counts[b] += 1;
                    boxes[b].grow_aabb(&bounds[id as usize]);
                }
            }
        }
        let mut best: Option<Best> = None;
        for (a, map) in maps.iter().enumerate() {
            if map.is_none() {
                continue;
            }
            let cnt = &counts[a * bins..(a + 1) * bins];
            let bx = &boxes[a * bins..(a + 1) * bins];
            let mut acc = Aabb::EMPTY;
            for j in (1..bins).rev() {
                acc.grow_aabb(&bx[j]);
                right_areas[j] = acc.half_area();
            }
            let mut left = Aabb::EMPTY;
            let mut nl = 0usize;
            for j in 1..bins {
                left.grow_aabb(&bx[j - 1]);
                nl += cnt[j - 1] as usize;
                if nl == 0 || nl == m {
                    continue;
                }
                let c = Best {
                    cost: cost.split_cost(
                        area,
                        left.half_area() as f64,
                        nl,
                        right_areas[j] as f64,
                        m - nl,
                    ),
                    imbalance: (2 * nl).abs_diff(m),
                    axis: a,
                    plane: j,
                };
                if best.as_ref().is_none_or(|b| c.better_than(b)) {
                    best = Some(c);
                }
            }
        }
        let leaf_ok = m <= max_leaf && best.as_ref().is_none_or(|b| b.cost >= cost.leaf_cost(m));
        if leaf_ok {
            values.push(SubtreeCost {
                cost: cost.leaf_cost(m),
                area,
            });
            continue;
        }
        let mid = match best {
            Some(b) => {
                let map = maps[b.axis].expect("binned axis");
                partition(seg, |id| map.bin(centroids[id as usize][b.axis]) < b.plane)
            }
            // Every centroid coincides: split the list in half.
            None => m / 2,
        };
        debug_assert!(mid > 0 && mid < m);
        tasks.push(Task::Combine(area));
        tasks.push(Task::Visit(s + mid, e));
        tasks.push(Task::Visit(s, s + mid));
    }
    values.pop().expect("root cost")
}

/// In-place partition; returns the number of ids for which `left` holds.
fn partition(ids: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    let mut j = ids.len();
    while i < j {
        if left(ids[i]) {
            i += 1;
        } else {
            j -= 1;
            ids.swap(i, j);
        }
    }
    i
}
