//! The cameras of the named scenes (the repository's `scenes/cameras.tsv`) and how a scene
//! folder's own `cameras.tsv` overrides them.

mod common;

use std::path::{Path, PathBuf};

use common::{camera_bits, old_cameras, temp_dir};
use sahara_scene::{
    default_camera, named_cameras, parse_cameras, workspace_root, Aabb, Camera, Catalog,
    CatalogWarning, Origin, UpAxis, Vec3A, EMBEDDED_CAMERAS,
};

/// A one-triangle OBJ file `name` in `dir`.
fn obj(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    p
}

fn find(cams: &[(String, Camera)], name: &str) -> Camera {
    cams.iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no camera for {name}"))
        .1
}

#[test]
fn embedded_table_gives_the_old_cameras() {
    let (cams, warnings) = parse_cameras(EMBEDDED_CAMERAS, Path::new("cameras.tsv"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let bounds = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
    for (name, old) in old_cameras() {
        assert_eq!(camera_bits(&find(&cams, name)), camera_bits(&old), "{name}");
        // The same through the public look-ups, whatever the bounds.
        assert_eq!(
            camera_bits(&default_camera(name, &bounds)),
            camera_bits(&old)
        );
    }
    let (named, warnings) = named_cameras();
    assert!(warnings.is_empty(), "{warnings:?}");
    for (name, old) in old_cameras() {
        assert_eq!(
            camera_bits(&find(&named, name)),
            camera_bits(&old),
            "{name}"
        );
    }
    // A scene without a row is framed, y up.
    assert_eq!(
        default_camera("utah_teapot", &bounds),
        Camera::framing(&bounds, UpAxis::Y)
    );
    // In the repository, `scenes/cameras.tsv` is a byte-identical copy of the crate's
    // canonical `cameras.tsv` (the embedded one): edit both together.
    let file = workspace_root().unwrap().join("scenes/cameras.tsv");
    assert_eq!(
        std::fs::read_to_string(file).unwrap(),
        EMBEDDED_CAMERAS,
        "scenes/cameras.tsv differs from crates/scene/cameras.tsv"
    );
}

#[test]
fn repository_folder_is_read_once_without_warnings() {
    let mut c = Catalog::default();
    c.add_dir(
        &workspace_root().unwrap().join("scenes"),
        Origin::Repository,
    );
    assert_eq!(c.dirs().len(), 1);
    assert!(c.warnings().is_empty(), "{:?}", c.warnings());
    // The folder holds no scene file.
    assert!(c.entries().is_empty(), "{:?}", c.names());
}

#[test]
fn named_cameras_apply_in_any_folder() {
    let dir = temp_dir("named-cameras");
    obj(&dir, "sponza_dabrovic.obj");
    obj(&dir, "utah_teapot.obj");
    let mut c = Catalog::procedural();
    c.add_dir(&dir, Origin::Dir);
    assert!(c.warnings().is_empty(), "{:?}", c.warnings());
    let (_, sponza) = old_cameras()[0];
    let e = c.get("sponza_dabrovic").unwrap();
    assert_eq!(camera_bits(&e.camera.unwrap()), camera_bits(&sponza));
    assert_eq!(
        camera_bits(&c.load("sponza_dabrovic").unwrap().camera),
        camera_bits(&sponza)
    );
    // Loading the file by path gives the camera of its name too.
    let by_path = dir.join("sponza_dabrovic.obj");
    let s = c.load(by_path.to_str().unwrap()).unwrap();
    assert_eq!(camera_bits(&s.camera), camera_bits(&sponza));
    // No row: framed when loaded.
    assert_eq!(c.get("utah_teapot").unwrap().camera, None);
    let t = c.load("utah_teapot").unwrap();
    assert_eq!(t.camera, Camera::framing(&t.bounds(), UpAxis::Y));
}

#[test]
fn own_folder_cameras_override_the_repository_ones() {
    let dir = temp_dir("own-cameras");
    obj(&dir, "sponza_dabrovic.obj");
    obj(&dir, "sibenik.obj");
    obj(&dir, "mine.obj");
    std::fs::write(
        dir.join("cameras.tsv"),
        "# my views\n\
         fov_y_degrees\tname\tup\teye\ttarget\n\
         30\tsponza_dabrovic\t0,1,0\t1,2,3\t4,5,6\n\
         90\tmine\t0,0,1\t0,-5,0\t0,0,0\n",
    )
    .unwrap();
    let mut c = Catalog::procedural();
    c.add_dir(&dir, Origin::Dir);
    assert!(c.warnings().is_empty(), "{:?}", c.warnings());
    let mine = Camera::new(
        Vec3A::new(1.0, 2.0, 3.0),
        Vec3A::new(4.0, 5.0, 6.0),
        Vec3A::Y,
        30.0,
    );
    assert_eq!(c.get("sponza_dabrovic").unwrap().camera, Some(mine));
    assert_eq!(c.load("sponza_dabrovic").unwrap().camera, mine);
    assert_eq!(c.load("mine").unwrap().camera.fov_y_degrees, 90.0);
    // A named scene without a row in the folder keeps the repository's camera.
    let (_, sibenik) = old_cameras()[1];
    let s = c.load("sibenik").unwrap();
    assert_eq!(camera_bits(&s.camera), camera_bits(&sibenik));
}

#[test]
fn malformed_rows_are_typed_warnings() {
    let dir = temp_dir("bad-cameras");
    obj(&dir, "sponza_dabrovic.obj");
    obj(&dir, "sibenik.obj");
    let file = dir.join("cameras.tsv");
    std::fs::write(
        &file,
        "name\teye\ttarget\tup\tfov_y_degrees\n\
         sponza_dabrovic\t1,2\t0,0,0\t0,1,0\t50\n\
         sibenik\t1,2,3\t0,0,0\t0,1,0\t180\n\
         \t1,2,3\t0,0,0\t0,1,0\t50\n\
         sibenik\t1,2,3\t0,0,nan\t0,1,0\t50\n\
         sibenik\t1,2,3\t0,0,0\t0,1,0\t50\n\
         sibenik\t9,9,9\t0,0,0\t0,1,0\t50\n",
    )
    .unwrap();
    let mut c = Catalog::procedural();
    c.add_dir(&dir, Origin::Dir);
    let file = file.canonicalize().unwrap();
    let row = |line, column: &'static str, value: &str| CatalogWarning::MalformedRow {
        file: file.clone(),
        line,
        column,
        value: value.to_string(),
    };
    assert_eq!(
        c.warnings(),
        [
            row(2, "eye", "1,2"),
            row(3, "fov_y_degrees", "180"),
            row(4, "name", ""),
            row(5, "target", "0,0,nan"),
            CatalogWarning::DuplicateCamera {
                file: file.clone(),
                line: 7,
                name: "sibenik".to_string()
            },
        ]
    );
    assert_eq!(
        c.warnings()[0].to_string(),
        format!(
            "{}: line 2: invalid or missing `eye`: `1,2`",
            file.display()
        )
    );
    // The malformed row is skipped: sponza keeps the repository's camera; the first valid
    // row of sibenik is used.
    let (_, sponza) = old_cameras()[0];
    let e = c.get("sponza_dabrovic").unwrap().camera.unwrap();
    assert_eq!(camera_bits(&e), camera_bits(&sponza));
    let s = c.get("sibenik").unwrap().camera.unwrap();
    assert_eq!(s.eye, Vec3A::new(1.0, 2.0, 3.0));

    // A header without the required columns: the whole file is ignored, with one warning.
    let (cams, w) = parse_cameras("name\teye\n a\t1,2,3\n", Path::new("c.tsv"));
    assert!(cams.is_empty());
    assert!(matches!(
        w.as_slice(),
        [CatalogWarning::MissingColumns { required, .. }] if required.len() == 5
    ));
}
