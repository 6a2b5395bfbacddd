//! Integration tests of rad-solver: closed forms in `analytic`, properties in `props`.

mod analytic;
mod pairs;
mod props;
mod rowset;
mod shooting;

use rad_solver::{FormFactors, Surfaces};

/// A random closed enclosure of `n >= 3` patches (each coupled to the next two, so it
/// is connected): a random sparse symmetric coupling `W`, areas `A_i = Σ_j W_ij` and
/// rows `F_ij = W_ij / A_i` (so reciprocal with unit row sums, as a real enclosure is),
/// stored as [`FormFactors::reciprocal`] stores it.
///
/// (Rows drawn at random and normalised, with random areas, are not always an
/// enclosure: with three patches, one larger than the other two together can see
/// only them, and no reciprocal scaling with those row sums exists.)
pub fn enclosure(n: usize, seed: u64, density: f64) -> (FormFactors, Vec<f64>) {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let mut w = vec![vec![0.0f64; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            // Always couple neighbours so the enclosure is connected.
            let near = j == (i + 1) % n || j == (i + 2) % n || i == (j + 1) % n || i == (j + 2) % n;
            if near || next() < density {
                let v = next() + 0.01;
                w[i][j] = v;
                w[j][i] = v;
            }
        }
    }
    let area: Vec<f64> = w.iter().map(|r| r.iter().sum()).collect();
    let rows: Vec<Vec<(u32, f64)>> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|&j| w[i][j] > 0.0)
                .map(|j| (j as u32, w[i][j] / area[i]))
                .collect()
        })
        .collect();
    let ff = FormFactors::from_rows(n, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])))
        .expect("valid rows");
    let (rec, report) = ff.reciprocal(&area, 1e-13, 10_000).expect("valid areas");
    assert!(report.converged, "{report:?}");
    (rec, area)
}

pub fn uniform(area: &[f64], e: [f64; 3], rho: [f64; 3]) -> Surfaces {
    Surfaces {
        area: area.to_vec(),
        emission: vec![e; area.len()],
        reflectance: vec![rho; area.len()],
    }
}
