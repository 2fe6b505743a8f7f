//! The checks of the fuzz targets (`fuzz/fuzz_targets/*.rs`), shared with the deterministic
//! corpus replay of the test suite (`tests/files.rs`).
//!
//! Each `check_*` takes arbitrary bytes and returns `Err(description)` when the code under
//! test broke one of its promises: a panic, a loader result that is not a valid mesh, an error
//! that does not name the file, a tree that validates but traces differently from brute
//! force. A typed error for malformed input is the expected answer and returns `Ok`.

use std::path::Path;

use sahara_builders::{registry, BuildError, BuildInput, CostModel};
use sahara_bvh::Bvh;
use sahara_geom::{Ray, Triangle, Vec3A};
use sahara_scene::{parse_gltf, parse_obj, Mesh, SceneError};
use sahara_traverse::WideBvh;

use crate::catch_quiet;

/// The file name loaders see in the checks (errors must name it).
pub const FUZZ_OBJ_NAME: &str = "fuzz-input.obj";
/// See [`FUZZ_OBJ_NAME`].
pub const FUZZ_GLTF_NAME: &str = "fuzz-input.glb";

fn check_loaded(
    result: Result<Result<Mesh, SceneError>, String>,
    name: &str,
) -> Result<(), String> {
    match result {
        Err(panic) => Err(format!("loader panicked: {panic}")),
        Ok(Ok(mesh)) => {
            mesh.validate(Path::new(name))
                .map_err(|e| format!("loader returned an invalid mesh: {e}"))?;
            let tris = mesh.triangles();
            if tris.iter().any(|t| !t.is_finite()) {
                return Err("loader returned a non-finite triangle".to_string());
            }
            Ok(())
        }
        Ok(Err(e)) => {
            let msg = e.to_string();
            if !msg.contains(name) {
                return Err(format!("error does not name the file: {msg}"));
            }
            Ok(())
        }
    }
}

/// OBJ loader ([`parse_obj`]): a valid mesh or a [`SceneError`] naming the file; never a
/// panic.
pub fn check_obj(data: &[u8]) -> Result<(), String> {
    check_loaded(
        catch_quiet(|| parse_obj(data, Path::new(FUZZ_OBJ_NAME))),
        FUZZ_OBJ_NAME,
    )
}

/// glTF/GLB loader ([`parse_gltf`], embedded buffers only): a valid mesh or a [`SceneError`]
/// naming the file; never a panic.
pub fn check_gltf(data: &[u8]) -> Result<(), String> {
    check_loaded(
        catch_quiet(|| parse_gltf(data, Path::new(FUZZ_GLTF_NAME), None)),
        FUZZ_GLTF_NAME,
    )
}

/// The triangles the BVH-file checks validate loaded trees against (and that the seed BVH
/// files are built over): 24 triangles of a small closed box and a few loose ones.
pub fn fixture_triangles() -> Vec<Triangle> {
    let mut tris = sahara_scene::closed_box(Vec3A::splat(-1.0), Vec3A::splat(1.0), 1).triangles();
    for i in 0..12 {
        let o = Vec3A::new(
            i as f32 * 0.5 - 3.0,
            2.0 + (i % 3) as f32,
            (i % 5) as f32 - 2.0,
        );
        tris.push(Triangle::new(
            o,
            o + Vec3A::X,
            o + Vec3A::new(0.0, 0.5, 0.5),
        ));
    }
    tris
}

/// Rays through the fixture (and some that miss), for the traversal checks.
pub fn fixture_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    for i in 0..48 {
        let a = i as f32 * 0.37;
        let d = Vec3A::new(a.cos(), (a * 1.7).sin(), (a * 0.3).cos() - 0.5);
        rays.push(Ray::new(Vec3A::new(0.1, 0.2, 0.3), d, 0.0, f32::INFINITY));
        rays.push(Ray::new(
            Vec3A::new(-6.0, a - 4.0, 0.0),
            Vec3A::new(1.0, 0.1, 0.05 * a),
            0.0,
            f32::INFINITY,
        ));
    }
    rays
}

/// The [`crate::KNOWN_BUGS`] entry that explains why a kernel may answer `ray` differently
/// from brute force, if any: brute force (the watertight test) hits a triangle with zero area,
/// hits a point outside the triangle's bounds (`false-hit`: degenerate triangles, or
/// coordinates whose products overflow `f32`), hits at `t = +inf` (`inf-t`), or hits within
/// a relative 1e-6 of `tmin` or `tmax` or at `t = 0`, or rays with a subnormal reciprocal
/// direction component (`slab-rounding`).
///
/// Only entries still listed in [`crate::KNOWN_BUGS`] explain anything: once a bug is fixed
/// and its entry removed, such rays are compared like all others.
pub fn explained_by_known_bug(tris: &[Triangle], ray: &Ray) -> Option<&'static str> {
    let id = suspect_class(tris, ray)?;
    crate::KNOWN_BUGS.iter().any(|b| b.id == id).then_some(id)
}

/// The class of numerical trouble `ray` runs into on `tris`, if any (see
/// [`explained_by_known_bug`]).
fn suspect_class(tris: &[Triangle], ray: &Ray) -> Option<&'static str> {
    if !ray.is_valid() {
        return None;
    }
    let w = ray.watertight();
    for tri in tris {
        let Some(h) = sahara_geom::intersect::intersect_triangle(&w, tri, ray.tmin, ray.tmax)
        else {
            continue;
        };
        if !h.t.is_finite() {
            return Some("inf-t");
        }
        if tri.area() == 0.0 || !tri.area().is_finite() {
            return Some("false-hit");
        }
        let p = ray.origin.as_dvec3() + ray.direction().as_dvec3() * f64::from(h.t);
        let b = tri.bounds();
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        // Per axis: a relative 1e-4 of the box's extent and of the point's magnitude.
        let tol = ((hi - lo) + p.abs()) * 1e-4 + 1e-30;
        if !p.is_finite()
            || (p - lo + tol).min_element() < 0.0
            || (hi - p + tol).min_element() < 0.0
        {
            return Some("false-hit");
        }
        let t = f64::from(h.t);
        let near_end = |end: f32| (t - f64::from(end)).abs() <= 1e-6 * f64::from(end).abs();
        let subnormal = ray
            .inv_direction()
            .to_array()
            .iter()
            .any(|x| *x != 0.0 && x.abs() < f32::MIN_POSITIVE);
        if near_end(ray.tmax) || near_end(ray.tmin) || t.abs() <= 1e-30 || subnormal {
            return Some("slab-rounding");
        }
    }
    None
}

/// Kernels of the traversal checks: the scalar reference and every wide kernel available, at
/// both precisions ([`crate::expand::kernels_equal_brute`]). With `tolerate_known_bugs`, rays
/// [`explained_by_known_bug`] are not compared.
fn traces_like_brute(
    bvh: &Bvh,
    tris: &[Triangle],
    rays: &[Ray],
    tolerate_known_bugs: bool,
) -> Result<(), String> {
    let mut w4 = WideBvh::<4>::from_bvh(bvh, tris);
    let mut w8 = WideBvh::<8>::from_bvh(bvh, tris);
    crate::expand::kernels_equal_brute(Some(bvh), &mut w4, &mut w8, tris, rays, tolerate_known_bugs)
}

/// BVH file loader ([`Bvh::load`]): a typed [`sahara_bvh::LoadError`] or a tree that passes
/// `validate_structure`; never a panic. A loaded tree that also validates against
/// [`fixture_triangles`] (and has no spatial splits, whose leaves need not cover whole
/// triangles) must trace exactly like brute force with every kernel.
pub fn check_bvh_file(data: &[u8]) -> Result<(), String> {
    check_loaded_bvh(data, &fixture_triangles(), &fixture_rays())
}

/// [`check_bvh_file`] with the triangles and rays a loaded tree is checked against.
pub(crate) fn check_loaded_bvh(data: &[u8], tris: &[Triangle], rays: &[Ray]) -> Result<(), String> {
    let loaded = catch_quiet(|| Bvh::load(&mut &data[..]))
        .map_err(|p| format!("Bvh::load panicked: {p}"))?;
    let Ok(bvh) = loaded else {
        return Ok(());
    };
    catch_quiet(|| bvh.validate_structure())
        .map_err(|p| format!("validate_structure panicked: {p}"))?
        .map_err(|e| format!("a loaded tree fails validate_structure: {e}"))?;
    let valid =
        catch_quiet(|| bvh.validate(tris)).map_err(|p| format!("validate panicked: {p}"))?;
    let _ = catch_quiet(|| sahara_metrics::sah(&bvh, &CostModel::default()))
        .map_err(|p| format!("sah panicked: {p}"))?;
    if valid.is_ok() && !bvh.spatial_splits {
        catch_quiet(|| traces_like_brute(&bvh, tris, rays, false))
            .map_err(|p| format!("traversal of a valid loaded tree panicked: {p}"))??;
    }
    Ok(())
}

/// Reads little-endian `f32`s from bytes (missing bytes are zero).
fn floats(data: &[u8]) -> Vec<f32> {
    data.chunks(4)
        .map(|c| {
            let mut b = [0u8; 4];
            b[..c.len()].copy_from_slice(c);
            f32::from_le_bytes(b)
        })
        .collect()
}

/// Bytes as a scene and rays: byte 0 gives the number of triangles (0 to 15), then 9 `f32`s
/// per triangle and 8 per ray (origin, direction, tmin, tmax). Checks that
/// [`BuildInput::new`] rejects exactly the non-finite inputs (naming the first bad triangle),
/// that every registered builder gives a valid tree with a finite SAH cost, and that every
/// kernel traces every ray exactly like brute force.
pub fn check_scene_bytes(data: &[u8]) -> Result<(), String> {
    check_scene_bytes_with(data, true)
}

/// True when a bounds extent exceeds what `Aabb::half_area` can square in `f32` (scenes where
/// the since-fixed `sah-overflow` made the SAH cost NaN; builders still rate splits in f32).
pub(crate) fn extent_overflows(tris: &[Triangle]) -> bool {
    let mut b = sahara_geom::Aabb::EMPTY;
    for t in tris {
        b.grow_aabb(&t.bounds());
    }
    !(b.half_area().is_finite())
}

/// [`check_scene_bytes`], optionally reporting the failures that [`crate::KNOWN_BUGS`]
/// explain (`tolerate_known_bugs = false`).
pub fn check_scene_bytes_with(data: &[u8], tolerate_known_bugs: bool) -> Result<(), String> {
    let Some((&head, rest)) = data.split_first() else {
        return Ok(());
    };
    let n = (head % 16) as usize;
    let f = floats(rest);
    if f.len() < 9 * n {
        return Ok(());
    }
    let v = |i: usize| Vec3A::new(f[i], f[i + 1], f[i + 2]);
    let tris: Vec<Triangle> = (0..n)
        .map(|t| Triangle::new(v(9 * t), v(9 * t + 3), v(9 * t + 6)))
        .collect();
    let rays: Vec<Ray> = f[9 * n..]
        .chunks_exact(8)
        .take(64)
        .map(|r| {
            Ray::new(
                Vec3A::new(r[0], r[1], r[2]),
                Vec3A::new(r[3], r[4], r[5]),
                r[6],
                r[7],
            )
        })
        .collect();
    let first_bad = tris.iter().position(|t| !t.is_finite());
    let input = catch_quiet(|| BuildInput::new(&tris, CostModel::default()))
        .map_err(|p| format!("BuildInput::new panicked: {p}"))?;
    let input = match (input, first_bad) {
        (Err(BuildError::NonFinite { triangle }), Some(i)) if triangle == i => return Ok(()),
        (Err(e), _) => {
            return Err(format!(
                "BuildInput::new: unexpected {e:?} (first non-finite: {first_bad:?})"
            ))
        }
        (Ok(_), Some(i)) => {
            return Err(format!("BuildInput::new accepted non-finite triangle {i}"))
        }
        (Ok(input), None) => input,
    };
    for entry in registry::entries() {
        let built = catch_quiet(|| (entry.make)().build(&input))
            .map_err(|p| format!("{}: build panicked: {p}", entry.name))?;
        let bvh = match built {
            Ok(b) => b,
            Err(e) => return Err(format!("{}: build error on finite input: {e}", entry.name)),
        };
        catch_quiet(|| bvh.validate(&tris))
            .map_err(|p| format!("{}: validate panicked: {p}", entry.name))?
            .map_err(|e| format!("{}: invalid tree: {e}", entry.name))?;
        let cost = sahara_metrics::sah(&bvh, &CostModel::default());
        let explained = tolerate_known_bugs && extent_overflows(&tris);
        if !cost.is_finite() && !explained {
            return Err(format!("{}: SAH cost {cost}", entry.name));
        }
        catch_quiet(|| traces_like_brute(&bvh, &tris, &rays, tolerate_known_bugs))
            .map_err(|p| format!("{}: traversal panicked: {p}", entry.name))?
            .map_err(|e| format!("{}: {e}", entry.name))?;
    }
    Ok(())
}
