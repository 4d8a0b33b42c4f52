//! Integration tests of `mcmc-charts`: random charts of every kind the contract covers pass the
//! chart checker, every charted move passes the balance checks of `mcmc-core`, and deliberately
//! broken variants are caught.

mod charts;
mod checker;
mod moves;
