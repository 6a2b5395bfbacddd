//! What a solve gives: the solve with its energy balance ([`Solved`]), the solution
//! file that `coherad solve` writes and `coherad render` reads (with serde: errors give
//! the line and column), and the checks on both.

use super::config::{SceneSolveConfig, Storage};
use crate::{Error, RowMethod, SceneFile};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;
use rad_solver::{EnergyBalance, Reciprocity, Solution, Surfaces};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A solve's answer on the process that speaks for the run: the solution file, the
/// solve and the rows' counts; `None` on the other processes sharing the run.
pub(crate) type Answer = Option<(SolutionFile, Solved, EstimateStats)>;

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
    pub(crate) fn shot(
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
    pub fn new(s: &Solved, opts: &SceneSolveConfig) -> SolverJson {
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

/// The solution file of a solve.
pub(crate) fn solution_file(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
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
            repair: Default::default(),
            repaired: false,
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
