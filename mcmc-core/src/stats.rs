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
    }
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
            "{:<28} {:>12} {:>12} {:>9} {:>9}",
            "move", "proposed", "accepted", "rate", "invalid"
        )?;
        for (i, k) in self.stats.kinds.iter().enumerate() {
            let name = self.names.get(i).map(String::as_str).unwrap_or("?");
            writeln!(
                f,
                "{:<28} {:>12} {:>12} {:>8.2}% {:>9}",
                name,
                k.proposed,
                k.accepted,
                100.0 * k.acceptance_rate(),
                k.invalid
            )?;
        }
        Ok(())
    }
}
