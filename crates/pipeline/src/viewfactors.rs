//! Surface-to-surface view factors: a scene's rows (averaged over several origins a
//! patch, for area-to-area factors) gathered by patch, polygon or named group, under an
//! enclosure rule, and written as JSON, CSV or Matrix Market.

mod exact;
mod motion;

pub use crate::moving::MOTION_KEEP_BYTES;
pub use exact::PolygonPairs;
pub use motion::{view_factors_over_motion, StepViewFactors};

use crate::rows::{check_rows, chunk_patches, for_each_chunk, stream_chunks};
use crate::{rows_with_caster, CasterJob, CasterKind, Error};
use rad_core::PatchId;
use rad_geometry::Scene;
pub use rad_hemisphere::MAX_ORIGINS;
use rad_hemisphere::{compute_area_rows, Caster, Hemisphere, Row};
pub use rad_solver::MAX_SCRIPT_F;
use rad_solver::{Enclosure, EnclosureReport, SurfaceMatrix};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Write;

/// What a row of the matrix is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Grouping {
    /// Patch to patch (the hemisphere rows themselves).
    Patch,
    /// Polygon to polygon.
    Polygon,
    /// Named group to named group (a polygon's `group`: the JSON format's field, an OBJ
    /// object or group).
    Group,
}

impl Grouping {
    pub const ALL: [Grouping; 3] = [Grouping::Patch, Grouping::Polygon, Grouping::Group];

    pub fn name(self) -> &'static str {
        match self {
            Grouping::Patch => "patch",
            Grouping::Polygon => "polygon",
            Grouping::Group => "group",
        }
    }
}

/// Origins a patch side unless told otherwise: 2 × 2 hemispheres a patch, the fewest
/// that put the closed forms of the validation suite within 1e-3 at their patch grids
/// (see the README's table; one origin leaves close surfaces point to area).
pub const DEFAULT_ORIGINS: u32 = 2;

/// How a pair of surfaces' factor is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ViewFactorMethod {
    /// In closed form where no polygon can come between a pair of polygons (the double
    /// contour integral), from hemispheres elsewhere; hemispheres alone by patch and
    /// past [`EXACT_MAX_POLYGONS`] polygons.
    Auto,
    /// In closed form for every pair: an error where a polygon may come between two.
    Exact,
    /// From `origins`² hemispheres a patch, every pair.
    Hemisphere,
}

impl ViewFactorMethod {
    pub fn name(self) -> &'static str {
        match self {
            ViewFactorMethod::Auto => "auto",
            ViewFactorMethod::Exact => "exact",
            ViewFactorMethod::Hemisphere => "hemisphere",
        }
    }
}

/// The relative tolerance of each closed-form factor's outer quadrature unless told
/// otherwise.
pub const DEFAULT_TOLERANCE: f64 = 1e-10;

/// What a polygon's closed-form factors leave of its area below this share is their
/// quadrature's error, not rays escaping.
const ESCAPE_FLOOR: f64 = 1e-8;

/// Polygons past which `auto` makes every factor from hemispheres: the shaft tests go
/// as the cube of the polygons.
pub const EXACT_MAX_POLYGONS: usize = 2_000;

/// How to make a scene's view factors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewFactorConfig {
    pub by: Grouping,
    pub method: ViewFactorMethod,
    /// Each closed-form factor's outer quadrature to this, relative to the first
    /// polygon's area.
    pub tolerance: f64,
    /// Origins a patch side (`origins²` hemispheres a patch).
    pub origins: u32,
    pub enclosure: Enclosure,
    pub caster: CasterKind,
    /// Hottel's total exchange factors from the surfaces' emissivities (1 − their
    /// materials' mean reflectance), after the enclosure rule: View3D's `emit=1`.
    pub script_f: bool,
}

impl ViewFactorConfig {
    /// The defaults for `scene`: by polygon, auto, [`DEFAULT_ORIGINS`], raw, the fastest
    /// caster.
    pub fn for_scene(scene: &Scene) -> ViewFactorConfig {
        ViewFactorConfig {
            by: Grouping::Polygon,
            method: ViewFactorMethod::Auto,
            tolerance: DEFAULT_TOLERANCE,
            origins: DEFAULT_ORIGINS,
            enclosure: Enclosure::Raw,
            caster: CasterKind::fastest_for(scene),
            script_f: false,
        }
    }

    /// Whether a file of `format` is written as its rows are made, never held
    /// ([`stream_patch_matrix`]): the binary format, patch to patch, raw, no script-F.
    pub fn streams_to(&self, format: MatrixFormat) -> bool {
        format == MatrixFormat::Bin
            && self.by == Grouping::Patch
            && self.enclosure == Enclosure::Raw
            && !self.script_f
    }
}

/// A scene's surface-to-surface view factors.
#[derive(Clone, Debug)]
pub struct ViewFactors {
    pub by: Grouping,
    pub origins: u32,
    pub enclosure: Enclosure,
    /// Whether `matrix` holds script-F ([`ViewFactorConfig::script_f`]).
    pub script_f: bool,
    /// One name a surface: the polygon's or group's name, or `patch N`.
    pub names: Vec<String>,
    /// The factors under the enclosure rule (areas included).
    pub matrix: SurfaceMatrix,
    /// Per surface, the area-weighted form factor of rays that left the scene, and of
    /// rays that met the back of a polygon (as computed, before the enclosure rule).
    pub escaped: Vec<f64>,
    pub back: Vec<f64>,
    /// ...and of rays that met an obstruction-only polygon.
    pub obstructed: Vec<f64>,
    /// Per surface, its area-weighted emissivity, 1 − the mean of its materials'
    /// reflectance channels (grey surfaces: what View3D's output lists).
    pub emissivity: Vec<f64>,
    pub report: EnclosureReport,
    /// Pairs of polygons made in closed form and from hemispheres (none of either when
    /// every factor came from hemispheres), and the polygons whose hemispheres were cast.
    pub exact_pairs: usize,
    pub hemisphere_pairs: usize,
    pub hemisphere_polygons: usize,
}

/// A patch of an obstruction polygon belongs to no surface.
const NO_SURFACE: u32 = u32::MAX;

/// The surfaces of `scene` under `by`: (each patch's surface, or [`NO_SURFACE`] for an
/// obstruction's, and the surfaces' names). Surfaces are numbered in order of their
/// first patch.
fn surfaces(scene: &Scene, by: Grouping) -> Result<(Vec<u32>, Vec<String>), Error> {
    let mut names = Vec::new();
    let mut of_polygon = Vec::with_capacity(scene.polygons().len());
    let mut index: HashMap<&str, u32> = HashMap::new();
    for (k, poly) in scene.polygons().iter().enumerate() {
        if scene.is_obstruction(k) {
            of_polygon.push(NO_SURFACE);
            continue;
        }
        let id = match by {
            Grouping::Patch => 0, // numbered per patch below
            Grouping::Polygon => {
                names.push(poly.name().to_string());
                names.len() as u32 - 1
            }
            Grouping::Group => {
                let Some(g) = scene.group(k) else {
                    return Err(Error::Parse {
                        what: "grouping",
                        input: "group".into(),
                        reason: format!(
                            "polygon {k} ({:?}) belongs to no group: give every polygon a \"group\" (or use --by polygon)",
                            poly.name()
                        ),
                    });
                };
                *index.entry(g).or_insert_with(|| {
                    names.push(g.to_string());
                    names.len() as u32 - 1
                })
            }
        };
        of_polygon.push(id);
    }
    let mut surface = Vec::with_capacity(scene.patches().len());
    for (p, patch) in scene.patches().iter().enumerate() {
        let s = of_polygon[patch.polygon as usize];
        if by == Grouping::Patch && s != NO_SURFACE {
            names.push(format!("patch {p}"));
            surface.push(names.len() as u32 - 1);
        } else {
            surface.push(s);
        }
    }
    Ok((surface, names))
}

/// Sums of `A_i F_ij` into surface rows, taken row by row in patch order (so the sums,
/// and their bits, do not depend on the thread count).
struct Gather<'a> {
    scene: &'a Scene,
    by: Grouping,
    surface: &'a [u32],
    /// Surface rows of a grouping whose surfaces are not contiguous in patch order.
    rows: Vec<HashMap<u32, f64>>,
    /// Where every surface's patches are contiguous: the surface being summed, its
    /// sums (dense, with the columns touched), and the finished rows.
    current: Option<usize>,
    dense: Vec<f64>,
    touched: Vec<u32>,
    done_rows: Vec<Vec<(u32, f64)>>,
    patch_rows: Vec<Vec<(u32, f64)>>,
    escaped: Vec<f64>,
    back: Vec<f64>,
    obstructed: Vec<f64>,
}

impl Gather<'_> {
    fn take(&mut self, row: &Row) {
        let s = self.surface[row.patch as usize] as usize;
        if self.by == Grouping::Patch {
            let (seen, blocked) = patch_row(self.surface, row);
            self.patch_rows[s] = seen;
            self.obstructed[s] = blocked;
            self.escaped[s] = row.escaped;
            self.back[s] = row.back;
            return;
        }
        let a = self.scene.patches()[row.patch as usize].area;
        if !self.done_rows.is_empty() {
            // Contiguous surfaces: a dense accumulator, the row flushed when it ends.
            if self.current != Some(s) {
                self.flush();
                self.current = Some(s);
            }
            for &(j, f) in &row.entries {
                match self.surface[j as usize] {
                    NO_SURFACE => self.obstructed[s] += a * f,
                    t => {
                        let v = &mut self.dense[t as usize];
                        if *v == 0.0 {
                            self.touched.push(t);
                        }
                        *v += a * f;
                    }
                }
            }
        } else {
            let acc = &mut self.rows[s];
            for &(j, f) in &row.entries {
                match self.surface[j as usize] {
                    NO_SURFACE => self.obstructed[s] += a * f,
                    t => *acc.entry(t).or_insert(0.0) += a * f,
                }
            }
        }
        self.escaped[s] += a * row.escaped;
        self.back[s] += a * row.back;
    }

    /// Finishes the current surface's row (contiguous surfaces): its sums, sorted by
    /// column (divided by the area later, as the other path's).
    fn flush(&mut self) {
        let Some(s) = self.current.take() else { return };
        self.touched.sort_unstable();
        let row = self
            .touched
            .iter()
            .map(|&t| (t, std::mem::take(&mut self.dense[t as usize])))
            .collect();
        self.touched.clear();
        self.done_rows[s] = row;
    }
}

/// A patch row's entries as surface columns (the very values: patch surfaces are the
/// patches, renumbered past obstructions), and what obstructions took.
fn patch_row(surface: &[u32], row: &Row) -> (Vec<(u32, f64)>, f64) {
    let mut blocked = 0.0;
    let seen = row
        .entries
        .iter()
        .filter_map(|&(j, f)| match surface[j as usize] {
            NO_SURFACE => {
                blocked += f;
                None
            }
            t => (f > 0.0).then_some((t, f)),
        })
        .collect();
    (seen, blocked)
}

/// Every patch's row but obstructions' (averaged over `opts.origins`² origins), of the
/// polygons `wanted` says (all if `None`), made in chunks of [`crate::STREAM_CHUNK`]
/// patches in parallel through `opts.caster` and handed to `sink` in patch order.
fn for_each_row(
    scene: &Scene,
    hemi: &Hemisphere,
    opts: &ViewFactorConfig,
    wanted: Option<&[bool]>,
    progress: &(dyn Fn(usize) + Sync),
    sink: &mut (dyn FnMut(&Row) -> Result<(), Error> + Send),
) -> Result<(), Error> {
    struct Job<'a, 'g> {
        hemi: &'a Hemisphere,
        origins: u32,
        wanted: Option<&'a [bool]>,
        progress: &'a (dyn Fn(usize) + Sync),
        sink: &'g mut (dyn FnMut(&Row) -> Result<(), Error> + Send),
    }
    impl CasterJob for Job<'_, '_> {
        type Out = ();
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<(), Error> {
            let chunks = stream_chunks(scene.patches().len());
            let sink = self.sink;
            for_each_chunk(
                &chunks,
                |r| {
                    let (mut patches, progress) = chunk_patches(r, self.progress);
                    patches.retain(|&p| {
                        let polygon = scene.patches()[p as usize].polygon as usize;
                        !scene.is_obstruction(polygon) && self.wanted.is_none_or(|w| w[polygon])
                    });
                    let rows = compute_area_rows(
                        scene,
                        caster,
                        self.hemi,
                        &patches,
                        self.origins,
                        &progress,
                    )?;
                    check_rows(&rows)?;
                    Ok(rows)
                },
                &mut |rows: Vec<Row>| rows.iter().try_for_each(&mut *sink),
            )
        }
    }
    rows_with_caster(
        scene,
        opts.caster,
        Job {
            hemi,
            origins: opts.origins,
            wanted,
            progress,
            sink,
        },
    )
}

/// What [`stream_patch_matrix`] wrote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Streamed {
    pub n_patches: usize,
    pub entries: u64,
    /// Rows that lose form factor to rays leaving the scene, or meeting backs.
    pub escaping_rows: usize,
    pub back_rows: usize,
}

/// Patch-to-patch factors, raw, written to `w` as a [`crate::matrix_file`] row by row
/// as they are made, never held: what `coherad viewfactors --by patch --enclosure raw
/// --format bin` runs, for matrices of any size. The bytes are [`write_view_factors`]'s
/// of the same run (tested).
pub fn stream_patch_matrix(
    scene: &Scene,
    hemi: &Hemisphere,
    opts: &ViewFactorConfig,
    run: &ViewFactorRun,
    w: &mut (dyn Write + Send),
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Streamed, Error> {
    let (surface, names) = surfaces(scene, Grouping::Patch)?;
    let n = names.len();
    let areas: Vec<f64> = (0..surface.len())
        .filter(|&p| surface[p] != NO_SURFACE)
        .map(|p| scene.patches()[p].area)
        .collect();
    let meta = bin_metadata(
        run,
        Grouping::Patch,
        opts.origins,
        Enclosure::Raw,
        false,
        &names,
    );
    let io = |e: std::io::Error| Error::Io {
        action: "write",
        path: "the matrix file".into(),
        source: e,
    };
    let mut out =
        crate::matrix_file::MatrixWriter::begin(w, n as u64, &meta, &areas).map_err(io)?;
    let mut done = Streamed {
        n_patches: n,
        entries: 0,
        escaping_rows: 0,
        back_rows: 0,
    };
    for_each_row(scene, hemi, opts, None, progress, &mut |r| {
        done.escaping_rows += usize::from(r.escaped > 0.0);
        done.back_rows += usize::from(r.back > 0.0);
        out.row(&patch_row(&surface, r).0).map_err(io)
    })?;
    done.entries = out.finish().map_err(io)?;
    Ok(done)
}

fn bin_metadata(
    run: &ViewFactorRun,
    by: Grouping,
    origins: u32,
    enclosure: Enclosure,
    script_f: bool,
    names: &[String],
) -> serde_json::Value {
    serde_json::json!({
        "what": "view factors F_IJ: row I sees column J",
        "scene": run.scene,
        "scene_hash": run.scene_hash,
        "resolution": [run.resolution.0, run.resolution.1],
        "by": by.name(),
        "origins": origins,
        "enclosure": enclosure.name(),
        "script_f": script_f,
        "names": names,
    })
}

fn write_bin(w: &mut dyn Write, vf: &ViewFactors, run: &ViewFactorRun) -> std::io::Result<()> {
    let meta = bin_metadata(run, vf.by, vf.origins, vf.enclosure, vf.script_f, &vf.names);
    let m = &vf.matrix;
    let mut out = crate::matrix_file::MatrixWriter::begin(w, m.n() as u64, &meta, &m.area)?;
    for row in &m.rows {
        out.row(row)?;
    }
    out.finish().map(|_| ())
}

/// The view factors of `scene` at hemisphere `hemi` by `opts`; `progress(n)` gets the
/// patches done so far. Rows are made in chunks of patches, in parallel, and
/// gathered in patch order: the same bits whatever the thread count.
pub fn view_factors(
    scene: &Scene,
    hemi: &Hemisphere,
    opts: &ViewFactorConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<ViewFactors, Error> {
    let pairs = exact_pairs(scene, opts)?;
    let wanted = pairs.as_ref().map(|p| p.obstructed.as_slice());
    // (No hemisphere at all where every pair is clear: not even a caster is built.)
    let none = wanted.is_some_and(|w| !w.contains(&true));
    view_factors_with(scene, opts, pairs.as_ref(), &mut |sink| {
        if none {
            return Ok(());
        }
        for_each_row(scene, hemi, opts, wanted, progress, sink)
    })
}

/// The polygons' pairs of an `exact` or `auto` run ([`PolygonPairs`]), or `None` where
/// every factor comes from hemispheres (`hemisphere`; `auto` by patch or past
/// [`EXACT_MAX_POLYGONS`] polygons); an error for `exact` by patch, or where a polygon
/// may come between two.
pub fn exact_pairs(scene: &Scene, opts: &ViewFactorConfig) -> Result<Option<PolygonPairs>, Error> {
    let n = scene.polygons().len();
    match opts.method {
        ViewFactorMethod::Hemisphere => return Ok(None),
        ViewFactorMethod::Auto if opts.by == Grouping::Patch || n > EXACT_MAX_POLYGONS => {
            return Ok(None)
        }
        ViewFactorMethod::Exact if opts.by == Grouping::Patch => {
            return Err(Error::Setting(
                "--method exact makes factors between polygons: use --by polygon or group \
                 (by patch, --method hemisphere)"
                    .into(),
            ))
        }
        _ => {}
    }
    let pairs = exact::polygon_pairs(scene, &vec![true; n], opts.tolerance)?;
    if opts.method == ViewFactorMethod::Exact && pairs.n_obstructed > 0 {
        let name = |k: u32| scene.polygons()[k as usize].name().to_string();
        let shown: Vec<String> = pairs
            .first_obstructed
            .iter()
            .map(|&(p, q, r)| {
                format!(
                    "{:?} and {:?} ({:?} may come between)",
                    name(p),
                    name(q),
                    name(r)
                )
            })
            .collect();
        return Err(Error::Setting(format!(
            "--method exact: {} pairs of polygons may have another between them, so their \
             factors need hemispheres; the first: {}; use --method auto",
            pairs.n_obstructed,
            shown.join(", ")
        )));
    }
    Ok(Some(pairs))
}

/// The patches whose rows view factors take: every patch but obstructions', in order
/// (what [`area_rows`] may be given in shares, and [`view_factors_of_rows`] wants
/// rows of).
pub fn row_patches(scene: &Scene) -> Vec<PatchId> {
    (0..scene.patches().len() as PatchId)
        .filter(|&p| !scene.is_obstruction(scene.patches()[p as usize].polygon as usize))
        .collect()
}

/// The rows view factors take of `patches` (any of [`row_patches`], in any order: a
/// process's share), averaged over `opts.origins`² origins through `opts.caster`, in
/// parallel; each the very row [`view_factors`] makes of that patch.
pub fn area_rows(
    scene: &Scene,
    hemi: &Hemisphere,
    opts: &ViewFactorConfig,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Row>, Error> {
    struct Job<'a> {
        hemi: &'a Hemisphere,
        origins: u32,
        patches: &'a [PatchId],
        progress: &'a (dyn Fn(usize) + Sync),
    }
    impl CasterJob for Job<'_> {
        type Out = Vec<Row>;
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Vec<Row>, Error> {
            let rows = compute_area_rows(
                scene,
                caster,
                self.hemi,
                self.patches,
                self.origins,
                self.progress,
            )?;
            check_rows(&rows)?;
            Ok(rows)
        }
    }
    let job = Job {
        hemi,
        origins: opts.origins,
        patches,
        progress,
    };
    rows_with_caster(scene, opts.caster, job)
}

/// [`view_factors`] of rows made elsewhere (by processes, [`area_rows`] of their
/// shares): `rows` one for each of [`row_patches`], in that order, each dropped once
/// summed; the same result, to the bit, as [`view_factors`] making them.
pub fn view_factors_of_rows(
    scene: &Scene,
    opts: &ViewFactorConfig,
    rows: Vec<Row>,
) -> Result<ViewFactors, Error> {
    let want = row_patches(scene);
    if rows.len() != want.len() || rows.iter().zip(&want).any(|(r, &p)| r.patch != p) {
        return Err(Error::Parse {
            what: "view-factor rows",
            input: format!("{} rows", rows.len()),
            reason: format!(
                "not one row for each of the {} patches, in order",
                want.len()
            ),
        });
    }
    let pairs = exact_pairs(scene, opts)?;
    let mut rows = Some(rows);
    view_factors_with(scene, opts, pairs.as_ref(), &mut |sink| {
        rows.take().into_iter().flatten().try_for_each(|r| sink(&r))
    })
}

/// Rows feed a sink, in patch order.
type RowFeed<'a> =
    dyn FnMut(&mut (dyn FnMut(&Row) -> Result<(), Error> + Send)) -> Result<(), Error> + 'a;

/// [`view_factors`] with its rows from `feed`, and the closed-form pairs where given.
fn view_factors_with(
    scene: &Scene,
    opts: &ViewFactorConfig,
    pairs: Option<&PolygonPairs>,
    feed: &mut RowFeed<'_>,
) -> Result<ViewFactors, Error> {
    let (surface, names) = surfaces(scene, opts.by)?;
    let n = names.len();
    let mut area = vec![0.0; n];
    let mut emissivity = vec![0.0; n];
    for (p, patch) in scene.patches().iter().enumerate() {
        if surface[p] == NO_SURFACE {
            continue;
        }
        let s = surface[p] as usize;
        area[s] += patch.area;
        let rho = scene.patch_material(p as PatchId).reflectance.0;
        emissivity[s] += patch.area * (1.0 - (rho[0] + rho[1] + rho[2]) / 3.0);
    }
    for s in 0..n {
        emissivity[s] /= area[s];
    }
    let (sums, counts) = match pairs {
        None => (gather_rows(scene, opts, &surface, &area, feed)?, [0; 3]),
        Some(pairs) => gather_pairs(scene, &surface, &area, pairs, feed)?,
    };
    let Sums {
        rows,
        escaped,
        back,
        obstructed,
    } = sums;
    // Rays that met an obstruction or the back of a polygon do not leak (only escaping
    // rays do); `closed` spreads them over the row, as View3D's encl=1 does. Where some
    // factors are in closed form and some from hemispheres, a row's sum also carries
    // their difference (the hemispheres' discretisation), which is no leak either:
    // there, all that did not escape counts as blocked.
    let blocked: Vec<f64> = (0..n)
        .map(|s| match pairs {
            None => obstructed[s] + back[s],
            Some(_) => {
                let seen: f64 = rows[s].iter().map(|e| e.1).sum();
                (1.0 - seen - escaped[s]).max(0.0)
            }
        })
        .collect();
    let raw = SurfaceMatrix { area, rows };
    let (mut matrix, report) = raw.into_enforced(opts.enclosure, &blocked)?;
    if opts.script_f {
        matrix = matrix.script_f(&emissivity)?;
    }
    Ok(ViewFactors {
        by: opts.by,
        origins: opts.origins,
        enclosure: opts.enclosure,
        script_f: opts.script_f,
        names,
        matrix,
        escaped,
        back,
        obstructed,
        emissivity,
        report,
        exact_pairs: counts[0],
        hemisphere_pairs: counts[1],
        hemisphere_polygons: counts[2],
    })
}

/// Surface rows (`F_IJ`) and, per surface, the share of rays that escaped, met a back
/// or an obstruction-only polygon.
struct Sums {
    rows: Vec<Vec<(u32, f64)>>,
    escaped: Vec<f64>,
    back: Vec<f64>,
    obstructed: Vec<f64>,
}

/// Every factor from the hemisphere rows `feed` gives: each surface's patches' rows
/// summed ([`Gather`]).
fn gather_rows(
    scene: &Scene,
    opts: &ViewFactorConfig,
    surface: &[u32],
    area: &[f64],
    feed: &mut RowFeed<'_>,
) -> Result<Sums, Error> {
    let n = area.len();
    // Each surface's patches one run in patch order (by polygon always; by group when
    // groups are contiguous, as a View3D file's are)?
    let contiguous = opts.by != Grouping::Patch && n > 0 && {
        let mut seen = vec![false; n];
        let mut last = NO_SURFACE;
        surface.iter().filter(|&&s| s != NO_SURFACE).all(|&s| {
            let fresh = s == last || !std::mem::replace(&mut seen[s as usize], true);
            last = s;
            fresh
        })
    };
    let mut gather = Gather {
        scene,
        by: opts.by,
        surface,
        rows: if opts.by == Grouping::Patch || contiguous {
            Vec::new()
        } else {
            vec![HashMap::new(); n]
        },
        current: None,
        dense: if contiguous { vec![0.0; n] } else { Vec::new() },
        touched: Vec::new(),
        done_rows: if contiguous {
            vec![Vec::new(); n]
        } else {
            Vec::new()
        },
        patch_rows: if opts.by == Grouping::Patch {
            vec![Vec::new(); n]
        } else {
            Vec::new()
        },
        escaped: vec![0.0; n],
        back: vec![0.0; n],
        obstructed: vec![0.0; n],
    };
    feed(&mut |r| {
        gather.take(r);
        Ok(())
    })?;
    gather.flush();
    let rows: Vec<Vec<(u32, f64)>> = if opts.by == Grouping::Patch {
        std::mem::take(&mut gather.patch_rows)
    } else if contiguous {
        let mut rows = std::mem::take(&mut gather.done_rows);
        for (s, row) in rows.iter_mut().enumerate() {
            row.iter_mut().for_each(|e| e.1 /= area[s]);
        }
        rows
    } else {
        gather
            .rows
            .iter()
            .enumerate()
            .map(|(s, acc)| {
                let mut row: Vec<(u32, f64)> =
                    acc.iter().map(|(&j, &v)| (j, v / area[s])).collect();
                row.sort_unstable_by_key(|e| e.0);
                row
            })
            .collect()
    };
    let (mut escaped, mut back, mut obstructed) = (gather.escaped, gather.back, gather.obstructed);
    if opts.by != Grouping::Patch {
        for s in 0..n {
            escaped[s] /= area[s];
            back[s] /= area[s];
            obstructed[s] /= area[s];
        }
    }
    Ok(Sums {
        rows,
        escaped,
        back,
        obstructed,
    })
}

/// The closed-form factors of `pairs`' clear pairs of polygons and, for the rest, the
/// hemisphere rows `feed` gives of the polygons [`PolygonPairs::obstructed`] marks (any
/// other row is passed over), summed polygon to polygon, then surface to surface; the
/// counts of pairs made each way and of polygons cast.
fn gather_pairs(
    scene: &Scene,
    surface: &[u32],
    area: &[f64],
    pairs: &PolygonPairs,
    feed: &mut RowFeed<'_>,
) -> Result<(Sums, [usize; 3]), Error> {
    let polygons = scene.polygons();
    let patch_polygon = |j: u32| scene.patches()[j as usize].polygon;
    let clear: HashSet<(u32, u32)> = pairs.clear.iter().map(|&(p, q, _, _)| (p, q)).collect();
    let is_clear = |p: u32, q: u32| clear.contains(&(p.min(q), p.max(q)));
    // A_p F_pq by polygon, each row in order of q.
    let mut by_polygon: Vec<BTreeMap<u32, f64>> = vec![BTreeMap::new(); polygons.len()];
    // Per polygon: what escaped, met a back (hemisphere rows only).
    let mut escaped = vec![0.0; polygons.len()];
    let mut back = vec![0.0; polygons.len()];
    let mut hemisphere_pairs: HashSet<(u32, u32)> = HashSet::new();
    feed(&mut |r| {
        let p = patch_polygon(r.patch);
        if !pairs.obstructed[p as usize] {
            return Ok(());
        }
        let a = scene.patches()[r.patch as usize].area;
        for &(j, f) in &r.entries {
            let q = patch_polygon(j);
            if q != p && !is_clear(p, q) {
                *by_polygon[p as usize].entry(q).or_insert(0.0) += a * f;
                hemisphere_pairs.insert((p.min(q), p.max(q)));
            }
        }
        escaped[p as usize] += a * r.escaped;
        back[p as usize] += a * r.back;
        Ok(())
    })?;
    for &(p, q, af, _) in &pairs.clear {
        *by_polygon[p as usize].entry(q).or_insert(0.0) += af;
        *by_polygon[q as usize].entry(p).or_insert(0.0) += af;
    }
    // A polygon cast by no hemisphere: what its closed-form factors leave escapes
    // (nothing, within their quadrature, in a closed scene).
    for (p, row) in by_polygon.iter().enumerate() {
        if !pairs.obstructed[p] {
            let seen: f64 = row.values().sum();
            let left = polygons[p].area() - seen;
            escaped[p] = if left > ESCAPE_FLOOR * polygons[p].area() {
                left
            } else {
                0.0
            };
        }
    }
    let n = area.len();
    let surface_of = |p: usize| surface[polygons[p].first_patch() as usize];
    let mut rows: Vec<BTreeMap<u32, f64>> = vec![BTreeMap::new(); n];
    let mut sums = Sums {
        rows: Vec::new(),
        escaped: vec![0.0; n],
        back: vec![0.0; n],
        obstructed: vec![0.0; n],
    };
    for (p, row) in by_polygon.iter().enumerate() {
        let s = surface_of(p);
        if s == NO_SURFACE {
            continue;
        }
        let s = s as usize;
        for (&q, &v) in row {
            match surface_of(q as usize) {
                NO_SURFACE => sums.obstructed[s] += v,
                t => *rows[s].entry(t).or_insert(0.0) += v,
            }
        }
        sums.escaped[s] += escaped[p];
        sums.back[s] += back[p];
    }
    sums.rows = rows
        .into_iter()
        .enumerate()
        .map(|(s, row)| row.into_iter().map(|(t, v)| (t, v / area[s])).collect())
        .collect();
    for s in 0..n {
        sums.escaped[s] /= area[s];
        sums.back[s] /= area[s];
        sums.obstructed[s] /= area[s];
    }
    let cast = pairs.obstructed.iter().filter(|&&o| o).count();
    Ok((sums, [pairs.clear.len(), hemisphere_pairs.len(), cast]))
}

/// The formats [`write_view_factors`] writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MatrixFormat {
    /// Our JSON: surfaces (name, area, row sum, escaped, back) and sparse rows.
    Json,
    /// A dense table: the first row and column the surfaces' names.
    Csv,
    /// Matrix Market coordinate, real, general (1-based; `scipy.io.mmread` reads it).
    Mtx,
    /// View3D's own text output (its format 0): a header line, the areas, one row of
    /// factors a surface (six decimals, as View3D writes them), the emissivities.
    View3d,
    /// coherad's compact binary file ([`crate::matrix_file`]): f64 triplets, written
    /// row by row.
    Bin,
}

impl MatrixFormat {
    pub const ALL: [MatrixFormat; 5] = [
        MatrixFormat::Json,
        MatrixFormat::Csv,
        MatrixFormat::Mtx,
        MatrixFormat::View3d,
        MatrixFormat::Bin,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MatrixFormat::Json => "json",
            MatrixFormat::Csv => "csv",
            MatrixFormat::Mtx => "mtx",
            MatrixFormat::View3d => "view3d",
            MatrixFormat::Bin => "bin",
        }
    }
}

/// The largest matrix written as CSV (a dense table of n² numbers).
pub const MAX_CSV_SURFACES: usize = 10_000;

/// Run facts a view-factor file records.
#[derive(Clone, Debug)]
pub struct ViewFactorRun {
    pub scene: String,
    pub scene_hash: String,
    pub resolution: (u32, u32),
}

/// Writes `vf` as `format` to `w`. Every value is written in its shortest form that
/// reads back to the same f64, so the formats agree to the bit.
pub fn write_view_factors(
    w: &mut dyn Write,
    vf: &ViewFactors,
    run: &ViewFactorRun,
    format: MatrixFormat,
) -> std::io::Result<()> {
    match format {
        MatrixFormat::Json => write_json(w, vf, run),
        MatrixFormat::Csv => write_csv(w, vf),
        MatrixFormat::Mtx => write_mtx(w, vf, run),
        MatrixFormat::View3d => write_view3d(w, vf),
        MatrixFormat::Bin => write_bin(w, vf, run),
    }
}

/// Refuses what a format cannot hold, before any work: CSV beyond
/// [`MAX_CSV_SURFACES`] surfaces.
pub fn check_format(format: MatrixFormat, n_surfaces: usize) -> Result<(), Error> {
    let dense = matches!(format, MatrixFormat::Csv | MatrixFormat::View3d);
    if dense && n_surfaces > MAX_CSV_SURFACES {
        return Err(Error::Parse {
            what: "format",
            input: format.name().into(),
            reason: format!(
                "a dense {} table of {n_surfaces} surfaces would hold {n_surfaces}² numbers (the limit is {MAX_CSV_SURFACES} surfaces): use --format mtx or json",
                format.name()
            ),
        });
    }
    Ok(())
}

/// The number of surfaces `by` makes of `scene` (for [`check_format`]), or the error
/// [`view_factors`] would give.
pub fn count_surfaces(scene: &Scene, by: Grouping) -> Result<usize, Error> {
    surfaces(scene, by).map(|(_, names)| names.len())
}

fn json_string(s: &str) -> String {
    serde_json::to_string(s).expect("a string serialises")
}

fn write_json(w: &mut dyn Write, vf: &ViewFactors, run: &ViewFactorRun) -> std::io::Result<()> {
    let m = &vf.matrix;
    let r = &vf.report;
    let q = |e: &rad_solver::ErrorQuantiles| {
        format!(
            "{{\"count\": {}, \"median\": {:e}, \"p90\": {:e}, \"p99\": {:e}, \"max\": {:e}}}",
            e.count, e.median, e.p90, e.p99, e.max
        )
    };
    let errors = |e: &rad_solver::EnclosureErrors| {
        format!(
            "{{\"row_sum\": {}, \"reciprocity\": {}}}",
            q(&e.row_sum),
            q(&e.reciprocity)
        )
    };
    writeln!(w, "{{")?;
    writeln!(w, "  \"scene\": {},", json_string(&run.scene))?;
    writeln!(w, "  \"scene_hash\": {},", json_string(&run.scene_hash))?;
    writeln!(
        w,
        "  \"resolution\": [{}, {}],",
        run.resolution.0, run.resolution.1
    )?;
    writeln!(w, "  \"by\": \"{}\",", vf.by.name())?;
    writeln!(w, "  \"origins\": {},", vf.origins)?;
    writeln!(w, "  \"enclosure\": \"{}\",", vf.enclosure.name())?;
    writeln!(w, "  \"script_f\": {},", vf.script_f)?;
    writeln!(
        w,
        "  \"report\": {{\"raw\": {}, \"fixed\": {}, \"max_change\": {:e}, \"products\": {}}},",
        errors(&r.raw),
        errors(&r.fixed),
        r.max_change,
        r.products
    )?;
    writeln!(w, "  \"surfaces\": [")?;
    for i in 0..m.n() {
        let row: Vec<String> = m.rows[i]
            .iter()
            .map(|&(j, f)| format!("[{j}, {f:?}]"))
            .collect();
        writeln!(
            w,
            "    {{\"id\": {i}, \"name\": {}, \"area\": {:?}, \"row_sum\": {:?}, \"escaped\": {:?}, \"back\": {:?}, \"obstructed\": {:?}, \"factors\": [{}]}}{}",
            json_string(&vf.names[i]),
            m.area[i],
            m.row_sum(i),
            vf.escaped[i],
            vf.back[i],
            vf.obstructed[i],
            row.join(", "),
            if i + 1 < m.n() { "," } else { "" }
        )?;
    }
    writeln!(w, "  ]")?;
    writeln!(w, "}}")
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Each row of `m` as a dense array (zeros where a surface is not seen), in order.
fn for_each_dense_row(
    m: &SurfaceMatrix,
    mut take: impl FnMut(usize, &[f64]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut dense = vec![0.0f64; m.n()];
    for (i, row) in m.rows.iter().enumerate() {
        dense.iter_mut().for_each(|v| *v = 0.0);
        for &(j, f) in row {
            dense[j as usize] = f;
        }
        take(i, &dense)?;
    }
    Ok(())
}

fn write_csv(w: &mut dyn Write, vf: &ViewFactors) -> std::io::Result<()> {
    let m = &vf.matrix;
    let header: Vec<String> = vf.names.iter().map(|n| csv_field(n)).collect();
    writeln!(w, ",{}", header.join(","))?;
    for_each_dense_row(m, |i, dense| {
        let cells: Vec<String> = dense.iter().map(|f| format!("{f:?}")).collect();
        writeln!(w, "{},{}", csv_field(&vf.names[i]), cells.join(","))
    })?;
    Ok(())
}

fn write_mtx(w: &mut dyn Write, vf: &ViewFactors, run: &ViewFactorRun) -> std::io::Result<()> {
    let m = &vf.matrix;
    writeln!(w, "%%MatrixMarket matrix coordinate real general")?;
    writeln!(
        w,
        "% coherad {} (row I sees column J) of {} by {}, {} origins a patch side, {}x{} hemisphere, enclosure {}",
        if vf.script_f { "total exchange factors script-F_IJ" } else { "view factors F_IJ" },
        json_string(&run.scene), vf.by.name(), vf.origins, run.resolution.0, run.resolution.1, vf.enclosure.name()
    )?;
    writeln!(w, "% scene_hash {}", run.scene_hash)?;
    for (i, name) in vf.names.iter().enumerate() {
        writeln!(
            w,
            "% surface {} area {:?} name {}",
            i + 1,
            m.area[i],
            json_string(name)
        )?;
    }
    let nnz: usize = m.rows.iter().map(Vec::len).sum();
    writeln!(w, "{} {} {}", m.n(), m.n(), nnz)?;
    for (i, row) in m.rows.iter().enumerate() {
        for &(j, f) in row {
            writeln!(w, "{} {} {:?}", i + 1, j + 1, f)?;
        }
    }
    Ok(())
}

fn write_view3d(w: &mut dyn Write, vf: &ViewFactors) -> std::io::Result<()> {
    let m = &vf.matrix;
    // View3D's header: program, version, format (0: text), encl, didemit, surfaces,
    // padded to 30 characters.
    let encl = u8::from(vf.enclosure == Enclosure::Closed);
    let header = format!(
        "coherad {} 0 {encl} {} {}",
        env!("CARGO_PKG_VERSION"),
        u8::from(vf.script_f),
        m.n()
    );
    writeln!(w, "{header:<30}")?;
    let areas: Vec<String> = m.area.iter().map(|a| format!("{}", Float(*a))).collect();
    writeln!(w, "{}", areas.join(" "))?;
    for_each_dense_row(m, |_, dense| {
        let cells: Vec<String> = dense.iter().map(|f| format!("{f:.6}")).collect();
        writeln!(w, "{}", cells.join(" "))
    })?;
    let emit: Vec<String> = vf.emissivity.iter().map(|e| format!("{e:.3}")).collect();
    writeln!(w, "{}", emit.join(" "))
}

/// An f64 as C's `%g` writes it (six significant digits, trailing zeros dropped).
struct Float(f64);

impl std::fmt::Display for Float {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        if x == 0.0 {
            return write!(f, "0");
        }
        // C's rule: the exponent after rounding to six digits picks the style.
        let s = format!("{x:.5e}");
        let (mant, e) = s.split_once('e').expect("an exponent");
        let exp: i32 = e.parse().expect("an integer exponent");
        let text = if !(-4..6).contains(&exp) {
            let mant = mant.trim_end_matches('0').trim_end_matches('.');
            format!("{mant}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
        } else {
            let decimals = (5 - exp).max(0) as usize;
            let s = format!("{x:.decimals$}");
            if s.contains('.') {
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            } else {
                s
            }
        };
        write!(f, "{text}")
    }
}

#[cfg(test)]
mod tests {
    use super::Float;

    #[test]
    fn floats_as_c_writes_them_with_percent_g() {
        for (x, want) in [
            (1.0, "1"),
            (0.01, "0.01"),
            (2.5, "2.5"),
            (123456.0, "123456"),
            (999_999.7, "1e+06"),
            (1_234_567.0, "1.23457e+06"),
            (0.0001, "0.0001"),
            (0.000_012_34, "1.234e-05"),
            (0.0, "0"),
        ] {
            assert_eq!(Float(x).to_string(), want, "{x}");
        }
    }
}
