//! Metropolis light transport: one driver shared by every Metropolis integrator, and the
//! primary-sample-space methods on top of it — PSSMLT (Kelemen et al. 2002, all-connection BDPT
//! target) and multiplexed MLT (Hachisuka, Kaplanyan & Dachsbacher 2014, one strategy per sample
//! chosen by a mutable coordinate).
//!
//! The driver (overview paper §5; charted-MLT paper §5.4): a bootstrap pass of independent samples
//! estimates the normalisation `b = E[I]` of the scalar importance `I`; chains are seeded by
//! systematic resampling of that population in proportion to `I` (no start-up bias), each seed is
//! replayed and must reproduce its bootstrap importance exactly; chains then run as `mcmc-core`
//! Metropolis–Hastings chains, and every proposal is recorded by its expected value (`a` for the
//! candidate, `1 − a` for the current state) with weight `b / I`, through a recorder ([`record`]):
//! splats on the film, or anything else a method deposits.

mod driver;
mod importance;
mod mmlt;
mod pssmlt;
pub mod record;
pub mod separate_direct;
mod stream;

pub use driver::{Method, MetropolisSettings, MetropolisStats, Seeding, run, run_with};
pub use importance::ImportanceKind;
pub use mmlt::Mmlt;
pub use pssmlt::{PrimaryProposal, PrimaryState, PrimaryTarget, Pssmlt, mutate_primary};
pub use record::{BootstrapSample, Contribution, ExpectedValue, Recordable, Recorder, Sink};
pub use separate_direct::{Chains, DIRECT_EDGES, DirectApart, SeparateDirect};
pub use stream::PrimaryStream;
