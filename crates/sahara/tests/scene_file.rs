//! Saving and loading a `Scene`: the round trip gives equal trees, layouts, triangles, masks
//! and answers at every level (after a refit too); every truncation, every bit flip and
//! consistent checksums over bad content are typed `LoadError`s, never a panic; scenes with
//! user primitives refuse to be saved.

use sahara::file::{SCENE_MAGIC, SCENE_VERSION};
use sahara::{
    Aabb, LoadError, Quality, Ray, Scene, SceneBuilder, SceneError, Triangle, Vec3A, ALL_MASK,
};
use sahara_fixtures::{rays::segments_in, soups::mixed_soup};
use sahara_geom::rng::Pcg32;

mod common;

use common::{reseal, scene_bits as bits};

fn scene(q: Quality) -> Scene {
    let mut b = SceneBuilder::new();
    let a = b.add_triangles(&mixed_soup(300, 3));
    b.add_triangles(&[]);
    let c = b.add_triangles(&mixed_soup(200, 6));
    b.set_mask(a, 0b01).unwrap();
    b.set_mask(c, 0b11).unwrap();
    b.build(q).unwrap()
}

fn saved(scene: &Scene) -> Vec<u8> {
    let mut file = Vec::new();
    scene.save(&mut file).unwrap();
    file
}

/// `layout`: the 8-wide layouts are compared too (a layout refitted in place is not the
/// collapse of the refitted tree that loading rebuilds, though both answer alike).
fn assert_same(a: &Scene, b: &Scene, layout: bool, what: &str) {
    assert_eq!(a.bvh(), b.bvh(), "{what}");
    assert!(
        !layout || a.wide() == b.wide(),
        "{what}: the layouts differ"
    );
    assert_eq!(
        (a.quality(), a.cost(), a.len()),
        (b.quality(), b.cost(), b.len())
    );
    assert_eq!(a.geometries().len(), b.geometries().len());
    for (x, y) in a.geometries().zip(b.geometries()) {
        assert_eq!(x.index(), y.index());
        assert_eq!(a.mask(x), b.mask(y), "{what}");
        assert_eq!(a.triangles(x), b.triangles(y), "{what}");
    }
    let mut rng = Pcg32::new(4, 4);
    let rays = segments_in(
        &Aabb::new(Vec3A::splat(-1.2), Vec3A::splat(1.2)),
        300,
        &mut rng,
    );
    for mask in [ALL_MASK, 0b01, 0b10] {
        let (x, y) = (a.closest_hits(&rays, mask), b.closest_hits(&rays, mask));
        assert_eq!(
            x.iter().map(|h| bits(*h)).collect::<Vec<_>>(),
            y.iter().map(|h| bits(*h)).collect::<Vec<_>>(),
            "{what}"
        );
        assert_eq!(a.any_hits(&rays, mask), b.any_hits(&rays, mask), "{what}");
    }
}

#[test]
fn scenes_round_trip_equal_at_every_level() {
    for q in Quality::ALL {
        let mut original = scene(q);
        let loaded = Scene::load(&mut saved(&original).as_slice()).unwrap();
        assert_same(&original, &loaded, true, &format!("{q}"));
        // The loaded scene is a scene of its own: same indices, new ids.
        let (old, new) = (original.geometry(0).unwrap(), loaded.geometry(0).unwrap());
        assert_ne!(old, new);
        assert_eq!(loaded.mask(old), None);
        // A refitted scene saves its moved triangles and refitted tree.
        let moved: Vec<Triangle> = original
            .triangles(old)
            .unwrap()
            .iter()
            .map(|t| Triangle::new(t.v[0] * 1.1, t.v[1] * 1.1, t.v[2] * 0.9))
            .collect();
        original.refit(old, &moved).unwrap();
        let loaded = Scene::load(&mut saved(&original).as_slice()).unwrap();
        assert_same(&original, &loaded, false, &format!("{q} refitted"));
        // The same bytes again, and a second round trip keeps the layout too.
        assert_eq!(saved(&loaded), saved(&original));
        let again = Scene::load(&mut saved(&loaded).as_slice()).unwrap();
        assert_same(&loaded, &again, true, &format!("{q} refitted, twice"));
    }
    // An empty scene.
    let empty = SceneBuilder::new().build(Quality::Fast).unwrap();
    assert!(Scene::load(&mut saved(&empty).as_slice())
        .unwrap()
        .is_empty());
}

#[test]
fn scenes_with_user_primitives_are_not_saved() {
    let mut b = SceneBuilder::new();
    b.add_triangles(&mixed_soup(10, 1));
    let ball = b.add_primitives(&[Aabb::new(Vec3A::ZERO, Vec3A::ONE)], |_: &Ray, _, _, _| {
        None
    });
    let scene = b.build(Quality::Medium).unwrap();
    let mut file = Vec::new();
    let err = scene.save(&mut file).unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::Unsupported);
    let inner = err.get_ref().and_then(|e| e.downcast_ref::<SceneError>());
    assert_eq!(inner, Some(&SceneError::UserPrimitives(ball)));
    assert!(file.is_empty(), "nothing is written");
}

#[test]
fn every_broken_scene_file_is_a_typed_error() {
    let file = saved(&scene(Quality::High));
    assert_eq!(&file[..8], &SCENE_MAGIC);
    assert_eq!(
        u32::from_le_bytes(file[8..12].try_into().unwrap()),
        SCENE_VERSION
    );
    let load = |bytes: &[u8]| Scene::load(&mut &bytes[..]);
    // Every truncation.
    for len in 0..file.len() {
        let e = load(&file[..len]).unwrap_err();
        assert!(
            matches!(e, LoadError::Truncated { .. } | LoadError::BadMagic),
            "length {len}: {e}"
        );
    }
    // Trailing bytes.
    let mut long = file.clone();
    long.extend_from_slice(&[0; 5]);
    assert!(matches!(load(&long), Err(LoadError::TrailingData(5))));
    // Every single-bit flip (a stride of bits through the payload, every bit of the header).
    let flips = (0..56 * 8).chain((56 * 8..file.len() * 8).step_by(37));
    for bit in flips {
        let mut broken = file.clone();
        broken[bit / 8] ^= 1 << (bit % 8);
        assert!(load(&broken).is_err(), "bit {bit} flipped still loads");
    }
    // Another magic and another version.
    let mut other = file.clone();
    other[..8].copy_from_slice(b"SAHARACC");
    assert!(matches!(load(&other), Err(LoadError::BadMagic)));
    let mut other = file.clone();
    other[8..12].copy_from_slice(&7u32.to_le_bytes());
    assert!(matches!(
        load(&other),
        Err(LoadError::UnsupportedVersion(7))
    ));
    // Consistent checksums over bad content.
    let forged = |edit: &dyn Fn(&mut Vec<u8>)| {
        let mut f = file.clone();
        edit(&mut f);
        reseal(&mut f, 48);
        load(&f).unwrap_err()
    };
    assert!(matches!(
        forged(&|f| f[12] = 9),
        LoadError::UnknownQuality(9)
    ));
    assert!(matches!(
        forged(&|f| f[16..20].copy_from_slice(&f32::NAN.to_le_bytes())),
        LoadError::InvalidCostModel
    ));
    // Geometry counts that do not add up to the triangles (3 geometries: 300, 0, 200).
    assert!(matches!(
        forged(&|f| f[56 + 12..56 + 16].copy_from_slice(&1u32.to_le_bytes())),
        LoadError::InvalidScene(_)
    ));
    // A NaN vertex in triangle 2.
    let tri = 56 + 3 * 8 + 2 * 36;
    assert!(matches!(
        forged(&|f| f[tri + 4..tri + 8].copy_from_slice(&f32::NAN.to_le_bytes())),
        LoadError::NonFinite(2)
    ));
    // A moved vertex: the tree no longer fits the triangles.
    assert!(matches!(
        forged(&|f| f[tri..tri + 4].copy_from_slice(&50.0f32.to_le_bytes())),
        LoadError::InvalidTree(_)
    ));
    // Huge announced sizes allocate nothing and fail.
    assert!(matches!(
        forged(&|f| f[32..40].copy_from_slice(&u64::MAX.to_le_bytes())),
        LoadError::Truncated { .. }
    ));
    // The embedded tree broken.
    let tree = 56 + 3 * 8 + 500 * 36;
    assert!(matches!(forged(&|f| f[tree] ^= 0xff), LoadError::Tree(_)));
}
