//! coherad's compact binary sparse-matrix file: a header, JSON metadata, the surfaces'
//! areas, then the entries as (row, column, value) triplets written row by row as they
//! are made (so a matrix need never be held whole), and a trailer that says how many
//! there are (so a truncated file is refused, never read short). Little-endian:
//!
//! | offset | bytes | what |
//! |---|---|---|
//! | 0 | 8 | magic `COHERADM` |
//! | 8 | 4 | version, 1 |
//! | 12 | 4 | 0 (reserved) |
//! | 16 | 8 | rows n |
//! | 24 | 8 | columns |
//! | 32 | 8 | metadata bytes m (UTF-8 JSON, padded with spaces to a multiple of 8) |
//! | 40 | m | metadata: `{"names": [...], ...}` |
//! | 40 + m | 8 n | areas, f64 |
//! | 40 + m + 8 n | 16 each | entries: row u32, column u32, value f64 |
//! | end − 16 | 8 | magic `COHERADE` |
//! | end − 8 | 8 | entries count |
//!
//! Read with numpy (the README has the snippet): `np.frombuffer(data, dtype=[("i",
//! "<u4"), ("j", "<u4"), ("f", "<f8")], count=nnz, offset=...)`.
//!
//! The steps of a motion go in one file ([`StepsWriter`]), each step a whole matrix file
//! as above, then an index:
//!
//! | offset | bytes | what |
//! |---|---|---|
//! | 0 | 8 | magic `COHERADS` |
//! | 8 | 4 | version, 1 |
//! | 12 | 4 | 0 (reserved) |
//! | 16 | … | step 0's matrix file, step 1's, … (each a multiple of 8 bytes) |
//! | end − 16 − 16 k | 16 each | the index: each step's offset and bytes, u64 |
//! | end − 16 | 8 | magic `COHERADI` |
//! | end − 8 | 8 | steps k |

use crate::Error;
use std::io::Write;

pub const MAGIC: &[u8; 8] = b"COHERADM";
pub const END_MAGIC: &[u8; 8] = b"COHERADE";
pub const VERSION: u32 = 1;
pub const STEPS_MAGIC: &[u8; 8] = b"COHERADS";
pub const INDEX_MAGIC: &[u8; 8] = b"COHERADI";
const STEPS_HEADER: usize = 16;
const HEADER: usize = 40;
const ENTRY: usize = 16;

/// Writes a matrix file row by row: [`MatrixWriter::begin`], [`MatrixWriter::row`] for
/// each row in order, [`MatrixWriter::finish`].
pub struct MatrixWriter<'w, W: Write + ?Sized> {
    w: &'w mut W,
    n_rows: u64,
    next_row: u64,
    entries: u64,
    buf: Vec<u8>,
}

impl<'w, W: Write + ?Sized> MatrixWriter<'w, W> {
    /// Writes the header, `metadata` (a JSON object) and the areas.
    pub fn begin(
        w: &'w mut W,
        n_cols: u64,
        metadata: &serde_json::Value,
        areas: &[f64],
    ) -> std::io::Result<MatrixWriter<'w, W>> {
        let mut meta = serde_json::to_vec(metadata).map_err(std::io::Error::other)?;
        while meta.len() % 8 != 0 {
            meta.push(b' ');
        }
        w.write_all(MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&0u32.to_le_bytes())?;
        w.write_all(&(areas.len() as u64).to_le_bytes())?;
        w.write_all(&n_cols.to_le_bytes())?;
        w.write_all(&(meta.len() as u64).to_le_bytes())?;
        w.write_all(&meta)?;
        for a in areas {
            w.write_all(&a.to_le_bytes())?;
        }
        Ok(MatrixWriter {
            w,
            n_rows: areas.len() as u64,
            next_row: 0,
            entries: 0,
            buf: Vec::new(),
        })
    }

    /// Writes the next row's entries (columns increasing).
    pub fn row(&mut self, entries: &[(u32, f64)]) -> std::io::Result<()> {
        let i = u32::try_from(self.next_row).map_err(std::io::Error::other)?;
        if self.next_row >= self.n_rows {
            return Err(std::io::Error::other("more rows than the header says"));
        }
        self.buf.clear();
        for &(j, f) in entries {
            self.buf.extend_from_slice(&i.to_le_bytes());
            self.buf.extend_from_slice(&j.to_le_bytes());
            self.buf.extend_from_slice(&f.to_le_bytes());
        }
        self.w.write_all(&self.buf)?;
        self.next_row += 1;
        self.entries += entries.len() as u64;
        Ok(())
    }

    /// Writes the trailer; every row must have been written.
    pub fn finish(self) -> std::io::Result<u64> {
        if self.next_row != self.n_rows {
            return Err(std::io::Error::other(format!(
                "{} of {} rows written",
                self.next_row, self.n_rows
            )));
        }
        self.w.write_all(END_MAGIC)?;
        self.w.write_all(&self.entries.to_le_bytes())?;
        Ok(self.entries)
    }
}

/// A matrix file read back.
#[derive(Clone, Debug, PartialEq)]
pub struct MatrixFile {
    pub n_cols: u64,
    pub metadata: serde_json::Value,
    pub areas: Vec<f64>,
    /// `(row, column, value)` in file order (row by row, columns increasing).
    pub entries: Vec<(u32, u32, f64)>,
}

/// Checks a `kind` file's frame: its head magic (after which `header` bytes), its
/// version and its trailer's magic (16 bytes from the end).
fn framed(
    bytes: &[u8],
    kind: &str,
    (head, trailer): (&[u8; 8], &[u8; 8]),
    header: usize,
) -> Result<(), String> {
    let name = |m: &[u8; 8]| String::from_utf8_lossy(m).into_owned();
    if bytes.len() < header + 16 || &bytes[..8] != head {
        return Err(format!(
            "not a coherad {kind} file (no {} header)",
            name(head)
        ));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(format!(
            "{kind} file version {version}; this coherad reads {VERSION}"
        ));
    }
    let tail = bytes.len() - 16;
    if &bytes[tail..tail + 8] != trailer {
        return Err(format!(
            "truncated: no {} trailer (an interrupted write?)",
            name(trailer)
        ));
    }
    Ok(())
}

/// Reads a matrix file's bytes; `what` names it in errors (truncated, not ours,
/// another version, inconsistent).
pub fn read_matrix_file(bytes: &[u8], what: &std::path::Path) -> Result<MatrixFile, Error> {
    let bad = |reason: String| Error::Solution {
        path: what.to_path_buf(),
        reason,
    };
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    framed(bytes, "matrix", (MAGIC, END_MAGIC), HEADER).map_err(bad)?;
    let (n_rows, n_cols, meta_len) = (u64_at(16), u64_at(24), u64_at(32));
    let tail = bytes.len() - 16;
    let nnz = u64_at(tail + 8);
    let areas_at = (HEADER as u64).checked_add(meta_len);
    let entries_at = areas_at.and_then(|a| n_rows.checked_mul(8).and_then(|b| a.checked_add(b)));
    let end = entries_at.and_then(|e| nnz.checked_mul(ENTRY as u64).and_then(|b| e.checked_add(b)));
    let (Some(areas_at), Some(entries_at), Some(end)) = (areas_at, entries_at, end) else {
        return Err(bad("its sizes overflow".into()));
    };
    if end != tail as u64 {
        return Err(bad(format!(
            "inconsistent: {n_rows} rows and {nnz} entries need {} bytes before the trailer, the file has {tail}",
            end
        )));
    }
    let metadata: serde_json::Value = serde_json::from_slice(&bytes[HEADER..areas_at as usize])
        .map_err(|e| bad(format!("bad metadata: {e}")))?;
    if let Some(names) = metadata.get("names").and_then(|n| n.as_array()) {
        if names.len() as u64 != n_rows {
            return Err(bad(format!("{} names for {n_rows} rows", names.len())));
        }
    }
    let areas: Vec<f64> = bytes[areas_at as usize..entries_at as usize]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    if let Some(k) = areas.iter().position(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(bad(format!("area {k} is {}, not finite and > 0", areas[k])));
    }
    let mut entries = Vec::with_capacity(nnz as usize);
    let mut last: Option<(u32, u32)> = None;
    for c in bytes[entries_at as usize..tail].chunks_exact(ENTRY) {
        let i = u32::from_le_bytes(c[0..4].try_into().expect("4 bytes"));
        let j = u32::from_le_bytes(c[4..8].try_into().expect("4 bytes"));
        let f = f64::from_le_bytes(c[8..16].try_into().expect("8 bytes"));
        if u64::from(i) >= n_rows || u64::from(j) >= n_cols || !f.is_finite() {
            return Err(bad(format!(
                "entry ({i}, {j}, {f}) is out of range or not finite"
            )));
        }
        if last.is_some_and(|l| l >= (i, j)) {
            return Err(bad(format!(
                "entry ({i}, {j}) is out of order (rows in order, columns increasing)"
            )));
        }
        last = Some((i, j));
        entries.push((i, j, f));
    }
    Ok(MatrixFile {
        n_cols,
        metadata,
        areas,
        entries,
    })
}

/// Writes the steps of a motion into one file: [`StepsWriter::begin`],
/// [`StepsWriter::step`] for each step in order, [`StepsWriter::finish`].
pub struct StepsWriter<'w, W: Write + ?Sized> {
    w: &'w mut W,
    at: u64,
    index: Vec<(u64, u64)>,
}

/// Counts the bytes written through it.
struct Counting<'a, W: Write + ?Sized> {
    w: &'a mut W,
    n: u64,
}

impl<W: Write + ?Sized> Write for Counting<'_, W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.w.write(buf)?;
        self.n += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

impl<'w, W: Write + ?Sized> StepsWriter<'w, W> {
    /// Writes the header.
    pub fn begin(w: &'w mut W) -> std::io::Result<StepsWriter<'w, W>> {
        w.write_all(STEPS_MAGIC)?;
        w.write_all(&VERSION.to_le_bytes())?;
        w.write_all(&0u32.to_le_bytes())?;
        Ok(StepsWriter {
            w,
            at: STEPS_HEADER as u64,
            index: Vec::new(),
        })
    }

    /// The next step: `write` writes one whole matrix file ([`MatrixWriter`]). After an
    /// error the file is no steps file: drop the writer (and the file).
    pub fn step(
        &mut self,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> std::io::Result<()> {
        let mut c = Counting { w: self.w, n: 0 };
        write(&mut c)?;
        if c.n % 8 != 0 || c.n < (HEADER + 16) as u64 {
            return Err(std::io::Error::other(format!(
                "step {} wrote {} bytes, not a matrix file",
                self.index.len(),
                c.n
            )));
        }
        self.index.push((self.at, c.n));
        self.at += c.n;
        Ok(())
    }

    /// Writes the index and the trailer; returns the steps written.
    pub fn finish(self) -> std::io::Result<usize> {
        for &(at, n) in &self.index {
            self.w.write_all(&at.to_le_bytes())?;
            self.w.write_all(&n.to_le_bytes())?;
        }
        self.w.write_all(INDEX_MAGIC)?;
        self.w.write_all(&(self.index.len() as u64).to_le_bytes())?;
        Ok(self.index.len())
    }
}

/// Reads a file of steps ([`StepsWriter`]): each step's matrix; `what` names it in
/// errors (truncated, not ours, another version, an index that does not tile the file,
/// a step's matrix bad, named by its step).
pub fn read_matrix_steps(bytes: &[u8], what: &std::path::Path) -> Result<Vec<MatrixFile>, Error> {
    let bad = |reason: String| Error::Solution {
        path: what.to_path_buf(),
        reason,
    };
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    framed(bytes, "steps", (STEPS_MAGIC, INDEX_MAGIC), STEPS_HEADER).map_err(bad)?;
    let tail = bytes.len() - 16;
    let k = u64_at(tail + 8);
    let index_at = k
        .checked_mul(16)
        .and_then(|b| (tail as u64).checked_sub(b))
        .filter(|&i| i >= STEPS_HEADER as u64);
    let Some(index_at) = index_at else {
        return Err(bad(format!("its index of {k} steps does not fit the file")));
    };
    let mut at = STEPS_HEADER as u64;
    // (No room made from `k` before each step is read: a crafted count is not trusted.)
    let mut steps = Vec::new();
    for s in 0..k as usize {
        let o = index_at as usize + 16 * s;
        let (start, n) = (u64_at(o), u64_at(o + 8));
        if start != at || n > index_at - at {
            return Err(bad(format!(
                "step {s}: its bytes {start}..{} do not follow the step before within the steps (which end at {index_at})",
                start.saturating_add(n)
            )));
        }
        let step = &bytes[start as usize..(start + n) as usize];
        let m = read_matrix_file(step, what).map_err(|e| match e {
            Error::Solution { reason, .. } => bad(format!("step {s}: {reason}")),
            e => e,
        })?;
        steps.push(m);
        at += n;
    }
    if at != index_at {
        return Err(bad(format!(
            "{} bytes between the last step and the index",
            index_at - at
        )));
    }
    Ok(steps)
}
