use sahara_bvh::{Bvh, LoadError, Node, ValidationError};
use sahara_geom::{Aabb, Triangle, Vec3A};

fn scene() -> (Vec<Triangle>, Bvh) {
    let tris: Vec<Triangle> = (0..4)
        .map(|i| {
            let o = Vec3A::new(i as f32 * 2.0, 0.0, 0.0);
            Triangle::new(o, o + Vec3A::X, o + Vec3A::Y)
        })
        .collect();
    let b = |r: std::ops::Range<usize>| {
        tris[r]
            .iter()
            .fold(Aabb::EMPTY, |a, t| a.union(&t.bounds()))
    };
    // root(0) -> inner(1) [leaf 2: 0, leaf 3: 1], leaf 4: 2,3
    let bvh = Bvh {
        nodes: vec![
            Node::inner(&b(0..4), 4),
            Node::inner(&b(0..2), 3),
            Node::leaf(&b(0..1), 0, 1),
            Node::leaf(&b(1..2), 1, 1),
            Node::leaf(&b(2..4), 2, 2),
        ],
        prim_indices: vec![0, 1, 2, 3],
        spatial_splits: false,
        ref_cuts: None,
    };
    (tris, bvh)
}

#[test]
fn valid_tree_and_stats() {
    let (tris, bvh) = scene();
    bvh.validate(&tris).unwrap();
    let s = bvh.stats();
    assert_eq!(s.nodes, 5);
    assert_eq!(s.leaves, 3);
    assert_eq!(s.inner, 2);
    assert_eq!(s.depth, 3);
    assert_eq!(s.max_leaf, 2);
    assert_eq!(s.leaf_histogram, vec![0, 2, 1]);
}

#[test]
fn empty_tree() {
    Bvh::empty().validate(&[]).unwrap();
    let (tris, _) = scene();
    assert_eq!(
        Bvh::empty().validate(&tris),
        Err(ValidationError::MissingRoot(4))
    );
}

#[test]
fn detects_errors() {
    let (tris, good) = scene();
    let mut b = good.clone();
    b.nodes[0].index = 0; // cycle to itself
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::ChildOutOfRange { .. })
    ));
    let mut b = good.clone();
    b.nodes[0].index = 99;
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::ChildOutOfRange { .. })
    ));
    let mut b = good.clone();
    b.nodes[2].max[0] += 100.0; // child sticks out of its parent
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::ChildNotContained { .. })
    ));
    let mut b = good.clone();
    b.nodes[4].min[0] += 0.5; // triangle 2 sticks out of its leaf
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::PrimitiveNotContained { .. })
    ));
    let mut b = good.clone();
    b.prim_indices[3] = 2; // triangle 3 missing, 2 twice
    assert!(b.validate(&tris).is_err());
    let mut b = good.clone();
    b.prim_indices[3] = 17;
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::PrimitiveOutOfRange { .. })
    ));
    let mut b = good.clone();
    b.nodes[4].count = 3; // range past the end
    assert!(matches!(
        b.validate(&tris),
        Err(ValidationError::LeafRangeOutOfBounds { .. })
    ));
    let mut b = good.clone();
    b.nodes[1].min[1] = f32::NAN;
    assert!(b.validate(&tris).is_err());
    let mut b = good;
    b.spatial_splits = true;
    b.prim_indices[3] = 2;
    // Duplicates are allowed with spatial splits, but triangle 3 is still unreferenced.
    assert_eq!(
        b.validate(&tris),
        Err(ValidationError::Unreferenced { prim: 3 })
    );
}

#[test]
fn save_load_round_trip_and_truncation() {
    let (_, bvh) = scene();
    let mut bytes = Vec::new();
    bvh.save(&mut bytes).unwrap();
    assert_eq!(Bvh::load(&mut bytes.as_slice()).unwrap(), bvh);
    // Every truncation is an error, never a panic.
    for cut in 0..bytes.len() {
        let err = Bvh::load(&mut &bytes[..cut]).unwrap_err();
        assert!(
            matches!(err, LoadError::Truncated { .. }),
            "cut {cut}: {err}"
        );
        assert!(err.to_string().contains("truncated"), "{err}");
    }
    // Every single-bit corruption is an error or a structurally valid tree.
    for i in 0..bytes.len() {
        let mut c = bytes.clone();
        c[i] ^= 0x10;
        if let Ok(t) = Bvh::load(&mut c.as_slice()) {
            t.validate_structure().unwrap();
        }
    }
    let mut c = bytes.clone();
    c[45] ^= 1;
    assert!(matches!(
        Bvh::load(&mut c.as_slice()),
        Err(LoadError::Checksum)
    ));
    let mut c = bytes.clone();
    c.push(0);
    assert!(matches!(
        Bvh::load(&mut c.as_slice()),
        Err(LoadError::TrailingData(1))
    ));
    let mut c = bytes.clone();
    c[0] = b'X';
    assert!(matches!(
        Bvh::load(&mut c.as_slice()),
        Err(LoadError::BadMagic)
    ));
}

#[test]
fn huge_size_fields_do_not_allocate() {
    let mut bytes = Vec::new();
    bytes.extend_from_slice(b"SAHARBVH");
    bytes.extend_from_slice(&1u32.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&(u64::MAX / 64).to_le_bytes());
    bytes.extend_from_slice(&u64::MAX.to_le_bytes());
    bytes.extend_from_slice(&0u64.to_le_bytes());
    assert!(matches!(
        Bvh::load(&mut bytes.as_slice()),
        Err(LoadError::Truncated { .. })
    ));
}

#[test]
fn structurally_broken_payload_is_rejected() {
    let (_, mut bvh) = scene();
    bvh.nodes[1].index = 1;
    let mut bytes = Vec::new();
    bvh.save(&mut bytes).unwrap();
    assert!(matches!(
        Bvh::load(&mut bytes.as_slice()),
        Err(LoadError::Invalid(_))
    ));
}

/// A tree with cut records: the scene's four triangles, the first one's reference cut into
/// two (leaves 2 and 3 hold its halves left and right of x = 0.5).
fn cut_scene() -> (Vec<Triangle>, Bvh) {
    use sahara_bvh::{Cut, Keep, RefCuts};
    let (tris, mut bvh) = scene();
    let cut = |keep| Cut {
        pos: 0.5,
        axis: 0,
        keep,
        depth: 1,
    };
    let mut cuts = RefCuts::new();
    cuts.push(&[cut(Keep::Below)]);
    cuts.push(&[cut(Keep::Above)]);
    cuts.push(&[]);
    cuts.push(&[]);
    bvh.prim_indices = vec![0, 0, 1, 2];
    bvh.spatial_splits = true;
    // The scene's triangle 1 is referenced nowhere: drop it.
    let tris = vec![tris[0], tris[2], tris[3]];
    let (l, r) = (cuts.replay(0, &tris[0]), cuts.replay(1, &tris[0]));
    // Node 1 (depth 1) made the cut: it is bounded by the reference before the cut.
    bvh.nodes[1] = Node::inner(&tris[0].bounds(), 3);
    bvh.nodes[2] = Node::leaf(&l, 0, 1);
    bvh.nodes[3] = Node::leaf(&r, 1, 1);
    bvh.ref_cuts = Some(cuts);
    (tris, bvh)
}

#[test]
fn cut_records_save_as_version_2_and_trees_without_them_as_version_1() {
    let (tris, bvh) = cut_scene();
    bvh.validate(&tris).unwrap();
    let mut file = Vec::new();
    bvh.save(&mut file).unwrap();
    assert_eq!(file[8..12], 2u32.to_le_bytes());
    assert_eq!(Bvh::load(&mut file.as_slice()).unwrap(), bvh);
    // Every truncation is refused.
    for cut in 0..file.len() {
        assert!(Bvh::load(&mut &file[..cut]).is_err(), "{cut}");
    }
    // A bad cut (axis 3) in the payload, checksum fixed: refused as invalid.
    let mut bad = file.clone();
    let at = bad.len() - 8 * 2 + 4;
    bad[at] |= 3;
    let sum = {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for &b in &bad[48..] {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        h
    };
    bad[32..40].copy_from_slice(&sum.to_le_bytes());
    assert!(matches!(
        Bvh::load(&mut bad.as_slice()),
        Err(LoadError::Invalid(ValidationError::BadCuts { .. }))
    ));
    // Without records: version 1, loadable, refits with whole boxes.
    let mut old = bvh.clone();
    old.ref_cuts = None;
    let mut v1 = Vec::new();
    old.save(&mut v1).unwrap();
    assert_eq!(v1[8..12], 1u32.to_le_bytes());
    let mut loaded = Bvh::load(&mut v1.as_slice()).unwrap();
    assert_eq!(loaded, old);
    loaded.refit_triangles(&tris).unwrap();
    assert!(loaded.nodes[2].bounds().contains_aabb(&tris[0].bounds()));
    // Records that do not match the references are a structure error.
    let mut short = bvh.clone();
    short.prim_indices.push(3);
    short.nodes[4] = Node::leaf(&short.nodes[4].bounds(), 2, 3);
    assert!(matches!(
        short.validate_structure(),
        Err(ValidationError::BadCuts { .. })
    ));
}

#[test]
fn refit_with_cut_records_keeps_the_halves_and_empty_leaves_validate() {
    let (tris, bvh) = cut_scene();
    let mut r = bvh.clone();
    r.refit_triangles(&tris).unwrap();
    assert_eq!(r, bvh);
    // Triangle 0 moved entirely right of the cut: the left half's leaf is empty, the tree
    // still validates (and node 1 holds the moved triangle).
    let mut moved = tris.clone();
    let d = Vec3A::new(3.0, 0.0, 0.0);
    moved[0] = Triangle::new(tris[0].v[0] + d, tris[0].v[1] + d, tris[0].v[2] + d);
    r.refit_triangles(&moved).unwrap();
    assert_eq!(r.nodes[2].bounds(), Aabb::EMPTY);
    assert!(r.nodes[3].bounds().contains_aabb(&moved[0].bounds()));
    r.validate(&moved).unwrap();
    // A tree without records rejects an empty node.
    let mut plain = r.clone();
    plain.ref_cuts = None;
    assert!(matches!(
        plain.validate(&moved),
        Err(ValidationError::BadBounds { node: 2 })
    ));
}
