//! Acceptance statistics per move kind.

use std::fmt;

/// Counters for one move kind.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KindStats {
    /// Proposals made.
    pub proposed: u64,
    /// Proposals accepted.
    pub accepted: u64,
    /// Sum of acceptance probabilities (its mean is a lower-variance acceptance estimate).
    pub acceptance_sum: f64,
    /// Proposals rejected because a density or ratio was NaN or `+inf`.
    pub invalid: u64,
    /// Proposals that could not be made because the move does not apply to the current state
    /// (counted in `proposed`, rejected with `a = 0`).
    pub not_applicable: u64,
    /// Proposals whose construction failed part-way (counted in `proposed`, rejected with `a = 0`).
    pub failed: u64,
}

impl KindStats {
    /// Fraction of proposals accepted (NaN when none were made).
    pub fn acceptance_rate(&self) -> f64 {
        self.accepted as f64 / self.proposed as f64
    }

    /// Mean acceptance probability (NaN when none were made).
    pub fn mean_acceptance(&self) -> f64 {
        self.acceptance_sum / self.proposed as f64
    }

    /// Add another counter.
    pub fn merge(&mut self, o: &KindStats) {
        self.proposed += o.proposed;
        self.accepted += o.accepted;
        self.acceptance_sum += o.acceptance_sum;
        self.invalid += o.invalid;
        self.not_applicable += o.not_applicable;
        self.failed += o.failed;
    }
}

/// Why a proposal could not be made (see [`crate::Chain::fail`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// The move does not apply to the current state (e.g. a perturbation of a path without the
    /// vertex types it needs).
    NotApplicable,
    /// The construction of the candidate failed (e.g. a ray escaped the scene).
    Failed,
}

/// Counters indexed by move kind ([`crate::Proposed::kind`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Counters per kind.
    pub kinds: Vec<KindStats>,
}

impl Stats {
    /// Record one proposal.
    #[inline]
    pub fn record(&mut self, kind: usize, acceptance: f64, accepted: bool, invalid: bool) {
        if kind >= self.kinds.len() {
            self.kinds.resize(kind + 1, KindStats::default());
        }
        let k = &mut self.kinds[kind];
        k.proposed += 1;
        k.accepted += accepted as u64;
        k.acceptance_sum += acceptance;
        k.invalid += invalid as u64;
    }

    /// Record a proposal that could not be made.
    #[inline]
    pub fn record_failure(&mut self, kind: usize, why: Failure) {
        self.record(kind, 0.0, false, false);
        let k = &mut self.kinds[kind];
        match why {
            Failure::NotApplicable => k.not_applicable += 1,
            Failure::Failed => k.failed += 1,
        }
    }

    /// All kinds together.
    pub fn total(&self) -> KindStats {
        let mut t = KindStats::default();
        for k in &self.kinds {
            t.merge(k);
        }
        t
    }

    /// Add another set of counters (e.g. of another chain).
    pub fn merge(&mut self, o: &Stats) {
        if o.kinds.len() > self.kinds.len() {
            self.kinds.resize(o.kinds.len(), KindStats::default());
        }
        for (a, b) in self.kinds.iter_mut().zip(&o.kinds) {
            a.merge(b);
        }
    }

    /// A table with one line per kind, using `names` (from [`crate::Proposal::kinds`]).
    pub fn table<'a>(&'a self, names: &'a [String]) -> StatsTable<'a> {
        StatsTable { stats: self, names }
    }
}

/// Display helper for [`Stats::table`].
pub struct StatsTable<'a> {
    stats: &'a Stats,
    names: &'a [String],
}

impl fmt::Display for StatsTable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<28} {:>12} {:>12} {:>9} {:>9} {:>12} {:>9}",
            "move", "proposed", "accepted", "rate", "invalid", "n/applicable", "failed"
        )?;
        // Kinds never proposed (e.g. switched off by their probability) are left out.
        for (i, k) in self
            .stats
            .kinds
            .iter()
            .enumerate()
            .filter(|(_, k)| k.proposed > 0)
        {
            let name = self.names.get(i).map(String::as_str).unwrap_or("?");
            writeln!(
                f,
                "{:<28} {:>12} {:>12} {:>8.2}% {:>9} {:>12} {:>9}",
                name,
                k.proposed,
                k.accepted,
                100.0 * k.acceptance_rate(),
                k.invalid,
                k.not_applicable,
                k.failed
            )?;
        }
        Ok(())
    }
}
