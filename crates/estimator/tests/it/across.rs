//! Estimation across polygons: a mesh's one-patch triangles of one plane estimated from
//! a neighbour's hemisphere in their own, turned frames.

use proptest::prelude::*;
use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_estimator::{
    estimate_rows, frame_turn, windows, Estimate, Estimator, EstimatorConfig, HoleFill,
    ImprovedEstimate, Mode, Outcome, Reprojection, Schedule, Source, SourceHemisphere, MAX_WINDOW,
};
use rad_geometry::scenes::cube;
use rad_geometry::{PatchGrid, PolygonDesc, Scene, SceneDesc};
use rad_hemisphere::{
    compute_rows, Caster, Hemisphere, HemisphereConfig, ItemBuffer, Row, Viewpoint,
};

fn config(mode: Mode) -> EstimatorConfig {
    EstimatorConfig {
        mode,
        fill: HoleFill::RingNeighbour,
        reprojection: Reprojection::LATERAL_10,
        boundary_lists: false,
        max_real_ray_share: 1.0,
        guess_stride: 1,
    }
}

/// The unit cube with its floor cut into two one-patch triangles along a diagonal,
/// their vertex lists turned by `turns` (so their frames' first axes differ).
fn split_floor(turns: [usize; 2]) -> SceneDesc {
    let mut desc = cube(4);
    let p = |x: f32, z: f32| glam::Vec3::new(x, 0.0, z);
    // Counter-clockwise seen from above (the floor faces +y).
    let mut a = vec![p(0.0, 0.0), p(0.0, 1.0), p(1.0, 1.0)];
    let mut b = vec![p(0.0, 0.0), p(1.0, 1.0), p(1.0, 0.0)];
    a.rotate_left(turns[0]);
    b.rotate_left(turns[1]);
    let triangle = |name: &str, vertices: Vec<glam::Vec3>| PolygonDesc {
        name: name.into(),
        vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
        material: 0,
        grid: PatchGrid::Cells { nu: 1, nv: 1 },
        group: None,
        obstruction: false,
        two_sided: false,
    };
    desc.polygons[0] = triangle("floor a", a);
    desc.polygons.push(triangle("floor b", b));
    desc
}

/// The unit cube, every face cut into `n` × `n` squares of two one-patch triangles each
/// (a closed mesh of 12 n² triangles).
fn mesh_cube(n: usize) -> SceneDesc {
    let mut desc = cube(1);
    let faces = std::mem::take(&mut desc.polygons);
    for face in faces {
        let [o, a, _, b] = [0, 1, 2, 3].map(|k| face.vertices[k].as_vec3());
        let (ea, eb) = ((a - o) / n as f32, (b - o) / n as f32);
        for i in 0..n {
            for j in 0..n {
                let q = |di: usize, dj: usize| o + ea * (i + di) as f32 + eb * (j + dj) as f32;
                for (k, tri) in [[q(0, 0), q(1, 0), q(1, 1)], [q(0, 0), q(1, 1), q(0, 1)]]
                    .into_iter()
                    .enumerate()
                {
                    desc.polygons.push(PolygonDesc {
                        name: format!("{} {i} {j} {k}", face.name),
                        vertices: tri.map(glam::Vec3::as_dvec3).to_vec(),
                        grid: PatchGrid::Cells { nu: 1, nv: 1 },
                        ..face.clone()
                    });
                }
            }
        }
    }
    desc
}

/// Cells where two item buffers differ.
fn differing(a: &ItemBuffer, b: &ItemBuffer) -> usize {
    a.patch.iter().zip(&b.patch).filter(|(x, y)| x != y).count()
}

/// Improved mode's estimate at `at` from `src` (default settings, every real ray
/// allowed), and the exact hemisphere there.
fn improved_against_exact<C: Caster>(
    est: &Estimator,
    scene: &Scene,
    caster: &C,
    src: &SourceHemisphere,
    at: Viewpoint,
    s: &mut C::Scratch,
) -> (Outcome, ImprovedEstimate, ItemBuffer) {
    let mut exact = ItemBuffer::default();
    caster.item_buffer_at(scene, est.hemisphere(), at, s, &mut exact);
    let mut i = ImprovedEstimate::default();
    let outcome = est.improved_at(scene, caster, src, at, &config(Mode::Improved), s, &mut i);
    (outcome, i, exact)
}

/// Zero motion to a viewpoint on another polygon of the plane: improved mode gives the
/// exact hemisphere there, in its own frame; faithful mode gives the source's cells
/// turned by the frames' turn (45° steps here, whole sectors at 24 × 96).
#[test]
fn zero_motion_across_polygons_gives_the_source_hemisphere_turned() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(24, 96)).unwrap();
    let est = Estimator::new(&hemi);
    for turns in [[0, 0], [0, 1], [1, 2], [2, 0], [2, 2]] {
        let scene = Scene::new(split_floor(turns)).unwrap();
        let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
        let mut s = grid.new_scratch();
        let (a, b) = (0u32, scene.polygons().len() as u32 - 1);
        let src_patch = scene.polygons()[a as usize].first_patch();
        let src = SourceHemisphere::cast(&scene, &grid, &hemi, src_patch, false, &mut s);
        let at = Viewpoint {
            point: scene.patches()[src_patch as usize].center,
            polygon: b,
        };
        let alpha = frame_turn(&scene, a, b).expect("one plane");
        let (outcome, i, exact) = improved_against_exact(&est, &scene, &grid, &src, at, &mut s);
        assert_eq!(outcome, Outcome::Estimated, "turns {turns:?}");
        assert_eq!(differing(&i.items, &exact), 0, "improved, turns {turns:?}");
        assert_eq!(i.real_rays, 0, "turns {turns:?}");
        let mut f = Estimate::default();
        est.faithful_at(&scene, &src, at, &config(Mode::Faithful), &mut f);
        assert_eq!(f.holes, 0, "turns {turns:?}");
        let sectors = alpha / hemi.d_phi();
        assert!(
            (sectors - sectors.round()).abs() < 1e-4,
            "a whole turn: {sectors}"
        );
        let k = (sectors.round() as i64).rem_euclid(hemi.n_phi() as i64) as usize;
        let n = hemi.n_phi();
        for c in 0..hemi.n_cells() {
            let turned = c / n * n + (c % n + n - k % n) % n;
            assert_eq!(
                f.items.patch[c],
                src.items().patch[turned],
                "faithful, turns {turns:?}, cell {c}"
            );
        }
        assert_eq!(differing(&f.items, &exact), 0, "faithful, turns {turns:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Zero motion from one triangle's patch to the other triangle of its plane,
    /// either way, whatever the turn between their frames and the grid's φ shift:
    /// improved mode gives that viewpoint's exact hemisphere (the cube's faces are
    /// large: every cell's polygon is among the guesses around it).
    #[test]
    fn zero_motion_across_polygons_at_any_turn(
        turns in (0usize..3, 0usize..3),
        reverse in any::<bool>(),
        shift in 0.0f64..1.0,
    ) {
        let scene = Scene::new(split_floor([turns.0, turns.1])).unwrap();
        let hemi = Hemisphere::new(HemisphereConfig {
            phi_shift: shift,
            ..HemisphereConfig::exact(30, 120)
        })
        .unwrap();
        let est = Estimator::new(&hemi);
        let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
        let mut s = grid.new_scratch();
        let (mut a, mut b) = (0u32, scene.polygons().len() as u32 - 1);
        if reverse {
            (a, b) = (b, a);
        }
        let src_patch = scene.polygons()[a as usize].first_patch();
        let src = SourceHemisphere::cast(&scene, &grid, &hemi, src_patch, false, &mut s);
        let at = Viewpoint { point: scene.patches()[src_patch as usize].center, polygon: b };
        let (_, i, exact) = improved_against_exact(&est, &scene, &grid, &src, at, &mut s);
        prop_assert_eq!(differing(&i.items, &exact), 0);
        prop_assert_eq!(i.real_rays, 0);
    }
}

/// Zero motion on a mesh: the viewpoint of a floor triangle's patch, on another
/// triangle of the floor; the walls and ceiling are facets of many triangles, which
/// improved mode locates cell by cell: the same patches as the exact hemisphere there.
#[test]
fn zero_motion_on_a_mesh_locates_every_cell() {
    let scene = Scene::new(mesh_cube(6)).unwrap();
    let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
    let est_hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    let est = Estimator::new(&est_hemi);
    let mut s = grid.new_scratch();
    let floor: Vec<u32> = (0..scene.polygons().len() as u32)
        .filter(|&p| scene.polygons()[p as usize].name().starts_with("floor"))
        .collect();
    assert!(scene.facets().is_several(scene.facets().facet_of(floor[0])));
    for (a, b) in [
        (floor[0], floor[7]),
        (floor[20], floor[3]),
        (floor[41], floor[40]),
    ] {
        let src_patch = scene.polygons()[a as usize].first_patch();
        let src = SourceHemisphere::cast(&scene, &grid, &est_hemi, src_patch, false, &mut s);
        let at = Viewpoint {
            point: scene.patches()[src_patch as usize].center,
            polygon: b,
        };
        let (_, i, exact) = improved_against_exact(&est, &scene, &grid, &src, at, &mut s);
        assert_eq!(differing(&i.items, &exact), 0, "{a} to {b}");
        assert_eq!(i.real_rays, 0, "{a} to {b}");
    }
}

/// A mesh's one-patch triangles are scheduled across polygons: every patch once, each
/// window of one plane and at most `MAX_WINDOW` patches, most windows estimating.
#[test]
fn a_mesh_is_scheduled_across_polygons() {
    let scene = Scene::new(mesh_cube(6)).unwrap();
    let schedule = Schedule::of(&scene);
    let mut seen = vec![0u32; scene.patches().len()];
    for (k, w) in schedule.windows().iter().enumerate() {
        let members: Vec<u32> = std::iter::once(w.centre)
            .chain(w.estimated.iter().copied())
            .collect();
        assert!(members.len() <= MAX_WINDOW);
        for &p in &members {
            seen[p as usize] += 1;
            assert_eq!(schedule.window_of(p), k);
            let (pa, pb) = (
                scene.patches()[w.centre as usize].polygon,
                scene.patches()[p as usize].polygon,
            );
            assert!(
                frame_turn(&scene, pa, pb).is_some(),
                "window {k}: one plane"
            );
        }
    }
    assert!(seen.iter().all(|&n| n == 1), "every patch once");
    assert_eq!(schedule.windows(), &windows(&scene)[..]);
    let estimating = schedule
        .windows()
        .iter()
        .filter(|w| !w.estimated.is_empty())
        .count();
    let patches_per_window = scene.patches().len() as f64 / schedule.windows().len() as f64;
    assert!(
        patches_per_window > 4.0,
        "{patches_per_window} patches a window"
    );
    assert!(
        estimating * 10 >= schedule.windows().len() * 9,
        "{estimating} estimating"
    );
}

/// The sum of a row's entries and its escaped and back form factors.
fn total(r: &Row) -> f64 {
    r.entries.iter().map(|e| e.1).sum::<f64>() + r.escaped + r.back
}

/// The L1 distance of two rows.
fn l1(a: &Row, b: &Row) -> f64 {
    let mut by: std::collections::BTreeMap<u32, f64> =
        a.entries.iter().map(|&(j, f)| (j, f)).collect();
    for &(j, f) in &b.entries {
        *by.entry(j).or_default() -= f;
    }
    by.values().map(|x| x.abs()).sum::<f64>()
        + (a.escaped - b.escaped).abs()
        + (a.back - b.back).abs()
}

/// Estimated rows of a closed mesh are valid rows (each sums to 1, nothing escapes,
/// nothing meets a back), many are estimated from another polygon's hemisphere, and
/// improved mode's are near the exact rows.
#[test]
fn estimated_rows_of_a_closed_mesh_are_valid() {
    let scene = Scene::new(mesh_cube(5)).unwrap();
    let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    let exact = compute_rows(&scene, &grid, &hemi, &all, &|_| {}).unwrap();
    let schedule = Schedule::of(&scene);
    for mode in [Mode::Improved, Mode::Faithful] {
        let cfg = EstimatorConfig {
            max_real_ray_share: 0.05,
            ..config(mode)
        };
        let (rows, stats) =
            estimate_rows(&scene, &grid, &hemi, &cfg, &schedule, &all, &|_| {}).unwrap();
        assert!(
            stats.estimated > scene.patches().len() / 2,
            "{mode:?}: {stats:?}"
        );
        let mut across = 0;
        let mut l1_sum = 0.0;
        for (p, r) in rows.iter().enumerate() {
            assert!((total(&r.row) - 1.0).abs() < 1e-9, "{mode:?} row {p}");
            assert_eq!(r.row.escaped, 0.0, "{mode:?} row {p}");
            assert_eq!(r.row.back, 0.0, "{mode:?} row {p}");
            if let Source::Estimated { from } = r.source {
                let (pf, pp) = (
                    scene.patches()[from as usize].polygon,
                    scene.patches()[p].polygon,
                );
                across += usize::from(pf != pp);
            }
            l1_sum += l1(&r.row, &exact[p]);
        }
        assert!(
            across > scene.patches().len() / 2,
            "{mode:?}: {across} across polygons"
        );
        let mean = l1_sum / rows.len() as f64;
        if mode == Mode::Improved {
            assert!(mean < 0.01, "improved: mean L1 {mean}");
        }
    }
}
