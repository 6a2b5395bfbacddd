//! Integration tests of rad-geometry.

mod errors;
mod facets;
mod frames;
mod fuzz;
mod meshes;
mod props;
mod repair;
mod scenes;
