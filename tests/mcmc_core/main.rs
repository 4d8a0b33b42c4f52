//! Integration tests of `mcmc-core`: property tests of detailed balance over random targets and
//! proposals, deliberately broken kernels that the checks must catch, tempering ladders, and
//! ensembles that do not depend on the thread count.
//!
//! Statistical tests are seeded (fixed outcome) and each states its false-positive rate; the
//! ignored test `rates::measured_rates` measures the rates over many seeds:
//! `cargo test --release --test mcmc_core -- --ignored --nocapture rates`.

mod broken;
mod ensemble;
mod finite;
mod kelemen;
mod properties;
mod rates;
mod tempering;
mod zoo;
