//! A new builder in one module: the object median split, on the crate's top-down driver, behind
//! the `Builder` trait and in the registry. Run it with
//! `cargo run --release -p sahara-builders --example median_split`.

use sahara_builders::registry::{self, Entry};
use sahara_builders::topdown::{self, Step, TopDown};
use sahara_builders::{BuildError, BuildInput, Bvh, Configured, Strategy};
use sahara_geom::Aabb;

/// Configuration of the median-split builder.
#[derive(Clone, Copy, Debug)]
pub struct MedianConfig {
    /// Nodes of at most this many primitives become leaves (at least 1). Default 4.
    pub max_leaf_size: usize,
}

impl Strategy for MedianConfig {
    const NAME: &'static str = "median";

    fn check(&self) -> Result<(), BuildError> {
        match self.max_leaf_size {
            0 => Err(BuildError::InvalidConfig(
                "median: max_leaf_size must be at least 1".into(),
            )),
            _ => Ok(()),
        }
    }

    fn describe(&self) -> String {
        format!(
            "object median split of the longest axis, leaves <= {}",
            self.max_leaf_size
        )
    }

    fn build_tree(&self, input: &BuildInput) -> Result<Bvh, BuildError> {
        let mut prims: Vec<u32> = (0..input.len() as u32).collect();
        Ok(topdown::build(
            &Median { input, cfg: *self },
            &mut prims[..],
            false,
        ))
    }
}

/// The rule: split every node above the leaf size at the median of its longest axis.
struct Median<'a> {
    input: &'a BuildInput<'a>,
    cfg: MedianConfig,
}

impl<'a> TopDown for Median<'a> {
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
        if prims.len() <= self.cfg.max_leaf_size {
            return Step::Leaf {
                bounds,
                task: prims,
            };
        }
        let axis = bounds.largest_axis();
        // A total order (centroid, then index), so the tree does not depend on the sort.
        prims.sort_unstable_by(|&p, &q| {
            c[p as usize][axis]
                .total_cmp(&c[q as usize][axis])
                .then(p.cmp(&q))
        });
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

/// Adds the builder to the registry (once: a second call reports the name as taken).
pub fn register() -> Result<(), registry::RegistryError> {
    registry::register(Entry {
        name: "median",
        summary: "object median split (an example of a builder defined outside the crate)",
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
    for name in ["median", "sweep"] {
        let bvh = registry::by_name(name).unwrap().build(&input).unwrap();
        bvh.validate(&tris).unwrap();
        println!("{name}: SAH {:.2}", sahara_metrics::sah(&bvh, &input.cost));
    }
}
