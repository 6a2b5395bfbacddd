//! Integration tests of rad-repro: physics invariants on the bench scenes.

mod invariants;
mod ranks;
mod viewfactors;
