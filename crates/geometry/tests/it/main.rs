//! Integration tests of rad-geometry.

mod errors;
mod frames;
mod props;
mod scenes;
