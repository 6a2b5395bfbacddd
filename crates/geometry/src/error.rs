//! Typed errors for scene construction and scene files.

use std::path::PathBuf;

/// What is wrong with one polygon.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PolygonProblem {
    #[error("has {count} vertices; a polygon needs at least 3")]
    TooFewVertices { count: usize },
    #[error("vertex {vertex} has a coordinate that is NaN or infinite ({value:?})")]
    NonFinite { vertex: usize, value: [f32; 3] },
    #[error("has vertex {vertex} at a coordinate of magnitude {value:e}, beyond {limit:e}: the f32 ray tests would overflow; express the scene in larger units")]
    OutOfRange {
        vertex: usize,
        value: f64,
        limit: f64,
    },
    #[error("is {diameter:e} across, under the {limit:e} that f32 ray tests resolve there (its coordinates reach {coordinate:e}; the limit is 1e-12, or 4e-6 of that: the tolerance its inside test grows it by): express the scene in smaller units, or nearer the origin, or drop the polygon")]
    TooSmall {
        diameter: f64,
        limit: f64,
        coordinate: f64,
    },
    #[error("is degenerate: area {area:e} (zero-length edge, collinear or repeated vertices)")]
    Degenerate { area: f64 },
    #[error("is not planar: vertex {vertex} lies {deviation:e} off its plane (tolerance {tolerance:e}, {rel_tolerance:e} of its diameter)")]
    NonPlanar {
        vertex: usize,
        deviation: f64,
        tolerance: f64,
        rel_tolerance: f64,
    },
    #[error("is not convex (or its vertices are not in order): it turns the wrong way at vertex {vertex}")]
    NonConvex { vertex: usize },
    #[error("has a patch grid of {nu} x {nv}; both counts must be at least 1")]
    ZeroPatchGrid { nu: u64, nv: u64 },
    #[error("has a patch grid of {nu} x {nv}, over the limit of {limit} cells a polygon")]
    PatchGridTooLarge { nu: u64, nv: u64, limit: u64 },
    #[error("has a patch grid of {nu} x {nv} none of whose cells keeps any area once clipped to it: its outline is too thin or too irregular to be cut (a sliver, nearly concave at its scale); drop it or split it")]
    EmptyTexture { nu: u64, nv: u64 },
    #[error("is both two_sided and an obstruction: an obstruction already blocks rays from both sides and gets no view factors; drop one of the two flags")]
    TwoSidedObstruction,
    #[error("has no usable target patch size ({size}); give a finite size > 0 (--patch-size for OBJ files)")]
    BadPatchSize { size: f64 },
    #[error("names material {name:?}, which the scene does not define")]
    UnknownMaterial { name: String },
    #[error("uses material index {index}, but the scene has {len} materials")]
    MaterialIndexOutOfRange { index: usize, len: usize },
}

/// Errors from building or reading a scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("polygon {polygon} ({name:?}) {problem}{hint}", hint = triangulate_hint(.problem))]
    Polygon {
        polygon: usize,
        name: String,
        problem: PolygonProblem,
    },
    #[error("material {material:?} has {what} {value:?}: {rule}")]
    Material {
        material: String,
        what: &'static str,
        value: [f64; 3],
        rule: &'static str,
    },
    #[error("material name {name:?} is defined twice")]
    DuplicateMaterial { name: String },
    #[error("polygons {a} ({a_name:?}) and {b} ({b_name:?}) lie in one plane, face the same way and overlap (shared area {area:e}): rays would meet only polygon {a}, and polygon {b} would silently receive no light; remove one, or cut them apart (--repair drops exact duplicates and faces folded onto a neighbour across a shared edge)")]
    Overlap {
        a: usize,
        a_name: String,
        b: usize,
        b_name: String,
        area: f64,
    },
    #[error("the scene divided by its largest coordinate ({unit:e}), which its rows are made from so that they do not depend on its scale, fails: {message}")]
    Divided { unit: f64, message: String },
    #[error("the scene has no polygons")]
    Empty,
    #[error("the scene would have {count} patches, over the limit of {limit} that patch ids allow (cut its polygons coarser, or split the scene)")]
    TooManyPatches { count: u64, limit: u64 },
    #[error("camera {problem}")]
    Camera { problem: String },
    #[error("{index_kind} index {index} is out of range (there are {len}) at {place}")]
    IndexOutOfRange {
        index_kind: &'static str,
        index: i64,
        len: usize,
        place: String,
    },
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}:{line}:{column}: {message}", path.display())]
    Json {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{}: {message}", path.display())]
    Obj { path: PathBuf, message: String },
    #[error("{} ({format}): {message}", path.display())]
    Mesh {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
    #[error("{} (material file): {message}", path.display())]
    MaterialFile { path: PathBuf, message: String },
    #[error("{}:{line}: {message}", path.display())]
    View3d {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}: unsupported scene file extension {ext:?} (expected .json, .obj, .vs3, .ply, .stl, .gltf or .glb)", path.display())]
    UnknownFormat { path: PathBuf, ext: String },
    #[error("{}: {source}", path.display())]
    InFile { path: PathBuf, source: Box<Error> },
    #[error("{}: {message}", path.display())]
    Motion { path: PathBuf, message: String },
    #[error("{}: step {step} ({name:?}, moving {groups}): {source}", path.display())]
    MotionStep {
        path: PathBuf,
        step: usize,
        name: String,
        groups: String,
        source: Box<Error>,
    },
}

/// What `--triangulate` would do about a face's problem, for the message.
fn triangulate_hint(problem: &PolygonProblem) -> &'static str {
    match problem {
        PolygonProblem::NonConvex { .. } | PolygonProblem::NonPlanar { .. } => {
            " (--triangulate splits concave and warped faces into triangles)"
        }
        PolygonProblem::Degenerate { .. } | PolygonProblem::TooFewVertices { .. } => {
            " (--triangulate drops degenerate faces, with a count)"
        }
        _ => "",
    }
}

impl Error {
    /// The innermost error, past any [`Error::InFile`] wrapper.
    pub fn root(&self) -> &Error {
        match self {
            Error::InFile { source, .. } => source.root(),
            e => e,
        }
    }

    /// The polygon problem, if this is one.
    pub fn polygon_problem(&self) -> Option<&PolygonProblem> {
        match self.root() {
            Error::Polygon { problem, .. } => Some(problem),
            _ => None,
        }
    }
}
