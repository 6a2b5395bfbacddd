//! Integration tests of rad-estimator.

mod props;
mod scenes;
