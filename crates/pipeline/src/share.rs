//! Sharing a run's rows among processes (MPI ranks, or any other): each one's part of
//! a patch list, balanced by expected cost, and rows as bytes to send and gather.
//! Nothing here knows MPI: the binary's `mpi` feature does the sending.
//!
//! Every patch's row is the same whichever process makes it (rows are independent,
//! and an estimated row depends only on its own polygon's patches, which a part never
//! splits), so rows gathered in part order are the single process's, to the bit.

use crate::{Error, RowMethod, Rows};
use rad_core::PatchId;
use rad_estimator::{EstimateStats, Mode};
use rad_geometry::Scene;
use rad_hemisphere::Row;
use std::ops::Range;

/// What an estimate costs, in exact hemispheres (measured on the loft at 180 × 720 by
/// `cargo bench -p rad-estimator`, centres by the scan: faithful 0.37, improved 0.63).
pub const ESTIMATE_UNITS: [(Mode, f64); 2] = [(Mode::Faithful, 0.37), (Mode::Improved, 0.63)];

/// The expected cost of each item of `patches` (a patch for exact rows; for estimated
/// rows a polygon's patches among `patches`, which are never split) in work units (an
/// exact hemisphere is 1): (the items as ranges of `patches`, their units).
///
/// An estimated polygon's units are its window centres (one a 3 × 3 block of its grid,
/// counted as ⌈nu / 3⌉ ⌈nv / 3⌉, at most its patch count) plus its other patches at
/// [`ESTIMATE_UNITS`].
pub fn work_items(
    scene: &Scene,
    method: RowMethod,
    patches: &[PatchId],
) -> (Vec<Range<usize>>, Vec<f64>) {
    let Some(mode) = method.mode() else {
        return (
            (0..patches.len()).map(|k| k..k + 1).collect(),
            vec![1.0; patches.len()],
        );
    };
    let estimate = ESTIMATE_UNITS
        .iter()
        .find(|(m, _)| *m == mode)
        .map_or(1.0, |e| e.1);
    let (mut items, mut units) = (Vec::new(), Vec::new());
    let mut k = 0;
    while k < patches.len() {
        let polygon = scene.patches()[patches[k] as usize].polygon;
        let start = k;
        while k < patches.len() && scene.patches()[patches[k] as usize].polygon == polygon {
            k += 1;
        }
        let n = (k - start) as f64;
        let (nu, nv) = scene.polygons()[polygon as usize].grid();
        let centres = ((nu.div_ceil(3) * nv.div_ceil(3)) as f64).min(n);
        items.push(start..k);
        units.push(centres + (n - centres) * estimate);
    }
    (items, units)
}

/// One process's share of a run: its patches (in the order of the list shared) and
/// their work units.
#[derive(Clone, Debug, PartialEq)]
pub struct Share {
    pub patches: Vec<PatchId>,
    pub units: f64,
}

/// `patches` shared among `parts` processes by expected cost, not by count: whole
/// items ([`work_items`]) go, largest first (ties in list order), to the share with
/// the fewest units so far (ties to the lower share); each share keeps its patches in
/// list order. Deterministic: every process computes the same shares.
pub fn shares(scene: &Scene, method: RowMethod, patches: &[PatchId], parts: usize) -> Vec<Share> {
    let parts = parts.max(1);
    let (items, units) = work_items(scene, method, patches);
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| units[b].total_cmp(&units[a]).then(a.cmp(&b)));
    let mut load = vec![0.0f64; parts];
    let mut owner = vec![0usize; items.len()];
    for k in order {
        let r = (0..parts)
            .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
            .unwrap();
        load[r] += units[k];
        owner[k] = r;
    }
    let mut out: Vec<Share> = load
        .iter()
        .map(|&units| Share {
            patches: Vec::new(),
            units,
        })
        .collect();
    for (k, item) in items.iter().enumerate() {
        out[owner[k]]
            .patches
            .extend_from_slice(&patches[item.clone()]);
    }
    out
}

/// A fingerprint of a run for processes to compare before their rows are joined: FNV-1a
/// of the scene's fingerprint and `what` (its resolution, method, options and patch
/// list, as the caller writes them).
pub fn run_fingerprint(scene_hash: u64, what: &[u8]) -> u64 {
    let h = crate::scene_file::fnv1a(crate::scene_file::FNV_OFFSET, &scene_hash.to_le_bytes());
    crate::scene_file::fnv1a(h, what)
}

const MAGIC: &[u8; 4] = b"CHRW";
const NONE: u32 = u32::MAX;

/// `rows` as bytes (little-endian: magic, row count, the counts of
/// [`EstimateStats`], then each row: patch, source or u32::MAX, back, escaped, entry
/// count, entries as (u32, f64)), for [`decode_rows`] in another process.
pub fn encode_rows(rows: &Rows) -> Vec<u8> {
    let mut b = Vec::new();
    encode_rows_into(rows, &mut b);
    b
}

/// [`encode_rows`] appended to `b` (after a caller's header, say).
pub fn encode_rows_into(rows: &Rows, b: &mut Vec<u8>) {
    let n: usize = rows.rows.iter().map(|r| 28 + 12 * r.entries.len()).sum();
    b.reserve(80 + n);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&(rows.rows.len() as u64).to_le_bytes());
    let s = &rows.stats;
    for c in [s.exact, s.estimated, s.fallback_exact] {
        b.extend_from_slice(&(c as u64).to_le_bytes());
    }
    for c in [s.real_rays, s.holes, s.polygon_tests] {
        b.extend_from_slice(&c.to_le_bytes());
    }
    for t in [s.exact_seconds, s.estimate_seconds] {
        b.extend_from_slice(&t.to_le_bytes());
    }
    for (r, src) in rows.rows.iter().zip(&rows.sources) {
        b.extend_from_slice(&r.patch.to_le_bytes());
        b.extend_from_slice(&src.unwrap_or(NONE).to_le_bytes());
        b.extend_from_slice(&r.back.to_le_bytes());
        b.extend_from_slice(&r.escaped.to_le_bytes());
        b.extend_from_slice(&(r.entries.len() as u32).to_le_bytes());
        for &(j, f) in &r.entries {
            b.extend_from_slice(&j.to_le_bytes());
            b.extend_from_slice(&f.to_le_bytes());
        }
    }
}

/// Reads [`encode_rows`]' bytes back as rows of `method`; truncated or inconsistent
/// bytes are an error, never a panic.
pub fn decode_rows(bytes: &[u8], method: RowMethod) -> Result<Rows, Error> {
    let bad = |reason: &str| Error::Parse {
        what: "rows from another process",
        input: format!("{} bytes", bytes.len()),
        reason: reason.to_string(),
    };
    let mut r = Reader { bytes, at: 0 };
    if r.take(4).ok_or_else(|| bad("truncated"))? != MAGIC {
        return Err(bad("not coherad rows"));
    }
    let mut head = [0u64; 9];
    for x in &mut head {
        *x = r.u64().ok_or_else(|| bad("truncated"))?;
    }
    let count = head[0];
    let stats = EstimateStats {
        exact: head[1] as usize,
        estimated: head[2] as usize,
        fallback_exact: head[3] as usize,
        real_rays: head[4],
        holes: head[5],
        polygon_tests: head[6],
        exact_seconds: f64::from_bits(head[7]),
        estimate_seconds: f64::from_bits(head[8]),
    };
    // Each row takes at least 28 bytes: a count the bytes cannot hold is refused.
    if count > (bytes.len() / 28) as u64 {
        return Err(bad("a row count larger than the bytes hold"));
    }
    let (mut rows, mut sources) = (Vec::with_capacity(count as usize), Vec::new());
    for _ in 0..count {
        let row = r.row().ok_or_else(|| bad("truncated"))?;
        rows.push(row.0);
        sources.push(row.1);
    }
    if r.at != bytes.len() {
        return Err(bad("bytes left over after the last row"));
    }
    Ok(Rows {
        method,
        rows,
        sources,
        stats,
    })
}

/// Little-endian reads that return `None` past the end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        self.u64().map(f64::from_bits)
    }
    /// One row of [`encode_rows`] and its source.
    fn row(&mut self) -> Option<(Row, Option<PatchId>)> {
        let patch = self.u32()?;
        let source = self.u32()?;
        let back = self.f64()?;
        let escaped = self.f64()?;
        let n = self.u32()? as usize;
        let body = self.take(n.checked_mul(12)?)?;
        let entries = body
            .chunks_exact(12)
            .map(|e| {
                let j = u32::from_le_bytes(e[..4].try_into().unwrap());
                (j, f64::from_le_bytes(e[4..].try_into().unwrap()))
            })
            .collect();
        let row = Row {
            patch,
            entries,
            back,
            escaped,
        };
        Some((row, (source != NONE).then_some(source)))
    }
}

/// Joins shares' rows into one run's over `patches` (the list shared): each row in its
/// patch's place in the list, the counts added. An error if the rows are not one row
/// for each patch of the list.
pub fn join_rows(method: RowMethod, patches: &[PatchId], parts: Vec<Rows>) -> Result<Rows, Error> {
    let bad = |reason: String| Error::Parse {
        what: "rows gathered from processes",
        input: format!("{} patches", patches.len()),
        reason,
    };
    let top = patches.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
    let mut place = vec![usize::MAX; top];
    for (k, &p) in patches.iter().enumerate() {
        place[p as usize] = k;
    }
    let mut rows: Vec<Option<(Row, Option<PatchId>)>> = vec![None; patches.len()];
    let mut stats = EstimateStats::default();
    for part in parts {
        stats.add(&part.stats);
        for (row, src) in part.rows.into_iter().zip(part.sources) {
            let k = place.get(row.patch as usize).copied().unwrap_or(usize::MAX);
            if k == usize::MAX || rows[k].is_some() {
                return Err(bad(format!("patch {}: not asked for, or twice", row.patch)));
            }
            rows[k] = Some((row, src));
        }
    }
    let mut all = Rows {
        method,
        rows: Vec::with_capacity(patches.len()),
        sources: Vec::with_capacity(patches.len()),
        stats,
    };
    for (k, r) in rows.into_iter().enumerate() {
        let (row, src) = r.ok_or_else(|| bad(format!("no row for patch {}", patches[k])))?;
        all.rows.push(row);
        all.sources.push(src);
    }
    Ok(all)
}

/// The processes a run is shared among, as the pipeline sees them: their number, this
/// one's place, and two collectives that every process calls in the same sequence. A
/// process's own failure is passed in as an `Err`, so that no process is left waiting;
/// when any part is an error, every process gets the same error (the first, by rank).
pub trait Peers {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    /// Every process's part, in rank order, on the first (`None` on the others).
    fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String>;
    /// Every process's part, in rank order, on every process.
    fn all_gather(&self, part: Result<Vec<u8>, String>) -> Result<Vec<Vec<u8>>, String>;
    /// Each process's `parts[d]` sent to process `d` (one part a process, its own
    /// included): what every process sent this one, in rank order.
    fn exchange(&self, parts: Result<Vec<Vec<u8>>, String>) -> Result<Vec<Vec<u8>>, String>;
}

/// A process's part: its run's fingerprint, then its rows ([`encode_rows`]).
pub(crate) fn encode_part(fingerprint: u64, rows: &Rows) -> Vec<u8> {
    let mut bytes = fingerprint.to_le_bytes().to_vec();
    encode_rows_into(rows, &mut bytes);
    bytes
}

/// Every process's [`encode_part`] read back, in rank order: an error naming the first
/// process whose fingerprint is not `fingerprint` (another run) or whose rows are cut.
/// Each part's bytes are dropped as soon as they are read.
pub(crate) fn decode_parts(
    parts: Vec<Vec<u8>>,
    fingerprint: u64,
    method: RowMethod,
) -> Result<Vec<Rows>, Error> {
    let mut made = Vec::with_capacity(parts.len());
    for (r, p) in parts.into_iter().enumerate() {
        if p.get(..8) != Some(&fingerprint.to_le_bytes()[..]) {
            return Err(Error::Peers(format!(
                "rank {r} made rows of another run (another scene file, resolution, method, options or patch list): start every rank with the same command"
            )));
        }
        made.push(
            decode_rows(&p[8..], method).map_err(|e| Error::Peers(format!("rank {r}: {e}")))?,
        );
    }
    Ok(made)
}

/// One process alone.
pub struct Alone;

impl Peers for Alone {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        part.map(|p| Some(vec![p]))
    }
    fn all_gather(&self, part: Result<Vec<u8>, String>) -> Result<Vec<Vec<u8>>, String> {
        part.map(|p| vec![p])
    }
    fn exchange(&self, parts: Result<Vec<Vec<u8>>, String>) -> Result<Vec<Vec<u8>>, String> {
        parts
    }
}

/// `run` on `size` processes simulated by threads of this one, each given its
/// [`Peers`] (collectives through shared memory, with the errors of MPI's ranks): what
/// each returned, in rank order. For tests and the reproduction's simulated larger
/// runs, which need no MPI. A process that returns or panics while others wait in a
/// collective makes theirs an error (as `mpirun` ends a job whose rank died); a panic is
/// passed on once every process has ended.
pub fn in_threads<T: Send>(size: usize, run: impl Fn(&dyn Peers) -> T + Sync) -> Vec<T> {
    let board = Board {
        state: std::sync::Mutex::new(BoardState {
            outgoing: (0..size).map(|_| None).collect(),
            kinds: vec![0; size],
            results: (0..size).map(|_| None).collect(),
            arrived: 0,
            generation: 0,
            gone: 0,
        }),
        turn: std::sync::Condvar::new(),
        size,
    };
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..size)
            .map(|rank| {
                let (board, run) = (&board, &run);
                scope.spawn(move || {
                    let me = Thread { board, rank };
                    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(&me)));
                    let mut st = board.state.lock().unwrap_or_else(|e| e.into_inner());
                    st.gone += 1;
                    board.turn.notify_all();
                    out
                })
            })
            .collect();
        let ended: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
        ended
            .into_iter()
            .map(|e| match e {
                Ok(Ok(v)) => v,
                Ok(Err(p)) | Err(p) => std::panic::resume_unwind(p),
            })
            .collect()
    })
}

type Parts = Result<Vec<Vec<u8>>, String>;

/// What simulated processes share: each one's outgoing parts, then each one's result.
struct Board {
    state: std::sync::Mutex<BoardState>,
    turn: std::sync::Condvar,
    size: usize,
}

struct BoardState {
    outgoing: Vec<Option<Parts>>,
    /// Which collective each process called (0 gather, 1 all-gather, 2 exchange).
    kinds: Vec<u8>,
    results: Vec<Option<Parts>>,
    arrived: usize,
    generation: u64,
    /// Processes whose `run` has ended (returned or panicked).
    gone: usize,
}

/// One simulated process.
struct Thread<'a> {
    board: &'a Board,
    rank: usize,
}

impl Thread<'_> {
    /// Every process's `out[d]` to process `d` in a collective of `kind`; when any
    /// process passes an error, every one gets the first (by rank), and when they call
    /// different collectives, an "out of step" error, as MPI's ranks do.
    fn swap(&self, kind: u8, out: Parts) -> Parts {
        let b = self.board;
        let mut st = b.state.lock().unwrap_or_else(|e| e.into_inner());
        let ended = "a process ended while the others were in a collective";
        if st.gone > 0 {
            return Err(ended.into());
        }
        st.outgoing[self.rank] = Some(out);
        st.kinds[self.rank] = kind;
        st.arrived += 1;
        if st.arrived == b.size {
            let outs: Vec<Parts> = st.outgoing.iter_mut().map(|o| o.take().unwrap()).collect();
            let mut failed = outs.iter().enumerate().find_map(|(r, o)| match o {
                Err(e) => Some(format!("rank {r}: {e}")),
                Ok(_) => None,
            });
            if failed.is_none() && st.kinds.iter().any(|&k| k != kind) {
                failed = Some(
                    "the processes are out of step (they called different collectives)".into(),
                );
            }
            let mut sent: Vec<Vec<Vec<u8>>> =
                outs.into_iter().map(|o| o.unwrap_or_default()).collect();
            for d in 0..b.size {
                st.results[d] = Some(match &failed {
                    Some(e) => Err(e.clone()),
                    None => Ok(sent.iter_mut().map(|s| std::mem::take(&mut s[d])).collect()),
                });
            }
            st.arrived = 0;
            st.generation += 1;
            b.turn.notify_all();
        } else {
            let generation = st.generation;
            while st.generation == generation {
                if st.gone > 0 {
                    st.arrived -= 1;
                    st.outgoing[self.rank] = None;
                    return Err(ended.into());
                }
                st = b.turn.wait(st).unwrap_or_else(|e| e.into_inner());
            }
        }
        st.results[self.rank].take().unwrap()
    }
}

impl Peers for Thread<'_> {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.board.size
    }
    fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        let size = self.board.size;
        let out = part.map(|p| {
            let mut v = vec![Vec::new(); size];
            v[0] = p;
            v
        });
        let got = self.swap(0, out)?;
        Ok((self.rank == 0).then_some(got))
    }
    fn all_gather(&self, part: Result<Vec<u8>, String>) -> Result<Vec<Vec<u8>>, String> {
        self.swap(1, part.map(|p| vec![p; self.board.size]))
    }
    fn exchange(&self, parts: Result<Vec<Vec<u8>>, String>) -> Result<Vec<Vec<u8>>, String> {
        let size = self.board.size;
        let parts = parts.and_then(|p| {
            (p.len() == size)
                .then_some(p)
                .ok_or_else(|| format!("an exchange needs one part for each of {size} processes"))
        });
        self.swap(2, parts)
    }
}

/// Rows shared among [`Peers`]: what [`shared_rows`] gives.
#[derive(Debug)]
pub struct SharedRows {
    /// The rows of the list, in its order (`None` on the processes but the first when
    /// gathered on the first only).
    pub rows: Option<Rows>,
    /// Each process's share.
    pub shares: Vec<Share>,
}

/// What processes sharing rows must agree on: the scene (and its fingerprint), the
/// method, and `what` (the caller's resolution and options, as bytes).
#[derive(Clone, Copy)]
pub struct SharedRun<'a> {
    pub scene: &'a Scene,
    pub scene_hash: u64,
    pub method: RowMethod,
    pub what: &'a [u8],
}

/// The rows of `patches` by the run's method, each of `peers` making its [`shares`]
/// share with `make` and the rows joined in the list's order (the same to the bit as
/// one process's rows), on the first process only or, with `everyone`, on every
/// process. Each part begins with [`run_fingerprint`] of the run's scene fingerprint
/// and `what` and the patch list, so that processes started on different runs are an
/// error, not a mixed output.
pub fn shared_rows(
    run: SharedRun<'_>,
    patches: &[PatchId],
    peers: &dyn Peers,
    everyone: bool,
    make: &mut dyn FnMut(&[PatchId]) -> Result<Rows, Error>,
) -> Result<SharedRows, Error> {
    let SharedRun {
        scene,
        scene_hash,
        method,
        what,
    } = run;
    let shares = shares(scene, method, patches, peers.size());
    if peers.size() == 1 {
        let rows = make(patches)?;
        return Ok(SharedRows {
            rows: Some(rows),
            shares,
        });
    }
    let mut key = what.to_vec();
    key.extend(patches.iter().flat_map(|p| p.to_le_bytes()));
    let fingerprint = run_fingerprint(scene_hash, &key);
    let part = make(&shares[peers.rank()].patches)
        .map(|r| encode_part(fingerprint, &r))
        .map_err(|e| e.to_string());
    let parts = if everyone {
        Some(peers.all_gather(part))
    } else {
        peers.gather(part).transpose()
    };
    let Some(parts) = parts else {
        return Ok(SharedRows { rows: None, shares });
    };
    let made = decode_parts(parts.map_err(Error::Peers)?, fingerprint, method)?;
    let rows = join_rows(method, patches, made)?;
    Ok(SharedRows {
        rows: Some(rows),
        shares,
    })
}
