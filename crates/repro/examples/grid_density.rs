//! Grid-density sweep on the loft: `cargo run --release -p rad-repro --example
//! grid_density -- 1 4 16 12,5,8` times one-thread 180 × 720 hemispheres (best of
//! REPS=5 passes over 16 patches) for each density (or fixed x,y,z voxel counts).

use rad_accel::{GridResolution, VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::loft;
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer};
fn main() {
    let scene = Scene::new(loft()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let patches: Vec<u32> = (0..16).map(|k| (k * 14400 / 16 + 37) as u32).collect();
    for arg in std::env::args().skip(1) {
        let res = if arg.contains(',') {
            let v: Vec<u32> = arg.split(',').map(|s| s.parse().unwrap()).collect();
            GridResolution::Fixed([v[0], v[1], v[2]])
        } else {
            GridResolution::Auto {
                density: arg.parse().unwrap(),
                max_per_axis: 256,
            }
        };
        let g = VoxelGrid::build(&scene, &VoxelGridConfig { resolution: res }).unwrap();
        let mut s = g.new_scratch();
        let mut buf = ItemBuffer::default();
        let mut dt = f64::INFINITY;
        for _ in 0..std::env::var("REPS")
            .map(|r| r.parse().unwrap())
            .unwrap_or(5)
        {
            let t = std::time::Instant::now();
            for &p in &patches {
                hemi.cast(&scene, &g, p, &mut s, &mut buf);
            }
            dt = dt.min(t.elapsed().as_secs_f64() / patches.len() as f64);
        }
        println!(
            "{arg}: dims {:?} occ {:.2} {:.2} ms/hemisphere {:.2} Mrays/s",
            g.dims(),
            g.mean_occupancy(),
            dt * 1e3,
            129600.0 / dt / 1e6
        );
    }
}
