//! How much rows made from the scene divided by its largest coordinate
//! (`Scene::for_rows`, what the pipeline makes rows from) differ from rows made from the
//! scene's own f32 coordinates (what it made them from before): cells that see another
//! patch, the largest entry difference, and the mean L1 difference of a row, over 64
//! patches of each scene at 180 x 720 through the scan:
//! `cargo run --release -p rad-repro --example divided_rows` (`MESHES=1`: the mesh
//! scenes too).

use rad_geometry::scenes::{
    blob_room, cornell_box, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
    CORNELL_PATCH_MM,
};
use rad_geometry::Scene;
use rad_hemisphere::{Caster, Hemisphere, HemisphereConfig, ItemBuffer, RowAccumulator, Scan};

fn main() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let mut scenes = vec![
        ("loft", loft()),
        ("cube", cube(10)),
        ("cornell", cornell_box(CORNELL_PATCH_MM)),
    ];
    if std::env::var("MESHES").is_ok_and(|v| v == "1") {
        scenes.extend([
            ("loft_patches", loft_patches()),
            ("loft_triangles", loft_triangles()),
            ("loft_fine", loft_fine_triangles()),
            ("blob_room", blob_room()),
        ]);
    }
    for (name, desc) in scenes {
        let scene = Scene::new(desc).unwrap();
        let divided = scene.for_rows().unwrap();
        let n = scene.patches().len();
        let patches: Vec<u32> = (0..64).map(|k| ((k * n / 64 + 37) % n) as u32).collect();
        let (mut sa, mut sb) = (Scan.scratch(), Scan.scratch());
        let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
        let mut acc = RowAccumulator::new(n);
        let (mut cells, mut most, mut l1) = (0usize, 0.0f64, 0.0f64);
        let mut dense = vec![0.0f64; n];
        for &p in &patches {
            Scan.item_buffer(&scene, &hemi, p, &mut sa, &mut a);
            Scan.item_buffer(divided, &hemi, p, &mut sb, &mut b);
            cells += a.patch.iter().zip(&b.patch).filter(|(x, y)| x != y).count();
            let (ra, rb) = (
                hemi.row_from_items(p, &a, &mut acc),
                hemi.row_from_items(p, &b, &mut acc),
            );
            dense.iter_mut().for_each(|x| *x = 0.0);
            ra.entries.iter().for_each(|&(j, f)| dense[j as usize] += f);
            rb.entries.iter().for_each(|&(j, f)| dense[j as usize] -= f);
            most = dense.iter().fold(most, |m, x| m.max(x.abs()));
            l1 += dense.iter().map(|x| x.abs()).sum::<f64>();
        }
        println!(
            "{name}: divided by itself: {}; {cells} of {} cells see another patch; largest entry difference {most:.2e}; mean L1 row difference {:.2e}",
            !std::ptr::eq(divided, &scene),
            patches.len() * hemi.n_cells(),
            l1 / patches.len() as f64
        );
    }
}
