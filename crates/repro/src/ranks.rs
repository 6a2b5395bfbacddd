//! A simulated larger run: many processes (threads of this one, through
//! `rad_pipeline::share::in_threads`, with the collectives and errors of MPI's ranks)
//! sharing the loft's rows and solves, each checked against one process to the bit,
//! with the balance of their shares in work units: ranks.json and the report's section.
//! No MPI needed; `coherad` under `mpirun` runs the same pipeline code.

use crate::Error;
use rad_geometry::scenes::{cornell_box, loft};
use rad_geometry::Scene;
use rad_pipeline::share::{in_threads, shared_rows, SharedRun};
use rad_pipeline::solve::{solve_scene, solve_scene_shared, SceneSolveConfig, SolutionFile};
use rad_pipeline::{
    rows, CasterKind, Hemisphere, HemisphereConfig, Mode, RowMethod, SceneFile, Solver, Storage,
};
use serde::Serialize;
use std::time::Instant;

/// One shared run at one process count.
#[derive(Clone, Debug, Serialize)]
pub struct RankRun {
    /// What was shared: `rows <method>` or `solve <storage> <solver>`.
    pub what: String,
    pub scene: String,
    pub processes: usize,
    /// Every process's share, in work units.
    pub units: Vec<f64>,
    /// The largest share over the mean.
    pub balance: f64,
    /// The same rows, or the same solution file (timings apart), as one process, to the
    /// bit.
    pub identical: bool,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Ranks {
    pub resolution: [u32; 2],
    pub runs: Vec<RankRun>,
}

fn scene_file(name: &str, scene: Scene) -> SceneFile {
    SceneFile {
        path: name.into(),
        scene,
        hash: 1,
        view3d: None,
        triangulation: Default::default(),
        repair: Default::default(),
        repaired: false,
        notes: Vec::new(),
    }
}

fn balance(units: &[f64]) -> f64 {
    let mean = units.iter().sum::<f64>() / units.len() as f64;
    units.iter().fold(0.0f64, |m, &u| m.max(u)) / mean
}

fn without_timings(file: &SolutionFile) -> serde_json::Value {
    let mut v = serde_json::to_value(file).expect("solution files serialise");
    if let Some(o) = v.as_object_mut() {
        o.remove("timings");
    }
    v
}

/// The loft's rows (exact, and estimated: whole polygons a share) on 2 to 16 processes
/// (quick: 2 to 8, at a lower resolution), and solves of the Cornell box (stored and
/// gathered, matrix-free, and by rows with Jacobi sweeps) on 2 to 8: every one checked
/// against one process. An error if any differs.
pub fn run(quick: bool, progress: &(dyn Fn(&str, usize, usize) + Sync)) -> Result<Ranks, Error> {
    let (nt, np) = if quick { (8, 32) } else { (24, 96) };
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    let counts: &[usize] = if quick { &[2, 3, 8] } else { &[2, 3, 4, 8, 16] };
    let mut runs = Vec::new();
    let lofts = scene_file("loft", Scene::new(loft())?);
    let all: Vec<u32> = (0..lofts.scene.patches().len() as u32).collect();
    let methods = [
        RowMethod::Exact {
            caster: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: CasterKind::Scan,
        },
    ];
    for (k, method) in methods.into_iter().enumerate() {
        progress("simulated ranks: rows", k, methods.len());
        let one = rows(&lofts.scene, &hemi, method, &all, &|_| {})?;
        for &size in counts {
            let t = Instant::now();
            let got = in_threads(size, |peers| {
                let run = SharedRun {
                    scene: &lofts.scene,
                    scene_hash: lofts.hash,
                    method,
                    what: b"ranks",
                };
                let mut make = |ids: &[u32]| rows(&lofts.scene, &hemi, method, ids, &|_| {});
                shared_rows(run, &all, peers, false, &mut make)
            });
            let seconds = t.elapsed().as_secs_f64();
            let first = got.into_iter().next().expect("one process at least")?;
            let units: Vec<f64> = first.shares.iter().map(|s| s.units).collect();
            let identical = first.rows.is_some_and(|r| r.rows == one.rows);
            runs.push(RankRun {
                what: format!("rows {}", method.name()),
                scene: "loft".into(),
                processes: size,
                balance: balance(&units),
                units,
                identical,
                seconds,
            });
        }
    }
    let cornell = scene_file("cornell", Scene::new(cornell_box(120.0))?);
    let method = methods[0];
    let solves = [
        (Storage::Stored, Solver::GaussSeidel),
        (Storage::MatrixFree, Solver::Progressive),
        (Storage::Stored, Solver::Jacobi),
    ];
    for (k, (storage, solver)) in solves.into_iter().enumerate() {
        progress("simulated ranks: solves", k, solves.len());
        let opts = SceneSolveConfig {
            solver,
            storage: Some(storage),
            ..SceneSolveConfig::default()
        };
        let (want, _, _) = solve_scene(&cornell, &hemi, method, &opts, &|_| {})?;
        let want = without_timings(&want);
        let all: Vec<u32> = (0..cornell.scene.patches().len() as u32).collect();
        for &size in counts.iter().filter(|&&s| s <= 8) {
            let t = Instant::now();
            let got = in_threads(size, |peers| {
                solve_scene_shared(&cornell, &hemi, method, &opts, &|_| {}, peers)
            });
            let seconds = t.elapsed().as_secs_f64();
            let first = got.into_iter().next().expect("one process at least")?;
            let identical = first.is_some_and(|(file, _, _)| without_timings(&file) == want);
            let shares = rad_pipeline::share::shares(&cornell.scene, method, &all, size);
            let units: Vec<f64> = shares.iter().map(|s| s.units).collect();
            runs.push(RankRun {
                what: format!("solve {} {}", storage.name(), solver.name()),
                scene: "cornell".into(),
                processes: size,
                balance: balance(&units),
                units,
                identical,
                seconds,
            });
        }
    }
    if let Some(r) = runs.iter().find(|r| !r.identical) {
        return Err(Error::Peers(format!(
            "simulated ranks: {} on the {} with {} processes differs from one process",
            r.what, r.scene, r.processes
        )));
    }
    Ok(Ranks {
        resolution: [nt, np],
        runs,
    })
}
