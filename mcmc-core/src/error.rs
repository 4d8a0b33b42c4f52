//! Errors of the public API.

use thiserror::Error;

/// What can go wrong when building or starting a sampler.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum McmcError {
    /// A parameter is out of its domain (NaN, non-positive scale, empty ladder, …).
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// A chain was started where the target is zero, NaN or infinite.
    #[error(
        "initial state has log density {ln_density}; a chain must start where the target is positive and finite"
    )]
    BadInitialState {
        /// The offending log density.
        ln_density: f64,
    },
    /// The combined mixture rule needs every component to evaluate its transition density.
    #[error(
        "mixture component `{component}` cannot evaluate its transition density, which the combined rule needs"
    )]
    MissingTransitionDensity {
        /// The component's name.
        component: String,
    },
    /// A statistical check was configured so that it cannot run.
    #[error("check cannot run: {0}")]
    Check(String),
}

pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<(), McmcError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(McmcError::InvalidParameter {
            name,
            reason: format!("must be finite and positive, got {v}"),
        })
    }
}

pub(crate) fn check_probability(name: &'static str, v: f64) -> Result<(), McmcError> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(McmcError::InvalidParameter {
            name,
            reason: format!("must be a probability in [0, 1], got {v}"),
        })
    }
}
