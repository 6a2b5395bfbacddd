//! `coherad._native`: the Rust half of the Python package (PyO3). Scenes load through
//! `rad_pipeline::SceneFile`, rows, view factors and solves run through the pipeline as
//! the `coherad` binary runs them, with the GIL released; arrays cross as little-endian
//! bytes that `coherad/__init__.py` wraps in numpy and scipy. Errors are
//! `coherad.CoheradError` with the binary's messages.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rad_pipeline::solve::{solve_over_motion, solve_scene, Solved};
use rad_pipeline::viewfactors::{
    view_factors, view_factors_over_motion, Grouping, ViewFactorConfig, ViewFactorMethod,
    ViewFactors,
};
use rad_pipeline::{
    pick_method, reflectance_of, settle_method, CasterKind, Enclosure, Hemisphere,
    HemisphereConfig, LoadConfig, MethodChoice, PickedMethod, RowMethod, SceneFile, SolveRequest,
    Solver, ViewFactorRequest,
};
use std::path::PathBuf;

create_exception!(
    coherad,
    CoheradError,
    PyException,
    "An error from coherad: a bad file, a bad value; the message names what and where."
);

fn fail(e: impl std::fmt::Display) -> PyErr {
    CoheradError::new_err(e.to_string())
}

/// Runs `work` without the GIL; a panic (a bug: every bad input is an error) becomes a
/// `CoheradError` saying so, rather than PyO3's `PanicException`.
fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> Result<T, rad_pipeline::Error> + Send,
) -> PyResult<T> {
    let caught = py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)));
    match caught {
        Ok(result) => result.map_err(fail),
        Err(p) => {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(fail(format!("internal error (please report it): {what}")))
        }
    }
}

/// Most surfaces `view_factors_raw` returns as a dense matrix (8 bytes a pair).
const MAX_DENSE_SURFACES: usize = 10_000;

/// A loaded, validated scene.
#[pyclass(module = "coherad._native", frozen)]
struct Scene {
    file: SceneFile,
    /// How it was read (a motion reads its description again).
    config: LoadConfig,
}

/// Little-endian bytes of a slice of plain numbers.
fn bytes_of<T: Copy, const N: usize>(py: Python<'_>, v: &[T], to: fn(T) -> [u8; N]) -> Py<PyBytes> {
    let mut out = Vec::with_capacity(v.len() * N);
    for &x in v {
        out.extend_from_slice(&to(x));
    }
    PyBytes::new(py, &out).unbind()
}

/// The row method of `method` ("auto", `coherad solve`'s default, "exact",
/// "estimated", "estimated/faithful" or "estimated/improved") through `caster`
/// (default: the fastest for the scene), as the binary picks it.
fn row_method(scene: &SceneFile, method: &str, caster: Option<&str>) -> PyResult<PickedMethod> {
    let caster = caster
        .map(str::parse::<CasterKind>)
        .transpose()
        .map_err(fail)?;
    let choice = method.parse::<MethodChoice>().map_err(fail)?;
    pick_method(scene, choice, caster).map_err(fail)
}

fn hemisphere((nt, np): (u32, u32)) -> PyResult<Hemisphere> {
    Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(fail)
}

#[pymethods]
impl Scene {
    /// The file it was loaded from.
    #[getter]
    fn path(&self) -> String {
        self.file.path.display().to_string()
    }
    /// Its fingerprint, as solution files record it.
    #[getter]
    fn scene_hash(&self) -> String {
        self.file.hash_text()
    }
    #[getter]
    fn n_patches(&self) -> usize {
        self.file.scene.patches().len()
    }
    #[getter]
    fn n_polygons(&self) -> usize {
        self.file.scene.polygons().len()
    }
    /// Warnings and notes from loading (what `--triangulate` and `--repair` did or
    /// would do, clamped values).
    #[getter]
    fn notes(&self) -> Vec<String> {
        let notes = self.file.load_notes();
        notes.into_iter().map(|n| n.text).collect()
    }

    /// The patches as bytes: centre (f32 × 3), normal (f32 × 3), area (f64), polygon (u32).
    fn patches_raw(&self, py: Python<'_>) -> (Py<PyBytes>, Py<PyBytes>, Py<PyBytes>, Py<PyBytes>) {
        let p = self.file.scene.patches();
        let centre: Vec<f32> = p.iter().flat_map(|x| x.center.to_array()).collect();
        let normal: Vec<f32> = p.iter().flat_map(|x| x.normal.to_array()).collect();
        let area: Vec<f64> = p.iter().map(|x| x.area).collect();
        let polygon: Vec<u32> = p.iter().map(|x| x.polygon).collect();
        (
            bytes_of(py, &centre, f32::to_le_bytes),
            bytes_of(py, &normal, f32::to_le_bytes),
            bytes_of(py, &area, f64::to_le_bytes),
            bytes_of(py, &polygon, u32::to_le_bytes),
        )
    }

    /// Form-factor rows as CSR bytes: (rows asked for as u32, indptr as i64, column
    /// indices as u32, values as f64, back and escaped form factor per row as f64).
    #[pyo3(signature = (resolution = (180, 720), method = "exact", caster = None, patches = None))]
    #[allow(clippy::type_complexity)]
    fn form_factors_raw(
        &self,
        py: Python<'_>,
        resolution: (u32, u32),
        method: &str,
        caster: Option<&str>,
        patches: Option<Vec<u32>>,
    ) -> PyResult<(
        Py<PyBytes>,
        Py<PyBytes>,
        Py<PyBytes>,
        Py<PyBytes>,
        Py<PyBytes>,
        Py<PyBytes>,
    )> {
        let method = row_method(&self.file, method, caster)?.method;
        let hemi = hemisphere(resolution)?;
        let n = self.file.scene.patches().len() as u32;
        let ids: Vec<u32> = patches.unwrap_or_else(|| (0..n).collect());
        if let Some(bad) = ids.iter().find(|&&p| p >= n) {
            return Err(fail(format!(
                "patch {bad} is out of range: the scene has {n} patches"
            )));
        }
        let scene = &self.file.scene;
        let made = detached(py, || {
            rad_pipeline::rows(scene, &hemi, method, &ids, &|_| {})
        })?;
        let mut indptr = Vec::with_capacity(made.rows.len() + 1);
        let (mut cols, mut vals) = (Vec::new(), Vec::new());
        let (mut back, mut escaped) = (Vec::new(), Vec::new());
        indptr.push(0i64);
        for row in &made.rows {
            for &(j, f) in &row.entries {
                cols.push(j);
                vals.push(f);
            }
            indptr.push(cols.len() as i64);
            back.push(row.back);
            escaped.push(row.escaped);
        }
        Ok((
            bytes_of(py, &ids, u32::to_le_bytes),
            bytes_of(py, &indptr, i64::to_le_bytes),
            bytes_of(py, &cols, u32::to_le_bytes),
            bytes_of(py, &vals, f64::to_le_bytes),
            bytes_of(py, &back, f64::to_le_bytes),
            bytes_of(py, &escaped, f64::to_le_bytes),
        ))
    }

    /// Surface view factors: (names, the dense matrix as f64 bytes row by row, areas,
    /// a dict of the enclosure report).
    /// With `motion` (a motion file), a list of those, one a step.
    #[pyo3(signature = (by = None, origins = None, enclosure = None, resolution = (180, 720), caster = None, script_f = None, method = None, tolerance = None, motion = None))]
    #[allow(clippy::too_many_arguments)]
    fn view_factors_raw(
        &self,
        py: Python<'_>,
        by: Option<&str>,
        origins: Option<u32>,
        enclosure: Option<&str>,
        resolution: (u32, u32),
        caster: Option<&str>,
        script_f: Option<bool>,
        method: Option<&str>,
        tolerance: Option<f64>,
        motion: Option<PathBuf>,
    ) -> PyResult<Vec<RawViewFactors>> {
        let scene = &self.file.scene;
        let grouping = |by: &str| match by {
            "patch" => Ok(Grouping::Patch),
            "polygon" => Ok(Grouping::Polygon),
            "group" => Ok(Grouping::Group),
            _ => Err(fail(format!(
                "by {by:?}: expected \"patch\", \"polygon\" or \"group\""
            ))),
        };
        let enclosure_of = |e: &str| match e {
            "raw" => Ok(Enclosure::Raw),
            "reciprocal" => Ok(Enclosure::Reciprocal),
            "closed" => Ok(Enclosure::Closed),
            _ => Err(fail(format!(
                "enclosure {e:?}: expected \"raw\", \"reciprocal\" or \"closed\""
            ))),
        };
        // The binary's defaults and checks: a View3D file's surfaces by group, its encl
        // and emit.
        let method = match method {
            None => None,
            Some("auto") => Some(ViewFactorMethod::Auto),
            Some("exact") => Some(ViewFactorMethod::Exact),
            Some("hemisphere") => Some(ViewFactorMethod::Hemisphere),
            Some(m) => {
                return Err(fail(format!(
                    "method {m:?}: expected \"auto\", \"exact\" or \"hemisphere\""
                )))
            }
        };
        let request = ViewFactorRequest {
            by: by.map(grouping).transpose()?,
            method,
            tolerance,
            origins,
            enclosure: enclosure.map(enclosure_of).transpose()?,
            script_f,
            caster: caster
                .map(str::parse::<CasterKind>)
                .transpose()
                .map_err(fail)?,
        };
        let (opts, n) = request.config(&self.file).map_err(fail)?;
        let by = opts.by.name();
        if n > MAX_DENSE_SURFACES {
            return Err(fail(format!(
                "view factors by {by}: {n} surfaces, over the {MAX_DENSE_SURFACES} a dense matrix is made for ({} GB); write it with `coherad viewfactors --format mtx` (scipy.io.mmread reads it) or `--format bin` (the README gives its numpy reader)",
                (n as f64 * n as f64 * 8.0 / 1e9).round()
            )));
        }
        let hemi = hemisphere(resolution)?;
        let Some(motion) = motion else {
            let vf = py
                .detach(|| view_factors(scene, &hemi, &opts, &|_| {}))
                .map_err(fail)?;
            return Ok(vec![packed(py, &vf, &opts)?]);
        };
        let made = py.detach(|| {
            let (_, desc) = SceneFile::load_keeping(&self.file.path, &self.config, true)?;
            let desc = desc.expect("kept when asked");
            let motion = rad_pipeline::read_motion(&motion).map_err(rad_pipeline::Error::from)?;
            let mut steps = Vec::new();
            view_factors_over_motion(&desc, scene, &motion, &hemi, &opts, &|_, _| {}, &mut |s| {
                steps.push(s.vf);
                Ok(())
            })?;
            Ok::<_, rad_pipeline::Error>(steps)
        });
        made.map_err(fail)?
            .iter()
            .map(|vf| packed(py, vf, &opts))
            .collect()
    }

    /// Radiosity of every patch, as `coherad solve` computes it: a list of (f64 × 3 bytes
    /// a patch, a dict of the solver's report), one solve, or one a step of `motion` (as
    /// `coherad solve --motion`: exact rows, each step's from the step before's, and
    /// Gauss-Seidel from the step before's radiosities).
    #[pyo3(signature = (resolution = (180, 720), method = "auto", caster = None, solver = "gauss-seidel", tolerance = None, reciprocal = true, motion = None))]
    #[allow(clippy::too_many_arguments)]
    fn solve_raw(
        &self,
        py: Python<'_>,
        resolution: (u32, u32),
        method: &str,
        caster: Option<&str>,
        solver: &str,
        tolerance: Option<f64>,
        reciprocal: bool,
        motion: Option<String>,
    ) -> PyResult<Vec<(Py<PyBytes>, Py<PyDict>)>> {
        let picked = row_method(&self.file, method, caster)?;
        let hemi = hemisphere(resolution)?;
        let solver = match solver {
            "gauss-seidel" => Solver::GaussSeidel,
            "progressive" => Solver::Progressive,
            "jacobi" => Solver::Jacobi,
            _ => {
                return Err(fail(format!(
                    "solver {solver:?}: expected \"gauss-seidel\", \"progressive\" or \"jacobi\""
                )))
            }
        };
        let request = SolveRequest {
            solver,
            tolerance,
            max_iterations: None,
            reciprocal,
            storage: None,
            memory_limit: None,
            temp_dir: None,
        };
        let opts = request.config().map_err(fail)?;
        let file = &self.file;
        if let Some(motion) = motion {
            let caster = match picked.method {
                RowMethod::Exact { caster } => caster,
                RowMethod::Estimated { centres, .. } if picked.auto => centres,
                RowMethod::Estimated { .. } => {
                    return Err(fail(
                        "a motion makes exact rows (each step's from the step before's hemispheres): use method=\"exact\" or \"auto\"",
                    ))
                }
            };
            let made = py.detach(|| {
                let (_, desc) = SceneFile::load_keeping(&file.path, &self.config, true)?;
                let desc = desc.expect("kept when asked");
                let motion = rad_pipeline::read_motion(motion.as_ref())
                    .map_err(rad_pipeline::Error::from)?;
                let mut steps = Vec::new();
                let both = (file, &desc);
                solve_over_motion(both, &motion, &hemi, caster, &opts, &|_, _| {}, &mut |s| {
                    steps.push(s.solved);
                    Ok(())
                })?;
                Ok::<_, rad_pipeline::Error>(steps)
            });
            return made
                .map_err(fail)?
                .iter()
                .map(|s| solved_for_python(py, s))
                .collect();
        }
        // (Auto's estimated rows give way to exact ones where only matrix-free solving
        // fits, as `coherad solve` does.)
        let (method, _) = settle_method(file, &hemi, &picked, &opts, 1).map_err(fail)?;
        let (_, solved, _) = detached(py, || solve_scene(file, &hemi, method, &opts, &|_| {}))?;
        Ok(vec![solved_for_python(py, &solved)?])
    }
}

/// A solve for Python: the radiosities as f64 bytes, and a dict of its report.
fn solved_for_python(py: Python<'_>, solved: &Solved) -> PyResult<(Py<PyBytes>, Py<PyDict>)> {
    let flat: Vec<f64> = solved
        .solution
        .radiosity
        .iter()
        .flatten()
        .copied()
        .collect();
    let report = PyDict::new(py);
    let r = &solved.solution.report;
    report.set_item("converged", r.converged)?;
    report.set_item("iterations", r.iterations)?;
    report.set_item("residual", r.residual)?;
    report.set_item("relative_imbalance", solved.balance.relative_imbalance)?;
    report.set_item("storage", solved.matrix.storage.to_string())?;
    Ok((bytes_of(py, &flat, f64::to_le_bytes), report.unbind()))
}

/// One matrix for Python: (names, the dense matrix as f64 bytes row by row, areas, a
/// dict of the enclosure report).
type RawViewFactors = (Vec<String>, Py<PyBytes>, Py<PyBytes>, Py<PyDict>);

fn packed(py: Python<'_>, vf: &ViewFactors, opts: &ViewFactorConfig) -> PyResult<RawViewFactors> {
    let by = opts.by.name();
    let n = vf.names.len();
    let mut dense = vec![0.0f64; n * n];
    for (i, row) in vf.matrix.rows.iter().enumerate() {
        for &(j, f) in row {
            dense[i * n + j as usize] = f;
        }
    }
    let report = PyDict::new(py);
    let r = &vf.report;
    report.set_item("enclosure", opts.enclosure.name())?;
    report.set_item("origins", opts.origins)?;
    report.set_item("by", by)?;
    report.set_item("script_f", vf.script_f)?;
    report.set_item("max_row_sum_error", r.fixed.row_sum.max)?;
    report.set_item("max_reciprocity_error", r.fixed.reciprocity.max)?;
    report.set_item("raw_max_row_sum_error", r.raw.row_sum.max)?;
    report.set_item("raw_max_reciprocity_error", r.raw.reciprocity.max)?;
    report.set_item("escaped", vf.escaped.clone())?;
    report.set_item("method", opts.method.name())?;
    report.set_item("exact_pairs", vf.exact_pairs)?;
    report.set_item("hemisphere_pairs", vf.hemisphere_pairs)?;
    report.set_item("back", vf.back.clone())?;
    Ok((
        vf.names.clone(),
        bytes_of(py, &dense, f64::to_le_bytes),
        bytes_of(py, &vf.matrix.area, f64::to_le_bytes),
        report.unbind(),
    ))
}

/// Loads and validates a scene file (any format the `coherad` binary reads).
#[pyfunction]
#[pyo3(signature = (path, patch_size = None, triangulate = false, reflectance = None, materials = None, repair = false, weld = None))]
fn load(
    py: Python<'_>,
    path: PathBuf,
    patch_size: Option<f64>,
    triangulate: bool,
    reflectance: Option<Vec<f64>>,
    materials: Option<PathBuf>,
    repair: bool,
    weld: Option<f64>,
) -> PyResult<Scene> {
    let reflectance = reflectance
        .as_deref()
        .map(reflectance_of)
        .transpose()
        .map_err(fail)?;
    let config = LoadConfig {
        patch_size,
        triangulate,
        reflectance,
        materials,
        repair,
        weld,
    };
    let file = py
        .detach(|| SceneFile::load_with(&path, &config))
        .map_err(fail)?;
    Ok(Scene { file, config })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add("CoheradError", m.py().get_type::<CoheradError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
