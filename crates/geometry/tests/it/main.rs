//! Integration tests of rad-geometry.

mod animation;
mod errors;
mod facets;
mod frames;
mod fuzz;
mod meshes;
mod props;
mod repair;
mod scenes;
