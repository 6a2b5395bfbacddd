//! A scene solved from rows averaged over `N`² origins a patch (area to area, as
//! `coherad viewfactors --origins N` makes them) instead of one at the patch's centre:
//! how far a coarse scene's polygons move when each patch gathers over its area.
//! Writes the radiosities as a solution-like JSON (`radiosity`, `ambient`) that
//! `python/reference/compare.py` reads.
//!
//! `cargo run --release -p rad-repro --example area_solve -- SCENE.json N OUT.json
//! [RES]`

use rad_pipeline::solve::{solve, surfaces, SceneSolveConfig};
use rad_pipeline::viewfactors::{area_rows, ViewFactorConfig};
use rad_pipeline::{Hemisphere, HemisphereConfig, SceneFile};
use rad_solver::FormFactors;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, n, out, rest @ ..] = &args[..] else {
        return Err("usage: area_solve SCENE.json N OUT.json [RES]".into());
    };
    let scene = SceneFile::load(scene.as_ref(), None)?;
    let (nt, np) = rad_pipeline::parse_resolution(rest.first().map_or("180x720", |s| s))?;
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    let opts = ViewFactorConfig {
        origins: n.parse()?,
        ..ViewFactorConfig::for_scene(&scene.scene)
    };
    let all: Vec<u32> = (0..scene.scene.patches().len() as u32).collect();
    let rows = area_rows(&scene.scene, &hemi, &opts, &all, &|_| {})?;
    let ff = FormFactors::from_rows(all.len(), rows.iter().map(|r| (r.patch, &r.entries[..])))?;
    let solved = solve(&ff, &surfaces(&scene.scene), &SceneSolveConfig::default())?;
    let json = serde_json::json!({
        "radiosity": solved.solution.radiosity,
        "ambient": solved.solution.ambient,
    });
    std::fs::write(out, serde_json::to_string(&json)?)?;
    Ok(())
}
