//! Radiosity of a scene through the library, as `coherad solve` makes it: load a scene
//! file, pick the rows' method, solve, write the solution file.
//!
//! `cargo run --release -p rad-pipeline --example solve -- SCENE OUT.json [45x180]`

use rad_pipeline::output::write_atomic;
use rad_pipeline::solve::solve_scene;
use rad_pipeline::{
    parse_resolution, pick_method, settle_method, Hemisphere, HemisphereConfig, MethodChoice, Mode,
    SceneFile, SolveRequest, Solver,
};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out, rest @ ..] = args.as_slice() else {
        return Err("usage: solve SCENE OUT.json [N_THETAxN_PHI]".into());
    };
    let scene = SceneFile::load(Path::new(scene), None)?;
    let (nt, np) = parse_resolution(rest.first().map_or("45x180", String::as_str))?;
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    // The defaults of `coherad solve`: Gauss-Seidel on reciprocal rows, the storage and
    // the method (exact, or estimated where that pays) chosen for the scene.
    let config = SolveRequest {
        solver: Solver::GaussSeidel,
        tolerance: None,
        max_iterations: None,
        reciprocal: true,
        storage: None,
        memory_limit: None,
        temp_dir: None,
    }
    .config()?;
    let picked = pick_method(&scene, MethodChoice::Auto(Mode::Improved), None)?;
    let (method, _) = settle_method(&scene, &hemi, &picked, &config, 1)?;
    let (file, solved, _) = solve_scene(&scene, &hemi, method, &config, &|_| {})?;
    let text = serde_json::to_string_pretty(&file)?;
    write_atomic(Path::new(out), |w| w.write_all(text.as_bytes()))?;
    let report = &solved.solution.report;
    println!(
        "{} patches by {method}: {} iterations, residual {:.1e}, energy imbalance {:.1e}; wrote {out}",
        file.n_patches, report.iterations, report.residual, solved.balance.relative_imbalance
    );
    Ok(())
}
