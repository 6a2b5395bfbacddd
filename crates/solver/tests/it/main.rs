//! Integration tests of rad-solver: closed forms in `analytic`, properties in `props`.

mod analytic;
mod pairs;
mod props;

use rad_solver::{FormFactors, Surfaces};

/// A random closed enclosure of `n >= 3` patches (each coupled to the next two, so a
/// reciprocal scaling exists): a random sparse symmetric coupling made
/// reciprocal with unit row sums by [`FormFactors::reciprocal`].
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
    let area: Vec<f64> = (0..n).map(|_| 0.5 + next()).collect();
    let mut rows: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for i in 0..n {
        for j in 0..n {
            // Always couple neighbours so the enclosure is connected.
            if i != j && (j == (i + 1) % n || j == (i + 2) % n || next() < density) {
                rows[i].push((j as u32, next() + 0.01));
            }
        }
        let s: f64 = rows[i].iter().map(|e| e.1).sum();
        for e in &mut rows[i] {
            e.1 /= s;
        }
    }
    let ff = FormFactors::from_rows(n, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])))
        .expect("valid rows");
    let (rec, _) = ff.reciprocal(&area, 1e-13, 10_000).expect("valid areas");
    (rec, area)
}

pub fn uniform(area: &[f64], e: [f64; 3], rho: [f64; 3]) -> Surfaces {
    Surfaces {
        area: area.to_vec(),
        emission: vec![e; area.len()],
        reflectance: vec![rho; area.len()],
    }
}
