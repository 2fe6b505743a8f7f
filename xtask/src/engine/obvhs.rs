//! obvhs 0.4 (a Rust BVH crate: PLOC + parallel reinsertion, compressed wide BVH8 traversal)
//! as a trace engine, and its PLOC tree as a sahara builder, for side-by-side figures.
//!
//! Only compiled with the cargo feature `obvhs` (off by default; it pulls the `obvhs` crate
//! from the registry). See docs/peers.md:
//!
//! ```text
//! cargo run --release -p xtask --features obvhs -- trace --scene sibenik --builder sweep \
//!     --engine obvhs --rays diffuse --threads 1
//! cargo run --release -p xtask --features obvhs -- trace --scene sibenik --builder obvhs-ploc \
//!     --layout bvh8 --rays diffuse --threads 1
//! ```
//!
//! * [`ObvhsTracer`] (`--engine obvhs`) builds obvhs's own CWBVH over the triangles with the
//!   `medium_build` preset (`build_cwbvh_from_tris`) and answers closest-hit queries with
//!   `CwBvh::ray_traverse` and any-hit queries with `CwBvh::ray_traverse_miss`, testing
//!   triangles with obvhs's `Triangle::intersect`. The builder's tree is ignored. Hits report
//!   `t` and the triangle; `u` and `v` are 0 (obvhs's traversal does not return them), so
//!   checksums (which hash `t` and the triangle) can equal sahara's only where every `t` is the
//!   same bit for bit. Work counters stay zero.
//! * [`PlocBuilder`] (`--builder obvhs-ploc`) builds obvhs's binary tree (`build_bvh2`,
//!   `medium_build`: PLOC, reinsertion, leaf collapse, reinsertion) over the primitive boxes of
//!   the [`BuildInput`] and converts it to a sahara [`Bvh`], so that its quality is measured with
//!   sahara's kernels and counters. It is not in the builders' registry (the builders crate
//!   does not depend on obvhs); the xtask resolves the name itself.

use anyhow::Result;
use obvhs::{
    aabb::Aabb as OAabb,
    ray::{Ray as ORay, RayHit},
    triangle::Triangle as OTriangle,
    BvhBuildParams,
};
use sahara_builders::{BuildError, BuildInput, Builder};
use sahara_bvh::{Bvh, Node};
use sahara_geom::{Aabb, Ray, Triangle};
use sahara_trace::{Hit, Tracer, WorkCounters};
use std::time::Duration;

/// The registry-like name of [`PlocBuilder`].
pub const PLOC_NAME: &str = "obvhs-ploc";

fn o_tri(t: &Triangle) -> OTriangle {
    let v = |i: usize| glam_obvhs::Vec3A::from_array(t.v[i].to_array());
    OTriangle {
        v0: v(0),
        v1: v(1),
        v2: v(2),
    }
}

/// obvhs's CWBVH over its own `medium_build` tree (see the module documentation).
pub struct ObvhsTracer {
    bvh: obvhs::cwbvh::CwBvh,
    /// The triangles in the order of the tree's primitive slots (`primitive_indices`), so
    /// that the intersection callback reads them without an indirection.
    slots: Vec<OTriangle>,
}

impl ObvhsTracer {
    /// Builds obvhs's tree over `tris`.
    pub fn new(tris: &[Triangle]) -> Result<Self> {
        let otris: Vec<OTriangle> = tris.iter().map(o_tri).collect();
        if otris.is_empty() {
            return Ok(Self {
                bvh: obvhs::cwbvh::CwBvh::default(),
                slots: Vec::new(),
            });
        }
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &otris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let slots = bvh
            .primitive_indices
            .iter()
            .map(|&i| otris[i as usize])
            .collect();
        Ok(Self { bvh, slots })
    }

    fn o_ray(ray: &Ray) -> ORay {
        ORay::new(
            glam_obvhs::Vec3A::from_array(ray.origin.to_array()),
            glam_obvhs::Vec3A::from_array(ray.direction().to_array()),
            ray.tmin,
            ray.tmax,
        )
    }
}

impl Tracer for ObvhsTracer {
    fn name(&self) -> &str {
        "obvhs"
    }

    fn closest_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> Hit {
        self.closest_hit_fast(ray)
    }

    fn any_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> bool {
        self.any_hit_fast(ray)
    }

    #[inline]
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        if !ray.is_valid() || self.slots.is_empty() {
            return Hit::MISS;
        }
        let mut hit = RayHit::none();
        let slots = &self.slots;
        if self
            .bvh
            .ray_traverse(Self::o_ray(ray), &mut hit, |r, id| slots[id].intersect(r))
        {
            Hit {
                t: hit.t,
                prim: self.bvh.primitive_indices[hit.primitive_id as usize],
                u: 0.0,
                v: 0.0,
            }
        } else {
            Hit::MISS
        }
    }

    #[inline]
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        if !ray.is_valid() || self.slots.is_empty() {
            return false;
        }
        let slots = &self.slots;
        !self
            .bvh
            .ray_traverse_miss(Self::o_ray(ray), |r, id| slots[id].intersect(r))
    }
}

/// obvhs's PLOC binary tree as a sahara builder (see the module documentation).
#[derive(Clone, Copy, Debug, Default)]
pub struct PlocBuilder;

impl Builder for PlocBuilder {
    fn name(&self) -> &str {
        PLOC_NAME
    }

    fn describe(&self) -> String {
        "obvhs 0.4 build_bvh2 (medium_build: PLOC, reinsertion, leaf collapse), converted".into()
    }

    fn build(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        if input.is_empty() {
            return Ok(Bvh::empty());
        }
        let boxes: Vec<OAabb> = input
            .bounds()
            .iter()
            .map(|b| {
                OAabb::new(
                    glam_obvhs::Vec3A::from_array(b.min.to_array()),
                    glam_obvhs::Vec3A::from_array(b.max.to_array()),
                )
            })
            .collect();
        let tree = obvhs::bvh2::builder::build_bvh2(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        Ok(convert(&tree, input.bounds()))
    }
}

/// obvhs's binary tree (root at 0, an inner node's children at `first_index` and
/// `first_index + 1`, a leaf's references at `primitive_indices[first_index..][..prim_count]`)
/// in sahara's depth-first layout, with every box recomputed from the primitive boxes
/// `bounds` (so leaf boxes are exactly the union of their primitives' boxes).
pub fn convert(tree: &obvhs::bvh2::Bvh2, bounds: &[Aabb]) -> Bvh {
    let mut out = Bvh {
        nodes: Vec::with_capacity(tree.nodes.len()),
        prim_indices: Vec::with_capacity(bounds.len()),
        spatial_splits: false,
        ref_cuts: None,
    };
    if tree.nodes.is_empty() {
        return out;
    }
    // Depth-first emission with an explicit stack: (obvhs node, parent slot to patch with
    // this node's index when it is a right child).
    enum Step {
        Visit(usize, Option<usize>),
        Close(usize),
    }
    let mut stack = vec![Step::Visit(0, None)];
    while let Some(step) = stack.pop() {
        match step {
            Step::Visit(i, patch) => {
                let n = &tree.nodes[i];
                let me = out.nodes.len();
                if let Some(p) = patch {
                    out.nodes[p].index = me as u32;
                }
                if n.prim_count > 0 {
                    let first = out.prim_indices.len();
                    let refs = &tree.primitive_indices
                        [n.first_index as usize..(n.first_index + n.prim_count) as usize];
                    let b = refs
                        .iter()
                        .fold(Aabb::EMPTY, |a, &r| a.union(&bounds[r as usize]));
                    out.prim_indices.extend_from_slice(refs);
                    out.nodes.push(Node::leaf(&b, first as u32, n.prim_count));
                } else {
                    out.nodes.push(Node::inner(&Aabb::EMPTY, 0));
                    let l = n.first_index as usize;
                    stack.push(Step::Close(me));
                    stack.push(Step::Visit(l + 1, Some(me)));
                    stack.push(Step::Visit(l, None));
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
    out
}

#[cfg(test)]
mod tests {
    //! Only with `--features obvhs`: the tree passes `Bvh::validate`, and obvhs's hits agree
    //! with sahara's reference on the same rays (mismatches counted and bounded).
    use super::*;
    use sahara_trace::{Bvh2Tracer, RayKind, RaySet};

    #[test]
    fn ploc_tree_converts_to_a_valid_bvh_and_traces_like_brute_force() {
        let scene = crate::util::load_scene("sphere_in_box:3000").unwrap();
        let input =
            BuildInput::new(&scene.triangles, sahara_builders::CostModel::default()).unwrap();
        let bvh = PlocBuilder.build(&input).unwrap();
        bvh.validate(&scene.triangles).unwrap();
        assert_eq!(
            crate::util::builder(PLOC_NAME).unwrap().name(),
            PLOC_NAME,
            "the xtask resolves the name"
        );
        // sahara's kernels over the converted tree give the brute-force hits.
        let t = sahara_trace::WideTracer::<8>::new(&bvh, &scene.triangles);
        let cam = scene.camera;
        let set = RaySet::primary(&cam, 48, 32);
        let brute = sahara_trace::BruteTracer::new(&scene.triangles);
        assert_eq!(
            sahara_trace::trace_set(&t, &set).checksum(),
            sahara_trace::trace_set(&brute, &set).checksum()
        );
        let empty = BuildInput::new(&[], sahara_builders::CostModel::default()).unwrap();
        assert!(PlocBuilder.build(&empty).unwrap().is_empty());
    }

    #[test]
    fn obvhs_hits_agree_with_the_reference() {
        let scene = crate::util::load_scene("teapot_stadium:5000").unwrap();
        let input =
            BuildInput::new(&scene.triangles, sahara_builders::CostModel::default()).unwrap();
        let bvh = crate::util::builder("sweep")
            .unwrap()
            .build(&input)
            .unwrap();
        let reference = Bvh2Tracer::new(&bvh, &scene.triangles);
        let engine = ObvhsTracer::new(&scene.triangles).unwrap();
        let cam = scene.camera;
        for kind in RayKind::ALL {
            let set = RaySet::generate(kind, &cam, 64, 48, &reference, &scene.triangles, 1);
            let m = crate::engine::peers::agreement(&reference, &engine, &set);
            eprintln!("obvhs, {kind}: {m}");
            // obvhs's triangle test is not watertight: a few rays may differ, not many.
            assert!(m.rate() < 0.01, "{kind}: {m}");
            assert!(m.rays > 100);
        }
    }
}
