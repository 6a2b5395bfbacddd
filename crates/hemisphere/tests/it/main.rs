//! Integration tests of rad-hemisphere.

mod analytic;
mod props;
mod scan;
