//! Rows of mesh scenes and the loft scaled by factors from 3.3e-6 to 6.1e5 (coordinates
//! multiplied in f64, as a file would give them) against the unscaled scene's, exact
//! and estimated, about 600 patches each at 45 x 180:
//! `cargo run --release -p rad-repro --example scale_check` prints how many rows are
//! the same to the bit.
use rad_geometry::{scenes, PatchGrid, Scene, SceneDesc};
use rad_pipeline::{rows, Hemisphere, HemisphereConfig, RowMethod};
fn scaled(desc: &SceneDesc, s: f64) -> SceneDesc {
    let mut d = desc.clone();
    for p in &mut d.polygons {
        for v in &mut p.vertices {
            *v *= s;
        }
        if let PatchGrid::Size(z) = &mut p.grid {
            *z *= s;
        }
    }
    d
}
fn main() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    for (name, desc) in [
        ("loft_triangles", scenes::loft_triangles()),
        ("blob_room", scenes::blob_room()),
        ("loft", scenes::loft()),
    ] {
        let base = Scene::new(desc.clone()).unwrap();
        let n = base.patches().len();
        let ids: Vec<u32> = (0..n as u32).step_by(n / 600).collect();
        for m in ["exact/hierarchy", "estimated/improved/hierarchy"] {
            let method: RowMethod = m.parse().unwrap();
            let a = rows(&base, &hemi, method, &ids, &|_| {}).unwrap();
            for s in [3.3e-6, 0.0271, 917.0, 6.1e5] {
                let other = Scene::new(scaled(&desc, s)).unwrap();
                let b = rows(&other, &hemi, method, &ids, &|_| {}).unwrap();
                let same = a.rows.iter().zip(&b.rows).filter(|(x, y)| x == y).count();
                println!(
                    "{name} {m} {s:e}: {same} of {} rows the same to the bit",
                    ids.len()
                );
            }
        }
    }
}
