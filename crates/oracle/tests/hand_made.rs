//! Hand-made cases with known exact answers, and the regression set from the
//! project's bug report.

use sahara_oracle::*;

type Tri = [[f32; 3]; 3];

const UNIT: Tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

fn down(origin: [f32; 3]) -> OracleRay {
    OracleRay {
        origin,
        dir: [0.0, 0.0, -1.0],
        tmin: 0.0,
        tmax: f32::INFINITY,
    }
}

fn at_z(t: Tri, z: f32) -> Tri {
    t.map(|v| [v[0], v[1], z])
}

#[test]
fn through_the_middle() {
    let o = Oracle::new(&[UNIT]);
    let ray = down([0.25, 0.25, 1.0]);
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.t, 1.0);
    assert_eq!(h.min_bary, 0.25);
    assert!(h.in_range && h.is_strict());
    let v = judge_closest_detailed(&o, &ray, Some((0, 1.0)));
    assert_eq!(v.class, Class::Agree);
    assert_eq!(v.t_rel_error, Some(0.0));
    let v = judge_closest_detailed(&o, &ray, Some((0, 1.5)));
    assert_eq!(v.class, Class::Agree);
    assert_eq!(v.t_rel_error, Some(0.5));
    assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
    assert_eq!(judge_any(&o, &ray, true), Class::Agree);
    assert_eq!(judge_any(&o, &ray, false), Class::Missed);
    assert_eq!(o.nearest(&ray).unwrap().prim, 0);
    assert!(o.occluded(&ray));
    // unnormalised direction: t scales
    let mut r2 = ray;
    r2.dir = [0.0, 0.0, -4.0];
    assert_eq!(o.exact(0, &r2).unwrap().t, 0.25);
}

#[test]
fn a_miss() {
    let o = Oracle::new(&[UNIT]);
    let ray = down([2.0, 2.0, 1.0]);
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.min_bary, -3.0);
    assert!(!h.is_strict());
    assert!(o.candidates(&ray, EDGE_BAND, Mode::Any).is_empty());
    // a huge band admits it
    assert_eq!(o.candidates(&ray, 3.0, Mode::Any).len(), 1);
    assert_eq!(judge_closest(&o, &ray, None), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::FalseHit);
    assert_eq!(judge_closest(&o, &ray, Some((7, 1.0))), Class::FalseHit);
    assert_eq!(judge_any(&o, &ray, true), Class::FalseHit);
    assert_eq!(judge_any(&o, &ray, false), Class::Agree);
    // behind the origin: not a candidate
    let behind = down([0.25, 0.25, -1.0]);
    assert_eq!(o.exact(0, &behind).unwrap().t, -1.0);
    assert_eq!(judge_closest(&o, &behind, Some((0, -1.0))), Class::FalseHit);
    assert_eq!(judge_closest(&o, &behind, None), Class::Agree);
}

#[test]
fn exactly_on_an_edge() {
    let o = Oracle::new(&[UNIT]);
    // x + y = 1 is the edge v1-v2: alpha == 0 exactly
    let ray = down([0.5, 0.5, 1.0]);
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.min_bary, 0.0);
    assert!(h.is_strict());
    assert_eq!(judge_closest(&o, &ray, None), Class::Edge);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Agree);
    assert_eq!(judge_any(&o, &ray, false), Class::Edge);
    assert_eq!(judge_any(&o, &ray, true), Class::Agree);
    // on a vertex
    let ray = down([0.0, 0.0, 1.0]);
    assert_eq!(o.exact(0, &ray).unwrap().min_bary, 0.0);
    assert_eq!(judge_closest(&o, &ray, None), Class::Edge);
    // just inside the band
    let ray = down([0.5, 0.5 + 2f32.powi(-15), 1.0]);
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.min_bary, -(2f64.powi(-15)));
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Edge);
    assert_eq!(judge_closest(&o, &ray, None), Class::Agree);
    assert_eq!(judge_any(&o, &ray, true), Class::Edge);
    assert_eq!(judge_any(&o, &ray, false), Class::Agree);
    assert_eq!(o.candidates(&ray, EDGE_BAND, Mode::Closest).len(), 1);
    assert_eq!(o.candidates(&ray, 0.0, Mode::Closest).len(), 0);
    // outside the band
    let ray = down([0.5, 0.5 + 2f32.powi(-10), 1.0]);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::FalseHit);
    assert_eq!(judge_any(&o, &ray, true), Class::FalseHit);
    // just inside, edge-band but strict
    let ray = down([0.5, 0.5 - 2f32.powi(-15), 1.0]);
    assert_eq!(judge_closest(&o, &ray, None), Class::Edge);
    let ray = down([0.5, 0.5 - 2f32.powi(-10), 1.0]);
    assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
}

#[test]
fn shared_edge_exact_tie() {
    let other: Tri = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let o = Oracle::new(&[UNIT, other]);
    let ray = down([0.5, 0.5, 1.0]);
    let c = o.candidates(&ray, EDGE_BAND, Mode::Closest);
    assert_eq!(c.iter().map(|h| h.prim).collect::<Vec<_>>(), vec![0, 1]);
    assert_eq!(c[0].cmp_t(&c[1]), std::cmp::Ordering::Equal);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((1, 1.0))), Class::Unorderable);
}

#[test]
fn coplanar_stacked() {
    let big: Tri = [[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]];
    let o = Oracle::new(&[UNIT, big]);
    let ray = down([0.25, 0.25, 1.0]);
    let c = o.candidates(&ray, EDGE_BAND, Mode::Closest);
    assert_eq!(c.len(), 2);
    assert!(c.iter().all(ExactHit::is_strict));
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((1, 1.0))), Class::Unorderable);

    // stacked 2 f32 ulps apart (at t = 1): not orderable
    let o = Oracle::new(&[at_z(UNIT, 0.0), at_z(UNIT, 2f32.powi(-22))]);
    assert_eq!(judge_closest(&o, &ray, Some((1, 1.0))), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Unorderable);
    // 8 ulps apart: orderable, the farther one is wrong
    let o = Oracle::new(&[at_z(UNIT, 0.0), at_z(UNIT, 2f32.powi(-20))]);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Farther);
    // far apart
    let o = Oracle::new(&[at_z(UNIT, 0.0), at_z(UNIT, 0.01)]);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Farther);
    assert_eq!(judge_closest(&o, &ray, Some((1, 0.99))), Class::Agree);
    // Closest keeps only up to the nearest + slack, Any keeps both
    assert_eq!(o.candidates(&ray, EDGE_BAND, Mode::Closest).len(), 1);
    assert_eq!(o.candidates(&ray, EDGE_BAND, Mode::Any).len(), 2);
    // farther one reported while the nearest is an edge hit
    let near_edge = down([0.5, 0.5, 1.0]);
    let big_far = at_z(big, -1.0);
    let o = Oracle::new(&[UNIT, big_far]);
    assert_eq!(judge_closest(&o, &near_edge, Some((1, 2.0))), Class::Edge);
}

#[test]
fn t_at_the_range_ends() {
    let o = Oracle::new(&[UNIT]);
    let mut ray = down([0.25, 0.25, 1.0]);
    ray.tmax = 1.0;
    let h = o.exact(0, &ray).unwrap();
    assert!(h.in_range && h.is_strict());
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, None), Class::Unorderable);
    assert_eq!(judge_any(&o, &ray, false), Class::Unorderable);
    assert_eq!(judge_any(&o, &ray, true), Class::Agree);

    // tmax one f32 step below the exact t: outside but within slack
    ray.tmax = 1.0f32.next_down();
    let h = o.exact(0, &ray).unwrap();
    assert!(!h.in_range);
    assert_eq!(judge_closest(&o, &ray, None), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Unorderable);
    assert_eq!(judge_any(&o, &ray, true), Class::Unorderable);
    assert_eq!(judge_any(&o, &ray, false), Class::Agree);

    // far below: a false hit
    ray.tmax = 0.5;
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::FalseHit);
    assert_eq!(judge_any(&o, &ray, true), Class::FalseHit);

    // tmin exactly at t
    let mut ray = down([0.25, 0.25, 1.0]);
    ray.tmin = 1.0;
    assert!(o.exact(0, &ray).unwrap().in_range);
    assert_eq!(judge_closest(&o, &ray, None), Class::Unorderable);
    ray.tmin = 1.0f32.next_up();
    assert!(!o.exact(0, &ray).unwrap().in_range);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.0))), Class::Unorderable);

    // negative tmin: a hit behind the origin counts
    let mut ray = down([0.25, 0.25, -1.0]);
    ray.tmin = -10.0;
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.t, -1.0);
    assert!(h.is_strict());
    assert_eq!(judge_closest(&o, &ray, Some((0, -1.0))), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
    ray.tmin = f32::NEG_INFINITY;
    assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
    // tmin > tmax: nothing
    ray.tmin = 5.0;
    ray.tmax = 1.0;
    assert!(o.candidates(&ray, EDGE_BAND, Mode::Any).is_empty());
}

#[test]
fn det_zero_ray_in_the_plane() {
    let o = Oracle::new(&[UNIT]);
    let ray = OracleRay {
        origin: [-1.0, 0.25, 0.0],
        dir: [1.0, 0.0, 0.0],
        tmin: 0.0,
        tmax: f32::INFINITY,
    };
    assert!(o.exact(0, &ray).is_none());
    assert!(o.candidates(&ray, 1.0, Mode::Any).is_empty());
    assert_eq!(judge_closest(&o, &ray, None), Class::Agree);
    assert_eq!(judge_closest(&o, &ray, Some((0, 1.25))), Class::Edge);
    assert_eq!(judge_any(&o, &ray, false), Class::Agree);
    // in the plane through a vertex only
    let mut r1 = ray;
    r1.origin = [-1.0, 1.0, 0.0];
    assert_eq!(judge_closest(&o, &r1, Some((0, 1.0))), Class::Edge);
    // in the plane but missing the triangle
    r1.origin = [-1.0, 5.0, 0.0];
    assert!(o.exact(0, &r1).is_none());
    assert_eq!(judge_closest(&o, &r1, Some((0, 1.0))), Class::FalseHit);
    // parallel above the plane
    let mut r2 = ray;
    r2.origin[2] = 1.0;
    assert!(o.exact(0, &r2).is_none());
    assert_eq!(judge_closest(&o, &r2, Some((0, 1.25))), Class::FalseHit);
    // a zero-area triangle with the ray through it
    let flat: Tri = [[-1.0, 0.25, 0.0], [0.0, 0.25, 0.0], [1.0, 0.25, 0.0]];
    let of = Oracle::new(&[flat]);
    assert_eq!(judge_closest(&of, &ray, Some((0, 1.0))), Class::FalseHit);
    // zero direction
    let r3 = OracleRay {
        dir: [0.0; 3],
        ..down([0.25, 0.25, 1.0])
    };
    assert!(o.exact(0, &r3).is_none());
    assert!(o.candidates(&r3, 1.0, Mode::Any).is_empty());
}

#[test]
fn degenerate_and_non_finite_inputs() {
    let flat: Tri = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]];
    let nan: Tri = [[f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let inf: Tri = [[0.0, 0.0, 0.0], [f32::INFINITY, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let o = Oracle::new(&[flat, nan, inf, UNIT]);
    let ray = down([0.25, 0.25, 1.0]);
    for p in 0..3 {
        assert!(o.exact(p, &ray).is_none(), "{p}");
    }
    assert_eq!(judge_closest(&o, &ray, Some((1, 1.0))), Class::FalseHit);
    assert_eq!(o.nearest(&ray).unwrap().prim, 3);
    let bad = [
        OracleRay {
            origin: [f32::NAN, 0.25, 1.0],
            ..ray
        },
        OracleRay {
            dir: [0.0, f32::INFINITY, -1.0],
            ..ray
        },
        OracleRay {
            tmax: f32::NAN,
            ..ray
        },
        OracleRay {
            tmin: f32::NAN,
            ..ray
        },
    ];
    for r in &bad {
        assert!(o.exact(3, r).is_none());
        assert!(o.candidates(r, EDGE_BAND, Mode::Any).is_empty());
        assert_eq!(judge_closest(&o, r, None), Class::Agree);
        assert_eq!(judge_closest(&o, r, Some((3, 1.0))), Class::FalseHit);
        assert_eq!(judge_any(&o, r, false), Class::Agree);
        assert_eq!(judge_any(&o, r, true), Class::FalseHit);
    }
    let empty = Oracle::new(&[]);
    assert!(empty.is_empty());
    assert!(empty.candidates(&ray, EDGE_BAND, Mode::Closest).is_empty());
    assert_eq!(judge_closest(&empty, &ray, None), Class::Agree);
}

#[test]
fn extreme_magnitudes() {
    // Subnormal and near-max coordinates go through the BigInt path.
    let tiny = 1e-40f32;
    let t: Tri = [[0.0, 0.0, 0.0], [tiny, 0.0, 0.0], [0.0, tiny, 0.0]];
    let o = Oracle::new(&[t]);
    let ray = OracleRay {
        origin: [tiny / 4.0, tiny / 4.0, 1.0],
        dir: [0.0, 0.0, -1.0],
        tmin: 0.0,
        tmax: f32::INFINITY,
    };
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.t, 1.0);
    assert!(h.is_strict());
    assert_eq!(o.nearest(&ray).unwrap().prim, 0);
    // huge t: direction a subnormal
    let ray = OracleRay {
        origin: [0.25, 0.25, 1e30],
        dir: [0.0, 0.0, -1e-40],
        tmin: 0.0,
        tmax: f32::INFINITY,
    };
    let o = Oracle::new(&[UNIT]);
    let h = o.exact(0, &ray).unwrap();
    let want = 1e30f32 as f64 / (-1e-40f32 as f64).abs();
    assert!((h.t - want).abs() <= want * 1e-15, "{} vs {want}", h.t);
    assert_eq!(o.nearest(&ray).unwrap().prim, 0);
    assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
    // near f32::MAX
    let m = f32::MAX / 4.0;
    let big: Tri = [[-m, -m, 0.0], [m, -m, 0.0], [-m, m, 0.0]];
    let o = Oracle::new(&[big]);
    let ray = down([-m / 2.0, -m / 2.0, m]);
    let h = o.exact(0, &ray).unwrap();
    assert_eq!(h.t, m as f64);
    assert_eq!(h.min_bary, 0.25);
    assert_eq!(o.nearest(&ray).unwrap().prim, 0);
}

fn regression_scene() -> Vec<Tri> {
    let v = [
        [1291.0f32, 498.0, 608.0],
        [960.0, 512.0, 608.0],
        [896.0, 512.0, 608.0],
        [1291.0, 498.0, 608.0],
        [704.0, 512.0, 608.0],
        [704.0, 480.0, 608.0],
        [2556.0, 2552.0, 320.0],
        [-2656.0, 2552.0, 1536.0],
        [2556.0, 2552.0, 1536.0],
    ];
    vec![[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]]
}

#[test]
fn bug_report_regression_set() {
    let o = Oracle::new(&regression_scene());
    // [ox, oy, oz, tmin, dx, dy, dz, tmax] (f32 as written) -> (prim, t, min_bary);
    // min_bary from an independent Python `fractions` evaluation of the same
    // formulas on the same f32 values.
    let rays: [(&str, u32, f64, f64); 3] = [
        (
            "1088.7493896484375 503.7196960449219 607.4789428710938 0 0.9298886656761169 0.35529518127441406 0.09524916857481003 inf",
            0,
            5.4704638,
            0.24969966658668263,
        ),
        (
            "1088.7493896484375 498.3222961425781 607.4788818359375 0 0.770610511302948 0.3941495716571808 0.5008049011230469 inf",
            1,
            1.0405612,
            0.127254274133194,
        ),
        (
            "-267.11016845703125 2551.98681640625 1535.2506103515625 0 -0.7435404062271118 0.22877588868141174 -0.6283384561538696 749.4059448242188",
            2,
            0.057626675,
            0.0006460515660727651,
        ),
    ];
    for (line, prim, t, mb) in rays {
        let r: Vec<f32> = line.split(' ').map(|x| x.parse().unwrap()).collect();
        let ray = OracleRay {
            origin: [r[0], r[1], r[2]],
            tmin: r[3],
            dir: [r[4], r[5], r[6]],
            tmax: r[7],
        };
        let h = o.exact(prim, &ray).unwrap();
        assert!(h.is_strict(), "{prim}: {h:?}");
        assert!(
            h.min_bary > 5.0 * EDGE_BAND,
            "{prim}: min_bary {}",
            h.min_bary
        );
        assert!(
            (h.min_bary - mb).abs() <= 1e-12 * mb,
            "{prim}: min_bary {}",
            h.min_bary
        );
        assert!((h.t - t).abs() <= 1e-6 * t, "{prim}: t {} vs {t}", h.t);
        let n = o.nearest(&ray).unwrap();
        assert_eq!(n.prim, prim);
        assert_eq!(judge_closest(&o, &ray, None), Class::Missed);
        assert_eq!(
            judge_closest(&o, &ray, Some((prim, t as f32))),
            Class::Agree
        );
        assert_eq!(judge_any(&o, &ray, false), Class::Missed);
        assert_eq!(judge_any(&o, &ray, true), Class::Agree);
        let v = judge_closest_detailed(&o, &ray, Some((prim, h.t as f32)));
        assert!(v.t_rel_error.unwrap() < 1e-7);
    }
}
