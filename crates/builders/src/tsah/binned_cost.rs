//! A small cost-only binned SAH build (Wald 2007, "On fast construction of SAH-based bounding
//! volume hierarchies") for the binned temporaries of the paper's builder: `K` equal-width bins
//! over the node's centroid bounds on each axis (`min(K, n)` at a node of `n` primitives, so that
//! small nodes cost no more than a sweep), Eq. 2 at the planes, the same leaf rule as the sweep
//! builder (a node above the leaf limit whose centroids all coincide is split in half), and
//! `c(T)` computed bottom-up without allocating a node.
//!
//! It works on a private copy of the primitives' boxes, which it partitions in place: every
//! pass reads memory sequentially. A primitive's centroid is the centre of its box, exactly as
//! [`crate::BuildInput::centroids`] computes it. Each node's bounds come from its parent's bins
//! and its centroid bounds from its parent's partition pass, so a node costs one binning pass and
//! one partition pass.

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
    /// Decide the node over `prims[start..end]`, with its bounds and centroid bounds.
    Visit {
        start: usize,
        end: usize,
        bounds: Aabb,
        centroids: Aabb,
    },
    /// Combine the two costs on top of the value stack into their parent's (of that area).
    Combine(f64),
}

/// The best plane found so far.
#[derive(Clone, Copy)]
struct Best {
    cost: f64,
    imbalance: usize,
    axis: usize,
    plane: usize,
    left: Aabb,
    right: Aabb,
}

impl Best {
    /// Lower cost, then more balanced, then lower axis, then lower plane.
    #[inline]
    fn better_than(&self, o: &Best) -> bool {
        if self.cost < o.cost {
            return true;
        }
        if self.cost > o.cost {
            return false;
        }
        match self.cost.total_cmp(&o.cost) {
            std::cmp::Ordering::Less => true,
            std::cmp::Ordering::Greater => false,
            std::cmp::Ordering::Equal => {
                (self.imbalance, self.axis, self.plane) < (o.imbalance, o.axis, o.plane)
            }
        }
    }
}

#[inline]
fn centroid(b: &Aabb) -> Vec3A {
    b.centroid()
}

/// `c(T)` of the binned SAH tree over the primitives whose boxes are `prims` (permuted in
/// place), relative to its bounds.
pub(crate) fn binned_cost(
    prims: &mut [Aabb],
    bins: usize,
    cost: &CostModel,
    max_leaf: usize,
    scratch: &mut BinnedScratch,
) -> SubtreeCost {
    let n = prims.len();
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
    let (root, root_c) = bounds_of(prims);
    tasks.push(Task::Visit {
        start: 0,
        end: n,
        bounds: root,
        centroids: root_c,
    });
    while let Some(task) = tasks.pop() {
        let (s, e, node, cb) = match task {
            Task::Combine(area) => {
                let r = values.pop().expect("right cost");
                let l = values.pop().expect("left cost");
                values.push(SubtreeCost {
                    cost: cost.inner_cost(area, l.area, l.cost, r.area, r.cost),
                    area,
                });
                continue;
            }
            Task::Visit {
                start,
                end,
                bounds,
                centroids,
            } => (start, end, bounds, centroids),
        };
        let seg = &mut prims[s..e];
        let m = seg.len();
        let area = node.half_area() as f64;
        if m == 1 {
            values.push(SubtreeCost {
                cost: cost.leaf_cost(1),
                area,
            });
            continue;
        }
        let k = bins.min(m);
        let maps: [Option<BinMap>; 3] =
            std::array::from_fn(|a| BinMap::new(cb.min[a], cb.max[a], k));
        let best = if maps.iter().all(Option::is_none) {
            None
        } else {
            best_plane(seg, &maps, k, area, cost, counts, boxes, right_areas)
        };
        let leaf_ok = m <= max_leaf && best.as_ref().is_none_or(|b| b.cost >= cost.leaf_cost(m));
        if leaf_ok {
            values.push(SubtreeCost {
                cost: cost.leaf_cost(m),
                area,
            });
            continue;
        }
        let (mid, lb, lc, rb, rc) = match best {
            Some(b) => {
                let map = maps[b.axis].expect("binned axis");
                let (mid, lc, rc) = partition(seg, |c| map.bin(c[b.axis]) < b.plane);
                (mid, b.left, lc, b.right, rc)
            }
            None => {
                // Every centroid coincides: split the list in half.
                let mid = m / 2;
                let (lb, lc) = bounds_of(&seg[..mid]);
                let (rb, rc) = bounds_of(&seg[mid..]);
                (mid, lb, lc, rb, rc)
            }
        };
        debug_assert!(mid > 0 && mid < m);
        tasks.push(Task::Combine(area));
        tasks.push(Task::Visit {
            start: s + mid,
            end: e,
            bounds: rb,
            centroids: rc,
        });
        tasks.push(Task::Visit {
            start: s,
            end: s + mid,
            bounds: lb,
            centroids: lc,
        });
    }
    values.pop().expect("root cost")
}

/// Bounds and centroid bounds of some boxes.
fn bounds_of(prims: &[Aabb]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut c = Aabb::EMPTY;
    for p in prims {
        b.grow_aabb(p);
        c.grow(centroid(p));
    }
    (b, c)
}

/// Bins the node on every axis with a map and returns its cheapest plane (`None` when no plane
/// separates anything).
#[allow(clippy::too_many_arguments)]
fn best_plane(
    seg: &[Aabb],
    maps: &[Option<BinMap>; 3],
    k: usize,
    area: f64,
    cost: &CostModel,
    counts: &mut [u32],
    boxes: &mut [Aabb],
    right_areas: &mut [f32],
) -> Option<Best> {
    let m = seg.len();
    let counts = &mut counts[..3 * k];
    let boxes = &mut boxes[..3 * k];
    counts.fill(0);
    boxes.fill(Aabb::EMPTY);
    // The three bin indices at once: clamping in floating point before truncating gives
    // exactly `BinMap::bin` (the operand is never negative). Axes without a map bin
    // everything into their bin 0 and are not evaluated.
    let lo = Vec3A::from_array(std::array::from_fn(|a| maps[a].map_or(0.0, |m| m.min)));
    let scale = Vec3A::from_array(std::array::from_fn(|a| maps[a].map_or(0.0, |m| m.scale)));
    let top = Vec3A::splat((k - 1) as f32);
    for p in seg {
        let v = ((centroid(p) - lo) * scale).min(top);
        let [bx, by, bz] = v.to_array();
        for (a, b) in [bx as usize, k + by as usize, 2 * k + bz as usize]
            .into_iter()
            .enumerate()
        {
            debug_assert!(b < (a + 1) * k);
            counts[b] += 1;
            boxes[b].grow_aabb(p);
        }
    }
    let mut best: Option<Best> = None;
    for (a, map) in maps.iter().enumerate() {
        if map.is_none() {
            continue;
        }
        let cnt = &counts[a * k..(a + 1) * k];
        let bx = &boxes[a * k..(a + 1) * k];
        let mut acc = Aabb::EMPTY;
        for j in (1..k).rev() {
            acc.grow_aabb(&bx[j]);
            right_areas[j] = acc.half_area();
        }
        let mut left = Aabb::EMPTY;
        let mut nl = 0usize;
        for j in 1..k {
            left.grow_aabb(&bx[j - 1]);
            nl += cnt[j - 1] as usize;
            if nl == 0 || nl == m {
                continue;
            }
            let c = cost.split_cost(
                area,
                left.half_area() as f64,
                nl,
                right_areas[j] as f64,
                m - nl,
            );
            let cand = Best {
                cost: c,
                imbalance: (2 * nl).abs_diff(m),
                axis: a,
                plane: j,
                left,
                right: Aabb::EMPTY,
            };
            if best.as_ref().is_none_or(|b| cand.better_than(b)) {
                best = Some(cand);
            }
        }
    }
    // The right box of the winner (only its area was kept during the sweep).
    if let Some(b) = &mut best {
        let bx = &boxes[b.axis * k..(b.axis + 1) * k];
        b.right = bx[b.plane..]
            .iter()
            .fold(Aabb::EMPTY, |acc, x| acc.union(x));
    }
    best
}

/// In-place partition by a predicate on the centroid; returns the number of boxes on the left
/// and the centroid bounds of both sides.
fn partition(seg: &mut [Aabb], left: impl Fn(Vec3A) -> bool) -> (usize, Aabb, Aabb) {
    let mut lc = Aabb::EMPTY;
    let mut rc = Aabb::EMPTY;
    let mut i = 0;
    let mut j = seg.len();
    while i < j {
        let c = centroid(&seg[i]);
        if left(c) {
            lc.grow(c);
            i += 1;
        } else {
            rc.grow(c);
            j -= 1;
            seg.swap(i, j);
        }
    }
    (i, lc, rc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::{sorted_orders, sweep_cost, Marks, SweepScratch};
    use sahara_geom::rng::Pcg32;

    fn boxes(n: usize) -> Vec<Aabb> {
        let mut r = Pcg32::new(1, 1);
        (0..n)
            .map(|_| {
                let o = Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()) * 100.0;
                Aabb::new(o, o + Vec3A::new(r.next_f32(), r.next_f32(), r.next_f32()))
            })
            .collect()
    }

    #[test]
    fn cost_is_plausible_and_leafy_inputs_are_leaves() {
        let cost = CostModel::default();
        let b = boxes(3000);
        let c = binned_cost(&mut b.clone(), 16, &cost, 8, &mut BinnedScratch::default());
        // Not better than the full sweep by much, and far below one big leaf.
        let cents: Vec<Vec3A> = b.iter().map(Aabb::centroid).collect();
        let ids: Vec<u32> = (0..b.len() as u32).collect();
        let [mut x, mut y, mut z] = sorted_orders(&cents, &ids);
        let s = sweep_cost(
            &b,
            [&mut x, &mut y, &mut z],
            &Marks::new(b.len()),
            &cost,
            8,
            &mut SweepScratch::new(),
        );
        assert!(
            c.cost >= s.cost * 0.9 && c.cost < s.cost * 1.5,
            "{} vs {}",
            c.cost,
            s.cost
        );
        assert_eq!(c.area, s.area);
        // Identical boxes: no plane, leaf while allowed, halves above the limit.
        let same = vec![b[0]; 8];
        let c = binned_cost(
            &mut same.clone(),
            16,
            &cost,
            8,
            &mut BinnedScratch::default(),
        );
        assert_eq!(c.cost, 8.0);
        let same = vec![b[0]; 9];
        let c = binned_cost(
            &mut same.clone(),
            16,
            &cost,
            8,
            &mut BinnedScratch::default(),
        );
        assert_eq!(c.cost, cost.inner_cost(c.area, c.area, 4.0, c.area, 5.0));
    }

    fn obj_boxes(path: &str) -> Vec<Aabb> {
        let text = std::fs::read_to_string(path).unwrap();
        let mut v = Vec::new();
        let mut out = Vec::new();
        for l in text.lines() {
            let mut it = l.split_ascii_whitespace();
            match it.next() {
                Some("v") => {
                    let c: Vec<f32> = it.map(|x| x.parse().unwrap()).collect();
                    v.push(Vec3A::new(c[0], c[1], c[2]));
                }
                Some("f") => {
                    let i: Vec<usize> = it.map(|x| x.parse::<usize>().unwrap() - 1).collect();
                    let t = sahara_geom::Triangle::new(v[i[0]], v[i[1]], v[i[2]]);
                    out.push(t.bounds());
                }
                _ => {}
            }
        }
        out
    }

    #[test]
    #[ignore]
    fn timing_vs_sweep() {
        let b = match std::env::var("OBJ") {
            Ok(p) => obj_boxes(&p),
            Err(_) => boxes(400_000),
        };
        let n = b.len();
        let cost = CostModel::default();
        for bins in [4, 8, 16, 32] {
            let t = std::time::Instant::now();
            let c = binned_cost(
                &mut b.clone(),
                bins,
                &cost,
                8,
                &mut BinnedScratch::default(),
            );
            eprintln!("binned {bins}: {:?} cost {}", t.elapsed(), c.cost);
        }
        let cents: Vec<Vec3A> = b.iter().map(Aabb::centroid).collect();
        let ids: Vec<u32> = (0..n as u32).collect();
        let [mut x, mut y, mut z] = sorted_orders(&cents, &ids);
        let t = std::time::Instant::now();
        let c = sweep_cost(
            &b,
            [&mut x, &mut y, &mut z],
            &Marks::new(n),
            &cost,
            8,
            &mut SweepScratch::new(),
        );
        eprintln!("sweep: {:?} cost {}", t.elapsed(), c.cost);
    }
}
