//! Summary statistics of samples: mean, median, percentiles, max.

use serde::Serialize;

/// Min, mean, median, 95th percentile and max of a sample (NaN-free), with its size.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Summary {
    pub n: usize,
    pub min: f64,
    pub mean: f64,
    pub median: f64,
    pub p95: f64,
    pub max: f64,
}

impl Summary {
    /// Summary of `values`; all zeros for an empty sample.
    pub fn of(values: &[f64]) -> Summary {
        if values.is_empty() {
            return Summary {
                n: 0,
                min: 0.0,
                mean: 0.0,
                median: 0.0,
                p95: 0.0,
                max: 0.0,
            };
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        Summary {
            n: v.len(),
            min: v[0],
            mean: v.iter().sum::<f64>() / v.len() as f64,
            median: percentile(&v, 0.5),
            p95: percentile(&v, 0.95),
            max: v[v.len() - 1],
        }
    }
}

/// The `q`-quantile of sorted `v` (linear interpolation between ranks).
pub fn percentile(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}
