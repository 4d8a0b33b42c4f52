//! How long a render runs: a number of samples per pixel (for Metropolis methods, mutations per
//! pixel), or a wall-clock time. One type for every integrator, so the command line and the
//! integrator registry hand the same budget to all of them.

use std::time::Duration;

/// How long to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Samples per pixel (mutations per pixel for Metropolis methods). Pass-based integrators
    /// run `⌈n⌉` passes, a fractional last one when `n` is not whole.
    SamplesPerPixel(f64),
    /// Wall-clock time (pass-based integrators: at least one whole pass, the last one possibly
    /// fractional; Metropolis methods: the chains, the bootstrap is extra).
    Time(Duration),
}

impl Budget {
    /// Check the budget: a positive finite number of samples, or a positive time.
    pub fn validate(&self) -> crate::Result<()> {
        let ok = match *self {
            Budget::SamplesPerPixel(n) => n > 0.0 && n.is_finite(),
            Budget::Time(t) => !t.is_zero(),
        };
        if ok {
            Ok(())
        } else {
            Err(crate::Error::InvalidParameter {
                name: "budget".into(),
                reason: format!(
                    "need a positive number of samples per pixel or time, got {self:?}"
                ),
            })
        }
    }
}
