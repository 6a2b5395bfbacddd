//! Integration tests of rad-accel.

mod props;
