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

use crate::Error;
use std::io::Write;

pub const MAGIC: &[u8; 8] = b"COHERADM";
pub const END_MAGIC: &[u8; 8] = b"COHERADE";
pub const VERSION: u32 = 1;
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

/// Reads a matrix file's bytes; `what` names it in errors (truncated, not ours,
/// another version, inconsistent).
pub fn read_matrix_file(bytes: &[u8], what: &std::path::Path) -> Result<MatrixFile, Error> {
    let bad = |reason: String| Error::Solution {
        path: what.to_path_buf(),
        reason,
    };
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    if bytes.len() < HEADER + 16 || &bytes[..8] != MAGIC {
        return Err(bad("not a coherad matrix file (no COHERADM header)".into()));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(bad(format!(
            "matrix file version {version}; this coherad reads {VERSION}"
        )));
    }
    let (n_rows, n_cols, meta_len) = (u64_at(16), u64_at(24), u64_at(32));
    let tail = bytes.len() - 16;
    if &bytes[tail..tail + 8] != END_MAGIC {
        return Err(bad(
            "truncated: no COHERADE trailer (an interrupted write?)".into(),
        ));
    }
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
