//! Surface-to-surface view factors through the library, as `coherad viewfactors` makes
//! them: load a scene file, settle the settings (a closed enclosure here), make the
//! factors, print each surface's largest and write the matrix as CSV.
//!
//! `cargo run --release -p rad-pipeline --example viewfactors -- SCENE OUT.csv [45x180]`

use rad_pipeline::output::write_atomic;
use rad_pipeline::viewfactors::{view_factors, write_view_factors, MatrixFormat, ViewFactorRun};
use rad_pipeline::{
    parse_resolution, Enclosure, Hemisphere, HemisphereConfig, SceneFile, ViewFactorRequest,
};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out, rest @ ..] = args.as_slice() else {
        return Err("usage: viewfactors SCENE OUT.csv [N_THETAxN_PHI]".into());
    };
    let scene = SceneFile::load(Path::new(scene), None)?;
    let (nt, np) = parse_resolution(rest.first().map_or("45x180", String::as_str))?;
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    // By polygon (a View3D file: by its surfaces), reciprocal, rows summing to 1.
    let request = ViewFactorRequest {
        enclosure: Some(Enclosure::Closed),
        ..ViewFactorRequest::default()
    };
    let (config, n_surfaces) = request.config(&scene)?;
    let vf = view_factors(&scene.scene, &hemi, &config, &|_| {})?;
    for (i, row) in vf.matrix.rows.iter().enumerate() {
        let (j, f) = row
            .iter()
            .copied()
            .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        println!(
            "{} sees {} most: F = {f:.6}",
            vf.names[i], vf.names[j as usize]
        );
    }
    let run = ViewFactorRun {
        scene: scene.path.display().to_string(),
        scene_hash: scene.hash_text(),
        resolution: (nt, np),
    };
    write_atomic(Path::new(out), |w| {
        write_view_factors(w, &vf, &run, MatrixFormat::Csv)
    })?;
    println!(
        "{n_surfaces} surfaces, largest |1 - row sum| {:.1e}; wrote {out}",
        vf.report.fixed.row_sum.max
    );
    Ok(())
}
