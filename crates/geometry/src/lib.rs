//! Polygons, patch textures, patches and scenes: validation, the JSON and OBJ/MTL scene
//! files, and the bench-scene builders.

mod adjacency;
mod clip;
mod error;
mod facets;
pub mod file;
mod hit_test;
mod overlap;
mod polygon;
mod scene;
pub mod scenes;
mod triangulate;

pub use adjacency::EdgeNeighbours;
pub use error::{Error, PolygonProblem};
pub use facets::{Facets, LocateScratch, Located, FACET_TILT};
pub use hit_test::{OriginTerms, PolygonHit, PolygonTerms, Shape, Triangle};
pub use overlap::{NORMAL_TOLERANCE, OVERLAP_FRACTION, PLANE_TOLERANCE};
pub use polygon::{reach_past_corners, vertices_problem};
pub use polygon::{
    Patch, Polygon, MAX_CELLS_PER_POLYGON, MAX_COORDINATE, MIN_POLYGON_SIZE,
    MIN_POLYGON_SIZE_RELATIVE, PLANARITY_TOLERANCE,
};
pub use scene::{
    Camera, Material, PatchGrid, PolygonDesc, Scene, SceneDesc, SeenTerms, MAX_PATCHES, SEVERAL,
};
pub use triangulate::{ear_clip, triangulate, Triangulation};
