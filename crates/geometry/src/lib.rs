//! Polygons, patch textures, patches and scenes: validation, the scene files (JSON, OBJ/MTL,
//! View3D, PLY, STL, glTF), the one ray–polygon hit test, and the bench-scene builders.
//!
//! - `adjacency`: [`EdgeNeighbours`], the polygon across each edge of a mesh.
//! - `clip`: 2-D helpers for patch textures (convex clipping, area, centroid).
//! - `error`: [`Error`] and [`PolygonProblem`], the typed errors of scenes and their files.
//! - `facets`: [`Facets`], a mesh's flat pieces, each with a grid that locates its polygons.
//! - `file`: the scene-file readers and the JSON writer ([`file::load`] with
//!   [`file::LoadConfig`]; `gltf`, `json`, `material_map`, `mesh` for PLY and STL, `obj`, `vs3`).
//! - `hit_test`: the shared ray–polygon test ([`PolygonTerms`], [`OriginTerms`], [`Shape`],
//!   `Polygon::intersect`, `Polygon::terms_at`, [`PolygonHit`]).
//! - `motion`: [`Motion`], named groups moved rigidly over steps (the motion file), and
//!   each step's scene.
//! - `overlap`: the coplanar overlaps a scene refuses.
//! - `polygon`: [`Polygon`] and [`Patch`]: validation, patch textures, the (u, v) → patch map.
//! - `repair`: `--repair`, meshes as they come: welding, duplicates, folds, orientation.
//! - `scene`: [`Scene`] and its description ([`SceneDesc`], [`PolygonDesc`], [`Material`],
//!   [`Camera`]); `Facets::of` and `Facets::exact`.
//! - `scenes`: the bench scenes (`canyon`, `cornell`, `cube`, `loft`, `meshes`).
//! - `triangulate`: `--triangulate`, ear clipping of concave and warped faces ([`ear_clip`]).

mod adjacency;
mod clip;
mod error;
mod facets;
pub mod file;
mod hit_test;
mod motion;
mod overlap;
mod polygon;
mod repair;
mod scene;
pub mod scenes;
mod triangulate;

pub use adjacency::EdgeNeighbours;
pub use error::{Error, PolygonProblem};
pub use facets::{Facets, LocateScratch, Located, FACET_TILT};
pub use hit_test::{OriginTerms, PolygonHit, PolygonTerms, Shape, Triangle};
pub use motion::{Motion, MotionStep, Rigid, MAX_STEPS, RIGID_TOLERANCE};
pub use overlap::{NORMAL_TOLERANCE, OVERLAP_FRACTION, PLANE_TOLERANCE};
pub use polygon::{reach_past_corners, vertices_problem};
pub use polygon::{
    Patch, Polygon, MAX_CELLS_PER_POLYGON, MAX_COORDINATE, MIN_POLYGON_SIZE,
    MIN_POLYGON_SIZE_RELATIVE, PLANARITY_TOLERANCE,
};
pub use repair::{repair, survey, Repair, REPAIR_EXAMPLES, WELD_RELATIVE};
pub use scene::{
    Camera, Material, PatchGrid, PolygonDesc, Scene, SceneDesc, SeenTerms, MAX_PATCHES, SEVERAL,
};
pub use triangulate::{ear_clip, triangulate, Triangulation};
