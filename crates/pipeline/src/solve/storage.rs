//! Which way a solve holds its form factors: the stored pair matrix when it fits the
//! memory limit; else out of core (every row made once and written compact to a
//! temporary file, then shot from there); else matrix-free shooting (each shooter's row
//! made when it shoots, kept while the limit allows): chosen from a sample of rows.

use super::config::{Storage, MATRIX_FREE_BATCH};
use crate::row_file::FILE_BYTES_PER_ENTRY;
use crate::{Error, RowMethod, STREAM_CHUNK};
use rad_core::PatchId;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;

/// Bytes a stored entry takes, all told (pairs at 16 bytes hold about 1.8 entries on the
/// loft, 8.6 bytes an entry measured; 10 leaves room for less symmetric patterns).
const STORED_BYTES_PER_ENTRY: f64 = 10.0;
/// Bytes a row entry takes while a chunk is made and taken (`(PatchId, f64)`).
const ROW_BYTES_PER_ENTRY: f64 = 16.0;
/// Bytes a patch takes in per-patch arrays (surfaces, radiosities, powers, ...).
pub(crate) const BYTES_PER_PATCH: f64 = 256.0;
/// Rows sampled to estimate the entries a row holds.
const SAMPLE_ROWS: usize = 64;

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
pub(crate) fn matrix_free_floor(n: usize, mean_entries: f64) -> f64 {
    n as f64 * BYTES_PER_PATCH + MATRIX_FREE_BATCH as f64 * mean_entries * ROW_BYTES_PER_ENTRY
}
