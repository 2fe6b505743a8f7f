/// Per-ray work counters, as a trait so that kernels compiled with [`NoStats`] pay nothing.
pub trait TraversalStats {
    /// An inner node was visited (its children's boxes tested). Does nothing by default.
    #[inline(always)]
    fn inner(&mut self) {}
    /// A leaf was visited. Does nothing by default.
    #[inline(always)]
    fn leaf(&mut self) {}
    /// `n` triangles were tested. Does nothing by default.
    #[inline(always)]
    fn triangles(&mut self, n: u32) {
        let _ = n;
    }
    /// The closest hit so far was found in lane `lane` of leaf packet `packet` of a wide tree
    /// ([`WideBvh`](crate::WideBvh)'s closest-hit kernels call it each time their hit
    /// improves, so the last call names the packet of the hit they return). Does nothing by
    /// default; [`HitLocation`] keeps it.
    #[inline(always)]
    fn closest_in_packet(&mut self, packet: u32, lane: u32) {
        let _ = (packet, lane);
    }
}

/// Where a wide tree's closest-hit query found its hit: the leaf packet and lane, so that
/// the hit triangle can be read back from the tree's own copy
/// ([`WideBvh::located_triangle`](crate::WideBvh::located_triangle)), which the traversal
/// has just loaded, instead of from the input array, a likely cache miss per hit. Pass it as
/// the query's statistics; it counts no work.
///
/// ```
/// use sahara_bvh::{Bvh, Node};
/// use sahara_geom::{Ray, Triangle, Vec3A};
/// use sahara_traverse::{Bvh8, HitLocation};
/// let tris = [Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y)];
/// let bvh = Bvh { nodes: vec![Node::leaf(&tris[0].bounds(), 0, 1)], prim_indices: vec![0], spatial_splits: false, ref_cuts: None };
/// let wide = Bvh8::from_bvh(&bvh, &tris);
/// let mut at = HitLocation::default();
/// let hit = wide.closest_hit(&Ray::new(Vec3A::new(0.25, 0.25, 1.0), -Vec3A::Z, 0.0, 2.0), &mut at);
/// assert!(hit.is_hit());
/// assert_eq!(wide.located_triangle(&at), Some(tris[0]));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HitLocation {
    /// `packet * 4 + lane + 1` of the last improving hit; 0 before any.
    pub(crate) slot: u32,
}

impl HitLocation {
    /// The packet index and lane, or `None` when no hit was recorded.
    #[inline]
    pub(crate) fn get(&self) -> Option<(usize, usize)> {
        let s = self.slot.checked_sub(1)? as usize;
        Some((s / 4, s % 4))
    }
}

impl TraversalStats for HitLocation {
    #[inline(always)]
    fn closest_in_packet(&mut self, packet: u32, lane: u32) {
        self.slot = packet.wrapping_mul(4).wrapping_add(lane).wrapping_add(1);
    }
}

/// Counting turned off: every method is the trait's empty inline default.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl TraversalStats for NoStats {}

/// Work done by one ray or a batch: inner nodes, leaves and triangles visited.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkCounters {
    /// Inner nodes visited.
    pub inner: u64,
    /// Leaves visited.
    pub leaves: u64,
    /// Triangles tested.
    pub triangles: u64,
}

impl TraversalStats for WorkCounters {
    #[inline(always)]
    fn inner(&mut self) {
        self.inner += 1;
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    #[inline(always)]
    fn triangles(&mut self, n: u32) {
        self.triangles += n as u64;
    }
}

impl std::ops::AddAssign for WorkCounters {
    fn add_assign(&mut self, o: Self) {
        self.inner += o.inner;
        self.leaves += o.leaves;
        self.triangles += o.triangles;
    }
}
