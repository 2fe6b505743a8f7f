//! Embree's own tree, built by Embree's builders and traced by sahara's kernels: the builders
//! `embree-medium` and `embree-high` (feature `embree`), so that a gap between Embree and
//! sahara can be split into the part that is the tree and the part that is the kernel.
//!
//! `rtcBuildBVH` (Embree's general BVH builder API) runs the same builders as a scene commit:
//! quality MEDIUM is the binned SAH builder over 32 bins, HIGH the spatial-split SAH builder.
//! It calls back for every node it creates, so the tree comes out in our own nodes. We ask
//! for a binary tree (branching factor 2) with the leaf parameters of Embree's 8-wide
//! `Triangle4` scene builder (`BVHNBuilderSAH<8, Triangle4>`: SAH in blocks of 4 primitives,
//! intersection and traversal cost 1, nodes of at most 4 primitives always leaves, leaves of
//! at most 28). Embree forms its 8-wide nodes from the same binary splits (it splits the
//! child of largest area until it has eight), so this binary tree holds exactly the split
//! decisions of Embree's scene tree; what differs from Embree's scene is only the way it is
//! widened (sahara's collapse, not Embree's greedy one) and the kernel.
//!
//! The tree is converted to a sahara [`Bvh`] (depth first, leaf boxes the union of the
//! references Embree gave the leaf, inner boxes the union of the children), so it passes
//! [`Bvh::validate`] and can be collapsed, measured and traced like any other builder's.
//! Spatial splits (HIGH) cut triangles with sahara's exact clipper ([`Clipper::split`]);
//! the reference array has room for 20% more references, Embree's default for its scenes.
//!
//! Embree's build runs on its own thread pool (all cores; `SAHARA_EMBREE_CONFIG` is passed to
//! the device, which is created once per process and configuration, so a build's time does
//! not include it; the callbacks, the clipper above all, still make these builds slower than
//! a scene commit). Its parallel partitions are not promised to be deterministic, so two builds
//! may differ in the order of a leaf's references; these builders are for measurements, not
//! for trees that must be reproduced bit for bit. See docs/embree.md.

use embree::sys;
use sahara_builders::split::spatial::Clipper;
use sahara_builders::{BuildError, BuildInput, Builder};
use sahara_bvh::{Bvh, Node};
use sahara_geom::{Aabb, Vec3A};
use std::ffi::{c_uint, c_void, CString};

/// The names of the builders of this module.
pub const NAMES: [&str; 2] = ["embree-medium", "embree-high"];

/// Leaf parameters of Embree's 8-wide `Triangle4` scene builder.
const SAH_BLOCK: u32 = 4;
const MIN_LEAF: u32 = 4;
const MAX_LEAF: u32 = 28;
/// Deep enough that Embree's depth limit (it forces leaves eight levels above it) never
/// binds on the shared scenes' binary trees.
const MAX_DEPTH: u32 = 128;

/// Embree's binned (MEDIUM) or spatial-split (HIGH) builder, as a sahara builder.
#[derive(Clone, Copy, Debug)]
pub struct EmbreeTreeBuilder {
    high: bool,
}

impl EmbreeTreeBuilder {
    /// The builder named `name` (one of [`NAMES`]).
    pub fn by_name(name: &str) -> Option<Self> {
        match name {
            "embree-medium" => Some(Self { high: false }),
            "embree-high" => Some(Self { high: true }),
            _ => None,
        }
    }
}

const TAG_INNER: u32 = 0;
const TAG_LEAF: u32 = 1;

/// An inner node as Embree's callbacks fill it (two children at most).
#[repr(C)]
struct Inner {
    tag: u32,
    count: u32,
    children: [*const u32; 2],
}

/// A leaf: its box and its references (at most [`MAX_LEAF`]).
#[repr(C)]
struct Leaf {
    tag: u32,
    count: u32,
    min: [f32; 3],
    max: [f32; 3],
    ids: [u32; MAX_LEAF as usize],
}

/// Room for one `T` from Embree's thread-local allocator (null when it fails), owned by the
/// BVH object until it is released.
///
/// # Safety
///
/// `alloc` is the allocator Embree passed to the callback.
unsafe fn alloc_node<T>(alloc: sys::RTCThreadLocalAllocator) -> *mut T {
    // SAFETY: the caller's contract; Embree returns memory of the requested size and
    // alignment, or null.
    unsafe {
        sys::rtcThreadLocalAlloc(alloc, std::mem::size_of::<T>(), std::mem::align_of::<T>())
            .cast::<T>()
    }
}

unsafe extern "C" fn create_node(
    alloc: sys::RTCThreadLocalAllocator,
    child_count: c_uint,
    _user: *mut c_void,
) -> *mut c_void {
    // SAFETY: Embree's allocator returns memory of the requested size and alignment (or
    // null), owned by the BVH object until it is released.
    unsafe {
        let p = alloc_node::<Inner>(alloc);
        if !p.is_null() {
            p.write(Inner {
                tag: TAG_INNER,
                count: child_count.min(2),
                children: [std::ptr::null(); 2],
            });
        }
        p.cast()
    }
}

unsafe extern "C" fn set_children(
    node: *mut c_void,
    children: *mut *mut c_void,
    count: c_uint,
    _user: *mut c_void,
) {
    // SAFETY: `node` came from `create_node`; `children` holds `count` node pointers.
    unsafe {
        let n = &mut *node.cast::<Inner>();
        n.count = count.min(2);
        for i in 0..n.count as usize {
            n.children[i] = (*children.add(i)).cast();
        }
    }
}

unsafe extern "C" fn set_bounds(
    _node: *mut c_void,
    _bounds: *mut *const sys::RTCBounds,
    _count: c_uint,
    _user: *mut c_void,
) {
    // The boxes are recomputed from the leaves on conversion.
}

unsafe extern "C" fn create_leaf(
    alloc: sys::RTCThreadLocalAllocator,
    prims: *const sys::RTCBuildPrimitive,
    count: usize,
    _user: *mut c_void,
) -> *mut c_void {
    // SAFETY: as in `create_node`; `prims` holds `count` primitives.
    unsafe {
        let p = alloc_node::<Leaf>(alloc);
        if p.is_null() {
            return p.cast();
        }
        let mut leaf = Leaf {
            tag: TAG_LEAF,
            count: count.min(MAX_LEAF as usize) as u32,
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            ids: [0; MAX_LEAF as usize],
        };
        for i in 0..leaf.count as usize {
            let r = &*prims.add(i);
            let (lo, hi) = (
                [r.lower_x, r.lower_y, r.lower_z],
                [r.upper_x, r.upper_y, r.upper_z],
            );
            for a in 0..3 {
                leaf.min[a] = leaf.min[a].min(lo[a]);
                leaf.max[a] = leaf.max[a].max(hi[a]);
            }
            leaf.ids[i] = r.primID;
        }
        // More than `MAX_LEAF` references would be a broken promise of Embree's; the
        // conversion reports it (`count` is kept, the ids beyond are not).
        leaf.count = count as u32;
        p.write(leaf);
        p.cast()
    }
}

unsafe extern "C" fn split_primitive(
    prim: *const sys::RTCBuildPrimitive,
    dim: c_uint,
    pos: f32,
    left: *mut sys::RTCBounds,
    right: *mut sys::RTCBounds,
    user: *mut c_void,
) {
    // SAFETY: `user` is the `Clipper` passed in `build`, alive for the whole build; the
    // pointers are Embree's, valid for this call.
    unsafe {
        let clipper = &*user.cast::<Clipper>();
        let r = &*prim;
        let b = Aabb::new(
            Vec3A::new(r.lower_x, r.lower_y, r.lower_z),
            Vec3A::new(r.upper_x, r.upper_y, r.upper_z),
        );
        let axis = (dim as usize).min(2);
        let (mut l, mut h) = clipper.split(r.primID, axis, pos, &b);
        // Embree expects two boxes: a half the triangle does not reach becomes a flat box
        // on the plane inside the other half (harmless: it holds no part of the triangle,
        // and it lies in its half).
        let flat = |o: &Aabb| {
            let mut f = *o;
            f.min[axis] = pos;
            f.max[axis] = pos;
            f
        };
        if l.is_empty() {
            l = flat(&h);
        }
        if h.is_empty() {
            h = flat(&l);
        }
        let out = |b: &Aabb| sys::RTCBounds {
            lower_x: b.min.x,
            lower_y: b.min.y,
            lower_z: b.min.z,
            align0: 0.0,
            upper_x: b.max.x,
            upper_y: b.max.y,
            upper_z: b.max.z,
            align1: 0.0,
        };
        left.write(out(&l));
        right.write(out(&h));
    }
}

/// A reference to an Embree device and a BVH object, released on drop.
struct Handles {
    device: sys::RTCDevice,
    bvh: sys::RTCBVH,
}

impl Drop for Handles {
    fn drop(&mut self) {
        // SAFETY: retained or created in `build`, released once; the BVH before its device.
        unsafe {
            if !self.bvh.is_null() {
                sys::rtcReleaseBVH(self.bvh);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

/// A device handle that may cross threads (Embree's devices are thread-safe).
struct SharedDevice(sys::RTCDevice);

// SAFETY: Embree documents its API calls on a device as thread-safe; the handle is only
// retained, used and released through that API.
unsafe impl Send for SharedDevice {}

/// The device of the last build and its configuration: later builds with the same
/// configuration reuse it, so that a build's time does not include creating a device (Embree
/// starts its thread pool there). Kept until the process ends.
static DEVICE: std::sync::Mutex<Option<(String, SharedDevice)>> = std::sync::Mutex::new(None);

/// A new reference to the device of `config` (created on first use, or when the
/// configuration changed); the caller releases it.
fn device(config: &str) -> Result<sys::RTCDevice, BuildError> {
    let mut slot = DEVICE.lock().unwrap_or_else(|e| e.into_inner());
    if slot.as_ref().is_none_or(|(c, _)| c != config) {
        let c =
            CString::new(config).map_err(|_| failed("SAHARA_EMBREE_CONFIG contains a NUL byte"))?;
        // SAFETY: a NUL-terminated configuration; the result is checked for null.
        let d = unsafe { sys::rtcNewDevice(c.as_ptr()) };
        if d.is_null() {
            return Err(failed("rtcNewDevice failed"));
        }
        if let Some((_, old)) = slot.replace((config.to_string(), SharedDevice(d))) {
            // SAFETY: the cache's own reference; builds still running hold their own.
            unsafe { sys::rtcReleaseDevice(old.0) };
        }
    }
    let d = slot.as_ref().expect("set above").1 .0;
    // SAFETY: a live device (the cache holds a reference while the lock is held).
    unsafe { sys::rtcRetainDevice(d) };
    Ok(d)
}

fn failed(what: &str) -> BuildError {
    BuildError::InvalidConfig(format!("Embree's rtcBuildBVH: {what}"))
}

impl Builder for EmbreeTreeBuilder {
    fn name(&self) -> &str {
        NAMES[usize::from(self.high)]
    }

    fn describe(&self) -> String {
        format!(
            "Embree 3 rtcBuildBVH, {} SAH, binary, leaf blocks of {SAH_BLOCK} (<= {MIN_LEAF} \
             always a leaf, <= {MAX_LEAF}), converted",
            if self.high { "spatial-split" } else { "binned" }
        )
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let n = input.len();
        if n == 0 {
            return Ok(Bvh::empty());
        }
        let clipper = match (self.high, input.clipper()) {
            (true, Some(c)) => Some(c),
            (true, None) => {
                return Err(failed(
                    "spatial splits need an input that can cut primitives",
                ))
            }
            (false, _) => None,
        };
        let capacity = if self.high { n + n / 5 } else { n };
        let mut prims: Vec<sys::RTCBuildPrimitive> = Vec::with_capacity(capacity);
        for (i, b) in input.bounds().iter().enumerate() {
            prims.push(sys::RTCBuildPrimitive {
                lower_x: b.min.x,
                lower_y: b.min.y,
                lower_z: b.min.z,
                geomID: 0,
                upper_x: b.max.x,
                upper_y: b.max.y,
                upper_z: b.max.z,
                primID: i as u32,
            });
        }
        let device = device(&std::env::var("SAHARA_EMBREE_CONFIG").unwrap_or_default())?;
        // SAFETY: `device` is a retained reference, released by `Handles` (as is the BVH,
        // checked for null); `prims` has `capacity` elements of room (the HIGH builder writes
        // split references into it), and `clipper` outlives the build.
        unsafe {
            let mut h = Handles {
                device,
                bvh: std::ptr::null_mut(),
            };
            h.bvh = sys::rtcNewBVH(device);
            if h.bvh.is_null() {
                return Err(failed("rtcNewBVH failed"));
            }
            let mut clip_slot = clipper;
            let args = sys::RTCBuildArguments {
                byteSize: std::mem::size_of::<sys::RTCBuildArguments>(),
                buildQuality: if self.high {
                    sys::RTCBuildQuality::HIGH
                } else {
                    sys::RTCBuildQuality::MEDIUM
                },
                buildFlags: sys::RTCBuildFlags::NONE,
                maxBranchingFactor: 2,
                maxDepth: MAX_DEPTH,
                sahBlockSize: SAH_BLOCK,
                minLeafSize: MIN_LEAF,
                maxLeafSize: MAX_LEAF,
                traversalCost: 1.0,
                intersectionCost: 1.0,
                bvh: h.bvh,
                primitives: prims.as_mut_ptr(),
                primitiveCount: n,
                primitiveArrayCapacity: capacity,
                createNode: Some(create_node),
                setNodeChildren: Some(set_children),
                setNodeBounds: Some(set_bounds),
                createLeaf: Some(create_leaf),
                splitPrimitive: if self.high {
                    Some(split_primitive)
                } else {
                    None
                },
                buildProgress: None,
                userPtr: match clip_slot.as_mut() {
                    Some(c) => (c as *mut Clipper).cast(),
                    None => std::ptr::null_mut(),
                },
            };
            let root = sys::rtcBuildBVH(&args);
            let err = sys::rtcGetDeviceError(device);
            if root.is_null() || err != sys::RTCError::NONE {
                return Err(failed(&format!("the build failed ({err:?})")));
            }
            convert(root.cast::<u32>().cast_const(), n, self.high)
        }
    }
}

/// Embree's nodes from `root` as a sahara [`Bvh`] over `n` primitives (see the module
/// documentation).
///
/// # Safety
///
/// `root` is the root returned by `rtcBuildBVH` with this module's callbacks, and the BVH
/// object holding the nodes is alive.
unsafe fn convert(root: *const u32, n: usize, spatial: bool) -> Result<Bvh, BuildError> {
    let mut out = Bvh {
        nodes: Vec::with_capacity(2 * n),
        prim_indices: Vec::with_capacity(n),
        spatial_splits: spatial,
        ref_cuts: None,
    };
    enum Step {
        Visit(*const u32, Option<usize>),
        Close(usize),
    }
    let mut stack = vec![Step::Visit(root, None)];
    while let Some(step) = stack.pop() {
        match step {
            Step::Visit(p, patch) => {
                if p.is_null() {
                    return Err(failed("a null child"));
                }
                let me = out.nodes.len();
                if let Some(parent) = patch {
                    out.nodes[parent].index = me as u32;
                }
                // SAFETY: every node starts with its tag (`Inner` and `Leaf` are repr(C)).
                match unsafe { *p } {
                    TAG_LEAF => {
                        // SAFETY: a leaf's tag means a `Leaf`.
                        let leaf = unsafe { &*p.cast::<Leaf>() };
                        if leaf.count == 0 || leaf.count > MAX_LEAF {
                            return Err(failed(&format!("a leaf of {} references", leaf.count)));
                        }
                        let b = Aabb::new(Vec3A::from(leaf.min), Vec3A::from(leaf.max));
                        let first = out.prim_indices.len() as u32;
                        out.prim_indices
                            .extend_from_slice(&leaf.ids[..leaf.count as usize]);
                        out.nodes.push(Node::leaf(&b, first, leaf.count));
                    }
                    TAG_INNER => {
                        // SAFETY: an inner node's tag means an `Inner`.
                        let inner = unsafe { &*p.cast::<Inner>() };
                        match inner.count {
                            2 => {
                                out.nodes.push(Node::inner(&Aabb::EMPTY, 0));
                                stack.push(Step::Close(me));
                                stack.push(Step::Visit(inner.children[1], Some(me)));
                                stack.push(Step::Visit(inner.children[0], None));
                            }
                            // A node of one child (Embree does not make them; tolerated).
                            1 => stack.push(Step::Visit(inner.children[0], patch)),
                            c => return Err(failed(&format!("an inner node of {c} children"))),
                        }
                    }
                    t => return Err(failed(&format!("an unknown node tag {t}"))),
                }
            }
            Step::Close(me) => {
                let (l, r) = out.children(me);
                let b = out.nodes[l].bounds().union(&out.nodes[r].bounds());
                let index = out.nodes[me].index;
                out.nodes[me] = Node::inner(&b, index);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    //! Only with `--features embree`: Embree's trees convert to valid sahara trees, with and
    //! without spatial splits, and sahara's kernels over them give the brute-force hits.
    use super::*;
    use sahara_metrics::CostModel;
    use sahara_trace::RaySet;

    #[test]
    fn embree_trees_are_valid_sahara_trees_that_trace_like_brute_force() {
        let scene = crate::util::load_scene("sphere_in_box:3000").unwrap();
        let tris = &scene.triangles;
        let input = BuildInput::new(tris, CostModel::default()).unwrap();
        let cam = scene.camera;
        let set = RaySet::primary(&cam, 48, 32);
        let brute = sahara_trace::BruteTracer::new(tris);
        let want = sahara_trace::trace_set(&brute, &set).checksum();
        for name in NAMES {
            let b = crate::util::builder(name).unwrap();
            assert_eq!(b.name(), name, "the xtask resolves the name");
            let bvh = b.build(&input).unwrap();
            bvh.validate(tris).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(bvh.nodes.len() > 100, "{name}: {} nodes", bvh.nodes.len());
            if name == "embree-medium" {
                assert_eq!(bvh.prim_indices.len(), tris.len(), "{name}");
            }
            let t = sahara_trace::WideTracer::<8>::new(&bvh, tris);
            assert_eq!(sahara_trace::trace_set(&t, &set).checksum(), want, "{name}");
        }
        let empty = BuildInput::new(&[], CostModel::default()).unwrap();
        assert!(EmbreeTreeBuilder::by_name("embree-high")
            .unwrap()
            .build(&empty)
            .unwrap()
            .is_empty());
    }
}
