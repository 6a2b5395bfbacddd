//! Settings of the estimator (no defaults here: the caller chooses, the JSON records).

use crate::Error;

/// Which estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// The report's method: reproject patch ids and fill holes; casts no rays.
    Faithful,
    /// Reproject polygons, then resolve every cell with its own ray against the polygons
    /// guessed for it and its 8 neighbours (a real ray where all of them miss).
    Improved,
}

impl Mode {
    /// Both modes, the report's first.
    pub const ALL: [Mode; 2] = [Mode::Faithful, Mode::Improved];

    /// Its stable name: `faithful` or `improved`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Faithful => "faithful",
            Mode::Improved => "improved",
        }
    }
}

/// How a cell that nothing lands in (a hole) is filled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HoleFill {
    /// Keep H1's entry for that cell.
    KeepSource,
    /// Take the nearest written cell of the same ring (H1's entry if the ring is empty).
    RingNeighbour,
}

/// Which ratio decides that a point is far enough for the first-order formulas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThresholdTest {
    /// The report's test: R / |C1C2| above the threshold (with the exact form also near
    /// the pole, sinθ < 0.05, where the first-order φ formula blows up).
    Distance,
    /// R sinθ / |C1C2| above the threshold: the first-order error in φ grows as
    /// |C1C2| / (R sinθ), so this bounds it directly.
    Lateral,
}

/// How points are reprojected from H1 to H2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reprojection {
    /// Exact Cartesian reprojection for every point.
    Exact,
    /// First-order formulas (1) where the test passes `threshold`, exact elsewhere.
    FirstOrder { test: ThresholdTest, threshold: f64 },
}

impl Reprojection {
    /// First order where R sinθ > 10 |C1C2|, exact elsewhere: the measured choice of
    /// coherad's defaults (as accurate as exact reprojection in the cube, where the
    /// report's R / |C1C2| > 10 is not: see README).
    pub const LATERAL_10: Reprojection = Reprojection::FirstOrder {
        test: ThresholdTest::Lateral,
        threshold: 10.0,
    };
}

/// Settings of an estimation run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorConfig {
    pub mode: Mode,
    pub fill: HoleFill,
    pub reprojection: Reprojection,
    /// Propagate rays that hit a patch on its polygon's boundary and reproject every
    /// patch they cross (§3.5.2).
    pub boundary_lists: bool,
    /// Improved mode: a patch whose estimate needs real rays for more than this share
    /// of its cells is computed exactly instead.
    pub max_real_ray_share: f64,
    /// Improved mode: the polygons are guessed on a grid s times coarser both ways,
    /// s the largest stride up to this one (1 to [`MAX_GUESS_STRIDE`]) that divides
    /// both N_θ and N_φ. At 1 every point of H1 is splatted and each cell is tested
    /// against the guesses of its 3 × 3 cells; at s > 1 the points of H1's cells
    /// (sI, sJ) are splatted and each cell is tested against the guesses of the 3 × 3
    /// coarse cells around its own. (With boundary lists, only the lists of the cell
    /// whose point stands for its s × s cells are splatted.)
    pub guess_stride: u32,
}

/// The largest [`EstimatorConfig::guess_stride`].
pub const MAX_GUESS_STRIDE: u32 = 4;

impl EstimatorConfig {
    /// Checks the numeric settings.
    pub fn validate(&self) -> Result<(), Error> {
        if let Reprojection::FirstOrder { threshold, .. } = self.reprojection {
            if !(threshold.is_finite() && threshold > 0.0) {
                return Err(Error::Config {
                    name: "threshold",
                    value: threshold,
                    rule: "must be finite and > 0",
                });
            }
        }
        if !(self.max_real_ray_share.is_finite() && (0.0..=1.0).contains(&self.max_real_ray_share))
        {
            return Err(Error::Config {
                name: "max_real_ray_share",
                value: self.max_real_ray_share,
                rule: "must be in [0, 1]",
            });
        }
        if !(1..=MAX_GUESS_STRIDE).contains(&self.guess_stride) {
            return Err(Error::Config {
                name: "guess_stride",
                value: self.guess_stride as f64,
                rule: "must be in 1..=4",
            });
        }
        Ok(())
    }
}
