//! Applying a spatial split: the straddling references cut exactly at the plane, with
//! reference unsplitting ([`apply_spatial`]), the record of those cuts ([`CutLog`]), and the
//! duplication budget shared between the two children ([`child_budgets`]).

use std::sync::Mutex;

use sahara_bvh::{Cut, Keep, RefCuts};
use sahara_geom::Aabb;

use super::clip::Clipper;
use super::SpatialCand;
use crate::split::half_area;
use crate::split::object::Ref;

/// No cut: [`Ref::cut`] of a reference that still has its primitive's whole box.
pub const NO_CUT: u32 = u32::MAX;

/// The cuts a build applied to its references, so that the tree can record where each leaf
/// reference was cut ([`sahara_bvh::RefCuts`], which refitting replays on moved triangles).
///
/// Each entry is a cut and the entry of the cut before it on the same reference (a forest of
/// chains: the two pieces of a reference share the chain of their parent). A reference holds
/// its last entry ([`Ref::cut`]). Entries are appended once per applied spatial split, under a
/// lock; their numbers depend on the order in which parallel subtrees are built, but the
/// chains, and so [`CutLog::resolve`], do not.
#[derive(Debug, Default)]
pub struct CutLog {
    entries: Mutex<Vec<(u32, Cut)>>,
}

impl CutLog {
    /// Appends entries (`(previous entry, cut)`); returns the number of the first.
    fn append(&self, new: &[(u32, Cut)]) -> u32 {
        let mut e = self.entries.lock().expect("cut log");
        let base = e.len() as u32;
        e.extend_from_slice(new);
        base
    }

    /// The cut records of references whose last entries are `heads` (in that order), each
    /// reference's cuts in the order they were applied.
    pub fn resolve(&self, heads: &[u32]) -> RefCuts {
        let e = self.entries.lock().expect("cut log");
        let mut out = RefCuts::new();
        let mut chain = Vec::new();
        for &h in heads {
            chain.clear();
            let mut at = h;
            while at != NO_CUT {
                let (prev, cut) = e[at as usize];
                chain.push(cut);
                at = prev;
            }
            chain.reverse();
            out.push(&chain);
        }
        out
    }
}

/// The two sides of a spatial split (with reference unsplitting if asked), or `None` when one
/// side would be empty. No primitive is lost: a reference is dropped from a side only when its
/// part there is empty, and then it goes whole to the other side. With a `log`, every piece
/// whose box was cut records the cut there ([`CutLog`]), made by the node at `depth`.
pub fn apply_spatial(
    clipper: &Clipper,
    refs: &[Ref],
    cand: &SpatialCand,
    unsplitting: bool,
    log: Option<(&CutLog, usize)>,
) -> Option<(Vec<Ref>, Vec<Ref>)> {
    let (axis, pos, map) = (cand.axis, cand.pos, cand.map);
    // The cuts to log: (goes left, index in its side, previous entry, cut).
    let mut cuts: Vec<(bool, usize, u32, Cut)> = Vec::new();
    let depth = log.map_or(Cut::NO_DEPTH, |(_, d)| (d as u32).min(Cut::MAX_DEPTH));
    let cut = |keep| Cut {
        pos,
        axis: axis as u8,
        keep,
        depth,
    };
    let mut left = Vec::with_capacity(cand.n_left);
    let mut right = Vec::with_capacity(cand.n_right);
    let mut lb = Aabb::EMPTY;
    let mut rb = Aabb::EMPTY;
    let mut straddling = Vec::new();
    for r in refs {
        let first = map.bin(r.bounds.min[axis]);
        let last = map.bin(r.bounds.max[axis]);
        if last < cand.plane {
            left.push(*r);
            lb.grow_aabb(&r.bounds);
        } else if first >= cand.plane {
            right.push(*r);
            rb.grow_aabb(&r.bounds);
        } else {
            straddling.push(*r);
        }
    }
    for s in straddling {
        let (pl, pr) = clipper.split(s.prim, axis, pos, &s.bounds);
        let piece = |bounds| Ref { bounds, ..s };
        let side = match (pl.is_empty(), pr.is_empty()) {
            // Rounding left nothing on either side: keep the reference whole.
            (true, true) => {
                if s.bounds.centroid()[axis] < pos {
                    Side::WholeLeft
                } else {
                    Side::WholeRight
                }
            }
            (false, true) => {
                cuts.push((true, left.len(), s.cut, cut(Keep::Both)));
                left.push(piece(pl));
                lb.grow_aabb(&pl);
                continue;
            }
            (true, false) => {
                cuts.push((false, right.len(), s.cut, cut(Keep::Both)));
                right.push(piece(pr));
                rb.grow_aabb(&pr);
                continue;
            }
            (false, false) if unsplitting => {
                let (nl, nr) = (left.len() as f64, right.len() as f64);
                let c_split =
                    half_area(&lb.union(&pl)) * (nl + 1.0) + half_area(&rb.union(&pr)) * (nr + 1.0);
                let c_left = half_area(&lb.union(&s.bounds)) * (nl + 1.0) + half_area(&rb) * nr;
                let c_right = half_area(&lb) * nl + half_area(&rb.union(&s.bounds)) * (nr + 1.0);
                if c_left < c_split && c_left <= c_right {
                    Side::WholeLeft
                } else if c_right < c_split {
                    Side::WholeRight
                } else {
                    Side::Split
                }
            }
            (false, false) => Side::Split,
        };
        match side {
            Side::WholeLeft => {
                left.push(s);
                lb.grow_aabb(&s.bounds);
            }
            Side::WholeRight => {
                right.push(s);
                rb.grow_aabb(&s.bounds);
            }
            Side::Split => {
                cuts.push((true, left.len(), s.cut, cut(Keep::Below)));
                left.push(piece(pl));
                lb.grow_aabb(&pl);
                cuts.push((false, right.len(), s.cut, cut(Keep::Above)));
                right.push(piece(pr));
                rb.grow_aabb(&pr);
            }
        }
    }
    if let Some((log, _)) = log.filter(|_| !cuts.is_empty()) {
        let entries: Vec<(u32, Cut)> = cuts.iter().map(|&(_, _, prev, c)| (prev, c)).collect();
        let base = log.append(&entries);
        for (k, &(to_left, i, _, _)) in cuts.iter().enumerate() {
            let side = if to_left { &mut left } else { &mut right };
            side[i].cut = base + k as u32;
        }
    }
    if left.is_empty() || right.is_empty() {
        None
    } else {
        Some((left, right))
    }
}

enum Side {
    WholeLeft,
    WholeRight,
    Split,
}

/// Splits what is left of a duplication budget between two children in proportion to their
/// reference counts (deterministic, whatever the order in which subtrees are built).
#[inline]
pub fn share_budget(budget: usize, n_left: usize, n_right: usize) -> (usize, usize) {
    let total = (n_left + n_right) as u128;
    if total == 0 {
        return (budget / 2, budget - budget / 2);
    }
    let left = (budget as u128 * n_left as u128 / total) as usize;
    (left, budget - left)
}

/// The duplication budgets of two children with `n_left` and `n_right` references made from
/// a parent with `n_parent` references and budget `budget`: what the split did not use, shared
/// in proportion to the children's reference counts.
pub fn child_budgets(
    n_parent: usize,
    n_left: usize,
    n_right: usize,
    budget: usize,
) -> (usize, usize) {
    let dups = (n_left + n_right).saturating_sub(n_parent);
    share_budget(budget.saturating_sub(dups), n_left, n_right)
}
