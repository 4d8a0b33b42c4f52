//! Ready-made proposals.

mod independence;
mod mixture;
mod random_walk;
mod unit_cube;

pub use independence::{Independence, UniformCube};
pub use mixture::{Mixture, MixtureRule, Selection, log_sum_exp};
pub use random_walk::GaussianRandomWalk;
pub use unit_cube::{CubeWalk, PreparedStep, SmallStep, wrap};
