//! Where spatial splits cut each reference: the record that lets a refit clip moved triangles
//! the way the builder clipped them ([`RefCuts`]).
//!
//! A spatial-split builder starts every reference with its triangle's bounds and, at each
//! spatial split it takes part in, replaces its box by the part of the triangle on one side
//! of the plane (`sahara_geom::clip::clip_halves`, which clips the whole triangle against
//! the reference's current box cut by the plane). The [`Cut`]s of a reference are those planes,
//! in the order they were applied. Replaying them on the same triangle ([`RefCuts::replay`])
//! runs the same computation on the same inputs, so it gives the builder's box bit for bit;
//! replaying them on a moved triangle gives a box that holds the moved triangle's part inside
//! the reference's *split region* (the intersection of the half spaces of its two-sided cuts).
//! The regions of one triangle's references cover all of space (a two-sided cut sends the part
//! on each side to its own reference; unsplitting and one-sided cuts keep the region whole),
//! so every point of a moved triangle stays inside some reference's box.

use crate::ValidationError;
use sahara_geom::{clip::clip_halves, Aabb, Triangle};

/// Which part of a reference a [`Cut`] kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Keep {
    /// The part below the plane (the other part went to another reference).
    Below,
    /// The part above the plane (the other part went to another reference).
    Above,
    /// The primitive met one side only when it was cut, and its reference kept that part:
    /// a replay keeps the parts on both sides (a moved primitive may cross the plane, and no
    /// other reference stands for the other side).
    Both,
}

/// One cut of a reference by a spatial split's plane `x[axis] = pos`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    /// The plane's coordinate.
    pub pos: f32,
    /// The plane's axis: 0, 1 or 2.
    pub axis: u8,
    /// The part the reference kept.
    pub keep: Keep,
    /// The depth (the root is 0) of the node whose split applied the cut, on the reference's
    /// path: the builders bound a node by its references *before* splitting them, so that
    /// node's box holds the reference's box before the cut, and a refit adds it there to give
    /// the build's boxes bit for bit. [`Cut::NO_DEPTH`] when the tree's inner boxes are the
    /// unions of their children's (after reinsertion, which changes the topology).
    pub depth: u32,
}

impl Cut {
    /// [`Cut::depth`] of a cut that no node's box accounts for.
    pub const NO_DEPTH: u32 = u32::MAX;
    /// Largest depth a file can store.
    pub const MAX_DEPTH: u32 = (1 << 26) - 2;

    /// The cut as two words (`pos`'s bits; `axis | keep << 2 | (depth + 1) << 4`, with 0 for
    /// [`Cut::NO_DEPTH`]), as files store it.
    pub fn to_words(&self) -> [u32; 2] {
        let keep = match self.keep {
            Keep::Below => 0,
            Keep::Above => 1,
            Keep::Both => 2,
        };
        let depth = if self.depth > Self::MAX_DEPTH {
            0
        } else {
            self.depth + 1
        };
        [
            self.pos.to_bits(),
            self.axis as u32 | keep << 2 | depth << 4,
        ]
    }

    /// The cut of [`Cut::to_words`]; `None` for an unknown code.
    pub fn from_words(words: [u32; 2]) -> Option<Cut> {
        let keep = match (words[1] >> 2) & 3 {
            0 => Keep::Below,
            1 => Keep::Above,
            2 => Keep::Both,
            _ => return None,
        };
        let depth = words[1] >> 4;
        Some(Cut {
            pos: f32::from_bits(words[0]),
            axis: (words[1] & 3) as u8,
            keep,
            depth: depth.checked_sub(1).unwrap_or(Self::NO_DEPTH),
        })
    }

    /// True when the axis is 0, 1 or 2, the position finite and the depth at most
    /// [`Cut::MAX_DEPTH`] or [`Cut::NO_DEPTH`].
    pub fn is_valid(&self) -> bool {
        self.axis < 3
            && self.pos.is_finite()
            && (self.depth <= Self::MAX_DEPTH || self.depth == Self::NO_DEPTH)
    }
}

/// The cuts of every reference of a tree (in the order of its reference array), recorded by
/// the spatial-split builders ([`crate::Bvh::ref_cuts`]).
///
/// ```
/// use sahara_bvh::{Cut, Keep, RefCuts};
/// use sahara_geom::{Triangle, Vec3A};
///
/// let tri = Triangle::new(Vec3A::ZERO, Vec3A::new(4.0, 0.0, 0.0), Vec3A::new(0.0, 4.0, 0.0));
/// let mut cuts = RefCuts::new();
/// cuts.push(&[]); // a reference that was never cut: the whole triangle's bounds
/// cuts.push(&[Cut { pos: 1.0, axis: 0, keep: Keep::Above, depth: 0 }]);
/// assert_eq!(cuts.replay(0, &tri), tri.bounds());
/// let b = cuts.replay(1, &tri);
/// assert_eq!(b.min.x, 1.0);
/// assert!(b.max.y < 3.0 + 1e-5); // the part right of x = 1 stays below y = 3
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct RefCuts {
    /// `starts[i]..starts[i + 1]` are reference `i`'s cuts.
    starts: Vec<u32>,
    cuts: Vec<Cut>,
}

impl Default for RefCuts {
    fn default() -> Self {
        Self::new()
    }
}

impl RefCuts {
    /// No reference yet.
    pub fn new() -> Self {
        Self {
            starts: vec![0],
            cuts: Vec::new(),
        }
    }

    /// Appends the next reference with its cuts (in the order they were applied).
    pub fn push(&mut self, cuts: &[Cut]) {
        self.cuts.extend_from_slice(cuts);
        self.starts.push(self.cuts.len() as u32);
    }

    /// The number of references.
    pub fn len(&self) -> usize {
        self.starts.len() - 1
    }

    /// True when there is no reference.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cuts of reference `i` (empty for a reference never cut).
    ///
    /// # Panics
    ///
    /// If `i >= self.len()`.
    pub fn get(&self, i: usize) -> &[Cut] {
        &self.cuts[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// The number of cuts of all references.
    pub fn cut_count(&self) -> usize {
        self.cuts.len()
    }

    /// Bytes of the record's arrays.
    pub fn memory_bytes(&self) -> usize {
        self.starts.len() * 4 + self.cuts.len() * std::mem::size_of::<Cut>()
    }

    /// The box of reference `i` over (possibly moved) `tri`: see [`replay_cuts`].
    pub fn replay(&self, i: usize, tri: &Triangle) -> Aabb {
        replay_cuts(self.get(i), tri, |_, _| {})
    }

    /// The same record with every [`Cut::depth`] set to [`Cut::NO_DEPTH`]: for a tree whose
    /// inner boxes are the unions of their children's.
    pub fn without_depths(mut self) -> RefCuts {
        for c in &mut self.cuts {
            c.depth = Cut::NO_DEPTH;
        }
        self
    }

    /// The record from its arrays (as [`RefCuts::starts`] and [`RefCuts::cuts`] give them);
    /// `None` unless `starts` starts at 0, never decreases and ends at `cuts.len()`, and
    /// every cut is valid ([`Cut::is_valid`]).
    pub fn from_parts(starts: Vec<u32>, cuts: Vec<Cut>) -> Option<RefCuts> {
        let ok = starts.first() == Some(&0)
            && starts.windows(2).all(|w| w[0] <= w[1])
            && starts.last().copied() == Some(cuts.len() as u32)
            && cuts.iter().all(Cut::is_valid);
        ok.then_some(RefCuts { starts, cuts })
    }

    /// The start of every reference's cuts, plus the end: `len() + 1` entries.
    pub fn starts(&self) -> &[u32] {
        &self.starts
    }

    /// All cuts, reference after reference.
    pub fn cuts(&self) -> &[Cut] {
        &self.cuts
    }

    /// Checks that the record has one entry per reference of a tree with `refs` references
    /// and valid cuts (records built with [`RefCuts::push`] are well formed; this catches
    /// arrays set by hand or loaded).
    pub fn check(&self, refs: usize) -> Result<(), ValidationError> {
        if self.len() != refs {
            return Err(ValidationError::BadCuts {
                reference: self.len().min(refs),
            });
        }
        match (0..refs).find(|&i| !self.get(i).iter().all(Cut::is_valid)) {
            Some(reference) => Err(ValidationError::BadCuts { reference }),
            None => Ok(()),
        }
    }
}

/// The box of a reference with `cuts` over triangle `tri`: the triangle's bounds, then each
/// cut in turn as the builder applied it (`clip_halves` against the current box and the plane,
/// keeping the recorded side, or both sides for [`Keep::Both`]). With the build's triangle it
/// is the builder's box, bit for bit; with a moved triangle it holds the part of the triangle
/// inside the reference's split region, and it is [`Aabb::EMPTY`] when the triangle left the
/// region (a box no ray hits). `before(cut, box)` sees the box each cut is applied to (not
/// called once the box is empty).
pub fn replay_cuts(cuts: &[Cut], tri: &Triangle, mut before: impl FnMut(&Cut, &Aabb)) -> Aabb {
    let mut b = tri.bounds();
    for c in cuts {
        before(c, &b);
        let (l, r) = clip_halves(tri, c.axis as usize, c.pos, &b);
        b = match c.keep {
            Keep::Below => l,
            Keep::Above => r,
            Keep::Both => l.union(&r),
        };
        if b.is_empty() {
            return Aabb::EMPTY;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    fn tri(x0: f32, x1: f32) -> Triangle {
        Triangle::new(
            Vec3A::new(x0, 0.0, 0.0),
            Vec3A::new(x1, 0.0, 0.0),
            Vec3A::new(x1, 1.0, 0.5),
        )
    }

    #[test]
    fn a_one_sided_cut_keeps_both_sides_of_a_moved_triangle() {
        // Built right of the plane x = 1 (a reference whose box straddled it, its triangle
        // not): it kept its right part. Moved across the plane, both parts count.
        let cut = Cut {
            pos: 1.0,
            axis: 0,
            keep: Keep::Both,
            depth: 0,
        };
        let built = tri(2.0, 3.0);
        assert_eq!(replay_cuts(&[cut], &built, |_, _| {}), built.bounds());
        let moved = tri(0.0, 3.0);
        let b = replay_cuts(&[cut], &moved, |_, _| {});
        assert!(b.contains_aabb(&moved.bounds()), "{b:?}");
    }

    #[test]
    fn a_two_sided_cut_keeps_its_side_and_empties_when_the_triangle_leaves() {
        let below = Cut {
            pos: 1.0,
            axis: 0,
            keep: Keep::Below,
            depth: 0,
        };
        let moved = tri(0.0, 3.0);
        let b = replay_cuts(&[below], &moved, |_, _| {});
        assert!(b.max.x <= 1.0 && b.min.x == 0.0);
        // Entirely right of the plane: the part below is empty, and the next cut is not
        // applied to anything.
        let mut applied = 0;
        let gone = replay_cuts(&[below, below], &tri(2.0, 3.0), |_, _| applied += 1);
        assert_eq!((gone, applied), (Aabb::EMPTY, 1));
    }

    #[test]
    fn cuts_survive_their_file_words_and_bad_words_are_refused() {
        for keep in [Keep::Below, Keep::Above, Keep::Both] {
            for depth in [0, 7, Cut::MAX_DEPTH, Cut::NO_DEPTH] {
                let c = Cut {
                    pos: -2.5,
                    axis: 2,
                    keep,
                    depth,
                };
                assert_eq!(Cut::from_words(c.to_words()), Some(c));
            }
        }
        assert_eq!(Cut::from_words([0, 3 << 2]), None);
        let bad_axis = Cut::from_words([0, 3]).unwrap();
        assert!(!bad_axis.is_valid());
        assert!(RefCuts::from_parts(vec![0, 1], vec![bad_axis]).is_none());
        assert!(RefCuts::from_parts(vec![0, 2], vec![]).is_none());
        assert!(RefCuts::from_parts(vec![1], vec![]).is_none());
        let mut ok = RefCuts::new();
        ok.push(&[]);
        assert_eq!(ok.check(2), Err(ValidationError::BadCuts { reference: 1 }));
        assert_eq!(ok.check(1), Ok(()));
    }
}
