//! Tempering: replica exchange (Swendsen & Wang 1986; Geyer 1991) and serial tempering (Marinari &
//! Parisi 1992) over any [`crate::Family`] of targets — tempered powers, or the per-chart targets
//! of charted Metropolis–Hastings, whose level changes re-parameterise the state through
//! [`crate::Family::transfer`].

mod replica_exchange;
mod round_trips;
mod serial_tempering;

pub use replica_exchange::{LevelObserver, OnlyLevel, ReplicaExchange, SwapSchedule};
pub use round_trips::RoundTrips;
pub use serial_tempering::{Adaptation, LevelProposal, SerialTempering};

/// Counters of moves between two levels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairStats {
    /// Moves attempted.
    pub attempted: u64,
    /// Moves accepted.
    pub accepted: u64,
    /// Sum of acceptance probabilities.
    pub acceptance_sum: f64,
    /// Moves rejected because a density or ratio was NaN or `+inf`.
    pub invalid: u64,
}

impl PairStats {
    /// Fraction accepted (NaN when none were attempted).
    pub fn rate(&self) -> f64 {
        self.accepted as f64 / self.attempted as f64
    }
    /// Mean acceptance probability (NaN when none were attempted).
    pub fn mean_acceptance(&self) -> f64 {
        self.acceptance_sum / self.attempted as f64
    }
    /// Add another counter (e.g. of another chain).
    pub fn merge(&mut self, o: &PairStats) {
        self.attempted += o.attempted;
        self.accepted += o.accepted;
        self.acceptance_sum += o.acceptance_sum;
        self.invalid += o.invalid;
    }
    pub(crate) fn record(&mut self, a: f64, accepted: bool, invalid: bool) {
        self.attempted += 1;
        self.accepted += accepted as u64;
        self.acceptance_sum += a;
        self.invalid += invalid as u64;
    }
}
