//! Writers: files written atomically (never a partial file), and the JSON of patches
//! and form-factor rows that the `coherad` binary prints.

use crate::Error;
use rad_geometry::Scene;
use rad_hemisphere::Row;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `path` through `fill`, all or nothing: the bytes go to a temporary file in
/// the same directory, which is renamed over `path` only once `fill` has succeeded and
/// the data are flushed. On any error the temporary file is removed and `path` is left
/// as it was.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut (dyn Write + Send)) -> std::io::Result<()>,
) -> Result<(), Error> {
    let err = |source| Error::Io {
        action: "write",
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| err(std::io::Error::other("not a file name")))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    remove_stale_temporaries(&dir, &name.to_string_lossy());
    // Removes the temporary file however this ends (an error, or a panic unwinding
    // through `fill`), unless it was renamed into place.
    struct Guard<'p>(&'p Path, bool);
    impl Drop for Guard<'_> {
        fn drop(&mut self) {
            if self.1 {
                let _ = std::fs::remove_file(self.0);
            }
        }
    }
    let mut guard = Guard(&tmp, true);
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        return Err(err(e));
    }
    guard.1 = false;
    Ok(())
}

/// Removes the temporary files of earlier writes of `name` in `dir` whose process has
/// gone (killed before it could clean up: `.{name}.{pid}.tmp` with no `/proc/{pid}`), so
/// that killed runs leave no litter that outlives the next write. Best effort, Linux.
fn remove_stale_temporaries(dir: &Path, name: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let file = file.to_string_lossy();
        let Some(pid) = file
            .strip_prefix(&prefix)
            .and_then(|rest| rest.strip_suffix(".tmp"))
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

fn arr3(v: glam::Vec3) -> [f32; 3] {
    v.to_array()
}

/// `{"patches":[{"id","polygon","center","normal","corners","area"}]}`; corners are
/// counter-clockwise seen from the side the normal points to.
pub fn write_patches_json(w: &mut dyn Write, scene: &Scene) -> std::io::Result<()> {
    #[derive(serde::Serialize)]
    struct P<'a> {
        id: usize,
        polygon: u32,
        polygon_name: &'a str,
        cell: [u32; 2],
        center: [f32; 3],
        normal: [f32; 3],
        corners: Vec<[f32; 3]>,
        area: f64,
        on_boundary: bool,
    }
    w.write_all(b"{\"patches\":[\n")?;
    for (id, p) in scene.patches().iter().enumerate() {
        if id > 0 {
            w.write_all(b",\n")?;
        }
        let rec = P {
            id,
            polygon: p.polygon,
            polygon_name: scene.polygons()[p.polygon as usize].name(),
            cell: p.cell,
            center: arr3(p.center),
            normal: arr3(p.normal),
            corners: p.corners.iter().copied().map(arr3).collect(),
            area: p.area,
            on_boundary: p.on_boundary,
        };
        serde_json::to_writer(&mut *w, &rec)?;
    }
    w.write_all(b"\n]}\n")
}

/// Header of a form-factor file; rows follow with [`write_row_json`], then
/// [`write_rows_footer`].
pub fn write_rows_header(
    w: &mut dyn Write,
    resolution: (u32, u32),
    method: &str,
    n_patches: usize,
) -> std::io::Result<()> {
    write!(
        w,
        "{{\"resolution\":[{},{}],\"method\":{},\"n_patches\":{},\"rows\":[\n",
        resolution.0,
        resolution.1,
        serde_json::to_string(method).expect("a string serialises"),
        n_patches
    )
}

/// One row: `{"patch":p,"source":"exact"|q,"entries":[[j,F],...],"back":b,"escaped":e}`,
/// `source` being `"exact"` for a ray-cast row or the id of the patch it was estimated
/// from; `first` is true for the first row of the file.
pub fn write_row_json(
    w: &mut dyn Write,
    row: &Row,
    estimated_from: Option<u32>,
    first: bool,
) -> std::io::Result<()> {
    #[derive(serde::Serialize)]
    #[serde(untagged)]
    enum Src {
        Exact(&'static str),
        From(u32),
    }
    #[derive(serde::Serialize)]
    struct R<'a> {
        patch: u32,
        source: Src,
        entries: &'a [(u32, f64)],
        back: f64,
        escaped: f64,
    }
    if !first {
        w.write_all(b",\n")?;
    }
    let source = estimated_from.map_or(Src::Exact("exact"), Src::From);
    serde_json::to_writer(
        &mut *w,
        &R {
            patch: row.patch,
            source,
            entries: &row.entries,
            back: row.back,
            escaped: row.escaped,
        },
    )?;
    Ok(())
}

pub fn write_rows_footer(w: &mut dyn Write) -> std::io::Result<()> {
    w.write_all(b"\n]}\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_writes_leave_no_file_and_keep_the_old_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.json");
        let e = write_atomic(&path, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(e.is_err());
        assert!(!path.exists());
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "temporary file left behind"
        );
        write_atomic(&path, |w| w.write_all(b"old")).unwrap();
        let _ = write_atomic(&path, |_| Err(std::io::Error::other("boom")));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
    }
}
