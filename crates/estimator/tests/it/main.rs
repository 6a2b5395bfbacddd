//! Integration tests of rad-estimator.

mod across;
mod props;
mod scenes;
