//! Integration tests of rad-geometry.

mod errors;
mod props;
mod scenes;
