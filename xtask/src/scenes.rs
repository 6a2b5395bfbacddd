//! `cargo xtask scenes`: rewrites bench-scenes/ from the builders in
//! `rad_geometry::scenes`.

use anyhow::{Context, Result};
use rad_geometry::file::{scene_desc_to_json, scene_desc_to_json_indexed};
use rad_geometry::scenes::{
    blob_room, cart_motion, cornell_box, cube, loft, loft_fine_triangles, loft_patches,
    loft_triangles, room_with_cart, satellite, satellite_motion, sculptures_100k, sculptures_1m,
    urban_canyon, CORNELL_PATCH_MM,
};
use rad_geometry::{Scene, SceneDesc};
use rad_pipeline::output::write_atomic;
use std::path::Path;

/// Rewrites the bench-scene files from their builders.
pub fn write_scenes(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let scenes = [
        ("cube.json", cube(10), "The report's empty cube: unit size, six inward faces, 10 x 10 patches each (rad_geometry::scenes::cube)."),
        ("loft.json", loft(), "Our loft-like interior to the report's counts, 185 polygons and 14,400 patches (rad_geometry::scenes::loft); the report never published its loft."),
        ("cornell.json", cornell_box(CORNELL_PATCH_MM), "The Cornell box from its published geometry, in mm (rad_geometry::scenes::cornell_box); RGB reflectances from Bitterli's cornell-box resource."),
    ];
    let meshes = [
        ("loft_patches.json", loft_patches(), "Our loft with every patch its own polygon: 14,400 one-patch polygons (rad_geometry::scenes::loft_patches)."),
        ("loft_triangles.json", loft_triangles(), "Our loft with every patch cut into two triangles: 28,800 one-patch triangles (rad_geometry::scenes::loft_triangles)."),
        ("loft_fine.json", loft_fine_triangles(), "Our loft with every patch cut 2 x 2, each quarter into two triangles: 115,200 one-patch triangles (rad_geometry::scenes::loft_fine_triangles)."),
        ("canyon.json", urban_canyon(), "An urban street canyon: two rows of six 12 x 12 x 25 m buildings either side of a 12 m street, every wall, roof and the ground cut into 1 m facets, one patch each, each building face a group: 20,536 facets (rad_geometry::scenes::urban_canyon)."),
        ("blob_room.json", blob_room(), "A star-shaped blob of 20,480 triangles (a displaced icosphere) in a closed 4 x 3 x 4 m room with a ceiling lamp (rad_geometry::scenes::blob_room)."),
    ];
    let all = scenes
        .into_iter()
        .map(|(n, d, a)| (n, d, a, false))
        .chain(meshes.into_iter().map(|(n, d, a)| (n, d, a, true)));
    for (name, desc, about, indexed) in all {
        write_scene(out, name, &desc, about, indexed)?;
    }
    let moving = [
        ("satellite.json", satellite(), "A satellite: a 1 m cube bus, two solar arrays of three 1 x 1 m two-sided panels along x (groups \"array +x\", \"array -x\"), a hexagonal antenna on a boom (rad_geometry::scenes::satellite); satellite_motion.json turns the arrays."),
        ("room_cart.json", room_with_cart(0.5), "A 5 x 3 x 4 m room with a ceiling light, a table and a 0.5 m cube cart (group \"cart\") on the floor (rad_geometry::scenes::room_with_cart); cart_motion.json slides the cart."),
    ];
    for (name, desc, about) in moving {
        write_scene(out, name, &desc, about, false)?;
    }
    for (name, motion, about) in [
        ("satellite_motion.json", satellite_motion(36), "The satellite's two arrays turning about the x axis, 10 degrees a step, 36 steps (rad_geometry::scenes::satellite_motion)."),
        ("cart_motion.json", cart_motion(10), "The cart sliding 2.5 m along the floor in 10 steps, turning a quarter turn (rad_geometry::scenes::cart_motion)."),
    ] {
        let path = out.join(name);
        let text = motion.to_json(Some(about));
        write_atomic(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// Writes the scan-like sculpture galleries (~10^5 and ~10^6 triangles; 8.6 and 85 MB,
/// too large to commit) to `out`.
pub fn write_sculptures(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let about = "A gallery of scan-like sculptures (displaced icospheres with crowded and sparse triangles, deep crevices and thin horns) in a closed room with a ceiling lamp, every triangle one patch";
    for (name, build, what) in [
        (
            "sculptures_100k.json",
            sculptures_100k as fn() -> _,
            "102,400 triangles (rad_geometry::scenes::sculptures_100k)",
        ),
        (
            "sculptures_1m.json",
            sculptures_1m,
            "983,040 triangles (rad_geometry::scenes::sculptures_1m)",
        ),
    ] {
        write_scene(out, name, &build(), &format!("{about}: {what}."), true)?;
    }
    Ok(())
}

/// Checks a built scene and writes it as `out/name`.
fn write_scene(out: &Path, name: &str, desc: &SceneDesc, about: &str, indexed: bool) -> Result<()> {
    Scene::new(desc.clone())
        .with_context(|| format!("the {name} builder makes an invalid scene"))?;
    let text = if indexed {
        scene_desc_to_json_indexed(desc, Some(about))
    } else {
        scene_desc_to_json(desc, Some(about))
    };
    let path = out.join(name);
    write_atomic(&path, |w| w.write_all(text.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
