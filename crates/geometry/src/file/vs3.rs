//! NIST View3D's 3-D input format (`.vs3`, format 3): `T` title, `C` control options,
//! `F 3`, `V` vertices, `S` surfaces, `O` obstructions, `End of data`.
//!
//! Each `S` surface is a polygon of its own group (named by its View3D name, or by
//! `n:name` when names repeat), so `coherad viewfactors --by group` gives View3D's
//! surface matrix; a surface with `cmb = m` joins surface m's group (View3D's
//! combining: areas and factors added); an `O` surface is an obstruction (it blocks,
//! it gets no row). Emissivities become grey materials (reflectance 1 − ε). What
//! coherad does not do is refused by line, never skipped: subsurfaces (`base` ≠ 0),
//! masking and null surfaces (`M`, `N`), format `3a`, unknown records or options.

use crate::error::Error;
use crate::scene::{Material, PatchGrid, PolygonDesc, SceneDesc};
use glam::DVec3;
use rad_core::Rgb;
use std::path::Path;

/// The patch grid of a View3D surface unless `--patch-size` is given: with the
/// default two origins a patch side, what puts the closed-form cases within 1e-3.
pub const VS3_DEFAULT_GRID: PatchGrid = PatchGrid::Cells { nu: 10, nv: 10 };

/// The `C` line's options that coherad honours, and those it reads but ignores.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct View3dControl {
    pub title: String,
    /// `encl=1`: the surfaces form an enclosure (rows closed to 1).
    pub encl: bool,
    /// `emit=1`: Hottel's total exchange factors (script-F) from the emissivities.
    pub emit: bool,
    /// Options of View3D's own integration (eps, maxU, ...), read and not used.
    pub ignored: Vec<String>,
    /// Each surface's emissivity, in surface order (S lines).
    pub emissivity: Vec<f64>,
}

/// Reads a `.vs3` file.
pub fn load_vs3(path: &Path, patch_size: Option<f64>) -> Result<(SceneDesc, View3dControl), Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    vs3_from_text(&text, patch_size).map_err(|(line, message)| Error::View3d {
        path: path.to_path_buf(),
        line,
        message,
    })
}

struct Surface {
    number: usize,
    line: usize,
    vertices: Vec<DVec3>,
    cmb: usize,
    emit: f64,
    name: String,
}

/// Parses the text of a `.vs3` file: the description and its control options, or
/// (line, message).
pub fn vs3_from_text(
    text: &str,
    patch_size: Option<f64>,
) -> Result<(SceneDesc, View3dControl), (usize, String)> {
    let mut control = View3dControl::default();
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut surfaces: Vec<Surface> = Vec::new();
    let mut obstructions: Vec<Surface> = Vec::new();
    let mut ended = false;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let body = raw.split('!').next().unwrap_or("");
        let words: Vec<&str> = body
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty())
            .collect();
        let Some(first) = words.first() else { continue };
        // The rest of the line after the first word (where it really is: commas
        // separate words too).
        let after = first.as_ptr() as usize - body.as_ptr() as usize + first.len();
        let rest = body[after..].trim();
        let kind = first.chars().next().map(|c| c.to_ascii_uppercase());
        let fields = &words[1..];
        let err = |m: String| (line, m);
        match kind {
            Some('T') => control.title = rest.to_string(),
            Some('C') => read_control(rest, &mut control).map_err(err)?,
            Some('F') => match fields.first().copied() {
                Some("3") => {}
                Some(f) if f.eq_ignore_ascii_case("3a") => {
                    return Err(err("format 3a (surfaces by position, azimuth and tilt) is not supported: give vertices (F 3)".into()))
                }
                other => return Err(err(format!("format {other:?}: only 3 (3-D vertices and surfaces) is read"))),
            },
            Some('V') => {
                let v = numbers::<4>(fields, "V n x y z").map_err(err)?;
                if v[0] as usize != vertices.len() + 1 || v[0].fract() != 0.0 {
                    return Err(err(format!("vertex {} out of sequence (expected {})", v[0], vertices.len() + 1)));
                }
                vertices.push(DVec3::new(v[1], v[2], v[3]));
            }
            Some('S') | Some('O') => {
                let is_s = kind == Some('S');
                if is_s && !obstructions.is_empty() {
                    return Err(err("an S surface after an O surface: obstructions come after every radiating surface".into()));
                }
                let expected = surfaces.len() + obstructions.len() + 1;
                let s = read_surface(fields, is_s, line, &vertices, expected, surfaces.len()).map_err(err)?;
                if is_s {
                    if s.cmb != 0 && surfaces[s.cmb - 1].cmb != 0 {
                        return Err(err(format!("cmb {} names a surface that is itself combined into {}: View3D does not chain combining", s.cmb, surfaces[s.cmb - 1].cmb)));
                    }
                    surfaces.push(s);
                } else {
                    obstructions.push(s);
                }
            }
            Some('M') | Some('N') => {
                return Err(err("masking (M) and null (N) surfaces are not supported: cut the opening into separate surfaces".into()))
            }
            Some('/') | Some('X') => {}
            Some('E') | Some('*') => {
                ended = true;
                break;
            }
            _ => return Err(err(format!("unknown record {first:?} (View3D's are T, C, F, V, S, O and End of data)"))),
        }
    }
    if !ended {
        return Err((
            text.lines().count(),
            "no \"End of data\" line: the file may be truncated".into(),
        ));
    }
    if surfaces.is_empty() {
        return Err((text.lines().count(), "no S surfaces".into()));
    }
    Ok((
        desc(surfaces, obstructions, patch_size, &mut control),
        control,
    ))
}

/// The scene of the surfaces read.
fn desc(
    surfaces: Vec<Surface>,
    obstructions: Vec<Surface>,
    patch_size: Option<f64>,
    control: &mut View3dControl,
) -> SceneDesc {
    let grid = patch_size.map_or(VS3_DEFAULT_GRID, PatchGrid::Size);
    let mut materials: Vec<Material> = Vec::new();
    let mut material_of = |emit: f64| {
        let name = format!("emissivity {emit}");
        if let Some(k) = materials.iter().position(|m| m.name == name) {
            return k;
        }
        materials.push(Material {
            name,
            reflectance: Rgb([1.0 - emit; 3]),
            emission: Rgb::BLACK,
        });
        materials.len() - 1
    };
    let unique = {
        let mut names: Vec<&str> = surfaces
            .iter()
            .filter(|s| s.cmb == 0)
            .map(|s| s.name.as_str())
            .collect();
        names.sort_unstable();
        names.windows(2).all(|w| w[0] != w[1])
    };
    let group_of = |s: &Surface| {
        if unique {
            s.name.clone()
        } else {
            format!("{}:{}", s.number, s.name)
        }
    };
    let mut polygons = Vec::with_capacity(surfaces.len() + obstructions.len());
    for s in &surfaces {
        let target = if s.cmb == 0 { s } else { &surfaces[s.cmb - 1] };
        polygons.push(PolygonDesc {
            name: format!("{} (surface {}, line {})", s.name, s.number, s.line),
            vertices: s.vertices.clone(),
            material: material_of(s.emit),
            grid,
            group: Some(group_of(target)),
            obstruction: false,
            two_sided: false,
        });
    }
    control.emissivity = surfaces
        .iter()
        .filter(|s| s.cmb == 0)
        .map(|s| s.emit)
        .collect();
    for s in &obstructions {
        polygons.push(PolygonDesc {
            name: format!("obstruction (surface {}, line {})", s.number, s.line),
            vertices: s.vertices.clone(),
            material: material_of(0.5),
            grid: PatchGrid::Cells { nu: 1, nv: 1 },
            group: None,
            obstruction: true,
            two_sided: false,
        });
    }
    SceneDesc {
        materials,
        polygons,
        camera: None,
    }
}

fn numbers<const N: usize>(fields: &[&str], form: &str) -> Result<[f64; N], String> {
    if fields.len() < N {
        return Err(format!("too few fields: expected {form}"));
    }
    let mut out = [0.0; N];
    for (k, w) in fields[..N].iter().enumerate() {
        out[k] = w
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{w:?} is not a finite number (expected {form})"))?;
    }
    Ok(out)
}

fn read_surface(
    fields: &[&str],
    is_s: bool,
    line: usize,
    vertices: &[DVec3],
    expected: usize,
    n_radiating: usize,
) -> Result<Surface, String> {
    let form = if is_s {
        "S n v1 v2 v3 v4 base cmb emit name"
    } else {
        "O n v1 v2 v3 v4"
    };
    let ints = numbers::<5>(fields, form)?;
    if ints.iter().any(|v| v.fract() != 0.0 || *v < 0.0) {
        return Err(format!(
            "surface and vertex numbers are whole numbers >= 0 ({form})"
        ));
    }
    let n = ints[0] as usize;
    if n != expected {
        return Err(format!("surface {n} out of sequence (expected {expected})"));
    }
    let nv = vertices.len();
    let mut ids: Vec<usize> = ints[1..].iter().map(|&v| v as usize).collect();
    if ids[3] == 0 {
        ids.pop(); // a triangle
    }
    if let Some(&bad) = ids.iter().find(|&&v| v == 0 || v > nv) {
        return Err(format!(
            "vertex {bad} is out of range (vertices 1 to {nv} are defined before this line)"
        ));
    }
    let points: Vec<DVec3> = ids.iter().map(|&v| vertices[v - 1]).collect();
    if !is_s {
        return Ok(Surface {
            number: n,
            line,
            vertices: points,
            cmb: 0,
            emit: 0.5,
            name: String::new(),
        });
    }
    let rest = numbers::<3>(&fields[5..], form)?;
    let (base, cmb, emit) = (rest[0], rest[1], rest[2]);
    if base != 0.0 {
        return Err(format!("surface {n} is a subsurface of surface {base}: subsurfaces are not supported; cut it out of its base (split the base into surfaces around it)"));
    }
    if cmb.fract() != 0.0 || cmb < 0.0 || (cmb != 0.0 && cmb as usize >= n.min(n_radiating + 1)) {
        return Err(format!(
            "cmb {cmb}: give 0, or an earlier S surface to combine surface {n} into"
        ));
    }
    if !(emit > 0.0 && emit <= 1.0) {
        return Err(format!("emissivity {emit} is not in (0, 1]"));
    }
    let name = fields
        .get(8)
        .map(|s| s.to_string())
        .ok_or_else(|| format!("no name (expected {form})"))?;
    Ok(Surface {
        number: n,
        line,
        vertices: points,
        cmb: cmb as usize,
        emit,
        name,
    })
}

fn read_control(text: &str, control: &mut View3dControl) -> Result<(), String> {
    let words: Vec<&str> = text
        .split(|c: char| c == '=' || c == ',' || c.is_whitespace())
        .filter(|w| !w.is_empty())
        .collect();
    if words.len() % 2 != 0 {
        return Err(format!("control line {text:?}: give key=value pairs"));
    }
    for pair in words.chunks(2) {
        let (key, value) = (pair[0], pair[1]);
        let v: f64 = value
            .parse()
            .map_err(|_| format!("control option {key}={value:?}: not a number"))?;
        match key.to_ascii_lowercase().as_str() {
            "encl" => control.encl = v != 0.0,
            "emit" => control.emit = v != 0.0,
            "eps" | "maxu" | "maxo" | "mino" | "row" | "col" | "out" | "list" | "prjd" | "maxv" => {
                control.ignored.push(format!("{key}={value}"))
            }
            _ => return Err(format!("unknown control option {key:?} (View3D's are eps, maxU, maxO, minO, row, col, encl, emit, out, list, prjD)")),
        }
    }
    Ok(())
}
