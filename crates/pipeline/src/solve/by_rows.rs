//! A stored solve shared by rows (`--solver jacobi`): each process makes and holds only
//! its share of the rows ([`crate::share::shares`], balanced by work units) as a
//! [`RowSet`], sends the transposes of its entries to the rows' holders, and then the
//! reciprocal scaling (Newton's method on `x ∘ (G x) = A ∘ F 1`) and the Jacobi sweeps
//! share only vectors, all-gathered: the scaling's x, the radiosities. Every row is
//! summed in column order and every vector is put together in patch order, so the
//! solution is the same to the bit whatever the number of processes (one included) and
//! threads; no process ever holds another's rows.

use super::config::{solve_key, Progress, SceneSolveConfig, Storage};
use super::config::{SCALING_ITERATIONS, SCALING_TOLERANCE};
use super::solution::{check_finite, solution_file, surfaces, Answer, MatrixJson, Solved};
use crate::share::{self, Peers, Share};
use crate::{Error, RowMethod, Rows, SceneFile};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_hemisphere::Hemisphere;
use rad_solver::{
    energy_balance_from, jacobi_with, median_bin, reciprocal_scaling, Reciprocity, RowSet, Surfaces,
};
use std::time::Instant;

/// Rounds in which the transposes of a process's entries are sent: each round's bytes
/// are about 12 / 8 = 1.5 bytes an entry it holds (those of rows held elsewhere).
const TRANSPOSE_ROUNDS: usize = 8;

/// [`super::solve_scene_shared`] for `--solver jacobi`: `None` on the processes
/// but the first.
pub(crate) fn solve_by_rows(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<Answer, Error> {
    let t = Instant::now();
    let n = scene.scene.patches().len();
    let all: Vec<PatchId> = (0..n as PatchId).collect();
    let shares = share::shares(&scene.scene, method, &all, peers.size());
    let (mut set, stats) = held_rows(scene, hemi, method, opts, progress, peers, &shares)?;
    let v = Vectors { peers, shares, n };
    let form_factors_seconds = t.elapsed().as_secs_f64();
    let surf = surfaces(&scene.scene);
    let t = Instant::now();
    let raw_sums = v.gather(&set.row_sums(), 1)?;
    let reciprocity = if opts.reciprocal {
        Some(make_reciprocal(&v, &mut set, &surf, &raw_sums)?)
    } else {
        None
    };
    let rec = reciprocity.is_some();
    let scaling_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let product = |b: &[[f64; 3]]| v.gather3(&set.apply(b, rec)?);
    let mut sweep = |sweeps, residual| progress(Progress::Sweeps { sweeps, residual });
    let (solution, h) = jacobi_with(&surf, &opts.config, product, &mut sweep)?;
    let solve_seconds = t.elapsed().as_secs_f64();
    let b = &solution.radiosity;
    let (balance, raw_balance) = if rec {
        let sums = v.gather(&set.reciprocal_row_sums()?, 1)?;
        let raw_h = v.gather3(&set.apply(b, false)?)?;
        (
            energy_balance_from(&surf, b, &h, &sums),
            energy_balance_from(&surf, b, &raw_h, &raw_sums),
        )
    } else {
        let e = energy_balance_from(&surf, b, &h, &raw_sums);
        (e, e)
    };
    let counts = [set.n_upper() as f64, set.bytes() as f64];
    let totals = v.totals(&counts)?;
    let solved = Solved {
        solution,
        reciprocity,
        balance,
        raw_balance,
        scaling_seconds,
        solve_seconds,
        matrix: MatrixJson {
            storage: Storage::Stored.name(),
            pairs: totals[0] as usize,
            bytes: totals[1] as usize,
            rows_made: n,
            cached_rows: 0,
            disk_bytes: 0,
        },
    };
    if peers.rank() > 0 {
        return Ok(None);
    }
    check_finite(&solved)?;
    let file = solution_file(scene, hemi, method, opts, &solved, form_factors_seconds);
    Ok(Some((file, solved, stats)))
}

/// This process's share of the rows, with every entry's transpose, and the run's row
/// counts (every process's added). The first collective carries each process's run
/// fingerprint, so that processes started on different runs (or one whose rows failed)
/// end every process with an error.
fn held_rows(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
    shares: &[Share],
) -> Result<(RowSet, EstimateStats), Error> {
    let n = scene.scene.patches().len();
    let mine = &shares[peers.rank()].patches;
    // Streamed into the set chunk by chunk: the rows are never held as rows.
    let mut set = RowSet::new(n);
    let made = crate::rows_streamed_of(
        &scene.scene,
        hemi,
        method,
        mine,
        &|k| progress(Progress::Rows(k)),
        &mut |made| {
            for r in &made.rows {
                set.push_row(r.patch, &r.entries)?;
            }
            Ok(())
        },
    )
    .map(|stats| (set, stats));
    let fingerprint = share::run_fingerprint(scene.hash, solve_key(hemi, method, opts).as_bytes());
    // The part: no rows, only their counts.
    let part = match &made {
        Ok((_, stats)) => Ok(share::encode_part(
            fingerprint,
            &Rows {
                method,
                rows: Vec::new(),
                sources: Vec::new(),
                stats: *stats,
            },
        )),
        Err(e) => Err(e.to_string()),
    };
    let (parts, (mut set, _)) = match (peers.all_gather(part), made) {
        (Ok(parts), Ok(made)) => (parts, made),
        // One's own error as it is; another's, as the peers give it.
        (_, Err(e)) if peers.size() == 1 => return Err(e),
        (Err(e), _) => return Err(Error::Peers(e)),
        (Ok(_), Err(e)) => return Err(e),
    };
    let mut stats = EstimateStats::default();
    for counts in share::decode_parts(parts, fingerprint, method)? {
        stats.add(&counts.stats);
    }
    let mut owner = vec![0u32; n];
    for (r, s) in shares.iter().enumerate() {
        for &p in &s.patches {
            owner[p as usize] = r as u32;
        }
    }
    // In rounds of rows, so that the bytes in flight are a fraction of the rows.
    let held = set.held().len();
    for round in 0..TRANSPOSE_ROUNDS {
        let rows = held * round / TRANSPOSE_ROUNDS..held * (round + 1) / TRANSPOSE_ROUNDS;
        let out = set
            .transposes(rows, &|j| owner[j as usize] as usize, peers.size())
            .map_err(|e| e.to_string());
        let got = peers.exchange(out).map_err(Error::Peers)?;
        set.add_transposes(&got)?;
    }
    set.finish_transposes()?;
    Ok((set, stats))
}

/// The reciprocal scaling of the rows held by every process: `set` made reciprocal, and
/// what the scaling changed (the same figures as [`rad_solver::PairMatrix::reciprocal`]
/// reports; the input asymmetries exactly its, the rest within rounding).
fn make_reciprocal(
    v: &Vectors<'_>,
    set: &mut RowSet,
    surf: &Surfaces,
    raw_sums: &[f64],
) -> Result<Reciprocity, Error> {
    let area = &surf.area;
    let (max_input_asymmetry, median_input_asymmetry) = v.asymmetry(set, area)?;
    let target: Vec<f64> = (0..v.n).map(|i| area[i] * raw_sums[i]).collect();
    let product = |x: &[f64]| v.gather(&set.g_product(area, x)?, 1);
    let (x, iterations, worst) =
        reciprocal_scaling(v.n, product, &target, SCALING_TOLERANCE, SCALING_ITERATIONS)?;
    if x.iter()
        .zip(&target)
        .any(|(x, &t)| !x.is_finite() || (t > 0.0 && *x <= 0.0))
    {
        return Err(rad_solver::Error::NoReciprocalScaling { iterations }.into());
    }
    let change = v.gather(&set.make_reciprocal(area, &x)?, 1)?;
    let new_sums = v.gather(&set.reciprocal_row_sums()?, 1)?;
    let max_row_sum_error = new_sums
        .iter()
        .zip(raw_sums)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    Ok(Reciprocity {
        max_input_asymmetry,
        median_input_asymmetry,
        mean_row_l1_change: change.iter().sum::<f64>() / v.n.max(1) as f64,
        max_row_sum_error,
        iterations,
        converged: worst <= SCALING_TOLERANCE,
    })
}

/// Vectors of the held rows' values put together in patch order on every process.
struct Vectors<'a> {
    peers: &'a dyn Peers,
    shares: Vec<Share>,
    n: usize,
}

impl Vectors<'_> {
    /// Every process's `width` values a held row (`mine`, this one's, in the order of
    /// its share), as one vector of `n · width` in patch order.
    fn gather(&self, mine: &[f64], width: usize) -> Result<Vec<f64>, Error> {
        let bytes: Vec<u8> = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        let parts = self.peers.all_gather(Ok(bytes)).map_err(Error::Peers)?;
        let mut all = vec![0.0; self.n * width];
        for (r, (part, share)) in parts.iter().zip(&self.shares).enumerate() {
            let want = share.patches.len() * width * 8;
            if part.len() != want {
                return Err(Error::Peers(format!(
                    "rank {r} sent {} bytes of a vector, not {want}: are the ranks on one run?",
                    part.len()
                )));
            }
            for (k, &i) in share.patches.iter().enumerate() {
                for c in 0..width {
                    let at = (k * width + c) * 8;
                    let bits = u64::from_le_bytes(part[at..at + 8].try_into().unwrap());
                    all[i as usize * width + c] = f64::from_bits(bits);
                }
            }
        }
        Ok(all)
    }

    /// [`Vectors::gather`] of RGB values.
    fn gather3(&self, mine: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, Error> {
        let flat: Vec<f64> = mine.iter().flatten().copied().collect();
        let all = self.gather(&flat, 3)?;
        Ok(all.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }

    /// Each of `counts` added over the processes, in rank order.
    fn totals(&self, counts: &[f64]) -> Result<Vec<f64>, Error> {
        let bytes: Vec<u8> = counts.iter().flat_map(|v| v.to_le_bytes()).collect();
        let parts = self.peers.all_gather(Ok(bytes)).map_err(Error::Peers)?;
        let mut total = vec![0.0; counts.len()];
        for part in &parts {
            for (t, c) in total.iter_mut().zip(part.chunks_exact(8)) {
                *t += f64::from_le_bytes(c.try_into().unwrap());
            }
        }
        Ok(total)
    }

    /// The largest and the median (the upper one of an even count) input asymmetry of
    /// every process's pairs ([`RowSet::for_each_asymmetry`]), exactly: a histogram of
    /// their leading bits, added over the processes, finds the median's bin, whose
    /// values alone are then gathered and ordered.
    fn asymmetry(&self, set: &RowSet, area: &[f64]) -> Result<(f64, f64), Error> {
        const SHIFT: u32 = 48;
        let bins = 1usize << (64 - SHIFT);
        let mut count = vec![0u64; bins];
        let mut max = 0.0f64;
        set.for_each_asymmetry(area, &mut |a| {
            count[(a.to_bits() >> SHIFT) as usize] += 1;
            max = max.max(a);
        })?;
        // Sent sparse: the largest, then (bin, count) of the bins that hold any.
        let mut bytes = max.to_le_bytes().to_vec();
        for (bin, &c) in count.iter().enumerate().filter(|(_, &c)| c > 0) {
            bytes.extend((bin as u64).to_le_bytes());
            bytes.extend(c.to_le_bytes());
        }
        let parts = self.peers.all_gather(Ok(bytes)).map_err(Error::Peers)?;
        count.iter_mut().for_each(|c| *c = 0);
        for part in &parts {
            let words: Vec<u64> = part
                .chunks_exact(8)
                .map(|w| u64::from_le_bytes(w.try_into().unwrap()))
                .collect();
            if part.len() % 8 != 0 || words.len() % 2 != 1 {
                return Err(Error::Peers("a histogram cut short".into()));
            }
            max = max.max(f64::from_bits(words[0]));
            for pair in words[1..].chunks_exact(2) {
                let slot = count.get_mut(pair[0] as usize);
                *slot.ok_or_else(|| Error::Peers("a histogram bin out of range".into()))? +=
                    pair[1];
            }
        }
        let Some((bin, k)) = median_bin(&count) else {
            return Ok((0.0, 0.0));
        };
        let mut inside = Vec::new();
        set.for_each_asymmetry(area, &mut |a| {
            if (a.to_bits() >> SHIFT) as usize == bin {
                inside.extend(a.to_le_bytes());
            }
        })?;
        let parts = self.peers.all_gather(Ok(inside)).map_err(Error::Peers)?;
        let mut values: Vec<f64> = parts
            .iter()
            .flat_map(|p| p.chunks_exact(8))
            .map(|w| f64::from_le_bytes(w.try_into().unwrap()))
            .collect();
        if k >= values.len() {
            return Err(Error::Peers("the median's bin came back short".into()));
        }
        let (_, median, _) = values.select_nth_unstable_by(k, f64::total_cmp);
        Ok((max, *median))
    }
}
