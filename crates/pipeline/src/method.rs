//! Ways to make rows, each one value with a stable name: exact through a caster, or
//! estimated with a mode and its window centres (and fallbacks, and real rays) through
//! a caster. Every front end (the `coherad` flags, the reproduction, the benches)
//! names its method with these; nothing else branches on names.

use crate::Error;
use rad_estimator::{Mode, Schedule};
use rad_geometry::Scene;
use std::fmt;
use std::str::FromStr;

/// Which caster makes exact hemispheres.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CasterKind {
    /// The polygon scan ([`rad_hemisphere::Scan`]): each polygon tested on the cells of
    /// its angular box; the fastest on the bench scenes.
    Scan,
    /// A ray a cell through the voxel grid ([`rad_accel::VoxelGrid`]): the report's way.
    Grid,
    /// The polygon scan over a bounding volume hierarchy
    /// ([`rad_hemisphere::Hierarchy`]): subtrees hidden behind nearer hits or behind
    /// the tangent plane are skipped whole; the fastest on curved meshes.
    Hierarchy,
    /// The polygon scan over a mesh's flat pieces ([`rad_hemisphere::FacetScan`]): each
    /// facet's cells find their triangle in the facet's grid; the fastest on meshes of a
    /// few large flat pieces cut into many triangles.
    Facets,
}

impl CasterKind {
    pub const ALL: [CasterKind; 4] = [
        CasterKind::Scan,
        CasterKind::Grid,
        CasterKind::Hierarchy,
        CasterKind::Facets,
    ];

    /// Below this many polygons the plain scan is the default, at or above it the
    /// hierarchy (measured on the bench scenes, one core, 180 × 720: on the report's
    /// 185-polygon loft the two are within noise of each other; from the 3.7k-triangle
    /// Cornell mesh up the hierarchy is faster, 2.3 times on the 115k-triangle loft).
    pub const HIERARCHY_FROM: usize = 1024;

    /// From this many polygons a facet on average, the facet scan is the default for a
    /// scene of [`CasterKind::HIERARCHY_FROM`] polygons or more (measured on the bench
    /// scenes, one core, 180 × 720, `MESHES=1 cargo run --release -p rad-repro
    /// --example scan_check`: 640 a facet on the 115k-triangle loft, 2.1 times the
    /// hierarchy's speed; 160 on the 29k-triangle loft, 1.4 times; 80 on the loft cut a
    /// polygon a patch, 0.77 times; about 1 on a room with a curved 20k-triangle blob,
    /// 0.28 times).
    pub const FACETS_FROM: usize = 128;

    /// Its stable name: `scan`, `grid`, `hierarchy` or `facets`.
    pub fn name(self) -> &'static str {
        match self {
            CasterKind::Scan => "scan",
            CasterKind::Grid => "grid",
            CasterKind::Hierarchy => "hierarchy",
            CasterKind::Facets => "facets",
        }
    }

    /// The fastest caster for `scene` (the documented rule: the plain scan below
    /// [`CasterKind::HIERARCHY_FROM`] polygons; from there the facet scan where its
    /// facets hold [`CasterKind::FACETS_FROM`] polygons or more on average, else the
    /// hierarchy).
    pub fn fastest_for(scene: &rad_geometry::Scene) -> CasterKind {
        let polygons = scene.polygons().len();
        if polygons < CasterKind::HIERARCHY_FROM {
            CasterKind::Scan
        } else if polygons >= CasterKind::FACETS_FROM * scene.facets().len() {
            CasterKind::Facets
        } else {
            CasterKind::Hierarchy
        }
    }
}

/// Patches a scene needs at least for [`RowMethod::auto_for`] to estimate its rows.
pub const AUTO_ESTIMATED_FROM: usize = 20_000;

/// The share of a scene's patches its windows must estimate (rather than cast as
/// centres) for [`RowMethod::auto_for`] to estimate its rows.
pub const AUTO_ESTIMATED_SHARE: f64 = 0.5;

/// A way to make rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RowMethod {
    /// Every hemisphere cast exactly.
    Exact { caster: CasterKind },
    /// The report's 3 × 3 windows: centres cast exactly, the rest estimated with `mode`
    /// (improved mode's real rays and exact fallbacks through the same caster).
    Estimated { mode: Mode, centres: CasterKind },
}

impl RowMethod {
    /// What `coherad solve` makes rows with unless told: estimated rows (improved mode,
    /// centres by the fastest caster) where estimation pays, exact rows by the fastest
    /// caster elsewhere. Estimation pays on a scene of at least [`AUTO_ESTIMATED_FROM`]
    /// patches whose windows estimate at least [`AUTO_ESTIMATED_SHARE`] of them (a
    /// mesh whose triangles lie in planes: walls, floors); measured, 2 threads, 180 ×
    /// 720, the whole-scene rows' time exact over estimated (results/meshes.json,
    /// Table 1, centres by the hierarchy): the loft tessellated into 28,800 triangles
    /// 1.49 (85 % of its patches estimated), into 115,200 triangles 1.87 (87 %); not on
    /// 14,400 one-patch polygons (0.98, 85 %), nor on a curved 21,808-triangle mesh
    /// (0.93: 6 % estimated). With the facet scan as the tessellated lofts' caster the
    /// gain fell to 1.16 and 1.02 at 2fef7f3, 0.99 and 1.11 at 1708b90 (README,
    /// "Estimation on meshes"). Returns the method and the share estimated (0 where not
    /// counted).
    pub fn auto_for(scene: &Scene) -> Result<(RowMethod, f64), Error> {
        let caster = CasterKind::fastest_for(scene);
        let n = scene.patches().len();
        if n >= AUTO_ESTIMATED_FROM {
            let schedule = Schedule::of(scene.for_rows()?);
            let estimated: usize = schedule.windows().iter().map(|w| w.estimated.len()).sum();
            let share = estimated as f64 / n as f64;
            if share >= AUTO_ESTIMATED_SHARE {
                let method = RowMethod::Estimated {
                    mode: Mode::Improved,
                    centres: caster,
                };
                return Ok((method, share));
            }
            return Ok((RowMethod::Exact { caster }, share));
        }
        Ok((RowMethod::Exact { caster }, 0.0))
    }

    /// Every method, exact ones first.
    pub fn all() -> Vec<RowMethod> {
        let exact = CasterKind::ALL.map(|caster| RowMethod::Exact { caster });
        let estimated = Mode::ALL.into_iter().flat_map(|mode| {
            CasterKind::ALL.map(move |centres| RowMethod::Estimated { mode, centres })
        });
        exact.into_iter().chain(estimated).collect()
    }

    /// Its stable name, `exact/<caster>` or `estimated/<mode>/<caster>`, which
    /// [`RowMethod::from_str`] reads back.
    pub fn name(self) -> String {
        match self {
            RowMethod::Exact { caster } => format!("exact/{}", caster.name()),
            RowMethod::Estimated { mode, centres } => {
                format!("estimated/{}/{}", mode.name(), centres.name())
            }
        }
    }

    /// What the rows are, without the caster: `exact`, `estimated/faithful` or
    /// `estimated/improved`. Every caster gives the same rows, to the bit, so this is
    /// what form-factor and solution files record.
    pub fn rows_name(self) -> &'static str {
        match self {
            RowMethod::Exact { .. } => "exact",
            RowMethod::Estimated {
                mode: Mode::Faithful,
                ..
            } => "estimated/faithful",
            RowMethod::Estimated {
                mode: Mode::Improved,
                ..
            } => "estimated/improved",
        }
    }

    /// The caster of its exact hemispheres.
    pub fn caster(self) -> CasterKind {
        match self {
            RowMethod::Exact { caster } => caster,
            RowMethod::Estimated { centres, .. } => centres,
        }
    }

    /// The estimator mode, for an estimated method.
    pub fn mode(self) -> Option<Mode> {
        match self {
            RowMethod::Exact { .. } => None,
            RowMethod::Estimated { mode, .. } => Some(mode),
        }
    }

    pub fn is_exact(self) -> bool {
        self.mode().is_none()
    }
}

impl fmt::Display for CasterKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl fmt::Display for RowMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

fn bad(what: &'static str, input: &str, reason: String) -> Error {
    Error::Parse {
        what,
        input: input.to_string(),
        reason,
    }
}

impl FromStr for CasterKind {
    type Err = Error;

    fn from_str(s: &str) -> Result<CasterKind, Error> {
        caster(s).ok_or_else(|| {
            bad(
                "caster",
                s,
                "expected scan, grid, hierarchy or facets".into(),
            )
        })
    }
}

fn caster(s: &str) -> Option<CasterKind> {
    CasterKind::ALL.into_iter().find(|c| c.name() == s)
}

fn mode(s: &str) -> Option<Mode> {
    Mode::ALL.into_iter().find(|m| m.name() == s)
}

impl FromStr for RowMethod {
    type Err = Error;

    /// A [`RowMethod::name`]; the caster may be left out (then the scan), so that a
    /// file's [`RowMethod::rows_name`] reads too.
    fn from_str(s: &str) -> Result<RowMethod, Error> {
        let err = |reason: String| bad("row method", s, reason);
        let caster_of = |c: Option<&str>| match c {
            None => Ok(CasterKind::Scan),
            Some(c) => caster(c).ok_or_else(|| {
                err(format!(
                    "unknown caster {c:?}: expected scan, grid or hierarchy"
                ))
            }),
        };
        let parts: Vec<&str> = s.split('/').collect();
        match parts[..] {
            ["exact"] | ["exact", _] => Ok(RowMethod::Exact {
                caster: caster_of(parts.get(1).copied())?,
            }),
            ["estimated", m] | ["estimated", m, _] => Ok(RowMethod::Estimated {
                mode: mode(m).ok_or_else(|| {
                    err(format!(
                        "unknown estimator mode {m:?}: expected faithful or improved"
                    ))
                })?,
                centres: caster_of(parts.get(2).copied())?,
            }),
            _ => Err(err(
                "expected exact[/CASTER] or estimated/MODE[/CASTER], e.g. estimated/improved/scan"
                    .into(),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_read_back() {
        let all = RowMethod::all();
        assert_eq!(all.len(), 12);
        for m in all {
            assert_eq!(m.name().parse::<RowMethod>().unwrap(), m, "{m}");
            let short: RowMethod = m.rows_name().parse().unwrap();
            assert_eq!(short.rows_name(), m.rows_name());
        }
        assert_eq!(
            "estimated/improved/grid".parse::<RowMethod>().unwrap(),
            RowMethod::Estimated {
                mode: Mode::Improved,
                centres: CasterKind::Grid
            }
        );
        for bad in [
            "",
            "exact/",
            "exact/bvh",
            "estimated",
            "estimated/best",
            "x/y/z/w",
        ] {
            let e = bad.parse::<RowMethod>().unwrap_err().to_string();
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
    }
}
