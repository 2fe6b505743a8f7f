//! Builders over primitive boxes (`BuildInput::from_boxes`), with and without a split
//! callback, and the public registration of builders.

use sahara_builders::registry::{self, Entry, RegistryError};
use sahara_builders::split::spatial::{clip_halves, SplitPrimitive};
use sahara_builders::sweep::SweepBuilder;
use sahara_builders::{BuildError, BuildInput, Builder, Bvh, CostModel};
use sahara_geom::{rng::Pcg32, Aabb, Axis, Triangle, Vec3A};
use sahara_metrics::sah;

fn soup(n: usize, seed: u64) -> Vec<Triangle> {
    sahara_scene::Procedural::Soup.scene(n, seed).triangles()
}

#[test]
fn bad_boxes_are_typed_errors() {
    let good = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let inverted = Aabb::new(Vec3A::ONE, Vec3A::ZERO);
    let nan = Aabb::new(Vec3A::new(f32::NAN, 0.0, 0.0), Vec3A::ONE);
    let inf = Aabb::new(Vec3A::ZERO, Vec3A::splat(f32::INFINITY));
    for (bad, i) in [(inverted, 1), (nan, 2), (inf, 1)] {
        let boxes = match i {
            1 => vec![good, bad],
            _ => vec![good, good, bad],
        };
        let e = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap_err();
        assert_eq!(e, BuildError::InvalidBox { primitive: i });
    }
    let input = BuildInput::from_boxes(&[], CostModel::default()).unwrap();
    assert!(SweepBuilder::default().build(&input).unwrap().is_empty());
}

/// Every leaf's references, as a multiset per primitive: each primitive appears at least once.
fn covers_every_primitive(bvh: &Bvh, n: usize) -> bool {
    let mut seen = vec![false; n];
    for &p in &bvh.prim_indices {
        seen[p as usize] = true;
    }
    seen.iter().all(|&s| s)
}

#[test]
fn object_split_builders_see_only_boxes() {
    // The same boxes give the same tree, whether they come from triangles or not: the
    // builders that do not cut primitives only ever read bounds and centroids.
    let tris = soup(3_000, 4);
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::bounds).collect();
    let from_tris = BuildInput::new(&tris, CostModel::default()).unwrap();
    let from_boxes = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    for e in registry::entries() {
        let b = (e.make)();
        let t = b.build(&from_boxes).unwrap();
        t.validate_structure().unwrap();
        assert!(covers_every_primitive(&t, boxes.len()), "{}", e.name);
        if e.spatial {
            // Without a split callback there is nothing to cut: no reference is duplicated.
            assert_eq!(t.prim_indices.len(), boxes.len(), "{}", e.name);
        } else if !e.small_inputs_only {
            let u = b.build(&from_tris).unwrap();
            assert_eq!(t.fingerprint(), u.fingerprint(), "{}", e.name);
        }
    }
}

/// Axis-aligned boxes as primitives: cutting one keeps the part on each side exactly.
struct Boxes<'a>(&'a [Aabb]);

impl SplitPrimitive for Boxes<'_> {
    fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        let b = self.0[prim as usize].intersection(bounds);
        let (mut l, mut r) = (b, b);
        l.max[axis] = l.max[axis].min(pos);
        r.min[axis] = r.min[axis].max(pos);
        let keep = |h: Aabb| if h.is_empty() { Aabb::EMPTY } else { h };
        (keep(l), keep(r))
    }
}

#[test]
fn spatial_splits_cut_user_primitives() {
    // Small boxes scattered in a cube, crossed by large thin slabs: object splits cannot
    // keep the slabs out of every node, cuts can.
    let mut rng = Pcg32::new(9, 9);
    let mut p = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut boxes: Vec<Aabb> = (0..600)
        .map(|_| {
            let o = p();
            Aabb::new(o, o + Vec3A::splat(0.01))
        })
        .collect();
    for i in 0..24 {
        let y = (i as f32 + 0.5) / 24.0;
        boxes.push(Aabb::new(
            Vec3A::new(0.0, y, 0.0),
            Vec3A::new(1.0, y + 0.002, 1.0),
        ));
    }
    let cut = Boxes(&boxes);
    let input = BuildInput::from_boxes(&boxes, CostModel::default())
        .unwrap()
        .with_splitter(&cut);
    let plain = BuildInput::from_boxes(&boxes, CostModel::default()).unwrap();
    for name in ["sbvh", "sbvh-refined", "tsah-sbvh"] {
        let b = registry::by_name(name).unwrap();
        let t = b.build(&input).unwrap();
        t.validate_structure().unwrap();
        assert!(covers_every_primitive(&t, boxes.len()), "{name}");
        assert!(
            t.prim_indices.len() > boxes.len(),
            "{name}: nothing was cut"
        );
        // Every leaf box overlaps the primitives it references, and lies inside their union.
        for n in t.nodes.iter().filter(|n| n.is_leaf()) {
            for &p in t.leaf_prims(n) {
                assert!(n.bounds().overlaps(&boxes[p as usize]), "{name}");
            }
        }
        // Without the callback nothing is cut.
        let uncut = b.build(&plain).unwrap();
        assert_eq!(uncut.prim_indices.len(), boxes.len(), "{name}");
    }
}

/// Triangles through the callback: exact clipping at every plane, the default binning.
struct ClippedTriangles<'a>(&'a [Triangle]);

impl SplitPrimitive for ClippedTriangles<'_> {
    fn split(&self, prim: u32, axis: Axis, pos: f32, bounds: &Aabb) -> (Aabb, Aabb) {
        clip_halves(&self.0[prim as usize], axis, pos, bounds)
    }
}

#[test]
fn a_callback_that_clips_triangles_builds_what_sbvh_builds() {
    // The built-in triangle path bins with a faster f32 slab clipper; through the callback
    // every plane is clipped exactly. Both must give trees of the same quality, well below
    // the object-split tree.
    let tris = sahara_scene::Procedural::TeapotStadium
        .scene(4_000, 3)
        .triangles();
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::bounds).collect();
    let cb = ClippedTriangles(&tris);
    let custom = BuildInput::from_boxes(&boxes, CostModel::default())
        .unwrap()
        .with_splitter(&cb);
    let builtin = BuildInput::new(&tris, CostModel::default()).unwrap();
    let sbvh = registry::by_name("sbvh").unwrap();
    let (a, b) = (sbvh.build(&custom).unwrap(), sbvh.build(&builtin).unwrap());
    a.validate(&tris).unwrap();
    let sweep = SweepBuilder::default().build(&builtin).unwrap();
    let (sa, sb, ss) = (
        sah(&a, &custom.cost),
        sah(&b, &custom.cost),
        sah(&sweep, &custom.cost),
    );
    assert!((sa - sb).abs() <= 0.02 * sb, "callback {sa}, built-in {sb}");
    assert!(sa < 0.97 * ss, "callback {sa}, sweep {ss}");
}

#[test]
fn registration_checks_names() {
    let mismatch = Entry::new("not-sweep", "a sweep builder under the wrong name", || {
        Box::new(SweepBuilder::default())
    });
    assert_eq!(
        registry::register(mismatch),
        Err(RegistryError::NameMismatch {
            entry: "not-sweep".into(),
            builder: "sweep".into()
        })
    );
    let taken = Entry::new("sweep", "a second sweep", || {
        Box::new(SweepBuilder::default())
    });
    assert_eq!(
        registry::register(taken),
        Err(RegistryError::Duplicate("sweep".into()))
    );
    let renamed = Entry::new(
        "sweep-again",
        "the sweep builder under another name",
        || Box::new(SweepBuilder::named("sweep-again", Default::default())),
    );
    registry::register(renamed).unwrap();
    assert!(registry::names().contains(&"sweep-again"));
    assert_eq!(
        registry::by_name("sweep-again").unwrap().name(),
        "sweep-again"
    );
}
