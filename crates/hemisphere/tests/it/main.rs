//! Integration tests of rad-hemisphere.

mod analytic;
mod origins;
mod props;
mod scale;
mod scan;
