//! Integration tests of rad-hemisphere.

mod analytic;
mod facets;
mod motion;
mod origins;
mod props;
mod scale;
mod scan;
