//! Replica exchange (parallel tempering): one chain per level of a family, local moves at each
//! level, and swaps between neighbouring levels.
//!
//! Swapping the states `x` (level k) and `z` (level k+1) proposes `y_k = transfer(k+1→k, z)` and
//! `y_{k+1} = transfer(k→k+1, x)` and accepts with
//! `min(1, π_k(y_k) π_{k+1}(y_{k+1}) / (π_k(x) π_{k+1}(z)) · exp(g_1 + g_2))`, where `g` are the
//! transfers' Green ratios (zero for a plain family, where this is the classic swap rule).
//!
//! Schedules: [`SwapSchedule::StochasticEvenOdd`] picks the even or the odd pairs at random each
//! round (each round is then a reversible kernel); [`SwapSchedule::DeterministicEvenOdd`] alternates
//! them (non-reversible, π-invariant; Okabe et al. 2001, Syed et al. 2022), which makes walkers travel
//! the ladder ballistically instead of diffusively.

use super::{PairStats, RoundTrips};
use crate::kernel::Observer;
use crate::rng::uniform;
use crate::{Chain, ChainRng, Family, Kernel, McmcError};

/// Which neighbouring pairs are proposed in each swap round.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwapSchedule {
    /// Even or odd pairs chosen at random each round (reversible).
    StochasticEvenOdd,
    /// Even pairs on even rounds, odd pairs on odd rounds (non-reversible).
    DeterministicEvenOdd,
}

/// Receives local-move proposals together with their level.
pub trait LevelObserver<S> {
    /// Called once per local proposal at `level`.
    fn observe(&mut self, level: usize, current: &S, proposed: &S, acceptance: f64, kind: usize);
}

impl<S> LevelObserver<S> for () {
    #[inline]
    fn observe(&mut self, _: usize, _: &S, _: &S, _: f64, _: usize) {}
}

/// Forwards the proposals of one level to an [`Observer`] (typically level 0, the target of
/// interest).
pub struct OnlyLevel<O> {
    /// The level observed.
    pub level: usize,
    /// The observer.
    pub observer: O,
}

impl<S, O: Observer<S>> LevelObserver<S> for OnlyLevel<O> {
    #[inline]
    fn observe(&mut self, level: usize, current: &S, proposed: &S, a: f64, kind: usize) {
        if level == self.level {
            self.observer.observe(current, proposed, a, kind)
        }
    }
}

struct AtLevel<'a, L> {
    level: usize,
    inner: &'a mut L,
}

impl<S, L: LevelObserver<S>> Observer<S> for AtLevel<'_, L> {
    #[inline]
    fn observe(&mut self, current: &S, proposed: &S, a: f64, kind: usize) {
        self.inner.observe(self.level, current, proposed, a, kind)
    }
}

/// Replica exchange over a family, with one local kernel per level.
pub struct ReplicaExchange<S, F, K> {
    /// The family of targets.
    pub family: F,
    /// Local kernel of each level (targeting that level's density).
    pub kernels: Vec<K>,
    /// `chains[k]` is the replica currently at level `k`.
    pub chains: Vec<Chain<S>>,
    /// `replica_at[k]` is the identity of the replica at level `k`.
    pub replica_at: Vec<usize>,
    /// Swap counters for each pair `(k, k+1)`.
    pub swaps: Vec<PairStats>,
    /// Round trips of replicas between the bottom and top levels.
    pub round_trips: RoundTrips,
    /// The swap schedule.
    pub schedule: SwapSchedule,
    /// Local steps per level between swap rounds.
    pub local_steps: usize,
    round: u64,
}

impl<S: Clone, F: Family<S>, K: Kernel<S>> ReplicaExchange<S, F, K> {
    /// Start replica `k` at `initial[k]` on level `k`.
    pub fn new(
        family: F,
        kernels: Vec<K>,
        initial: Vec<S>,
        schedule: SwapSchedule,
    ) -> Result<Self, McmcError> {
        let n = family.levels();
        if n == 0 || kernels.len() != n || initial.len() != n {
            return Err(McmcError::InvalidParameter {
                name: "levels",
                reason: format!(
                    "family has {n} levels, {} kernels and {} initial states were given",
                    kernels.len(),
                    initial.len()
                ),
            });
        }
        let mut chains = Vec::with_capacity(n);
        for (k, mut x) in initial.into_iter().enumerate() {
            let l = family.ln_density(k, &mut x);
            chains.push(Chain::with_density(x, l)?);
        }
        let mut round_trips = RoundTrips::new(n);
        round_trips.visit(0, 0, n);
        Ok(Self {
            family,
            kernels,
            chains,
            replica_at: (0..n).collect(),
            swaps: vec![PairStats::default(); n.saturating_sub(1)],
            round_trips,
            schedule,
            local_steps: 1,
            round: 0,
        })
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.chains.len()
    }

    /// One sweep: `local_steps` local moves at every level, then one swap round.
    pub fn sweep<O: LevelObserver<S>>(&mut self, rng: &mut ChainRng, observer: &mut O) {
        for (k, (kernel, chain)) in self.kernels.iter_mut().zip(&mut self.chains).enumerate() {
            let mut obs = AtLevel {
                level: k,
                inner: &mut *observer,
            };
            for _ in 0..self.local_steps {
                kernel.step(chain, rng, &mut obs);
            }
        }
        self.swap_round(rng);
    }

    /// One round of swap proposals between neighbouring levels, as the schedule says.
    pub fn swap_round(&mut self, rng: &mut ChainRng) {
        let n = self.levels();
        let odd = match self.schedule {
            SwapSchedule::StochasticEvenOdd => uniform(rng) < 0.5,
            SwapSchedule::DeterministicEvenOdd => self.round % 2 == 1,
        };
        self.round += 1;
        let mut k = odd as usize;
        while k + 1 < n {
            self.try_swap(k, rng);
            k += 2;
        }
        for level in [0, n - 1] {
            self.round_trips.visit(self.replica_at[level], level, n);
        }
    }

    /// Propose swapping the replicas at levels `k` and `k+1`; returns whether it was accepted.
    pub fn try_swap(&mut self, k: usize, rng: &mut ChainRng) -> bool {
        let (p, l1, l2) = self.swap_candidates(k, rng);
        let invalid = [p, l1, l2]
            .iter()
            .any(|v| v.is_nan() || *v == f64::INFINITY);
        let accepted = !invalid && (p >= 1.0 || (p > 0.0 && uniform(rng) < p));
        self.swaps[k].record(if invalid { 0.0 } else { p }, accepted, invalid);
        if accepted {
            let (lo, hi) = self.chains.split_at_mut(k + 1);
            let (a, b) = (&mut lo[k], &mut hi[0]);
            std::mem::swap(&mut a.state, &mut a.candidate);
            std::mem::swap(&mut b.state, &mut b.candidate);
            a.ln_density = l1;
            b.ln_density = l2;
            self.replica_at.swap(k, k + 1);
        }
        accepted
    }

    /// Write the swap candidates of pair `(k, k+1)` into the chains' candidate buffers and return
    /// `(acceptance probability, ln π_k(y_k), ln π_{k+1}(y_{k+1}))`; the probability is NaN when a
    /// density or Green ratio was NaN or `+inf` (the swap is then rejected and counted as invalid). Exposed so the exact finite-space
    /// checks enumerate the same computation the sampler runs.
    pub fn swap_candidates(&mut self, k: usize, rng: &mut ChainRng) -> (f64, f64, f64) {
        let (lo, hi) = self.chains.split_at_mut(k + 1);
        let (a, b) = (&mut lo[k], &mut hi[0]);
        let g1 = self
            .family
            .transfer(k + 1, k, &b.state, &mut a.candidate, rng);
        let l1 = self.family.ln_density(k, &mut a.candidate);
        let g2 = self
            .family
            .transfer(k, k + 1, &a.state, &mut b.candidate, rng);
        let l2 = self.family.ln_density(k + 1, &mut b.candidate);
        let (p, invalid) = crate::kernel::acceptance(a.ln_density + b.ln_density, l1 + l2, g1 + g2);
        // An invalid swap is reported with a NaN probability so `try_swap` can count it.
        (if invalid { f64::NAN } else { p }, l1, l2)
    }

    /// Number of swap rounds done.
    pub fn rounds(&self) -> u64 {
        self.round
    }
}
