//! Integration tests of sahara-trace: ray sets, batch tracing, kernels against brute force,
//! files and images.

use sahara_bvh::{Bvh, Node};
use sahara_geom::{rng::Pcg32, Aabb, Ray, Triangle, Vec3A};
use sahara_trace::*;
use sahara_traverse::brute;
use std::path::PathBuf;

// ---------------------------------------------------------------------------------------------
// A small scene and a tiny median-split builder (the tests must not depend on sahara-builders).

/// 300 random small triangles in `[-1, 1]^3`, a 10x10 grid of quads (200 triangles sharing
/// edges and vertices) as a back wall, and a large ground quad.
fn scene() -> Vec<Triangle> {
    let mut rng = Pcg32::new(2024, 3);
    let mut tris = Vec::new();
    for _ in 0..300 {
        let c = Vec3A::new(
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
            rng.range_f32(-1.0, 1.0),
        );
        let mut v = || {
            c + Vec3A::new(
                rng.range_f32(-0.2, 0.2),
                rng.range_f32(-0.2, 0.2),
                rng.range_f32(-0.2, 0.2),
            )
        };
        tris.push(Triangle::new(v(), v(), v()));
    }
    let n = 10;
    let p = |i: usize, j: usize| {
        Vec3A::new(
            -1.5 + 3.0 * i as f32 / n as f32,
            -1.5 + 3.0 * j as f32 / n as f32,
            -1.5,
        )
    };
    for i in 0..n {
        for j in 0..n {
            tris.push(Triangle::new(p(i, j), p(i + 1, j), p(i + 1, j + 1)));
            tris.push(Triangle::new(p(i, j), p(i + 1, j + 1), p(i, j + 1)));
        }
    }
    let g = |x: f32, z: f32| Vec3A::new(x, -1.3, z);
    tris.push(Triangle::new(g(-3.0, -3.0), g(3.0, -3.0), g(3.0, 3.0)));
    tris.push(Triangle::new(g(-3.0, -3.0), g(3.0, 3.0), g(-3.0, 3.0)));
    tris
}

/// The test scene and its median-split tree.
fn scene_and_bvh() -> (Vec<Triangle>, Bvh) {
    let tris = scene();
    let bvh = median_split_bvh(&tris);
    (tris, bvh)
}

/// Median split on the largest axis of the centroid bounds, leaves of at most 4 triangles.
fn median_split_bvh(tris: &[Triangle]) -> Bvh {
    fn rec(tris: &[Triangle], idx: &mut [u32], first: usize, nodes: &mut Vec<Node>) {
        let bounds = idx
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(&tris[i as usize].bounds()));
        if idx.len() <= 4 {
            nodes.push(Node::leaf(&bounds, first as u32, idx.len() as u32));
            return;
        }
        let cb = Aabb::from_points(idx.iter().map(|&i| tris[i as usize].centroid()));
        let axis = cb.largest_axis();
        idx.sort_by(|&a, &b| {
            tris[a as usize].centroid()[axis].total_cmp(&tris[b as usize].centroid()[axis])
        });
        let me = nodes.len();
        nodes.push(Node::inner(&bounds, 0));
        let mid = idx.len() / 2;
        let (l, r) = idx.split_at_mut(mid);
        rec(tris, l, first, nodes);
        nodes[me].index = nodes.len() as u32;
        rec(tris, r, first + mid, nodes);
    }
    let mut idx: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = Vec::new();
    rec(tris, &mut idx, 0, &mut nodes);
    let bvh = Bvh {
        nodes,
        prim_indices: idx,
        spatial_splits: false,
        ref_cuts: None,
    };
    bvh.validate(tris).expect("test builder makes valid trees");
    bvh
}

fn camera() -> Camera {
    Camera::new(
        Vec3A::new(0.3, 0.6, 4.0),
        Vec3A::new(0.0, -0.2, 0.0),
        Vec3A::Y,
        50.0,
    )
}

const W: u32 = 64;
const H: u32 = 48;

fn with_threads<R: Send>(n: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("sahara-trace-tests");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

// ---------------------------------------------------------------------------------------------
// Camera.

#[test]
fn centre_pixel_points_at_target() {
    let cams = [
        camera(),
        Camera::new(
            Vec3A::new(10.0, -3.0, 2.0),
            Vec3A::new(-1.0, 2.0, 0.5),
            Vec3A::Z,
            35.0,
        ),
        Camera::new(
            Vec3A::ZERO,
            Vec3A::new(0.0, 0.0, -7.0),
            Vec3A::new(0.3, 1.0, 0.0),
            90.0,
        ),
    ];
    for cam in cams {
        for (w, h) in [(101, 75), (1, 1), (3, 9)] {
            let r = cam.primary_ray(w / 2, h / 2, w, h);
            let to_target = (cam.target - cam.eye).normalize();
            assert_eq!(r.origin, cam.eye);
            assert_eq!((r.tmin, r.tmax), (0.0, f32::INFINITY));
            assert!((r.direction().length() - 1.0).abs() < 1e-6);
            assert!(
                r.direction().dot(to_target) > 1.0 - 1e-6,
                "{cam:?} {w}x{h}: {:?} vs {to_target:?}",
                r.direction()
            );
        }
        // The image's up is the camera's up side: the top row looks more "up" than the bottom.
        let top = cam.primary_ray(50, 0, 101, 75).direction();
        let bottom = cam.primary_ray(50, 74, 101, 75).direction();
        assert!(top.dot(cam.up) > bottom.dot(cam.up));
    }
}

#[test]
fn primary_set_matches_primary_ray() {
    let cam = camera();
    let set = RaySet::primary(&cam, 7, 5);
    assert_eq!(
        (set.kind, set.width, set.height, set.len()),
        (RayKind::Primary, 7, 5, 35)
    );
    for (i, r) in set.rays.iter().enumerate() {
        assert_eq!(set.pixel[i], i as u32);
        assert_eq!(*r, cam.primary_ray(i as u32 % 7, i as u32 / 7, 7, 5));
    }
}

// ---------------------------------------------------------------------------------------------
// Ray sets.

#[test]
fn diffuse_rays_leave_the_surface_into_the_hemisphere_of_the_facing_normal() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    let primary = RaySet::primary(&camera(), W, H);
    let hits = trace_closest(&tracer, &primary.rays);
    let diag = scene_bounds(&tris).extent().length();
    for kind in [RayKind::Diffuse, RayKind::AmbientOcclusion] {
        let set = RaySet::spawn(&primary, &hits, kind, &tris, 11);
        assert_eq!(set.kind, kind);
        assert_eq!(set.len(), hit_count(&hits));
        assert!(
            set.len() > (W * H / 2) as usize,
            "scene should cover most pixels"
        );
        assert!(set.pixel.windows(2).all(|w| w[0] < w[1]));
        let back = trace_closest(&tracer, &set.rays);
        for (i, (ray, &px)) in set.rays.iter().zip(&set.pixel).enumerate() {
            let prim_ray = &primary.rays[px as usize];
            let hit = hits[px as usize];
            let tri = &tris[hit.prim as usize];
            let mut n = tri.normal();
            if n.dot(prim_ray.direction()) > 0.0 {
                n = -n;
            }
            assert!(ray.is_valid());
            assert!((ray.direction().length() - 1.0).abs() < 1e-5);
            assert!(ray.direction().dot(n) > 0.0, "ray {i} below its surface");
            // The origin is on the side the primary ray came from, just off the hit point.
            let p = tri.point(hit.u, hit.v);
            let off = (ray.origin - p).dot(n);
            assert!(off > 0.0 && off <= 1e-4 * p.abs().max_element().max(diag * 1e-3) * 1.001);
            assert_eq!(ray.tmin, 0.0);
            match kind {
                RayKind::AmbientOcclusion => {
                    assert!((ray.tmax - AO_DISTANCE_FRACTION * diag).abs() <= 1e-6 * diag)
                }
                _ => assert_eq!(ray.tmax, f32::INFINITY),
            }
            // Never re-hits the (planar) triangle it starts from.
            assert_ne!(back[i].prim, hit.prim, "ray {i} self-intersects");
        }
    }
}

#[test]
fn ray_sets_are_deterministic_across_thread_counts_and_seeded() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    for kind in RayKind::ALL {
        let one = with_threads(1, || {
            RaySet::generate(kind, &camera(), W, H, &tracer, &tris, 5)
        });
        let two = with_threads(2, || {
            RaySet::generate(kind, &camera(), W, H, &tracer, &tris, 5)
        });
        assert_eq!(one, two, "{kind}");
        // Bit-identical, not only equal as floats.
        assert_eq!(encode_rays(&one.rays), encode_rays(&two.rays));
        let other = RaySet::generate(kind, &camera(), W, H, &tracer, &tris, 6);
        if kind == RayKind::Primary {
            assert_eq!(one, other);
        } else {
            assert_eq!(one.pixel, other.pixel);
            assert_ne!(one.rays, other.rays, "{kind}: the seed must matter");
        }
    }
    // Diffuse and AO rays of one seed start at the same points but go different ways.
    let d = RaySet::diffuse(&camera(), W, H, &tracer, &tris, 5);
    let a = RaySet::ambient_occlusion(&camera(), W, H, &tracer, &tris, 5);
    assert_eq!(d.pixel, a.pixel);
    assert!(d
        .rays
        .iter()
        .zip(&a.rays)
        .all(|(x, y)| x.origin == y.origin));
    assert!(d
        .rays
        .iter()
        .zip(&a.rays)
        .any(|(x, y)| x.direction() != y.direction()));
    // Each ray depends only on (seed, pixel): a generator for any pixel reproduces it.
    let i = d.len() / 3;
    let mut rng = ray_rng(5, d.pixel[i], RayKind::Diffuse);
    let hit = trace_closest(
        &tracer,
        &[camera().primary_ray(d.pixel[i] % W, d.pixel[i] / W, W, H)],
    )[0];
    let prim_dir = camera()
        .primary_ray(d.pixel[i] % W, d.pixel[i] / W, W, H)
        .direction();
    let mut n = tris[hit.prim as usize].normal();
    if n.dot(prim_dir) > 0.0 {
        n = -n;
    }
    let (r1, r2) = (rng.next_f32(), rng.next_f32());
    assert_eq!(d.rays[i].direction(), cosine_hemisphere(n, r1, r2));
}

// ---------------------------------------------------------------------------------------------
// Batch tracing.

#[test]
fn batch_results_equal_one_by_one_tracing_on_any_thread_count() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    for kind in RayKind::ALL {
        let set = RaySet::generate(kind, &camera(), W, H, &tracer, &tris, 1);
        let single_closest: Vec<Hit> = set
            .rays
            .iter()
            .map(|r| tracer.closest_hit_fast(r))
            .collect();
        let single_any: Vec<bool> = set.rays.iter().map(|r| tracer.any_hit_fast(r)).collect();
        let mut single_work = Vec::new();
        for r in &set.rays {
            let mut c = WorkCounters::default();
            assert_eq!(tracer.closest_hit(r, &mut c), tracer.closest_hit_fast(r));
            single_work.push(c);
        }
        for threads in [1, 2] {
            with_threads(threads, || {
                assert_eq!(trace_closest(&tracer, &set.rays), single_closest);
                assert_eq!(trace_any(&tracer, &set.rays), single_any);
                let mut buf = vec![Hit::MISS; 3];
                trace_closest_into(&tracer, &set.rays, &mut buf);
                assert_eq!(buf, single_closest);
                let mut occ = vec![true; set.len() + 10];
                trace_any_into(&tracer, &set.rays, &mut occ);
                assert_eq!(occ, single_any);
                let c = trace_closest_counted(&tracer, &set.rays);
                assert_eq!(c.results, single_closest);
                assert_eq!(c.work, single_work);
                let mut total = WorkCounters::default();
                for w in &single_work {
                    total += *w;
                }
                assert_eq!(c.total, total);
                let a = trace_any_counted(&tracer, &set.rays);
                assert_eq!(a.results, single_any);
                assert_eq!(a.work.len(), set.len());
                // Tracing a set picks the query of its kind.
                let r = trace_set(&tracer, &set);
                let rc = trace_set_counted(&tracer, &set);
                assert_eq!(rc.results, r);
                if kind.uses_any_hit() {
                    assert_eq!(r, TraceResults::Any(single_any.clone()));
                    assert_eq!(r.checksum(), checksum_occlusion(&single_any));
                    assert_eq!(rc.total, a.total);
                } else {
                    assert_eq!(r, TraceResults::Closest(single_closest.clone()));
                    assert_eq!(r.checksum(), checksum(&single_closest));
                    assert_eq!(rc.total, c.total);
                }
            });
        }
    }
}

#[test]
fn bvh2_tracer_equals_brute_force_ray_by_ray() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    let brute_tracer = BruteTracer::new(&tris);
    for kind in RayKind::ALL {
        let set = RaySet::generate(kind, &camera(), W, H, &tracer, &tris, 42);
        // The set must be the same whichever correct tracer generated it.
        assert_eq!(
            set,
            RaySet::generate(kind, &camera(), W, H, &brute_tracer, &tris, 42),
            "{kind}"
        );
        let fast = trace_closest(&tracer, &set.rays);
        let counted = trace_closest_counted(&tracer, &set.rays);
        let any = trace_any(&tracer, &set.rays);
        let mut hits = 0;
        for (i, r) in set.rays.iter().enumerate() {
            let b = brute::closest_hit(&tris, r);
            assert_eq!(fast[i], b, "{kind} ray {i}: {r:?}");
            assert_eq!(counted.results[i], b, "{kind} ray {i}");
            assert_eq!(any[i], brute::any_hit(&tris, r), "{kind} ray {i}");
            hits += usize::from(b.is_hit());
        }
        assert_eq!(
            checksum(&fast),
            checksum(&trace_closest(&brute_tracer, &set.rays))
        );
        // Meaningful sets: rays hit, and the tree does less work than brute force.
        assert!(
            hits > set.len() / 20,
            "{kind}: only {hits} of {} rays hit",
            set.len()
        );
        assert!(
            hits < set.len() || kind == RayKind::Primary,
            "{kind}: every ray hit"
        );
        let per_ray = counted.per_ray();
        assert!(
            per_ray.triangles < tris.len() as f64 / 4.0,
            "{kind}: {per_ray:?}"
        );
        assert!(per_ray.inner > 1.0 && per_ray.leaves >= 1.0);
    }
}

#[test]
fn every_available_backend_gives_the_reference_checksums() {
    let (tris, bvh) = scene_and_bvh();
    let reference = Bvh2Tracer::new(&bvh, &tris);
    let mut tried = 0;
    for backend in Backend::ALL.into_iter().filter(|b| b.is_available()) {
        let t4 = WideTracer::<4>::with_backend(&bvh, &tris, backend).unwrap();
        let t8 = WideTracer::<8>::with_backend(&bvh, &tris, backend).unwrap();
        assert_eq!((t4.backend(), t8.backend()), (backend, backend));
        for kind in RayKind::ALL {
            let set = RaySet::generate(kind, &camera(), W, H, &reference, &tris, 5);
            let want = trace_set(&reference, &set);
            for t in [&t4 as &dyn Tracer, &t8] {
                let got = trace_set(t, &set);
                assert_eq!(
                    got.checksum(),
                    want.checksum(),
                    "{} with {backend}, {kind}",
                    t.name()
                );
                let counted = trace_set_counted(t, &set);
                assert_eq!(counted.results.checksum(), want.checksum());
            }
        }
        tried += 1;
    }
    // Portable and (on x86-64) SSE2 exist everywhere.
    let expected = if cfg!(target_arch = "x86_64") { 2 } else { 1 };
    assert!(tried >= expected, "{tried} backends");
    // The default tracer runs the best backend.
    assert_eq!(WideTracer::<8>::new(&bvh, &tris).backend(), Backend::best());
}

#[test]
fn backends_a_cpu_lacks_are_typed_errors() {
    // A CPU with SSE2 and AVX2 but no AVX-512 (simulated).
    let avx2_only = |b: Backend| b != Backend::Avx512;
    assert_eq!(parse_backend("avx2", avx2_only), Ok(Backend::Avx2));
    assert_eq!(parse_backend("AVX2", avx2_only), Ok(Backend::Avx2));
    assert_eq!(parse_backend("portable", avx2_only), Ok(Backend::Portable));
    let e = parse_backend("avx512", avx2_only).unwrap_err();
    assert_eq!(
        e,
        BackendError::Unavailable {
            wanted: Backend::Avx512,
            available: vec![Backend::Portable, Backend::Sse2, Backend::Avx2],
        }
    );
    let msg = e.to_string();
    assert!(msg.contains("avx512") && msg.contains("AVX-512F"), "{msg}");
    assert!(msg.contains("portable, sse2, avx2"), "{msg}");
    // A CPU with nothing but the portable kernels.
    let portable_only = |b: Backend| b == Backend::Portable;
    for name in ["sse2", "avx2", "avx512"] {
        assert!(matches!(
            parse_backend(name, portable_only),
            Err(BackendError::Unavailable { .. })
        ));
    }
    assert_eq!(
        parse_backend("neon", avx2_only),
        Err(BackendError::Unknown("neon".into()))
    );
    assert_eq!(require_backend(Backend::Sse2, avx2_only), Ok(Backend::Sse2));
    // On this CPU: every backend it lacks is refused by the tracer too.
    let (tris, bvh) = scene_and_bvh();
    for b in Backend::ALL {
        assert_eq!(
            WideTracer::<8>::with_backend(&bvh, &tris, b).is_ok(),
            b.is_available(),
            "{b}"
        );
    }
}

#[test]
fn checksums_and_counts() {
    let h = |t: f32, prim: u32| Hit {
        t,
        prim,
        u: 0.25,
        v: 0.5,
    };
    let a = [h(1.0, 3), Hit::MISS, h(2.5, 0)];
    assert_eq!(hit_count(&a), 2);
    assert_eq!(checksum(&a), checksum(&a.clone()));
    // Barycentrics are not part of the checksum; t, prim and order are.
    let mut b = a;
    b[0].u = 0.0;
    assert_eq!(checksum(&a), checksum(&b));
    b[0].t = f32::from_bits(1.0f32.to_bits() + 1);
    assert_ne!(checksum(&a), checksum(&b));
    assert_ne!(checksum(&a), checksum(&[a[2], a[1], a[0]]));
    assert_ne!(checksum(&[]), checksum(&[Hit::MISS]));
    assert_eq!(occluded_count(&[true, false, true]), 2);
    assert_ne!(
        checksum_occlusion(&[true, false]),
        checksum_occlusion(&[false, true])
    );
    // FNV-1a of nothing is the offset basis.
    assert_eq!(checksum(&[]), 0xcbf2_9ce4_8422_2325);
}

#[test]
fn invalid_rays_and_empty_scenes_miss() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    let bad = [
        Ray::new(Vec3A::ZERO, Vec3A::ZERO, 0.0, f32::INFINITY),
        Ray::new(Vec3A::splat(f32::NAN), Vec3A::Z, 0.0, f32::INFINITY),
        Ray::new(Vec3A::ZERO, Vec3A::Z, 1.0, 0.5),
    ];
    assert!(trace_closest(&tracer, &bad).iter().all(|h| *h == Hit::MISS));
    assert!(trace_any(&tracer, &bad).iter().all(|&o| !o));
    let empty = Bvh::empty();
    let none = Bvh2Tracer::new(&empty, &[]);
    let set = RaySet::diffuse(&camera(), 8, 8, &none, &[], 1);
    assert!(set.is_empty());
    assert_eq!(
        trace_set_counted(&none, &set).per_ray(),
        WorkPerRay::default()
    );
}

// ---------------------------------------------------------------------------------------------
// Files.

fn some_rays() -> Vec<Ray> {
    let mut rng = Pcg32::new(9, 9);
    (0..100)
        .map(|i| {
            let o = Vec3A::new(rng.range_f32(-5.0, 5.0), rng.range_f32(-5.0, 5.0), -0.0);
            let d = Vec3A::new(rng.range_f32(-1.0, 1.0), 0.0, rng.range_f32(-1.0, 1.0));
            let tmax = if i % 2 == 0 {
                f32::INFINITY
            } else {
                rng.range_f32(0.0, 9.0)
            };
            Ray::new(o, d, rng.next_f32(), tmax)
        })
        .collect()
}

#[test]
fn ray_and_hit_files_round_trip() {
    let rays = some_rays();
    let path = tmp("round_trip.rays");
    write_rays(&path, &rays).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 100 * 32);
    let back = read_rays(&path).unwrap();
    assert_eq!(back, rays);
    assert_eq!(encode_rays(&back), encode_rays(&rays));

    let (tris, bvh) = scene_and_bvh();
    let set = RaySet::primary(&camera(), 16, 12);
    let hits = trace_closest(&Bvh2Tracer::new(&bvh, &tris), &set.rays);
    assert!(hits.contains(&Hit::MISS) && hit_count(&hits) > 0);
    let path = tmp("round_trip.hits");
    write_hits(&path, &hits).unwrap();
    assert_eq!(
        std::fs::metadata(&path).unwrap().len(),
        hits.len() as u64 * 16
    );
    assert_eq!(read_hits(&path).unwrap(), hits);

    // Record layout: little-endian [ox, oy, oz, tmin, dx, dy, dz, tmax] and [t, prim, u, v].
    let r = Ray::new(
        Vec3A::new(1.0, 2.0, 3.0),
        Vec3A::new(5.0, 6.0, 7.0),
        4.0,
        8.0,
    );
    let bytes = encode_rays(&[r]);
    let floats: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(floats, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
    let hb = encode_hits(&[
        Hit::MISS,
        Hit {
            t: 1.5,
            prim: 7,
            u: 0.25,
            v: 0.5,
        },
    ]);
    assert_eq!(&hb[0..4], &f32::INFINITY.to_le_bytes());
    assert_eq!(&hb[4..8], &u32::MAX.to_le_bytes());
    assert_eq!(
        &hb[16..32],
        &[
            1.5f32.to_le_bytes(),
            7u32.to_le_bytes(),
            0.25f32.to_le_bytes(),
            0.5f32.to_le_bytes()
        ]
        .concat()
    );

    // Empty files are empty sets.
    let path = tmp("empty.rays");
    write_rays(&path, &[]).unwrap();
    assert!(read_rays(&path).unwrap().is_empty());
}

#[test]
fn truncated_and_missing_files_are_typed_errors_naming_the_file() {
    let full = encode_rays(&some_rays()[..3]);
    for cut in [1, 31, 33, 95] {
        let path = tmp(&format!("truncated_{cut}.rays"));
        std::fs::write(&path, &full[..cut]).unwrap();
        match read_rays(&path) {
            Err(e @ TraceError::BadLength { .. }) => {
                let msg = e.to_string();
                assert!(msg.contains(&format!("truncated_{cut}.rays")), "{msg}");
                assert!(
                    msg.contains(&cut.to_string()) && msg.contains("32"),
                    "{msg}"
                );
            }
            other => panic!("{cut}: {other:?}"),
        }
    }
    let hits = encode_hits(&[Hit::MISS; 3]);
    for cut in [1, 15, 17, 47] {
        let path = tmp(&format!("truncated_{cut}.hits"));
        std::fs::write(&path, &hits[..cut]).unwrap();
        let err = read_hits(&path).unwrap_err();
        assert!(
            matches!(err, TraceError::BadLength { record: 16, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains(&format!("truncated_{cut}.hits")));
    }
    // A ray file is not a hit file unless its length happens to fit.
    let path = tmp("odd.bin");
    std::fs::write(&path, [0u8; 48]).unwrap();
    assert!(read_rays(&path).is_err());
    assert_eq!(read_hits(&path).unwrap().len(), 3);

    let missing = tmp("does_not_exist.rays");
    let err = read_rays(&missing).unwrap_err();
    assert!(matches!(err, TraceError::Io { .. }));
    assert!(err.to_string().contains("does_not_exist.rays"));
    assert!(matches!(read_hits(&missing), Err(TraceError::Io { .. })));
    // A directory is unreadable as a file; writing into a missing folder fails too.
    let dir = tmp("");
    assert!(matches!(read_rays(&dir), Err(TraceError::Io { .. })));
    let nowhere = tmp("no/such/dir/x.hits");
    let err = write_hits(&nowhere, &[Hit::MISS]).unwrap_err();
    assert!(err.to_string().contains("x.hits"));
}

mod files_prop {
    use super::*;
    use proptest::prelude::*;

    fn finite() -> impl Strategy<Value = f32> {
        -1e6f32..1e6
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn encode_decode_round_trip(raw in proptest::collection::vec(proptest::array::uniform8(finite()), 0..20)) {
            let rays: Vec<Ray> = raw
                .iter()
                .map(|a| Ray::new(Vec3A::new(a[0], a[1], a[2]), Vec3A::new(a[4], a[5], a[6]), a[3], a[7]))
                .collect();
            prop_assert_eq!(decode_rays(&encode_rays(&rays)).unwrap(), rays);
            let hits: Vec<Hit> = raw
                .iter()
                .map(|a| Hit { t: a[0], prim: a[1].to_bits(), u: a[2], v: a[3] })
                .collect();
            prop_assert_eq!(decode_hits(&encode_hits(&hits)).unwrap(), hits);
        }

        #[test]
        fn decode_rejects_partial_records(len in 0usize..200) {
            let bytes = vec![0u8; len];
            prop_assert_eq!(decode_rays(&bytes).is_some(), len % 32 == 0);
            prop_assert_eq!(decode_hits(&bytes).is_some(), len % 16 == 0);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Images.

#[test]
fn shaded_render_and_heat_map_are_written_as_png() {
    let (tris, bvh) = scene_and_bvh();
    let tracer = Bvh2Tracer::new(&bvh, &tris);
    let set = RaySet::primary(&camera(), W, H);
    let counted = trace_closest_counted(&tracer, &set.rays);
    let img = shade(
        W,
        H,
        &set.pixel,
        &set.rays,
        &counted.results,
        &tris,
        Shading::PrimitiveColours,
    );
    assert_eq!(img.data.len(), (W * H * 3) as usize);
    for (i, h) in counted.results.iter().enumerate() {
        assert_eq!(img.get(i) == Some(MISS_COLOUR), !h.is_hit(), "pixel {i}");
    }
    let path = tmp("shaded.png");
    img.write_png(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");

    let heat = heat_map(W, H, &set.pixel, &counted.work, 99.0);
    let totals: Vec<u64> = counted.work.iter().map(work_total).collect();
    assert_eq!(heat.max, *totals.iter().max().unwrap());
    assert!(heat.scale_max >= 1.0 && heat.scale_max <= heat.max as f64);
    heat.image.write_png(tmp("heat.png")).unwrap();

    // Secondary sets cover only some pixels; the rest stay black.
    let ao = RaySet::ambient_occlusion(&camera(), W, H, &tracer, &tris, 3);
    let work = trace_set_counted(&tracer, &ao).work;
    let heat = heat_map(W, H, &ao.pixel, &work, 99.0);
    let missed = counted.results.iter().position(|h| !h.is_hit()).unwrap();
    assert_eq!(heat.image.get(missed), Some([0, 0, 0]));

    // Bad outputs are errors, not panics.
    assert!(matches!(
        RgbImage::new(0, 0).write_png(tmp("empty.png")),
        Err(TraceError::Image { .. }) | Ok(())
    ));
    let err = img.write_png(tmp("no/such/dir/x.png")).unwrap_err();
    assert!(err.to_string().contains("x.png"));
}
