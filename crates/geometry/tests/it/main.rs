//! Integration tests of rad-geometry.

mod errors;
mod frames;
mod meshes;
mod props;
mod scenes;
