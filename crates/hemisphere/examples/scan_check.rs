//! Scan vs grid on the loft, cube and Cornell box (and with `MESHES=1` the mesh
//! scenes): `cargo run --release -p rad-hemisphere --example scan_check`: checks the
//! item buffers are equal and times both (one thread).

use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::{
    blob_room, cornell_box, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
    CORNELL_PATCH_MM,
};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer, ScanScratch};

fn main() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    // MESHES=1: the mesh scenes too (slower).
    let meshes = std::env::var("MESHES").is_ok_and(|v| v == "1");
    let mut scenes = vec![
        ("loft", loft()),
        ("cube", cube(10)),
        ("cornell", cornell_box(CORNELL_PATCH_MM)),
    ];
    if meshes {
        scenes.extend([
            ("loft_patches", loft_patches()),
            ("loft_triangles", loft_triangles()),
            ("loft_fine", loft_fine_triangles()),
            ("blob_room", blob_room()),
        ]);
    }
    for (name, desc) in scenes {
        let scene = Scene::new(desc).unwrap();
        let n = scene.patches().len();
        let patches: Vec<u32> = (0..32).map(|k| ((k * n / 32 + 37) % n) as u32).collect();
        let g = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
        let mut s = g.new_scratch();
        let mut ss = ScanScratch::default();
        let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
        let (mut tg, mut ts) = (0.0, 0.0);
        let mut bad = 0;
        for &p in &patches {
            let t = std::time::Instant::now();
            hemi.cast(&scene, &g, p, &mut s, &mut a);
            tg += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            hemi.scan(&scene, p, &mut ss, &mut b);
            ts += t.elapsed().as_secs_f64();
            let diff = (0..a.patch.len())
                .filter(|&k| a.patch[k] != b.patch[k] || a.dist[k].to_bits() != b.dist[k].to_bits())
                .count();
            if diff > 0 {
                bad += 1;
                eprintln!("{name} patch {p}: {diff} cells differ");
            }
        }
        let k = patches.len() as f64;
        println!(
            "{name}: grid {:.2} ms, scan {:.2} ms per hemisphere; {:.2} tests/cell, {:.2} full polygons/hemisphere; {bad} differing",
            tg / k * 1e3,
            ts / k * 1e3,
            ss.stats.tests as f64 / ss.stats.hemispheres as f64 / hemi.n_cells() as f64,
            ss.stats.full as f64 / ss.stats.hemispheres as f64
        );
    }
}
