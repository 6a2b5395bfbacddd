//! The polygon scan gives the voxel grid's item buffers, to the bit.

use proptest::prelude::*;
use rad_accel::{GridResolution, VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::{cornell_box, cube, loft, CORNELL_PATCH_MM};
use rad_geometry::{Scene, SceneDesc};
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer, ScanScratch};
use rad_testkit::random_scene;

fn grid(scene: &Scene, density: f64) -> VoxelGrid<'_> {
    let resolution = GridResolution::Auto {
        density,
        max_per_axis: 64,
    };
    VoxelGrid::build(scene, &VoxelGridConfig { resolution }).unwrap()
}

/// The first cell where the two buffers differ (patch, or distance bits).
fn first_difference(a: &ItemBuffer, b: &ItemBuffer) -> Option<usize> {
    assert_eq!(a.patch.len(), b.patch.len());
    (0..a.patch.len())
        .find(|&k| a.patch[k] != b.patch[k] || a.dist[k].to_bits() != b.dist[k].to_bits())
}

/// Scans and casts `patches`; the index of a patch whose buffers differ, with the cell.
fn compare(
    scene: &Scene,
    hemi: &Hemisphere,
    patches: &[u32],
    density: f64,
) -> Option<(u32, usize)> {
    let grid = grid(scene, density);
    let mut gs = grid.new_scratch();
    let mut ss = ScanScratch::default();
    let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
    patches.iter().find_map(|&p| {
        hemi.cast(scene, &grid, p, &mut gs, &mut a);
        hemi.scan(scene, p, &mut ss, &mut b);
        first_difference(&a, &b).map(|k| (p, k))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    /// Random scenes of intersecting polygons (patch centres on or near other polygons'
    /// planes, back faces, general convex polygons), random resolutions and φ shifts.
    #[test]
    fn scan_matches_the_grid_on_random_scenes(
        desc in random_scene(10),
        n_theta in 1u32..40,
        n_phi in 1u32..120,
        shift in prop_oneof![Just(0.0), Just(0.5), 0.0f64..1.0],
        picks in proptest::collection::vec(any::<prop::sample::Index>(), 1..6),
        density in prop_oneof![Just(0.5), Just(4.0), Just(16.0)],
        offset in prop_oneof![Just(0.0f32), Just(37.0), Just(-300.0)],
    ) {
        // Far from the origin, f32 rounding is coarser than the scene's details.
        let mut desc = desc;
        for p in &mut desc.polygons {
            for v in &mut p.vertices {
                *v += glam::Vec3::new(offset, -0.5 * offset, 0.25 * offset);
            }
        }
        let scene = Scene::new(desc);
        // (f32 vertices so far out may fail the planarity check: draw again)
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let hemi = Hemisphere::new(HemisphereConfig { phi_shift: shift, ..HemisphereConfig::exact(n_theta, n_phi) }).unwrap();
        let patches: Vec<u32> = picks.iter().map(|i| i.index(scene.patches().len()) as u32).collect();
        prop_assert_eq!(compare(&scene, &hemi, &patches, density), None);
    }
}

fn spread(scene: &Scene, k: usize) -> Vec<u32> {
    let n = scene.patches().len();
    (0..k)
        .map(|i| ((i * n) / k + (7 * i) % (n / k).max(1)) as u32)
        .collect()
}

fn check_scene(desc: SceneDesc, k: usize, hemi: &Hemisphere) {
    let scene = Scene::new(desc).unwrap();
    let patches = spread(&scene, k);
    assert_eq!(compare(&scene, hemi, &patches, 4.0), None);
}

#[test]
fn scan_matches_the_grid_on_the_bench_scenes() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    check_scene(loft(), 120, &hemi);
    check_scene(cube(10), 60, &hemi);
    check_scene(cornell_box(CORNELL_PATCH_MM), 60, &hemi);
    // The report's resolution, and a turned grid.
    let full = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    check_scene(loft(), 8, &full);
    let turned = Hemisphere::new(HemisphereConfig {
        phi_shift: 0.5,
        ..HemisphereConfig::exact(90, 360)
    })
    .unwrap();
    check_scene(loft(), 16, &turned);
}

/// The scan really skips work: far fewer (cell, polygon) tests than polygons per cell.
#[test]
fn scan_tests_few_polygons_per_cell() {
    let scene = Scene::new(loft()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let mut ss = ScanScratch::default();
    let mut buf = ItemBuffer::default();
    for p in spread(&scene, 20) {
        hemi.scan(&scene, p, &mut ss, &mut buf);
    }
    let per_cell = ss.stats.tests as f64 / (ss.stats.hemispheres as f64 * hemi.n_cells() as f64);
    assert!(
        per_cell < 12.0,
        "{per_cell} tests per cell of {} polygons",
        scene.polygons().len()
    );
}
