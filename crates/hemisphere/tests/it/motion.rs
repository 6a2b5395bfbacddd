//! Rows of moved scenes from the step before's item buffers: the very rows a whole
//! computation makes, to the bit, over random scenes and random rigid motions, one and
//! several origins a patch; and only what may change is cast again.

use glam::{DVec3, Vec3};
use proptest::prelude::*;
use rad_accel::WideBvh;
use rad_geometry::{scenes, Motion, MotionStep, Rigid, Scene, SceneDesc};
use rad_hemisphere::{
    compute_area_rows, moved_area_rows, moved_area_rows_from, moved_polygons, Hemisphere,
    HemisphereConfig, Hierarchy, KeptBuffers, Scan,
};
use std::collections::BTreeMap;

/// Runs `motion` over `desc` step by step, keeping buffers, and checks each step's rows
/// against a whole computation of that step; returns each step's share of cells cast.
fn run(desc: &SceneDesc, motion: &Motion, hemi: &Hemisphere, origins: u32) -> Vec<f64> {
    let cut = Scene::new(desc.clone()).unwrap();
    let mut kept = KeptBuffers::new();
    let mut before: Option<Scene> = None;
    let mut shares = Vec::new();
    let unit = motion.unit(desc);
    for k in 0..motion.steps.len() {
        let Ok(scene) = motion.step_scene(desc, &cut, k, unit) else {
            // (A random step may lay a polygon over another: refused, as it should be.)
            before = None;
            continue;
        };
        let rows_scene = scene.for_rows().unwrap();
        let moved = before
            .as_ref()
            .map(|b| moved_polygons(b.for_rows().unwrap(), rows_scene));
        let all: Vec<u32> = (0..rows_scene.patches().len() as u32).collect();
        let bvh = WideBvh::new(rows_scene);
        // (Every kept patch cast in part, however much: the path under test.)
        let (rows, stats) = moved_area_rows_from(
            (rows_scene, &Scan, &bvh, hemi),
            &all,
            origins,
            moved.as_deref(),
            &mut kept,
            1.0,
            &|_| {},
        )
        .unwrap();
        let whole = compute_area_rows(rows_scene, &Scan, hemi, &all, origins, &|_| {}).unwrap();
        assert_eq!(rows, whole, "step {k}, {origins} origins");
        if moved.as_ref().is_some_and(|m| !m.iter().any(|&x| x)) {
            assert_eq!(
                stats.cells_cast, 0,
                "nothing moved, nothing cast: {stats:?}"
            );
        }
        shares.push(stats.cast_share());
        before = Some(scene);
    }
    shares
}

fn pose() -> impl Strategy<Value = Rigid> {
    (
        rad_testkit::unit_vector(),
        -3.2f64..3.2,
        (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
    )
        .prop_map(|(axis, angle, (x, y, z))| {
            Rigid::turn(axis.as_dvec3(), angle, DVec3::ZERO, DVec3::new(x, y, z))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn moved_rows_are_whole_rows(
        scene in rad_testkit::random_scene(6),
        groups in proptest::collection::vec(0u8..3, 6),
        sides in rad_testkit::two_sided_flags(),
        steps in proptest::collection::vec((pose(), pose(), any::<bool>()), 3),
        origins in 1u32..3,
    ) {
        let mut desc = rad_testkit::with_two_sided(scene, &sides);
        for (k, p) in desc.polygons.iter_mut().enumerate() {
            p.group = match groups[k % groups.len()] {
                0 => None,
                1 => Some("a".into()),
                _ => Some("b".into()),
            };
        }
        // A sliver (a 0.5 degree tip), which moves: its hit test reaches far past its tip.
        let tip = 0.5f64.to_radians();
        desc.polygons.push(rad_geometry::PolygonDesc {
            name: "sliver".into(),
            vertices: vec![
                DVec3::new(0.0, 0.0, 0.3),
                DVec3::new(1.5, 1.5 * tip.tan(), 0.3),
                DVec3::new(1.5, 0.0, 0.3),
            ],
            material: 0,
            grid: rad_geometry::PatchGrid::Cells { nu: 1, nv: 1 },
            group: Some("a".into()),
            obstruction: false,
            two_sided: false,
        });
        let motion = Motion {
            path: "random".into(),
            steps: steps
                .iter()
                .enumerate()
                .map(|(k, (a, b, both))| MotionStep {
                    name: format!("{k}"),
                    poses: if *both {
                        BTreeMap::from([("a".to_string(), *a), ("b".to_string(), *b)])
                    } else {
                        BTreeMap::from([("a".to_string(), *a)])
                    },
                })
                .collect(),
        };
        let hemi = Hemisphere::new(HemisphereConfig::exact(10, 40)).unwrap();
        run(&desc, &motion, &hemi, origins);
    }
}

/// A box sliding across a room's floor: the rows equal whole ones, through the
/// hierarchy too, and a step casts only a small share of the cells again.
#[test]
fn a_box_sliding_in_a_room_casts_little() {
    let mut desc = scenes::cube(6);
    let lo = Vec3::new(0.1, 0.0, 0.1);
    let mut cart = scenes::cube(1);
    for p in &mut cart.polygons {
        for v in &mut p.vertices {
            *v = lo.as_dvec3() + *v * 0.12;
        }
        // (The unit cube's faces face inward: turn them out.)
        p.vertices.reverse();
        p.group = Some("cart".into());
        p.name = format!("cart {}", p.name);
    }
    // (Its floor face would lie on the room's floor: lift the box off it.)
    for p in &mut cart.polygons {
        for v in &mut p.vertices {
            v.y += 0.01;
        }
    }
    desc.polygons.extend(cart.polygons);
    let motion = Motion {
        path: "slide".into(),
        steps: (0..4)
            .map(|k| MotionStep {
                name: format!("{k}"),
                poses: BTreeMap::from([(
                    "cart".to_string(),
                    Rigid::turn(
                        DVec3::Y,
                        0.1 * k as f64,
                        DVec3::ZERO,
                        DVec3::new(0.15 * k as f64, 0.0, 0.1 * k as f64),
                    ),
                )]),
            })
            .collect(),
    };
    let hemi = Hemisphere::new(HemisphereConfig::exact(20, 80)).unwrap();
    let shares = run(&desc, &motion, &hemi, 1);
    assert_eq!(shares.len(), 4);
    assert_eq!(shares[0], 1.0, "the first step casts everything");
    for s in &shares[1..] {
        assert!(*s > 0.0 && *s < 0.2, "a step casts {s} of the cells again");
    }
    // Through the hierarchy as the whole caster, the same rows.
    let cut = Scene::new(desc.clone()).unwrap();
    let unit = motion.unit(&desc);
    let s0 = motion.step_scene(&desc, &cut, 0, unit).unwrap();
    let s1 = motion.step_scene(&desc, &cut, 1, unit).unwrap();
    let (r0, r1) = (s0.for_rows().unwrap(), s1.for_rows().unwrap());
    let all: Vec<u32> = (0..r1.patches().len() as u32).collect();
    let mut kept = KeptBuffers::new();
    let t0 = Hierarchy::new(r0);
    moved_area_rows(
        r0,
        &t0,
        &WideBvh::new(r0),
        &hemi,
        &all,
        2,
        None,
        &mut kept,
        &|_| {},
    )
    .unwrap();
    let t1 = Hierarchy::new(r1);
    let moved = moved_polygons(r0, r1);
    let (rows, _) = moved_area_rows(
        r1,
        &t1,
        &WideBvh::new(r1),
        &hemi,
        &all,
        2,
        Some(&moved),
        &mut kept,
        &|_| {},
    )
    .unwrap();
    assert_eq!(
        rows,
        compute_area_rows(r1, &t1, &hemi, &all, 2, &|_| {}).unwrap()
    );
    // Kept within a budget of bytes: the patches past it are cast whole, the same rows.
    let mut small = KeptBuffers::with_budget(20_000);
    let (_, first) = moved_area_rows(
        r0,
        &t0,
        &WideBvh::new(r0),
        &hemi,
        &all,
        2,
        None,
        &mut small,
        &|_| {},
    )
    .unwrap();
    assert!(
        first.not_kept > 0 && first.kept_bytes <= 20_000,
        "{first:?}"
    );
    let (rows, next) = moved_area_rows(
        r1,
        &t1,
        &WideBvh::new(r1),
        &hemi,
        &all,
        2,
        Some(&moved),
        &mut small,
        &|_| {},
    )
    .unwrap();
    assert_eq!(
        rows,
        compute_area_rows(r1, &t1, &hemi, &all, 2, &|_| {}).unwrap()
    );
    assert!(next.whole >= first.not_kept, "{next:?}");
}
