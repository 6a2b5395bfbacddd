//! `reproduce` and `scenes`: run the experiments, write results and scene files.

use anyhow::{Context, Result};
use rad_geometry::file::{scene_desc_to_json, scene_desc_to_json_indexed};
use rad_geometry::scenes::{
    blob_room, cornell_box, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
    urban_canyon, CORNELL_PATCH_MM,
};
use rad_geometry::Scene;
use rad_pipeline::output::write_atomic;
use rad_repro::Provenance;
use std::path::Path;
use std::time::Instant;

pub fn reproduce(quick: bool, out: &Path, root: &Path, args: &[String]) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let t = Instant::now();
    let provenance = provenance(root, args);
    eprintln!(
        "coherad reproduce{}: writing to {}",
        if quick { " --quick" } else { "" },
        out.display()
    );
    let progress = |stage: &str, step: usize, of: usize| {
        eprintln!(
            "  {stage}: {step}/{of} ({:.1} s)",
            t.elapsed().as_secs_f64()
        );
    };
    // The solves first, each a child process on an otherwise idle machine: a child's
    // peak resident set (wait4's ru_maxrss) starts from this process's own at the fork
    // (Linux keeps the forked copy's high-water mark across exec), and this process
    // grows to gigabytes in the sections below (every child then reported 3,511 MiB).
    let solves = crate::solves::run(quick, root, &root.join("target").join("solves-work"))?;
    let r = rad_repro::reproduce::run(quick, &progress).context("the reproduction failed")?;
    let write = |name: &str, text: String| -> Result<()> {
        let path = out.join(name);
        write_atomic(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("  wrote {}", path.display());
        Ok(())
    };
    write("cube_accuracy.json", r.cube_json(&provenance))?;
    write("loft_checks.json", r.loft_json(&provenance))?;
    write("cube_error.json", r.estimation_json(&provenance))?;
    write("loft_speedup.json", r.loft_speedup_json(&provenance))?;
    write("radiosity.json", r.radiosity_json(&provenance))?;
    write("scaling.json", r.scaling_json(&provenance))?;
    write("viewfactors.json", r.viewfactors_json(&provenance))?;
    write("ranks.json", r.ranks_json(&provenance))?;
    write("meshes.json", r.meshes_json(&provenance))?;
    let plot = crate::plot::scaling_png(&r.scaling)?;
    let path = out.join("scaling.png");
    write_atomic(&path, |w| w.write_all(&plot))
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("  wrote {}", path.display());
    // Images: EXR, and PNG previews; the loft's renders share the exact one's exposure.
    let mut shared: Option<f32> = None;
    for (stem, img, group) in &r.radiosity.images {
        let exr = out.join(format!("{stem}.exr"));
        rad_pipeline::images::write_exr(&exr, img)
            .with_context(|| format!("writing {}", exr.display()))?;
        let exposure = if *group {
            *shared.get_or_insert_with(|| rad_pipeline::images::auto_exposure(img))
        } else if stem.contains("reldiff") {
            1.0
        } else {
            rad_pipeline::images::auto_exposure(img)
        };
        let png = out.join(format!("{stem}.png"));
        rad_pipeline::images::write_png(&png, img, exposure)
            .with_context(|| format!("writing {}", png.display()))?;
        eprintln!("  wrote {} and .png", exr.display());
    }
    write("solves.json", crate::solves::json(&provenance, &solves))?;
    write("solves.md", crate::solves::markdown(&solves))?;
    let wall = t.elapsed().as_secs_f64();
    write(
        "REPORT.md",
        r.report(&provenance, wall) + &crate::solves::markdown(&solves),
    )?;
    eprintln!("done in {wall:.1} s");
    Ok(())
}

/// `cargo xtask solves [--quick]`: the solve section alone, into `out` (solves.json,
/// solves.md).
pub fn solves_alone(quick: bool, out: &Path, root: &Path, args: &[String]) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let provenance = provenance(root, args);
    let solves = crate::solves::run(quick, root, &root.join("target").join("solves-work"))?;
    for (name, text) in [
        ("solves.json", crate::solves::json(&provenance, &solves)),
        ("solves.md", crate::solves::markdown(&solves)),
    ] {
        let path = out.join(name);
        write_atomic(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("  wrote {}", path.display());
    }
    Ok(())
}

/// Where the figures come from: this revision, machine, thread count and command.
fn provenance(root: &Path, args: &[String]) -> Provenance {
    Provenance {
        git_revision: git_revision(root),
        cpu_model: cpu_model(),
        nproc: std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1),
        threads: rayon::current_num_threads(),
        profile: if cfg!(debug_assertions) {
            "debug".into()
        } else {
            "release".into()
        },
        command: format!("cargo xtask {}", args.join(" ")),
    }
}

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
        Scene::new(desc.clone())
            .with_context(|| format!("the {name} builder makes an invalid scene"))?;
        let text = if indexed {
            scene_desc_to_json_indexed(&desc, Some(about))
        } else {
            scene_desc_to_json(&desc, Some(about))
        };
        let path = out.join(name);
        write_atomic(&path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn git_revision(root: &Path) -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into())
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}
