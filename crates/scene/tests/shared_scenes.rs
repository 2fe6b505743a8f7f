//! The real scenes of `../shared/scenes`, when that folder exists (skipped otherwise).
//!
//! The heavy check of every scene (triangle counts, checksums, load times) is `#[ignore]`d:
//! `cargo xtask verify` runs it (or `cargo test --release -p sahara-scene --test shared_scenes
//! -- --ignored --nocapture`).

mod common;

use std::time::Instant;

use sahara_scene::{Catalog, EntryKind, Origin};

fn shared_catalog() -> Option<Catalog> {
    let Some(dir) = common::shared_scenes() else {
        eprintln!("note: ../shared/scenes not found, skipping the real-scene tests");
        return None;
    };
    let mut c = Catalog::procedural();
    c.add_dir(&dir, Origin::Shared);
    assert!(c.warnings().is_empty(), "{:?}", c.warnings());
    Some(c)
}

#[test]
fn utah_teapot_matches_manifest() {
    let Some(c) = shared_catalog() else { return };
    let entry = c.get("utah_teapot").expect("utah_teapot in the manifest");
    assert_eq!(entry.origin, Origin::Shared);
    let s = c.load("utah_teapot").unwrap();
    assert_eq!(Some(s.triangle_count()), entry.triangles);
    assert_eq!(s.triangle_count(), 16_256);
    let st = s.mesh.stats();
    assert_eq!((st.zero_area, st.index_degenerate), (0, 0));
    // Loading by path gives the same mesh.
    let by_path = c.load(entry.path().unwrap().to_str().unwrap()).unwrap();
    assert_eq!(by_path.mesh, s.mesh);
    assert!(c.verify("utah_teapot").unwrap());
}

#[test]
fn glb_matches_its_obj() {
    let Some(c) = shared_catalog() else { return };
    let glb = c.load("gltf_2cylinder_engine_glb").unwrap();
    assert!(matches!(
        c.get("gltf_2cylinder_engine_glb").unwrap().kind,
        EntryKind::File {
            format: sahara_scene::Format::Glb,
            ..
        }
    ));
    let obj = c.load("gltf_2cylinder_engine").unwrap();
    assert_eq!(glb.triangle_count(), 121_496);
    assert_eq!(obj.triangle_count(), 121_496);
    let (a, b) = (glb.bounds(), obj.bounds());
    let diag = b.extent().length();
    assert!(
        (a.min - b.min).abs().max_element() <= 1e-3 * diag,
        "{a:?} vs {b:?}"
    );
    assert!(
        (a.max - b.max).abs().max_element() <= 1e-3 * diag,
        "{a:?} vs {b:?}"
    );
    let (sa, sb) = (glb.mesh.stats(), obj.mesh.stats());
    assert_eq!(sa.index_degenerate, 11_154);
    assert_eq!(sb.index_degenerate, 11_154);
}

/// The named scenes of the shared folder get the cameras of `scenes/cameras.tsv`, bit for bit
/// the ones the evaluation always used.
#[test]
fn named_scenes_have_their_cameras() {
    let Some(c) = shared_catalog() else { return };
    for (name, old) in common::old_cameras() {
        let Some(e) = c.get(name) else { continue };
        let camera = e.camera.unwrap_or_else(|| panic!("{name}: no camera"));
        assert_eq!(
            common::camera_bits(&camera),
            common::camera_bits(&old),
            "{name}"
        );
    }
}

/// Loads every scene of the manifest, checks its triangle count and checksum, and prints
/// the load times and statistics.
#[test]
#[ignore = "heavy check: loads ~50 MB of scenes; run by `cargo xtask verify`"]
fn all_shared_scenes_load() {
    let Some(c) = shared_catalog() else { return };
    println!(
        "{:<28} {:>9} {:>9} {:>8} {:>8} {:>8} {:>9} {:>9}",
        "name", "triangles", "vertices", "zero", "idx-deg", "unused", "load ms", "sha ms"
    );
    for e in c.entries().iter().filter(|e| e.origin == Origin::Shared) {
        let t = Instant::now();
        let s = c
            .load_entry(e)
            .unwrap_or_else(|err| panic!("{}: {err}", e.name));
        let load_ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(Some(s.triangle_count()), e.triangles, "{}", e.name);
        let t = Instant::now();
        assert!(c.verify(&e.name).unwrap(), "{}", e.name);
        let sha_ms = t.elapsed().as_secs_f64() * 1e3;
        let st = s.mesh.stats();
        println!(
            "{:<28} {:>9} {:>9} {:>8} {:>8} {:>8} {:>9.1} {:>9.1}",
            e.name,
            st.triangles,
            st.vertices,
            st.zero_area,
            st.index_degenerate,
            st.unused_vertices,
            load_ms,
            sha_ms
        );
    }
}
