//! How a solve holds its form factors: the stored pair matrix when it fits the memory
//! limit; else out of core (every row made once and written compact to a temporary
//! file, then shot from there); else matrix-free shooting (each shooter's row made when
//! it shoots, kept while the limit allows): chosen from a sample of rows.

use crate::row_file::{RowFile, FILE_BYTES_PER_ENTRY};
use crate::share::Peers;
use crate::{rows_with_caster, CasterJob, Error, RowMethod, Rows, STREAM_CHUNK};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Caster, Hemisphere};
use rad_solver::{
    shoot_matrix_free, MatrixFreeConfig, MatrixFreeStats, RowSums, ShootProgress, ShotRow,
    Solution, Surfaces,
};
use rayon::prelude::*;

/// The default of `--memory-limit`: 1.5 GiB for the form factors, so that a solve
/// (scene, caster and per-patch arrays on top) stays within 2 GiB on a 100k-patch mesh.
pub const DEFAULT_MEMORY_LIMIT: usize = 1536 << 20;

/// Shooters taken at a time by matrix-free solving (their rows made in parallel).
pub const MATRIX_FREE_BATCH: usize = 64;

/// How far matrix-free and out-of-core shooting overshoot
/// ([`rad_solver::MatrixFreeConfig::overshoot`]): on the loft at 180 × 720 (out of core,
/// exact rows, against a solve to 1e-7), 1.2 took 65,280 shots to the default tolerance
/// against 120,064 without overshooting, its radiosities nearer the converged ones
/// (mean relative difference 5.4e-4 against 7.0e-4); 1.1, 1.3 and 1.4 took 83,840,
/// 77,632 and 108,864.
pub const MATRIX_FREE_OVERSHOOT: f64 = 1.2;

/// Bytes a stored entry takes, all told (pairs at 16 bytes hold about 1.8 entries on the
/// loft, 8.6 bytes an entry measured; 10 leaves room for less symmetric patterns).
const STORED_BYTES_PER_ENTRY: f64 = 10.0;
/// Bytes a row entry takes while a chunk is made and taken (`(PatchId, f64)`).
const ROW_BYTES_PER_ENTRY: f64 = 16.0;
/// Bytes a patch takes in per-patch arrays (surfaces, radiosities, powers, ...).
const BYTES_PER_PATCH: f64 = 256.0;
/// Rows sampled to estimate the entries a row holds.
const SAMPLE_ROWS: usize = 64;

/// How the form factors are held during a solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// Every row made once, streamed into the pair storage, made reciprocal, solved.
    Stored,
    /// No matrix: matrix-free progressive refinement (exact rows only).
    MatrixFree,
    /// Every row made once (exact or estimated) and written compact to an unnamed
    /// temporary file ([`crate::row_file::RowFile`]), then the matrix-free shooting read
    /// from there (rows kept in memory while the limit allows). One process only.
    OutOfCore,
}

impl Storage {
    pub fn name(self) -> &'static str {
        match self {
            Storage::Stored => "stored",
            Storage::MatrixFree => "matrix-free",
            Storage::OutOfCore => "out-of-core",
        }
    }
}

/// What a long solve reports as it goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Progress {
    /// Rows made so far (the stored path).
    Rows(usize),
    /// Shots so far and the share of the emitted power still unshot (matrix-free).
    Shots { shots: usize, unshot: f64 },
    /// Jacobi sweeps so far and the residual of the radiosities they reached.
    Sweeps { sweeps: usize, residual: f64 },
}

impl Progress {
    /// Shooting's report as a solve's.
    fn of(p: ShootProgress) -> Progress {
        match p {
            ShootProgress::Rows(k) => Progress::Rows(k),
            ShootProgress::Shots { shots, pending } => Progress::Shots {
                shots,
                unshot: pending,
            },
        }
    }
}

/// Chunks of rows a stream holds at most: one being made and one being taken, and for
/// estimated rows those made ahead of their chunk ([`crate::rows::AHEAD_CHUNKS`]).
fn chunks_held(method: RowMethod) -> f64 {
    if method.is_exact() {
        2.0
    } else {
        (2 + crate::rows::AHEAD_CHUNKS) as f64
    }
}

fn mib(bytes: f64) -> u64 {
    (bytes / (1u64 << 20) as f64).ceil() as u64
}

/// The storage to use for `scene` by `method` within `limit` bytes: stored if its
/// estimate (from [`SAMPLE_ROWS`] rows spread over the patches) fits; else out of core
/// if `temp` (the temporary folder, `None` in a run shared among processes) has room for
/// the rows' file and the stream of rows fits the limit; else matrix-free if the method
/// is exact and its working set fits; else an error saying what would.
pub fn choose(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    limit: usize,
    temp: Option<&std::path::Path>,
) -> Result<Storage, Error> {
    let n = scene.patches().len();
    let mean = mean_entries(scene, hemi, method)?;
    let stored = mean * n as f64 * STORED_BYTES_PER_ENTRY
        + stream_bytes(method, mean)
        + n as f64 * BYTES_PER_PATCH;
    if stored <= limit as f64 {
        return Ok(Storage::Stored);
    }
    let file = mean * n as f64 * FILE_BYTES_PER_ENTRY;
    let room = temp.map(|dir| crate::row_file::free_bytes(dir).map_or(f64::INFINITY, |b| b as f64));
    let out_of_core = out_of_core_floor(n, method, mean);
    if room.is_some_and(|room| 1.1 * file <= room) && out_of_core <= limit as f64 {
        return Ok(Storage::OutOfCore);
    }
    if !method.is_exact() {
        let (what, need) = match room {
            Some(room) if 1.1 * file > room => (
                format!(
                    "the rows of {n} patches (stored: {} MiB of memory; out of core: {} MiB of disk, {} MiB free in the temporary folder)",
                    mib(stored),
                    mib(file),
                    mib(room)
                ),
                stored,
            ),
            Some(_) => (
                format!("out-of-core solving of {n} patches"),
                out_of_core,
            ),
            None => (format!("the stored rows of {n} patches"), stored),
        };
        return Err(Error::MemoryLimit {
            what,
            need_mib: mib(need),
            limit_mib: mib(limit as f64),
            hint: "raise --memory-limit, free disk space or name another --temp-dir, or use --method exact, which can solve matrix-free",
        });
    }
    let free = matrix_free_floor(n, mean);
    if free > limit as f64 {
        return Err(Error::MemoryLimit {
            what: format!("matrix-free solving of {n} patches"),
            need_mib: mib(free),
            limit_mib: mib(limit as f64),
            hint: "raise --memory-limit",
        });
    }
    Ok(Storage::MatrixFree)
}

/// Bytes the rows being streamed take at most: the chunks held at a time.
fn stream_bytes(method: RowMethod, mean_entries: f64) -> f64 {
    chunks_held(method) * (STREAM_CHUNK as f64) * mean_entries * ROW_BYTES_PER_ENTRY
}

/// The least out-of-core solving needs: per-patch arrays, the file's index, and the
/// stream of rows (then one batch of rows being shot, which is less).
fn out_of_core_floor(n: usize, method: RowMethod, mean_entries: f64) -> f64 {
    n as f64 * (BYTES_PER_PATCH + 12.0) + stream_bytes(method, mean_entries)
}

/// Bytes a row entry takes in a [`rad_solver::RowSet`], all told: 12, times the union
/// of F's and Fᵀ's patterns over F's (1.075 on the loft at 180 × 720: 78.8 M positions
/// for 73.3 M entries; 1.1 leaves room for less symmetric patterns).
const ROW_SET_BYTES_PER_ENTRY: f64 = 12.0 * 1.1;

/// Whether a solve shared by rows (`--solver jacobi`) among `processes` fits `limit`
/// bytes a process: its share of the rows in a row set, the chunks of rows a stream holds,
/// a round of transposes in flight both ways, and the per-patch vectors every process
/// holds (estimated from [`SAMPLE_ROWS`] rows, as [`choose`] does); else an error
/// saying what would.
pub fn check_by_rows(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    limit: usize,
    processes: usize,
) -> Result<(), Error> {
    let n = scene.patches().len();
    let mean = mean_entries(scene, hemi, method)?;
    let share = mean * n as f64 / processes.max(1) as f64;
    let need = share * ROW_SET_BYTES_PER_ENTRY
        + stream_bytes(method, mean)
        + 2.0 * share * 12.0 / 8.0
        + n as f64 * BYTES_PER_PATCH;
    if need > limit as f64 {
        return Err(Error::MemoryLimit {
            what: format!(
                "the rows of {n} patches shared by rows among {processes} {} (each its share)",
                if processes == 1 { "process" } else { "processes" }
            ),
            need_mib: mib(need),
            limit_mib: mib(limit as f64),
            hint: "raise --memory-limit, share among more processes (mpirun -n), or solve matrix-free (--storage matrix-free)",
        });
    }
    Ok(())
}

/// Entries a row holds, on average over [`SAMPLE_ROWS`] exact rows spread over the
/// patches.
fn mean_entries(scene: &Scene, hemi: &Hemisphere, method: RowMethod) -> Result<f64, Error> {
    let n = scene.patches().len();
    let k = n.min(SAMPLE_ROWS);
    let sample: Vec<PatchId> = (0..k).map(|s| (s * n / k.max(1)) as PatchId).collect();
    let exact = RowMethod::Exact {
        caster: method.caster(),
    };
    let rows = crate::rows(scene, hemi, exact, &sample, &|_| {})?.rows;
    Ok(rows.iter().map(|r| r.entries.len()).sum::<usize>() as f64 / k.max(1) as f64)
}

/// The least matrix-free solving needs: per-patch arrays and one batch of rows.
fn matrix_free_floor(n: usize, mean_entries: f64) -> f64 {
    n as f64 * BYTES_PER_PATCH + MATRIX_FREE_BATCH as f64 * mean_entries * ROW_BYTES_PER_ENTRY
}

/// Matrix-free shooting of `scene`'s exact rows through `method`'s caster, rows kept in
/// what the memory limit leaves. Shared among `peers`, every process runs the same
/// shooting and each batch's rows are made in shares ([`crate::share::shared_rows`]) and
/// gathered by every process: the same shots, to the bit, whatever their number.
pub(crate) fn solve_matrix_free(
    scene: &crate::SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    surfaces: &Surfaces,
    opts: &crate::solve::SolveOptions,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<(Solution, MatrixFreeStats), Error> {
    if !method.is_exact() {
        return Err(Error::Parse {
            what: "method",
            input: method.name(),
            reason: "matrix-free solving casts each shooter's row exactly: use --method exact"
                .into(),
        });
    }
    struct Job<'a> {
        scene: &'a crate::SceneFile,
        hemi: &'a Hemisphere,
        method: RowMethod,
        surfaces: &'a Surfaces,
        config: MatrixFreeConfig,
        progress: &'a (dyn Fn(Progress) + Sync),
        peers: &'a dyn Peers,
        key: String,
    }
    impl CasterJob for Job<'_> {
        type Out = (Solution, MatrixFreeStats);
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Self::Out, Error> {
            let mut make = |ids: &[PatchId]| -> Result<Rows, Error> {
                let rows = compute_rows(scene, caster, self.hemi, ids, &|_| {})?;
                Ok(Rows {
                    method: self.method,
                    sources: vec![None; rows.len()],
                    stats: EstimateStats {
                        exact: rows.len(),
                        ..EstimateStats::default()
                    },
                    rows,
                })
            };
            let mut rows = |ids: &[PatchId], _: &mut Vec<ShotRow>| -> Result<Vec<ShotRow>, Error> {
                let made = if self.peers.size() == 1 {
                    make(ids)?
                } else {
                    let run = crate::share::SharedRun {
                        scene,
                        scene_hash: self.scene.hash,
                        method: self.method,
                        what: self.key.as_bytes(),
                    };
                    crate::share::shared_rows(run, ids, self.peers, true, &mut make)?
                        .rows
                        .expect("gathered by every process")
                };
                Ok(made.rows.into_iter().map(shot_row).collect())
            };
            let mut progress = |p| (self.progress)(Progress::of(p));
            // (The rows' sums first, by a pass of rows: kept while the limit allows.)
            shoot_matrix_free(self.surfaces, &self.config, None, &mut rows, &mut progress)
        }
    }
    let n = scene.scene.patches().len();
    let cache_bytes = (opts.memory_limit as f64 - matrix_free_floor(n, 0.0)).max(0.0) as usize;
    rows_with_caster(
        &scene.scene,
        method.caster(),
        Job {
            scene,
            hemi,
            method,
            surfaces,
            config: MatrixFreeConfig {
                solve: opts.matrix_free,
                batch: MATRIX_FREE_BATCH,
                overshoot: MATRIX_FREE_OVERSHOOT,
                cache_bytes,
            },
            progress,
            peers,
            key: crate::solve::solve_key(hemi, method, opts),
        },
    )
}

/// What out-of-core solving wrote and did.
#[derive(Clone, Copy, Debug, Default)]
pub struct OutOfCoreStats {
    /// The rows' file: its bytes and entries.
    pub file_bytes: u64,
    pub entries: u64,
    /// Seconds making and writing every row, then shooting.
    pub rows_seconds: f64,
    pub shoot_seconds: f64,
}

/// Out-of-core solving: every row of `scene` by `method` (exact or estimated) made once,
/// streamed ([`crate::rows_streamed`]) into an unnamed temporary file in `temp`, then
/// shot from there as matrix-free solving shoots ([`shoot_matrix_free`]: the same
/// batches, the same answer whatever the threads; with exact rows, matrix-free solving's
/// answer to the bit), rows kept in memory while the limit allows. The file is gone when
/// this returns, or when the process ends however it ends.
pub(crate) fn solve_out_of_core(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    surfaces: &Surfaces,
    opts: &crate::solve::SolveOptions,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(Solution, MatrixFreeStats, EstimateStats, OutOfCoreStats), Error> {
    let n = scene.patches().len();
    let t = std::time::Instant::now();
    let temp = opts.temp_dir();
    let mut file = RowFile::create_in(&temp, n)?;
    let rows_progress = |k| progress(Progress::Rows(k));
    // (The sums shooting needs, of the values as the file holds them, as the rows pass:
    // they come in patch order.)
    let mut sums = RowSums::new(n);
    let stats = crate::rows_streamed(scene, hemi, method, &rows_progress, &mut |made| {
        for r in &made.rows {
            file.push(r.patch, &r.entries)?;
            let area = surfaces.area[r.patch as usize];
            sums.add(r.patch, area, r.entries.iter().map(|&(j, f)| (j, f as f32)))?;
        }
        Ok(())
    })?;
    file.finish()?;
    let mut out = OutOfCoreStats {
        file_bytes: file.bytes(),
        entries: file.entries(),
        rows_seconds: t.elapsed().as_secs_f64(),
        ..OutOfCoreStats::default()
    };
    let t = std::time::Instant::now();
    let config = MatrixFreeConfig {
        solve: opts.matrix_free,
        batch: MATRIX_FREE_BATCH,
        overshoot: MATRIX_FREE_OVERSHOOT,
        cache_bytes: (opts.memory_limit as f64 - n as f64 * (BYTES_PER_PATCH + 12.0)).max(0.0)
            as usize,
    };
    let mut rows = |ids: &[PatchId], spare: &mut Vec<ShotRow>| -> Result<Vec<ShotRow>, Error> {
        // (Into the storage of rows shot and dropped: fresh storage costs its pages.)
        let reuse = spare.len().saturating_sub(ids.len());
        let mut into: Vec<ShotRow> = spare.drain(reuse..).collect();
        into.resize_with(ids.len(), ShotRow::default);
        ids.par_iter()
            .zip(into)
            .map(|(&p, mut row)| file.read_into(p, &mut row).map(|()| row))
            .collect()
    };
    let mut shots = |p| progress(Progress::of(p));
    let (solution, m) = shoot_matrix_free(surfaces, &config, Some(sums), &mut rows, &mut shots)?;
    out.shoot_seconds = t.elapsed().as_secs_f64();
    Ok((solution, m, stats, out))
}

/// A row as shooting takes it: values rounded to `f32`, as the stored matrix holds them
/// (non-finite values are refused where rows are made).
fn shot_row(r: rad_hemisphere::Row) -> ShotRow {
    ShotRow {
        columns: r.entries.iter().map(|e| e.0).collect(),
        values: r.entries.iter().map(|e| e.1 as f32).collect(),
    }
}
