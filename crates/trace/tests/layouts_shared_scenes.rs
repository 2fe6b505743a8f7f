//! Every traversal layout agrees ray by ray with the scalar reference on every shared scene,
//! for primary, diffuse and ambient-occlusion rays (issue 7's "done when").
//!
//! For each scene — the files of the scene catalog ([`Catalog::discover`]: `../shared/scenes`
//! or `$SAHARA_SCENES`) and two procedural scenes, so that something is checked on every
//! machine — the test:
//!
//! 1. builds a binary tree with the registry builders `sweep` and `sbvh` (spatial splits: a
//!    triangle referenced by several leaves) and validates it;
//! 2. generates the three [`RaySet`]s of the evaluation from the scene's camera (primary rays,
//!    one diffuse bounce and one AO ray from each primary hit) with the scalar reference as
//!    the tracer;
//! 3. traces every ray with the scalar reference kernels (`sahara_traverse::scalar`) on each
//!    tree, closest hit and any hit, and pins the reference itself: its closest hits against
//!    brute force (`sahara_traverse::brute`) on every [`BRUTE_STRIDE`]-th ray (sparser on the
//!    largest scenes by default, see [`BRUTE_BUDGET`]), against the other builder's tree on
//!    every ray (the hits cannot depend on the builder), and `any_hit == closest hit found` on
//!    every ray;
//! 4. collapses each tree into [`Bvh4`](sahara_traverse::Bvh4) and
//!    [`Bvh8`](sahara_traverse::Bvh8) and traces every ray with every
//!    [`Backend`] this CPU runs, closest hit and any hit, and requires the reference's answer
//!    bit for bit: `t`, `u`, `v` compared as bits, and `prim`.
//!
//! Failures name the scene, builder, layout, backend, ray kind, ray index and pixel.
//!
//! By default the images are 128×96 pixels, and a file that holds a model already listed in
//! another format (the engine's GLB: its OBJ's model, up to the exporter's rounding of the
//! vertices) is skipped (`Catalog::distinct_files`). `SAHARA_VERIFY_ALL=1` (what `cargo xtask verify` sets) traces
//! 1024×768 images and includes every catalog entry; it takes minutes. Without scene files
//! only the procedural scenes are checked.

use rayon::prelude::*;
use sahara_builders::{registry, BuildInput, CostModel};
use sahara_fixtures::scenes::{shared_scene_files, verify_all};
use sahara_geom::{Ray, Triangle};
use sahara_scene::{Catalog, Procedural, Scene};
use sahara_trace::{Bvh2Tracer, Camera, RayKind, RaySet};
use sahara_traverse::{brute, scalar, Backend, Bvh, Hit, NoStats, WideBvh};
use std::time::Instant;

/// The builders whose trees are traced: the greedy SAH sweep, and the spatial-split builder
/// (triangles referenced by several leaves).
const BUILDERS: [&str; 2] = ["sweep", "sbvh"];

/// The reference is compared with brute force on rays `0, s, 2s, …` of every set, with the
/// stride `s` of [`brute_stride`]: `BRUTE_STRIDE`, or more on large scenes.
const BRUTE_STRIDE: usize = 17;

/// Brute force tests at most about this many (ray, triangle) pairs per ray set (about a
/// second on one core; ten times as many with `SAHARA_VERIFY_ALL`): on the largest scenes the
/// stride grows beyond [`BRUTE_STRIDE`].
const BRUTE_BUDGET: usize = 50_000_000;

/// The seed of the diffuse and AO ray sets.
const SEED: u64 = 7;

/// The image size of the ray sets.
fn resolution() -> (u32, u32) {
    if verify_all() {
        (1024, 768)
    } else {
        (128, 96)
    }
}

/// A hit as bits: `t`, `prim`, `u`, `v`. Unlike `Hit`'s `PartialEq`, this tells `-0.0` from
/// `0.0` and compares NaNs.
fn bits(h: &Hit) -> (u32, u32, u32, u32) {
    (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())
}

/// One ray set and the reference's answers for it.
struct Traced {
    set: RaySet,
    closest: Vec<Hit>,
    any: Vec<bool>,
}

impl Traced {
    fn kind(&self) -> &'static str {
        self.set.kind.name()
    }

    /// `ray i (pixel x,y)`.
    fn ray_label(&self, i: usize) -> String {
        let p = self.set.pixel[i];
        let w = self.set.width.max(1);
        format!("ray {i} (pixel {},{})", p % w, p / w)
    }
}

/// Panics with the first ray whose answer differs from the reference's, and how many differ.
fn assert_same(what: &str, traced: &Traced, closest: &[Hit], any: &[bool]) {
    let bad_closest: Vec<usize> = (0..traced.set.len())
        .into_par_iter()
        .filter(|&i| bits(&closest[i]) != bits(&traced.closest[i]))
        .collect();
    if let Some(&i) = bad_closest.first() {
        panic!(
            "{what}, {} rays: closest hit of {} differs from the scalar reference \
             ({} of {} rays differ)\n  ray:       {:?}\n  got:       {:?}\n  reference: {:?}",
            traced.kind(),
            traced.ray_label(i),
            bad_closest.len(),
            traced.set.len(),
            traced.set.rays[i],
            closest[i],
            traced.closest[i],
        );
    }
    let bad_any: Vec<usize> = (0..traced.set.len())
        .into_par_iter()
        .filter(|&i| any[i] != traced.any[i])
        .collect();
    if let Some(&i) = bad_any.first() {
        panic!(
            "{what}, {} rays: any hit of {} is {} but the scalar reference says {} \
             ({} of {} rays differ)\n  ray: {:?}",
            traced.kind(),
            traced.ray_label(i),
            any[i],
            traced.any[i],
            bad_any.len(),
            traced.set.len(),
            traced.set.rays[i],
        );
    }
}

/// Traces every ray of `set` with the scalar reference on `bvh`.
fn trace_reference(bvh: &Bvh, tris: &[Triangle], set: &RaySet) -> Traced {
    let closest = set
        .rays
        .par_iter()
        .map(|r| scalar::closest_hit(bvh, tris, r, &mut NoStats))
        .collect();
    let any = set
        .rays
        .par_iter()
        .map(|r| scalar::any_hit(bvh, tris, r, &mut NoStats))
        .collect();
    Traced {
        set: set.clone(),
        closest,
        any,
    }
}

/// The stride of the rays checked against brute force: [`BRUTE_STRIDE`], grown so that
/// `rays / stride * triangles` stays within [`BRUTE_BUDGET`] (ten times that with
/// `SAHARA_VERIFY_ALL`).
fn brute_stride(rays: usize, triangles: usize) -> usize {
    let budget = if verify_all() {
        10 * BRUTE_BUDGET
    } else {
        BRUTE_BUDGET
    };
    BRUTE_STRIDE.max((rays * triangles).div_ceil(budget))
}

/// Brute force's closest hit on every [`brute_stride`]-th ray: `(ray index, hit)`.
fn brute_subset(tris: &[Triangle], rays: &[Ray]) -> Vec<(usize, Hit)> {
    (0..rays.len())
        .into_par_iter()
        .step_by(brute_stride(rays.len(), tris.len()))
        .map(|i| (i, brute::closest_hit(tris, &rays[i])))
        .collect()
}

/// The reference on one tree against brute force's closest hits (a subset of the rays),
/// against itself (`any_hit` == closest hit found, which pins the any hits to brute force
/// too), and against the reference on the first builder's tree (every ray).
fn check_reference(what: &str, traced: &Traced, brute: &[(usize, Hit)], first: Option<&Traced>) {
    for (i, h) in brute {
        assert_eq!(
            bits(&traced.closest[*i]),
            bits(h),
            "{what}, {} rays: closest hit of {} differs from brute force\n  ray: {:?}\n  \
             reference: {:?}\n  brute force: {h:?}",
            traced.kind(),
            traced.ray_label(*i),
            traced.set.rays[*i],
            traced.closest[*i],
        );
    }
    for (i, (h, a)) in traced.closest.iter().zip(&traced.any).enumerate() {
        assert_eq!(
            h.is_hit(),
            *a,
            "{what}, {} rays: any hit of {} is {a} but the closest hit is {h:?}",
            traced.kind(),
            traced.ray_label(i),
        );
    }
    if let Some(first) = first {
        assert_same(
            &format!("{what} (against the reference on the {} tree)", BUILDERS[0]),
            first,
            &traced.closest,
            &traced.any,
        );
    }
}

/// One wide layout with every available backend against the reference, on every ray set.
fn check_wide<const W: usize>(what: &str, wide: &WideBvh<W>, sets: &[Traced]) {
    for backend in Backend::ALL.into_iter().filter(|b| b.is_available()) {
        for traced in sets {
            let rays = &traced.set.rays;
            let closest: Vec<Hit> = rays
                .par_iter()
                .map(|r| wide.closest_hit_with(backend, r, &mut NoStats))
                .collect();
            let any: Vec<bool> = rays
                .par_iter()
                .map(|r| wide.any_hit_with(backend, r, &mut NoStats))
                .collect();
            assert_same(
                &format!("{what}, backend {backend}"),
                traced,
                &closest,
                &any,
            );
        }
    }
}

/// Collapses `bvh` to its `W`-wide tree (timed in `time.collapse`) and checks that tree
/// against the reference's answers `traced` (timed in `time.wide`); `what` names the scene and
/// the builder.
fn check_layout<const W: usize>(
    what: &str,
    bvh: &Bvh,
    tris: &[Triangle],
    traced: &[Traced],
    time: &mut Phases,
) {
    let wide = timed(&mut time.collapse, || WideBvh::<W>::from_bvh(bvh, tris));
    timed(&mut time.wide, || {
        check_wide(&format!("{what}, layout bvh{W}"), &wide, traced)
    });
}

/// Seconds spent in each phase of the check of a scene.
#[derive(Default)]
struct Phases {
    load: f64,
    build: f64,
    reference: f64,
    brute: f64,
    collapse: f64,
    wide: f64,
}

/// Runs `f`, adding its wall time to `seconds`.
fn timed<T>(seconds: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let result = f();
    *seconds += t0.elapsed().as_secs_f64();
    result
}

/// Runs every check on one scene (loaded or generated in `load_seconds`); returns the number
/// of rays of each kind.
fn check_scene(name: &str, scene: &Scene, load_seconds: f64) -> [usize; 3] {
    let mut time = Phases {
        load: load_seconds,
        ..Phases::default()
    };
    let tris = scene.triangles();
    let c = scene.camera;
    let camera = Camera::new(c.eye, c.target, c.up, c.fov_y_degrees);
    let (width, height) = resolution();
    let input = BuildInput::new(&tris, CostModel::default())
        .unwrap_or_else(|e| panic!("{name}: build input: {e}"));

    // The ray sets and the reference's answers on the first builder's tree, and brute force
    // on a subset of the rays.
    let mut first: Option<Vec<Traced>> = None;
    let mut brute: Vec<Vec<(usize, Hit)>> = Vec::new();
    let mut references = Vec::new();
    for builder in BUILDERS {
        let bvh = timed(&mut time.build, || {
            registry::by_name(builder)
                .unwrap_or_else(|| panic!("no builder {builder:?} in the registry"))
                .build(&input)
                .unwrap_or_else(|e| panic!("{name}, builder {builder}: build failed: {e}"))
        });
        bvh.validate(&tris)
            .unwrap_or_else(|e| panic!("{name}, builder {builder}: invalid tree: {e}"));
        references.push(bvh.stats().references);

        let traced: Vec<Traced> = match &first {
            None => {
                let sets: Vec<Traced> = timed(&mut time.reference, || {
                    let tracer = Bvh2Tracer::new(&bvh, &tris);
                    RayKind::ALL
                        .into_iter()
                        .map(|kind| {
                            let set = RaySet::generate(
                                kind, &camera, width, height, &tracer, &tris, SEED,
                            );
                            trace_reference(&bvh, &tris, &set)
                        })
                        .collect()
                });
                brute = timed(&mut time.brute, || {
                    sets.iter()
                        .map(|t| brute_subset(&tris, &t.set.rays))
                        .collect()
                });
                sets
            }
            Some(first) => timed(&mut time.reference, || {
                first
                    .iter()
                    .map(|f| trace_reference(&bvh, &tris, &f.set))
                    .collect()
            }),
        };
        let what =
            format!("{name}, builder {builder}, layout bvh2, backend scalar (the reference)");
        for (k, t) in traced.iter().enumerate() {
            check_reference(&what, t, &brute[k], first.as_ref().map(|f| &f[k]));
        }

        let tree = format!("{name}, builder {builder}");
        check_layout::<4>(&tree, &bvh, &tris, &traced, &mut time);
        check_layout::<8>(&tree, &bvh, &tris, &traced, &mut time);

        if first.is_none() {
            first = Some(traced);
        }
    }

    let sets = first.expect("at least one builder");
    let counts = [0, 1, 2].map(|k| sets[k].set.len());
    let hits = sets[0].closest.iter().filter(|h| h.is_hit()).count();
    let occluded = sets[2].any.iter().filter(|&&a| a).count();
    let brute_rays: usize = brute.iter().map(Vec::len).sum();
    let references: Vec<String> = BUILDERS
        .iter()
        .zip(&references)
        .map(|(b, r)| format!("{b} {r}"))
        .collect();
    eprintln!(
        "{name}: {} triangles (references: {}), {width}x{height}: {} primary ({hits} hit), \
         {} diffuse, {} ao ({occluded} occluded) rays, {brute_rays} of them also by brute \
         force; seconds: load {:.1}, build {:.1}, reference {:.1}, brute {:.1}, \
         collapse {:.1}, wide {:.1}",
        tris.len(),
        references.join(", "),
        counts[0],
        counts[1],
        counts[2],
        time.load,
        time.build,
        time.reference,
        time.brute,
        time.collapse,
        time.wide,
    );
    assert!(
        hits > 0,
        "{name}: no primary ray hits anything, so no secondary ray is checked"
    );
    counts
}

#[test]
fn layouts_agree_with_the_reference_on_procedural_scenes() {
    // An interior (every primary ray hits; secondary rays start on a closed surface) and
    // extreme differences of triangle size and density.
    for p in [Procedural::SphereInBox, Procedural::TeapotStadium] {
        let t0 = Instant::now();
        let scene = p.scene(p.default_size(), sahara_scene::DEFAULT_SEED);
        check_scene(p.name(), &scene, t0.elapsed().as_secs_f64());
    }
}

#[test]
fn layouts_agree_with_the_reference_on_shared_scenes() {
    let catalog = Catalog::discover();
    // Another format of a model already listed (the engine's GLB: its OBJ's model, vertices
    // differing by the exporter's rounding) is checked only by `cargo xtask verify`.
    let Some(files) = shared_scene_files(&catalog, verify_all()) else {
        return;
    };
    let backends: Vec<&str> = Backend::ALL
        .into_iter()
        .filter(|b| b.is_available())
        .map(Backend::name)
        .collect();
    eprintln!(
        "{} scene files, {BUILDERS:?} trees, layouts bvh4 and bvh8 with backends {backends:?}",
        files.len()
    );
    let start = Instant::now();
    let mut total = 0;
    for e in &files {
        let t0 = Instant::now();
        let scene = catalog
            .load_entry(e)
            .unwrap_or_else(|err| panic!("{}: cannot load: {err}", e.name));
        let load = t0.elapsed().as_secs_f64();
        total += check_scene(&e.name, &scene, load).iter().sum::<usize>();
    }
    eprintln!(
        "{} shared scenes, {total} rays: every layout and backend equals the reference ({:.1} s)",
        files.len(),
        start.elapsed().as_secs_f64()
    );
}
