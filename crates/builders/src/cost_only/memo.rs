//! The subtree memo of the paper's builders: cost-only builds over overlapping sets of
//! primitives (the temporaries of a node's neighbouring candidates, and of a node and its
//! children) take each other's subtree costs, keyed by the set of primitives.

use std::sync::Mutex;

use super::levels::{SubtreeCost, TopLevels};
use crate::topdown::Rule;

/// A rule whose cost-only builds share subtree costs through a [`SubtreeMemo`]
/// ([`cost_with_top_levels`](super::cost_with_top_levels) looks up and stores every node the
/// rule keys). A rule may only key nodes whose subtree is a function of the key's set of
/// references (see [`SubtreeMemo`]).
pub trait Memoised: Rule {
    /// The memo of subtree costs this rule shares with other cost-only builds over the same
    /// primitives, and the key of a node in it (`None`: do not look the node up).
    fn memo(&self, task: &Self::Task) -> Option<(MemoView<'_>, MemoKey)>;

    /// [`memo`](Self::memo) of the two children of a split node, given the node's own (the
    /// cost-only build asks only for the children of a node that [`memo`](Self::memo) keyed,
    /// so a rule must not key a child whose parent it would not key). A rule may derive the
    /// keys from the parent's, which is cheaper than hashing both children (see
    /// [`MemoKey::without`]). By default [`memo`](Self::memo) of each child.
    fn child_memo<'s>(
        &'s self,
        _parent: &(MemoView<'s>, MemoKey),
        left: &Self::Task,
        right: &Self::Task,
    ) -> [Option<(MemoView<'s>, MemoKey)>; 2] {
        [self.memo(left), self.memo(right)]
    }
}

/// The set of references of a node, as a key of a [`SubtreeMemo`]: the number of references
/// and two independent 64-bit sums of a hash of each reference's primitive (order-independent,
/// so equal sets have equal keys whatever their order; different sets collide with
/// probability about 2^-128 per pair).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MemoKey {
    n: usize,
    a: u64,
    b: u64,
}

impl MemoKey {
    /// The key of this set without the subset keyed `part` (which must be a subset of it):
    /// the sums are of one hash per reference, so the difference is exactly the key the rest
    /// of the set would get. A split node's larger child is keyed this way from the node and
    /// the smaller child, which hashes only the smaller one.
    #[inline]
    pub fn without(&self, part: &MemoKey) -> MemoKey {
        debug_assert!(part.n <= self.n);
        MemoKey {
            n: self.n - part.n,
            a: self.a.wrapping_sub(part.a),
            b: self.b.wrapping_sub(part.b),
        }
    }
}

/// Hashes a [`MemoKey`] for the memo's table: its sums are already uniformly mixed, so the
/// table takes the first one and the count (a keyed hash such as the default SipHash would
/// cost more than the lookup saves).
#[derive(Default, Clone, Copy)]
struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }

    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        }
    }

    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = self.0.rotate_left(29) ^ x;
    }

    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

type KeyTable = std::collections::HashMap<MemoKey, Known, std::hash::BuildHasherDefault<KeyHasher>>;

/// Subtree costs that cost-only builds over subsets of the same primitives share: the cost of
/// a node's subtree is a function of its set of references for rules like the sweep (the same
/// set gives the same sorted orders, decisions and sums), so a build that meets a set another
/// build has costed takes its value instead of building the subtree again. The paper's
/// builders rate a node's neighbouring candidates, whose sides differ by a few primitives:
/// their temporaries share most subtrees, and so do a node's temporaries and its children's.
///
/// Builds may label primitives locally: a memo maps its builds' ids to global ones
/// ([`SubtreeMemo::new`]) and keys sets by the global ids, so that builds can also read the
/// entries of another memo, whose builds labelled the primitives otherwise ([`MemoView`]).
///
/// Only nodes of at least [`SubtreeMemo::min_size`] references are stored and looked up. The
/// values are those the build would compute, bit for bit, so the memo changes the speed,
/// never a cost (but for a collision of [`MemoKey`]s). Thread-safe; which build stores a value
/// first depends on the threads' timing, not the value.
#[derive(Debug)]
pub struct SubtreeMemo {
    min_size: usize,
    /// The two hashes of each local id's global id (the terms of [`MemoKey`]'s sums).
    hashes: Vec<[u64; 2]>,
    known: Mutex<KeyTable>,
}

/// A memo entry: the subtree's cost, its root's left size (`0` for a leaf) and, when it was
/// costed within the top levels of a build, the subtree's own top levels.
#[derive(Clone, Debug)]
pub(super) struct Known {
    pub(super) cost: SubtreeCost,
    pub(super) left_len: usize,
    pub(super) top: Option<Box<TopLevels>>,
}

impl SubtreeMemo {
    /// An empty memo for nodes of at least `min_size` references (at least 2), whose builds
    /// label primitive `global[i]` as `i`.
    pub fn new(min_size: usize, global: &[u32]) -> Self {
        // splitmix64's finaliser, of two different inputs per primitive.
        #[inline(always)]
        fn mix(mut z: u64) -> u64 {
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        let hashes = global
            .iter()
            .map(|&g| {
                let x = u64::from(g).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                [mix(x), mix(x ^ 0x5851_f42d_4c95_7f2d)]
            })
            .collect();
        Self {
            min_size: min_size.max(2),
            hashes,
            known: Mutex::new(Default::default()),
        }
    }

    /// The smallest node stored.
    #[inline]
    pub fn min_size(&self) -> usize {
        self.min_size
    }

    /// The key of the set of local `ids` (in any order).
    #[inline]
    pub fn key(&self, ids: &[u32]) -> MemoKey {
        let (mut a, mut b) = (0u64, 0u64);
        for &id in ids {
            let [x, y] = self.hashes[id as usize];
            a = a.wrapping_add(x);
            b = b.wrapping_add(y);
        }
        MemoKey { n: ids.len(), a, b }
    }

    /// Number of subtrees stored.
    pub fn len(&self) -> usize {
        self.known.lock().expect("memo").len()
    }

    /// True when nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn get(&self, k: &MemoKey) -> Option<Known> {
        self.known.lock().expect("memo").get(k).cloned()
    }

    fn put(&self, k: MemoKey, v: Known) {
        let mut m = self.known.lock().expect("memo");
        let e = m.entry(k).or_insert_with(|| v.clone());
        // Top levels are worth keeping when the first entry had none.
        if e.top.is_none() {
            e.top = v.top;
        }
    }
}

/// What a cost-only build reads and writes: its own [`SubtreeMemo`] (its ids' labels, and where
/// it stores), and another memo over the same primitives it reads as well (the parent node's,
/// in the paper's builders).
#[derive(Clone, Copy, Debug)]
pub struct MemoView<'a> {
    /// Keys, lookups and stores.
    pub own: &'a SubtreeMemo,
    /// Lookups only.
    pub other: Option<&'a SubtreeMemo>,
}

impl MemoView<'_> {
    pub(super) fn get(&self, k: &MemoKey) -> Option<Known> {
        self.own
            .get(k)
            .or_else(|| self.other.and_then(|o| o.get(k)))
    }

    pub(super) fn put(&self, k: MemoKey, v: Known) {
        self.own.put(k, v)
    }
}
