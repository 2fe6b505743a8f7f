/// Per-ray work counters, as a trait so that kernels compiled with [`NoStats`] pay nothing.
pub trait TraversalStats {
    /// An inner node was visited (its children's boxes tested).
    fn inner(&mut self);
    /// A leaf was visited.
    fn leaf(&mut self);
    /// `n` triangles were tested.
    fn triangles(&mut self, n: u32);
}

/// Counting turned off: every method is an empty inline function.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl TraversalStats for NoStats {
    #[inline(always)]
    fn inner(&mut self) {}
    #[inline(always)]
    fn leaf(&mut self) {}
    #[inline(always)]
    fn triangles(&mut self, _: u32) {}
}

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
