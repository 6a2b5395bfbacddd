//! From rows to radiosities: a scene's surfaces, the reciprocal matrix, a solve with
//! its energy balance, and the solution file that `coherad solve` writes and
//! `coherad render` reads (with serde: errors give the line and column).

use crate::{Error, Progress, RowMethod, SceneFile, Storage, DEFAULT_MEMORY_LIMIT};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;
use rad_solver::{
    energy_balance, gauss_seidel, jacobi, progressive, EnergyBalance, FormFactors, PairBuilder,
    PairMatrix, Reciprocity, Solution, SolveConfig, Solver, Surfaces,
};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// Area, emission and reflectance of every patch, from the scene's materials.
pub fn surfaces(scene: &Scene) -> Surfaces {
    let n = scene.patches().len();
    let mut s = Surfaces {
        area: Vec::with_capacity(n),
        emission: Vec::with_capacity(n),
        reflectance: Vec::with_capacity(n),
    };
    for (i, p) in scene.patches().iter().enumerate() {
        let m = scene.patch_material(i as PatchId);
        s.area.push(p.area);
        s.emission.push(m.emission.0);
        s.reflectance.push(m.reflectance.0);
    }
    s
}

/// How to solve.
#[derive(Clone, Debug)]
pub struct SolveOptions {
    pub solver: Solver,
    pub config: SolveConfig,
    /// Make the matrix reciprocal first ([`FormFactors::reciprocal`]); without it the
    /// energy balance holds only to the reciprocity error of the rows.
    pub reciprocal: bool,
    /// How to hold the form factors; `None`: by [`crate::storage::choose`] within
    /// `memory_limit`.
    pub storage: Option<Storage>,
    /// Bytes the form factors may take (the stored matrix, or matrix-free solving's
    /// rows): [`DEFAULT_MEMORY_LIMIT`].
    pub memory_limit: usize,
    /// When matrix-free solving stops: the largest unshot radiosity over the largest
    /// radiosity at most `tolerance` ([`MATRIX_FREE_TOLERANCE`] by default), or
    /// `max_iterations` shots.
    pub matrix_free: SolveConfig,
    /// Where out-of-core solving writes its rows (an unnamed file, gone when the process
    /// ends); `None`: the system's temporary folder (`TMPDIR`, else `/tmp`).
    pub temp_dir: Option<std::path::PathBuf>,
}

impl SolveOptions {
    /// The folder out-of-core solving writes to.
    pub fn temp_dir(&self) -> std::path::PathBuf {
        self.temp_dir.clone().unwrap_or_else(std::env::temp_dir)
    }
}

/// The default stopping point of matrix-free solving (its measure: the largest unshot
/// radiosity over the largest radiosity).
pub const MATRIX_FREE_TOLERANCE: f64 = 1e-4;

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            solver: Solver::GaussSeidel,
            config: SolveConfig::default(),
            reciprocal: true,
            storage: None,
            memory_limit: DEFAULT_MEMORY_LIMIT,
            matrix_free: SolveConfig {
                tolerance: MATRIX_FREE_TOLERANCE,
                ..SolveConfig::default()
            },
            temp_dir: None,
        }
    }
}

/// Tolerance and iteration cap of the reciprocal scaling.
pub(crate) const SCALING_TOLERANCE: f64 = 1e-9;
pub(crate) const SCALING_ITERATIONS: usize = 5_000;

/// A solve and what it says about energy.
#[derive(Clone, Debug)]
pub struct Solved {
    pub solution: Solution,
    /// What the reciprocal scaling changed (None if it was not asked for).
    pub reciprocity: Option<Reciprocity>,
    /// Energy balance under the matrix solved.
    pub balance: EnergyBalance,
    /// Energy balance of the same radiosities under the rows as computed (before the
    /// scaling): off by their reciprocity error.
    pub raw_balance: EnergyBalance,
    pub scaling_seconds: f64,
    pub solve_seconds: f64,
    /// The matrix solved: its stored pairs and the bytes they take.
    pub matrix: MatrixJson,
}

impl Solved {
    /// A matrix-free or out-of-core run as a solve: its energy accounts, no reciprocal
    /// scaling; `disk_bytes`: the rows' file, if any.
    fn shot(
        storage: Storage,
        solution: Solution,
        m: rad_solver::MatrixFreeStats,
        solve_seconds: f64,
        disk_bytes: u64,
    ) -> Solved {
        let balance = EnergyBalance {
            emitted: m.emitted,
            absorbed: m.absorbed,
            escaped: std::array::from_fn(|c| m.escaped[c] + m.unshot[c]),
            relative_imbalance: m.relative_imbalance,
        };
        Solved {
            solution,
            reciprocity: None,
            balance,
            raw_balance: balance,
            scaling_seconds: 0.0,
            solve_seconds,
            matrix: MatrixJson {
                storage: storage.name(),
                pairs: 0,
                bytes: m.cached_bytes,
                rows_made: m.rows_made,
                cached_rows: m.cached_rows,
                disk_bytes,
            },
        }
    }
}

/// The stored matrix of a solve.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MatrixJson {
    /// [`Storage::name`].
    pub storage: &'static str,
    /// Pairs `i < j` with `F_ij` or `F_ji` stored ([`PairMatrix::n_pairs`]).
    pub pairs: usize,
    /// Bytes of the rows as computed and of their reciprocal scaling, together (matrix
    /// free: of the rows kept for shooters that shoot again).
    pub bytes: usize,
    /// Rows made (stored: one a patch; matrix-free: one a shot not served by the cache;
    /// out of core: rows read back from the file) and rows kept at the end.
    pub rows_made: usize,
    pub cached_rows: usize,
    /// Bytes of the rows' temporary file (out of core; 0 otherwise).
    pub disk_bytes: u64,
}

/// Solves `ff` (rows as computed) for `surfaces`: [`solve_pairs`] on the same values.
pub fn solve(ff: &FormFactors, surfaces: &Surfaces, opts: &SolveOptions) -> Result<Solved, Error> {
    solve_pairs(&PairMatrix::from_form_factors(ff), surfaces, opts)
}

/// Solves `ff` (rows as computed, stored by pairs) for `surfaces`.
pub fn solve_pairs(
    ff: &PairMatrix,
    surfaces: &Surfaces,
    opts: &SolveOptions,
) -> Result<Solved, Error> {
    let t = Instant::now();
    let (matrix, reciprocity) = if opts.reciprocal {
        let (m, r) = ff.reciprocal(&surfaces.area, SCALING_TOLERANCE, SCALING_ITERATIONS)?;
        (Some(m), Some(r))
    } else {
        (None, None)
    };
    let scaling_seconds = t.elapsed().as_secs_f64();
    let m = matrix.as_ref().unwrap_or(ff);
    let t = Instant::now();
    let solution = match opts.solver {
        Solver::GaussSeidel => gauss_seidel(m, surfaces, &opts.config)?,
        Solver::Progressive => progressive(m, surfaces, &opts.config)?,
        Solver::Jacobi => jacobi(m, surfaces, &opts.config)?,
    };
    let solve_seconds = t.elapsed().as_secs_f64();
    let balance = energy_balance(m, surfaces, &solution.radiosity);
    let raw_balance = if matrix.is_some() {
        energy_balance(ff, surfaces, &solution.radiosity)
    } else {
        balance
    };
    Ok(Solved {
        solution,
        reciprocity,
        balance,
        raw_balance,
        scaling_seconds,
        solve_seconds,
        matrix: MatrixJson {
            storage: Storage::Stored.name(),
            rows_made: ff.n_patches(),
            cached_rows: 0,
            disk_bytes: 0,
            pairs: ff.n_pairs(),
            bytes: ff.pattern_bytes()
                + ff.heap_bytes()
                + matrix.as_ref().map_or(0, |m| m.heap_bytes()),
        },
    })
}

/// The solver's part of a solution file.
#[derive(Clone, Debug, Serialize)]
pub struct SolverJson {
    pub solver: &'static str,
    pub tolerance: f64,
    pub iterations: usize,
    pub residual: f64,
    pub converged: bool,
    pub reciprocal: bool,
    pub reciprocity: Option<ReciprocityJson>,
    pub energy: EnergyJson,
}

#[derive(Clone, Debug, Serialize)]
pub struct ReciprocityJson {
    pub max_input_asymmetry: f64,
    pub median_input_asymmetry: f64,
    pub mean_row_l1_change: f64,
    pub max_row_sum_error: f64,
    pub iterations: usize,
    pub converged: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct EnergyJson {
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub escaped: [f64; 3],
    pub relative_imbalance: f64,
    /// The same radiosities under the rows as computed.
    pub relative_imbalance_unscaled_rows: f64,
}

impl SolverJson {
    pub fn new(s: &Solved, opts: &SolveOptions) -> SolverJson {
        let r = &s.solution.report;
        SolverJson {
            solver: r.solver.name(),
            tolerance: if s.matrix.storage != Storage::Stored.name() {
                opts.matrix_free.tolerance
            } else {
                opts.config.tolerance
            },
            iterations: r.iterations,
            residual: r.residual,
            converged: r.converged,
            reciprocal: s.reciprocity.is_some(),
            reciprocity: s.reciprocity.map(|r| ReciprocityJson {
                max_input_asymmetry: r.max_input_asymmetry,
                median_input_asymmetry: r.median_input_asymmetry,
                mean_row_l1_change: r.mean_row_l1_change,
                max_row_sum_error: r.max_row_sum_error,
                iterations: r.iterations,
                converged: r.converged,
            }),
            energy: EnergyJson {
                emitted: s.balance.emitted,
                absorbed: s.balance.absorbed,
                escaped: s.balance.escaped,
                relative_imbalance: s.balance.relative_imbalance,
                relative_imbalance_unscaled_rows: s.raw_balance.relative_imbalance,
            },
        }
    }
}

/// The solution file of `coherad solve`.
#[derive(Clone, Debug, Serialize)]
pub struct SolutionFile {
    /// The scene file, as given.
    pub scene: String,
    /// Its fingerprint ([`SceneFile::hash_text`]): a solution is read back only against
    /// the very scene it was made for.
    pub scene_hash: String,
    pub resolution: [u32; 2],
    /// [`RowMethod::rows_name`].
    pub method: &'static str,
    pub n_patches: usize,
    pub solver: SolverJson,
    /// Seconds: form factors, reciprocal scaling, solve.
    pub timings: Timings,
    /// The stored matrix.
    pub matrix: MatrixJson,
    /// Progressive refinement's ambient term (added for display as `ρ · ambient`).
    pub ambient: [f64; 3],
    /// Radiosity per patch, in patch order: `radiosity[i]` is patch i's RGB.
    pub radiosity: Vec<[f64; 3]>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct Timings {
    pub form_factors_seconds: f64,
    pub scaling_seconds: f64,
    pub solve_seconds: f64,
}

/// Every row of `scene` by `method`, made reciprocal unless told otherwise, solved:
/// the solution file, the solve (its reciprocity and energy balance) and the rows'
/// counts. Rows are streamed into the pair storage as they are made
/// ([`crate::rows_streamed`]), never held as rows; `progress(n)` gets the rows done.
pub fn solve_scene(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SolveOptions,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(SolutionFile, Solved, EstimateStats), Error> {
    let solved = solve_scene_shared(scene, hemi, method, opts, progress, &crate::share::Alone)?;
    Ok(solved.expect("one process solves"))
}

/// What a method [`RowMethod::auto_for`] picked becomes for a solve with `opts` among
/// `processes` processes: estimated rows stay where a storage that takes them (stored,
/// out of core) is asked for, or fits the limit and the temporary folder; where
/// matrix-free solving is asked for, or is the only storage that fits, the rows are made
/// exactly (matrix-free solving casts each shooter's row), by the estimate's caster.
/// Returns the method and whether it changed (exact methods never do).
pub fn settle_auto(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SolveOptions,
    processes: usize,
) -> Result<(RowMethod, bool), Error> {
    let RowMethod::Estimated { centres, .. } = method else {
        return Ok((method, false));
    };
    let exact = RowMethod::Exact { caster: centres };
    match opts.storage {
        Some(Storage::MatrixFree) => Ok((exact, true)),
        Some(_) => Ok((method, false)),
        None if opts.solver == Solver::Jacobi => Ok((method, false)),
        None => {
            let temp = (processes == 1).then(|| opts.temp_dir());
            let (limit, temp) = (opts.memory_limit, temp.as_deref());
            if crate::storage::choose(scene, hemi, method, limit, temp).is_ok() {
                return Ok((method, false));
            }
            Ok(
                match crate::storage::choose(scene, hemi, exact, limit, temp) {
                    Ok(_) => (exact, true),
                    Err(_) => (method, false),
                },
            )
        }
    }
}

/// [`solve_scene`] shared among `peers` (MPI ranks, say), the same solution to the bit
/// whatever their number: stored, each makes its share of the rows ([`crate::share`]),
/// gathered on the first, which solves; matrix-free, every process runs the same
/// shooting, each making its share of every batch's rows, which all of them gather.
/// `None` on the processes but the first.
pub fn solve_scene_shared(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SolveOptions,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn crate::share::Peers,
) -> Result<Option<(SolutionFile, Solved, EstimateStats)>, Error> {
    if !opts.reciprocal && opts.solver == Solver::Progressive {
        return Err(Error::Parse {
            what: "solver",
            input: "progressive".into(),
            reason: "cannot converge on raw rows: shooting takes F_ji from F_ij by \
                     reciprocity, which raw rows hold only to their discretisation error; \
                     use Gauss-Seidel, or reciprocal rows"
                .into(),
        });
    }
    let n = scene.scene.patches().len();
    let storage = match opts.storage {
        Some(s) => s,
        // (Its rows are shared by rows: each process's share must fit the limit.)
        None if opts.solver == Solver::Jacobi => {
            let (limit, size) = (opts.memory_limit, peers.size());
            crate::storage::check_by_rows(&scene.scene, hemi, method, limit, size)?;
            Storage::Stored
        }
        None => {
            // (Out of core is one process's: its rows go to its own disk.)
            let temp = (peers.size() == 1).then(|| opts.temp_dir());
            let limit = opts.memory_limit;
            crate::storage::choose(&scene.scene, hemi, method, limit, temp.as_deref())?
        }
    };
    if opts.solver == Solver::Jacobi {
        if storage != Storage::Stored {
            return Err(Error::Parse {
                what: "solver",
                input: "jacobi".into(),
                reason: "sweeps stored rows (--storage stored); matrix-free and out-of-core \
                         solving shoot, by progressive refinement"
                    .into(),
            });
        }
        return crate::by_rows::solve_by_rows(scene, hemi, method, opts, progress, peers);
    }
    let t = Instant::now();
    if storage == Storage::MatrixFree {
        let (solution, m) = crate::storage::solve_matrix_free(
            scene,
            hemi,
            method,
            &surfaces(&scene.scene),
            opts,
            progress,
            peers,
        )?;
        if peers.rank() > 0 {
            return Ok(None);
        }
        let solved = Solved::shot(storage, solution, m, t.elapsed().as_secs_f64(), 0);
        check_finite(&solved)?;
        let stats = EstimateStats {
            exact: m.rows_made,
            ..EstimateStats::default()
        };
        return Ok(Some((
            solution_file(scene, hemi, method, opts, &solved, 0.0),
            solved,
            stats,
        )));
    }
    if storage == Storage::OutOfCore {
        return solve_out_of_core(scene, hemi, method, opts, progress, peers);
    }
    let mut builder = PairBuilder::new(n);
    let rows_progress = |k| progress(Progress::Rows(k));
    let stats = if peers.size() == 1 {
        crate::rows_streamed(&scene.scene, hemi, method, &rows_progress, &mut |made| {
            for r in &made.rows {
                builder.push_row(r.patch, &r.entries)?;
            }
            Ok(())
        })?
    } else {
        let all: Vec<PatchId> = (0..n as PatchId).collect();
        let what = solve_key(hemi, method, opts);
        let run = crate::share::SharedRun {
            scene: &scene.scene,
            scene_hash: scene.hash,
            method,
            what: what.as_bytes(),
        };
        let shared = crate::share::shared_rows(run, &all, peers, false, &mut |ids| {
            crate::rows(&scene.scene, hemi, method, ids, &rows_progress)
        })?;
        let Some(made) = shared.rows else {
            return Ok(None);
        };
        // (Each row dropped once pushed.)
        for r in made.rows {
            builder.push_row(r.patch, &r.entries)?;
        }
        made.stats
    };
    let raw = builder.finish()?;
    let form_factors_seconds = t.elapsed().as_secs_f64();
    let solved = solve_pairs(&raw, &surfaces(&scene.scene), opts)?;
    drop(raw);
    check_finite(&solved)?;
    let file = solution_file(scene, hemi, method, opts, &solved, form_factors_seconds);
    Ok(Some((file, solved, stats)))
}

/// [`solve_scene_shared`] out of core ([`crate::storage::solve_out_of_core`]): one
/// process only.
fn solve_out_of_core(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SolveOptions,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn crate::share::Peers,
) -> Result<Option<(SolutionFile, Solved, EstimateStats)>, Error> {
    let storage = Storage::OutOfCore;
    if peers.size() > 1 {
        return Err(Error::Parse {
            what: "storage",
            input: storage.name().into(),
            reason: "out-of-core solving runs in one process (its rows go to that \
                     process's disk); shared among processes, use --storage stored or \
                     matrix-free"
                .into(),
        });
    }
    let surfaces = surfaces(&scene.scene);
    let (solution, m, stats, out) =
        crate::storage::solve_out_of_core(&scene.scene, hemi, method, &surfaces, opts, progress)?;
    let solved = Solved::shot(storage, solution, m, out.shoot_seconds, out.file_bytes);
    check_finite(&solved)?;
    Ok(Some((
        solution_file(scene, hemi, method, opts, &solved, out.rows_seconds),
        solved,
        stats,
    )))
}

/// What processes sharing a solve must agree on besides the scene (for
/// [`crate::share::run_fingerprint`]).
pub(crate) fn solve_key(hemi: &Hemisphere, method: RowMethod, opts: &SolveOptions) -> String {
    format!(
        "solve {}x{} {} {opts:?}",
        hemi.n_theta(),
        hemi.n_phi(),
        method.name()
    )
}

/// The solution file of a solve.
pub(crate) fn solution_file(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SolveOptions,
    solved: &Solved,
    form_factors_seconds: f64,
) -> SolutionFile {
    SolutionFile {
        scene: scene.path.display().to_string(),
        scene_hash: scene.hash_text(),
        resolution: [hemi.n_theta() as u32, hemi.n_phi() as u32],
        method: method.rows_name(),
        n_patches: scene.scene.patches().len(),
        solver: SolverJson::new(solved, opts),
        timings: Timings {
            form_factors_seconds,
            scaling_seconds: solved.scaling_seconds,
            solve_seconds: solved.solve_seconds,
        },
        matrix: solved.matrix,
        ambient: solved.solution.ambient,
        radiosity: solved.solution.radiosity.clone(),
    }
}

/// Refuses a solve that produced a non-finite radiosity, ambient term or energy figure.
pub(crate) fn check_finite(solved: &Solved) -> Result<(), Error> {
    let bad = |what: String, value: f64, place| Err(Error::NonFinite { what, value, place });
    let s = &solved.solution;
    for (i, b) in s.radiosity.iter().enumerate() {
        if let Some(&c) = b.iter().find(|c| !c.is_finite()) {
            return bad(format!("the radiosity of patch {i}"), c, "the solver");
        }
    }
    if let Some(&c) = s.ambient.iter().find(|c| !c.is_finite()) {
        return bad("the ambient term".into(), c, "the solver");
    }
    if !s.report.residual.is_finite() {
        return bad("the residual".into(), s.report.residual, "the solver");
    }
    let e = &solved.balance;
    if !e.relative_imbalance.is_finite() {
        return bad(
            "the energy imbalance".into(),
            e.relative_imbalance,
            "the energy balance",
        );
    }
    Ok(())
}

/// What [`read_solution`] reads of a solution file.
#[derive(Deserialize)]
struct SolutionIn {
    scene_hash: Option<String>,
    radiosity: Vec<[f64; 3]>,
    #[serde(default)]
    ambient: [f64; 3],
}

/// Reads the radiosities of the solution file `path`, for display (ambient term
/// added), and checks them against `scene`: made for that very scene file (its
/// fingerprint), the right count, finite and non-negative.
pub fn read_solution(path: &Path, scene: &SceneFile) -> Result<Vec<[f64; 3]>, Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        action: "read",
        path: path.to_path_buf(),
        source,
    })?;
    parse_solution(&text, scene).map_err(|reason| Error::Solution {
        path: path.to_path_buf(),
        reason,
    })
}

/// [`read_solution`] of a file's text; the error's reason.
fn parse_solution(text: &str, scene: &SceneFile) -> Result<Vec<[f64; 3]>, String> {
    let v: SolutionIn =
        serde_json::from_str(text).map_err(|e| format!("not a solution file: {e}"))?;
    let want = scene.hash_text();
    match v.scene_hash {
        Some(h) if h == want => {}
        Some(h) => {
            return Err(format!(
                "made for another scene: its scene_hash is {h}, {} (as loaded, with \
                 --patch-size if given) is {want}; solve this scene again",
                scene.path.display()
            ))
        }
        None => {
            return Err(
                "has no scene_hash (written by an older coherad?): solve the scene again".into(),
            )
        }
    }
    let n = scene.scene.patches().len();
    if v.radiosity.len() != n {
        return Err(format!(
            "{} radiosities for a scene of {n} patches",
            v.radiosity.len()
        ));
    }
    let check = |x: [f64; 3], what: &str| {
        if x.iter().all(|c| c.is_finite() && *c >= 0.0) {
            Ok(x)
        } else {
            Err(format!("{what} is {x:?}, not three finite numbers >= 0"))
        }
    };
    let ambient = check(v.ambient, "ambient")?;
    let s = surfaces(&scene.scene);
    v.radiosity
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let r = check(x, &format!("radiosity of patch {i}"))?;
            Ok(std::array::from_fn(|c| {
                r[c] + s.reflectance[i][c] * ambient[c]
            }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rad_geometry::scenes::cube;

    fn cube_file(hash: u64) -> SceneFile {
        SceneFile {
            path: "cube.json".into(),
            scene: Scene::new(cube(2)).unwrap(),
            hash,
            view3d: None,
            triangulation: Default::default(),
            notes: Vec::new(),
        }
    }

    #[test]
    fn solution_files_are_checked_against_the_scene() {
        let scene = cube_file(7);
        let file = |b: &[[f64; 3]], hash: &str| {
            format!(
                "{{\"scene_hash\": \"{hash}\", \"radiosity\": {}, \"ambient\": [1, 0, 0]}}",
                serde_json::to_string(b).unwrap()
            )
        };
        let ok = file(&[[0.5, 0.25, 0.0]; 24], &scene.hash_text());
        let b = parse_solution(&ok, &scene).unwrap();
        assert_eq!(b[3], [0.5 + 0.7, 0.25, 0.0]);
        let other = file(&[[0.5, 0.25, 0.0]; 24], &cube_file(8).hash_text());
        let mut bad = vec![[0.5, 0.25, 0.0]; 24];
        bad[5][1] = -1.0;
        for (text, want) in [
            ("{".to_string(), "line 1 column 1"),
            ("{}".to_string(), "missing field `radiosity`"),
            ("{\"radiosity\": 3}".to_string(), "invalid type"),
            (other, "made for another scene"),
            ("{\"radiosity\": []}".to_string(), "no scene_hash"),
            (
                file(&[[1.0; 3]], &scene.hash_text()),
                "1 radiosities for a scene of 24",
            ),
            (file(&bad, &scene.hash_text()), "radiosity of patch 5"),
        ] {
            let e = parse_solution(&text, &scene).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
    }
}
