//! A builder written outside the crate in one module: the object median split on the top-down
//! driver, behind the `Builder` trait, in the registry (`cargo run -p sahara-builders --example
//! median_split`).

use sahara_builders::registry::{self, Entry, RegistryError};
use sahara_builders::topdown::{self, Rule, Step};
use sahara_builders::{BuildError, BuildInput, Bvh, Configured, Strategy};
use sahara_geom::Aabb;

/// Configuration: nodes of at most `max_leaf_size` primitives (at least 1) become leaves.
#[derive(Clone, Copy, Debug)]
pub struct MedianConfig {
    pub max_leaf_size: usize,
}

impl Strategy for MedianConfig {
    const NAME: &'static str = "median";

    fn check(&self) -> Result<(), BuildError> {
        let e = || BuildError::InvalidConfig("median: max_leaf_size must be >= 1".into());
        (self.max_leaf_size > 0).then_some(()).ok_or_else(e)
    }

    fn describe(&self) -> String {
        format!("object median split, leaves <= {}", self.max_leaf_size)
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let mut prims: Vec<u32> = (0..input.len() as u32).collect();
        let rule = Median {
            input,
            max_leaf: self.max_leaf_size,
        };
        Ok(topdown::build(&rule, &mut prims[..], false))
    }
}

/// The rule: split a node above the leaf size at the median of its longest axis.
struct Median<'a> {
    input: &'a BuildInput<'a>,
    max_leaf: usize,
}

impl<'a> Rule for Median<'a> {
    type Task = &'a mut [u32];
    type Scratch = ();

    fn size(&self, prims: &Self::Task) -> usize {
        prims.len()
    }

    fn split(&self, prims: Self::Task, _: &mut ()) -> Step<Self::Task> {
        let (b, c) = (self.input.bounds(), self.input.centroids());
        let bounds = prims
            .iter()
            .fold(Aabb::EMPTY, |acc, &p| acc.union(&b[p as usize]));
        if prims.len() <= self.max_leaf {
            return Step::Leaf {
                bounds,
                task: prims,
            };
        }
        let axis = bounds.largest_axis();
        // A total order (centroid, then index): the tree does not depend on the sort.
        let at = |p: u32| c[p as usize][axis];
        prims.sort_unstable_by(|&p, &q| at(p).total_cmp(&at(q)).then(p.cmp(&q)));
        let (left, right) = prims.split_at_mut(prims.len() / 2);
        Step::Split {
            bounds,
            left,
            right,
        }
    }

    fn leaf_refs(&self, prims: &Self::Task, out: &mut Vec<u32>) {
        out.extend_from_slice(prims);
    }
}

/// Adds the builder to the registry (a second call reports the name as taken).
pub fn register() -> Result<(), RegistryError> {
    registry::register(Entry {
        name: "median",
        summary: "object median split (a builder defined outside the crate)",
        spatial: false,
        small_inputs_only: false,
        max_practical_triangles: None,
        make: || Box::new(Configured::new(MedianConfig { max_leaf_size: 4 })),
    })
}

#[allow(dead_code)]
fn main() {
    register().unwrap();
    let tris = sahara_scene::Procedural::Soup.scene(20_000, 1).triangles();
    let input = BuildInput::new(&tris, Default::default()).unwrap();
    let bvh = registry::by_name("median").unwrap().build(&input).unwrap();
    bvh.validate(&tris).unwrap();
    println!(
        "median split: SAH {:.2}",
        sahara_metrics::sah(&bvh, &input.cost)
    );
}
