//! Integration tests of rad-hemisphere.

mod analytic;
mod facets;
mod origins;
mod props;
mod scale;
mod scan;
