//! What a front end asks for, checked and settled once for both front ends (the
//! `coherad` binary and the Python package): the way to make rows (a method, auto's
//! pick, a caster), a solve's settings and how auto's pick settles against the
//! storage, and view factors' settings with a View3D file's own defaults. A bad value
//! is [`Error::Setting`], named as the binary's flag names it.

use crate::solve::{settle_auto, SceneSolveConfig, Storage};
use crate::viewfactors::{
    count_surfaces, Grouping, ViewFactorConfig, ViewFactorMethod, MAX_ORIGINS, MAX_SCRIPT_F,
};
use crate::{CasterKind, Error, RowMethod, SceneFile};
use rad_estimator::Mode;
use rad_hemisphere::Hemisphere;
use rad_solver::{Enclosure, Solver};
use std::path::PathBuf;
use std::str::FromStr;

/// The way to make rows a front end asks for (`--method` with `--estimator`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodChoice {
    /// [`RowMethod::auto_for`]'s pick; where it estimates, in this mode.
    Auto(Mode),
    Exact,
    Estimated(Mode),
}

impl FromStr for MethodChoice {
    type Err = Error;

    /// `auto`, `exact`, `estimated` (improved), `estimated/improved` or
    /// `estimated/faithful`.
    fn from_str(s: &str) -> Result<Self, Error> {
        Ok(match s {
            "auto" => MethodChoice::Auto(Mode::Improved),
            "exact" => MethodChoice::Exact,
            "estimated" | "estimated/improved" => MethodChoice::Estimated(Mode::Improved),
            "estimated/faithful" => MethodChoice::Estimated(Mode::Faithful),
            _ => {
                return Err(Error::Setting(format!(
                    "method {s:?}: expected \"auto\", \"exact\", \"estimated\", \
                     \"estimated/faithful\" or \"estimated/improved\""
                )))
            }
        })
    }
}

/// A method as picked for a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PickedMethod {
    pub method: RowMethod,
    /// Whether auto picked it.
    pub auto: bool,
    /// Where auto picked estimated rows: the share of the patches its windows estimate.
    pub auto_estimated_share: Option<f64>,
}

/// The method `choice` names for `scene`, its casts through `caster` (default: the
/// fastest for the scene, [`CasterKind::fastest_for`]).
pub fn pick_method(
    scene: &SceneFile,
    choice: MethodChoice,
    caster: Option<CasterKind>,
) -> Result<PickedMethod, Error> {
    let caster = caster.unwrap_or_else(|| CasterKind::fastest_for(&scene.scene));
    let (mode, auto, share) = match choice {
        MethodChoice::Exact => (None, false, None),
        MethodChoice::Estimated(mode) => (Some(mode), false, None),
        MethodChoice::Auto(mode) => match RowMethod::auto_for(&scene.scene)? {
            (picked, share) if !picked.is_exact() => (Some(mode), true, Some(share)),
            _ => (None, true, None),
        },
    };
    let method = match mode {
        Some(mode) => RowMethod::Estimated {
            mode,
            centres: caster,
        },
        None => RowMethod::Exact { caster },
    };
    Ok(PickedMethod {
        method,
        auto,
        auto_estimated_share: share,
    })
}

/// A solve as a front end asks for it; `None`: the default.
#[derive(Clone, Debug)]
pub struct SolveRequest {
    pub solver: Solver,
    /// Where the solve stops (stored: the residual; matrix-free and out of core: the
    /// largest pending radiosity over the largest radiosity).
    pub tolerance: Option<f64>,
    pub max_iterations: Option<u64>,
    /// Make the rows reciprocal first (`--raw` is `false`).
    pub reciprocal: bool,
    pub storage: Option<Storage>,
    /// Bytes the form factors may take ([`crate::DEFAULT_MEMORY_LIMIT`]).
    pub memory_limit: Option<usize>,
    pub temp_dir: Option<PathBuf>,
}

impl SolveRequest {
    /// The solve's settings: the tolerance (finite and > 0) and the iteration cap
    /// apply to stored and to shooting solves alike; raw rows are refused under
    /// progressive refinement, which cannot converge on them.
    pub fn config(&self) -> Result<SceneSolveConfig, Error> {
        if let Some(t) = self.tolerance.filter(|t| !(t.is_finite() && *t > 0.0)) {
            return Err(Error::Setting(format!(
                "--tolerance must be finite and > 0, not {t}"
            )));
        }
        if !self.reciprocal && self.solver == Solver::Progressive {
            return Err(Error::Setting(
                "--raw with --solver progressive cannot converge: shooting takes F_ji from \
                 F_ij by reciprocity, which raw rows hold only to their discretisation \
                 error; use --solver gauss-seidel, or drop --raw"
                    .into(),
            ));
        }
        let mut config = SceneSolveConfig {
            solver: self.solver,
            reciprocal: self.reciprocal,
            storage: self.storage,
            temp_dir: self.temp_dir.clone(),
            ..SceneSolveConfig::default()
        };
        if let Some(limit) = self.memory_limit {
            config.memory_limit = limit;
        }
        if let Some(t) = self.tolerance {
            config.config.tolerance = t;
            config.matrix_free.tolerance = t;
        }
        if let Some(n) = self.max_iterations {
            let n = usize::try_from(n).unwrap_or(usize::MAX);
            config.config.max_iterations = n;
            config.matrix_free.max_iterations = n;
        }
        Ok(config)
    }
}

/// The method a solve by `config` among `processes` makes rows with: auto's pick
/// settled against the storage ([`settle_auto`]: estimated rows give way to exact ones
/// where matrix-free solving is asked for or the only storage that fits), any other as
/// asked; and whether auto's pick changed.
pub fn settle_method(
    scene: &SceneFile,
    hemi: &Hemisphere,
    picked: &PickedMethod,
    config: &SceneSolveConfig,
    processes: usize,
) -> Result<(RowMethod, bool), Error> {
    if !picked.auto {
        return Ok((picked.method, false));
    }
    settle_auto(&scene.scene, hemi, picked.method, config, processes)
}

/// View factors as a front end asks for them; `None`: the default (a View3D file's own
/// where it gives one).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewFactorRequest {
    pub by: Option<Grouping>,
    pub method: Option<ViewFactorMethod>,
    /// The closed-form factors' quadrature tolerance (finite, > 0, below 1).
    pub tolerance: Option<f64>,
    pub origins: Option<u32>,
    pub enclosure: Option<Enclosure>,
    pub script_f: Option<bool>,
    pub caster: Option<CasterKind>,
}

impl ViewFactorRequest {
    /// The settings for `scene`, checked: by group for a View3D file (else by polygon),
    /// its `encl=1` a closed enclosure and its `emit=1` script-F unless asked
    /// otherwise; 1 to [`MAX_ORIGINS`] origins a side; script-F on at most
    /// [`MAX_SCRIPT_F`] surfaces. Also the number of surfaces.
    pub fn config(&self, scene: &SceneFile) -> Result<(ViewFactorConfig, usize), Error> {
        let v3 = scene.view3d.as_ref();
        let mut config = ViewFactorConfig::for_scene(&scene.scene);
        config.by = self.by.unwrap_or(if v3.is_some() {
            Grouping::Group
        } else {
            Grouping::Polygon
        });
        config.enclosure = self.enclosure.unwrap_or(if v3.is_some_and(|c| c.encl) {
            Enclosure::Closed
        } else {
            Enclosure::Raw
        });
        config.script_f = self.script_f.unwrap_or(v3.is_some_and(|c| c.emit));
        if let Some(origins) = self.origins {
            config.origins = origins;
        }
        if let Some(method) = self.method {
            config.method = method;
        }
        if let Some(t) = self.tolerance {
            if !(t.is_finite() && t > 0.0 && t < 1.0) {
                return Err(Error::Setting(format!(
                    "--tolerance {t}: give a relative tolerance in (0, 1), say 1e-10"
                )));
            }
            config.tolerance = t;
        }
        if let Some(caster) = self.caster {
            config.caster = caster;
        }
        if !(1..=MAX_ORIGINS).contains(&config.origins) {
            return Err(Error::Setting(format!(
                "--origins {} is invalid: give 1 to {MAX_ORIGINS} (N x N hemispheres a patch)",
                config.origins
            )));
        }
        let n_surfaces = count_surfaces(&scene.scene, config.by)?;
        if config.script_f && n_surfaces > MAX_SCRIPT_F {
            return Err(Error::Setting(format!(
                "--script-f solves a dense system of the surfaces: {n_surfaces} is over the \
                 limit of {MAX_SCRIPT_F} (use --by group, or fewer surfaces)"
            )));
        }
        Ok((config, n_surfaces))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_parse_or_are_refused_by_name() {
        assert_eq!(
            "auto".parse::<MethodChoice>().unwrap(),
            MethodChoice::Auto(Mode::Improved)
        );
        assert_eq!(
            "estimated/faithful".parse::<MethodChoice>().unwrap(),
            MethodChoice::Estimated(Mode::Faithful)
        );
        let e = "fast".parse::<MethodChoice>().unwrap_err().to_string();
        assert!(e.contains("\"fast\"") && e.contains("\"auto\""), "{e}");
    }

    #[test]
    fn solve_settings_are_checked_once() {
        let ask = |tolerance, reciprocal, solver| SolveRequest {
            solver,
            tolerance,
            max_iterations: Some(7),
            reciprocal,
            storage: None,
            memory_limit: None,
            temp_dir: None,
        };
        let c = ask(Some(1e-3), true, Solver::GaussSeidel).config().unwrap();
        assert_eq!(c.config.tolerance, 1e-3);
        assert_eq!(c.matrix_free.tolerance, 1e-3);
        assert_eq!(c.matrix_free.max_iterations, 7);
        assert_eq!(c.memory_limit, crate::DEFAULT_MEMORY_LIMIT);
        for t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = ask(Some(t), true, Solver::GaussSeidel)
                .config()
                .unwrap_err();
            assert!(e.to_string().contains("--tolerance"), "{e}");
        }
        let e = ask(None, false, Solver::Progressive).config().unwrap_err();
        assert!(e.to_string().contains("--raw"), "{e}");
    }
}
