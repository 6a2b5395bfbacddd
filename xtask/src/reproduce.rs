//! `cargo xtask reproduce`: the report's experiments and solves, written to results/
//! (or `--out`), and the README's figures table when it writes results/.

use crate::provenance::provenance;
use crate::solves::{REPORT_FULL, REPORT_QUICK};
use crate::{write_file, write_text};
use anyhow::{Context, Result};
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
    let progress = |stage: &str, step: usize, of: usize| say_progress(&t, stage, step, of);
    // The solves first, each a child process on an otherwise idle machine: a child's
    // peak resident set (wait4's ru_maxrss) starts from this process's own at the fork
    // (Linux keeps the forked copy's high-water mark across exec), and this process
    // grows in the sections below.
    let cases = if quick { REPORT_QUICK } else { REPORT_FULL };
    let solves = crate::solves::run(cases, root, &root.join("target").join("solves-work"))?;
    let r = rad_repro::reproduce::run(quick, &progress).context("the reproduction failed")?;
    write_text(out, "cube_accuracy.json", &r.cube_json(&provenance))?;
    write_text(out, "loft_checks.json", &r.loft_json(&provenance))?;
    write_text(out, "cube_error.json", &r.estimation_json(&provenance))?;
    write_text(out, "loft_speedup.json", &r.loft_speedup_json(&provenance))?;
    write_text(out, "radiosity.json", &r.radiosity_json(&provenance))?;
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
    write_text(
        out,
        "solves.json",
        &crate::solves::json(&provenance, &solves),
    )?;
    let solves_md = crate::solves::markdown(&solves, "solves.json");
    write_text(out, "solves.md", &solves_md)?;
    let wall = t.elapsed().as_secs_f64();
    write_text(
        out,
        "REPORT.md",
        &(r.report(&provenance, wall) + &solves_md),
    )?;
    crate::figures::update_readme(root, out)?;
    eprintln!("done in {wall:.1} s");
    Ok(())
}

/// `cargo xtask bench`: the extended measurements (`sections`, default all: scaling,
/// viewfactors, ranks, meshes, motion, solves), written to results/ (or `--out`) beside the
/// reproduction's files, with BENCH.md.
pub fn bench(
    quick: bool,
    sections: &[String],
    out: &Path,
    root: &Path,
    args: &[String],
) -> Result<()> {
    use rad_repro::bench::Section;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let t = Instant::now();
    let provenance = provenance(root, args);
    let chosen: Vec<Section> = Section::ALL
        .into_iter()
        .filter(|s| sections.is_empty() || sections.iter().any(|n| n == s.name()))
        .collect();
    let solves_asked = sections.is_empty() || sections.iter().any(|n| n == "solves");
    eprintln!(
        "coherad bench{}: writing to {}",
        if quick { " --quick" } else { "" },
        out.display()
    );
    let progress = |stage: &str, step: usize, of: usize| say_progress(&t, stage, step, of);
    // (The solves first, as in the reproduction: their peak memory is their own.)
    let solves = if solves_asked {
        let cases = if quick {
            crate::solves::BENCH_QUICK
        } else {
            crate::solves::BENCH_FULL
        };
        crate::solves::run(cases, root, &root.join("target").join("solves-work"))?
    } else {
        Vec::new()
    };
    let b = rad_repro::bench::run(quick, &chosen, &progress).context("the bench failed")?;
    let files = [
        ("scaling.json", b.scaling_json(&provenance)),
        ("viewfactors.json", b.viewfactors_json(&provenance)),
        ("ranks.json", b.ranks_json(&provenance)),
        ("meshes.json", b.meshes_json(&provenance)),
        ("motion.json", b.motion_json(&provenance)),
    ];
    for (name, text) in files {
        if let Some(text) = text {
            write_text(out, name, &text)?;
        }
    }
    if let Some(scaling) = &b.scaling {
        write_file(
            &out.join("scaling.png"),
            &crate::plot::scaling_png(scaling)?,
        )?;
    }
    let mut solves_md = String::new();
    if solves_asked {
        let json = crate::solves::json(&provenance, &solves);
        write_text(out, "solves_large.json", &json)?;
        solves_md = crate::solves::markdown(&solves, "solves_large.json");
    }
    let wall = t.elapsed().as_secs_f64();
    write_text(out, "BENCH.md", &(b.report(&provenance, wall) + &solves_md))?;
    crate::figures::update_readme(root, out)?;
    eprintln!("done in {wall:.1} s");
    Ok(())
}

/// A section's progress on standard error, with the seconds since `t`.
fn say_progress(t: &Instant, stage: &str, step: usize, of: usize) {
    eprintln!(
        "  {stage}: {step}/{of} ({:.1} s)",
        t.elapsed().as_secs_f64()
    );
}
