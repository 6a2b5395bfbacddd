//! Rows spilled to disk for out-of-core solving: each row written once, compact (its
//! column gaps as LEB128 varints, then its values as little-endian `f32`, as the stored
//! matrix rounds them), to an unnamed temporary file that the system removes when the
//! process ends, however it ends (nothing is left behind by a killed run), and read back
//! by patch from any thread.

use crate::Error;
use rad_core::PatchId;
use rad_solver::ShotRow;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Bytes an entry takes on disk, about (a value's 4 and a column gap's 1 to 2), for
/// estimating a file before it is written.
pub(crate) const FILE_BYTES_PER_ENTRY: f64 = 5.5;

/// Rows of `n` patches on disk, one a patch, written in any order and read by patch.
pub struct RowFile {
    dir: PathBuf,
    file: File,
    writer: Option<BufWriter<File>>,
    /// By patch: where its row starts and how many bytes it takes (`u64::MAX`: none yet).
    index: Vec<(u64, u32)>,
    at: u64,
    entries: u64,
    scratch: Vec<u8>,
}

impl RowFile {
    /// An empty file for the rows of `n` patches, in the folder `dir`.
    pub fn create_in(dir: &Path, n: usize) -> Result<RowFile, Error> {
        let io = |source| Error::Io {
            action: "create a temporary file in",
            path: dir.to_path_buf(),
            source,
        };
        let file = tempfile::tempfile_in(dir).map_err(io)?;
        let writer = BufWriter::with_capacity(8 << 20, file.try_clone().map_err(io)?);
        Ok(RowFile {
            dir: dir.to_path_buf(),
            file,
            writer: Some(writer),
            index: vec![(u64::MAX, 0); n],
            at: 0,
            entries: 0,
            scratch: Vec::new(),
        })
    }

    /// Writes `patch`'s row (`F_pj` by increasing j; values finite and >= 0).
    pub fn push(&mut self, patch: PatchId, entries: &[(PatchId, f64)]) -> Result<(), Error> {
        let n = self.index.len();
        let p = patch as usize;
        if p >= n {
            return Err(rad_solver::Error::EntryOutOfRange {
                row: patch,
                column: patch,
                n_patches: n,
            }
            .into());
        }
        if self.index[p].0 != u64::MAX {
            return Err(rad_solver::Error::DuplicateRow { patch }.into());
        }
        let Some(writer) = self.writer.as_mut() else {
            return Err(Error::Parse {
                what: "row file",
                input: self.dir.display().to_string(),
                reason: "rows pushed after it was finished".into(),
            });
        };
        let buf = &mut self.scratch;
        buf.clear();
        put_varint(buf, entries.len() as u64);
        let mut last: Option<PatchId> = None;
        for &(j, _) in entries {
            if j as usize >= n || last.is_some_and(|l| j <= l) {
                return Err(Error::Parse {
                    what: "row",
                    input: format!("patch {patch}"),
                    reason: format!(
                        "its columns must increase and stay below {n}; column {j} follows {last:?}"
                    ),
                });
            }
            put_varint(buf, (j - last.map_or(0, |l| l + 1)) as u64);
            last = Some(j);
        }
        for &(j, v) in entries {
            let f = v as f32;
            if !f.is_finite() || f < 0.0 {
                return Err(rad_solver::Error::BadValue {
                    row: patch,
                    column: j,
                    value: v,
                }
                .into());
            }
            buf.extend_from_slice(&f.to_le_bytes());
        }
        let len = u32::try_from(buf.len()).map_err(|_| Error::Parse {
            what: "row",
            input: format!("patch {patch}"),
            reason: "over 4 GiB on disk".into(),
        })?;
        writer.write_all(buf).map_err(|source| Error::Io {
            action: "write a temporary file in",
            path: self.dir.clone(),
            source,
        })?;
        self.index[p] = (self.at, len);
        self.at += len as u64;
        self.entries += entries.len() as u64;
        Ok(())
    }

    /// Flushes what was written; every patch must have its row.
    pub fn finish(&mut self) -> Result<(), Error> {
        if let Some(mut w) = self.writer.take() {
            w.flush().map_err(|source| Error::Io {
                action: "write a temporary file in",
                path: self.dir.clone(),
                source,
            })?;
        }
        if let Some(p) = self.index.iter().position(|e| e.0 == u64::MAX) {
            return Err(rad_solver::Error::MissingRow {
                patch: p as PatchId,
                n_patches: self.index.len(),
            }
            .into());
        }
        Ok(())
    }

    /// Bytes written, and entries.
    pub fn bytes(&self) -> u64 {
        self.at
    }
    pub fn entries(&self) -> u64 {
        self.entries
    }

    /// `patch`'s row, read back (after [`RowFile::finish`]).
    pub fn read(&self, patch: PatchId) -> Result<ShotRow, Error> {
        let mut row = ShotRow::default();
        self.read_into(patch, &mut row)?;
        Ok(row)
    }

    /// [`RowFile::read`] into `row`'s storage.
    pub fn read_into(&self, patch: PatchId, row: &mut ShotRow) -> Result<(), Error> {
        let &(at, len) = self.index.get(patch as usize).ok_or_else(|| {
            Error::from(rad_solver::Error::MissingRow {
                patch,
                n_patches: self.index.len(),
            })
        })?;
        if at == u64::MAX || self.writer.is_some() {
            return Err(rad_solver::Error::MissingRow {
                patch,
                n_patches: self.index.len(),
            }
            .into());
        }
        thread_local! {
            // (Each thread's buffer, kept: a fresh one a row costs its pages each time.)
            static BUF: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        BUF.with_borrow_mut(|buf| {
            buf.resize(len as usize, 0);
            read_at(&self.file, buf, at).map_err(|source| Error::Io {
                action: "read a temporary file in",
                path: self.dir.clone(),
                source,
            })?;
            decode(buf, row).ok_or_else(|| Error::Parse {
                what: "row file",
                input: self.dir.display().to_string(),
                reason: format!("the row of patch {patch} does not read back as written"),
            })
        })
    }
}

#[cfg(unix)]
fn read_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, at)
}

#[cfg(not(unix))]
fn read_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    let mut done = 0;
    while done < buf.len() {
        let k = std::os::windows::fs::FileExt::seek_read(file, &mut buf[done..], at + done as u64)?;
        if k == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        done += k;
    }
    Ok(())
}

fn put_varint(buf: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        buf.push((v as u8) | 0x80);
        v >>= 7;
    }
    buf.push(v as u8);
}

fn get_varint(buf: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *buf.get(*at)?;
        *at += 1;
        v |= ((b & 0x7f) as u64) << shift;
        if b < 0x80 {
            return Some(v);
        }
    }
    None
}

/// A row as [`RowFile::push`] wrote it, into `row`; `None` if the bytes are not one.
fn decode(buf: &[u8], row: &mut ShotRow) -> Option<()> {
    let mut at = 0;
    let count = usize::try_from(get_varint(buf, &mut at)?).ok()?;
    let (columns, values) = (&mut row.columns, &mut row.values);
    columns.clear();
    values.clear();
    columns.reserve(count.min(buf.len()));
    let mut next = 0u64;
    for _ in 0..count {
        let j = next + get_varint(buf, &mut at)?;
        columns.push(PatchId::try_from(j).ok()?);
        next = j + 1;
    }
    let values_bytes = buf.get(at..)?;
    if values_bytes.len() != 4 * count {
        return None;
    }
    values.extend(
        values_bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
    );
    Some(())
}

/// Bytes free for an unprivileged user in the file system holding `dir` (`None` if the
/// system does not say).
pub(crate) fn free_bytes(dir: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let path = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
        let mut stat = std::mem::MaybeUninit::<libc::statvfs>::uninit();
        // SAFETY: `path` is a NUL-terminated string and `stat` a buffer of the right
        // type, which statvfs fills when it returns 0.
        let stat = unsafe {
            if libc::statvfs(path.as_ptr(), stat.as_mut_ptr()) != 0 {
                return None;
            }
            stat.assume_init()
        };
        #[allow(clippy::unnecessary_cast)]
        Some(stat.f_bavail as u64 * stat.f_frsize as u64)
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_read_back_as_written_in_any_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = RowFile::create_in(dir.path(), 300).unwrap();
        let row = |p: u32| -> Vec<(PatchId, f64)> {
            (0..300u32)
                .filter(|j| (j * 7 + p) % 5 == 0 || *j == 299)
                .map(|j| (j, 1.0 / (1.0 + j as f64 + p as f64)))
                .collect()
        };
        for p in (0..300u32).rev() {
            f.push(p, &row(p)).unwrap();
        }
        f.push(7, &[]).unwrap_err();
        f.finish().unwrap();
        // Nothing named in the folder: the file is unnamed.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        for p in [0u32, 1, 150, 299] {
            let got = f.read(p).unwrap();
            let want = row(p);
            assert_eq!(got.columns, want.iter().map(|e| e.0).collect::<Vec<_>>());
            assert_eq!(
                got.values,
                want.iter().map(|e| e.1 as f32).collect::<Vec<_>>()
            );
        }
        assert_eq!(
            f.entries(),
            (0..300).map(|p| row(p).len() as u64).sum::<u64>()
        );
    }

    #[test]
    fn bad_rows_and_missing_rows_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = RowFile::create_in(dir.path(), 3).unwrap();
        assert!(f.push(3, &[]).is_err());
        let e = f.push(0, &[(2, 0.1), (1, 0.1)]).unwrap_err().to_string();
        assert!(e.contains("increase"), "{e}");
        let e = f.push(0, &[(1, f64::NAN)]).unwrap_err().to_string();
        assert!(e.contains("not a finite value"), "{e}");
        f.push(0, &[(1, 0.5)]).unwrap();
        let e = f.finish().unwrap_err().to_string();
        assert!(e.contains("no row for patch 1"), "{e}");
        let missing = Path::new("/nonexistent/coherad");
        let e = RowFile::create_in(missing, 3).err().unwrap().to_string();
        assert!(e.contains("/nonexistent/coherad"), "{e}");
    }

    #[test]
    fn varints_round_trip() {
        let mut buf = Vec::new();
        let values = [0u64, 1, 127, 128, 300, u32::MAX as u64, u64::MAX];
        for v in values {
            put_varint(&mut buf, v);
        }
        let mut at = 0;
        for v in values {
            assert_eq!(get_varint(&buf, &mut at), Some(v));
        }
        assert_eq!(get_varint(&buf, &mut at), None);
        assert!(decode(&[5, 0], &mut ShotRow::default()).is_none());
    }
}
