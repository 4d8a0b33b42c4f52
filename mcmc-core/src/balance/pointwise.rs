//! The pointwise detailed-balance identity
//! `ln π(x) + ln q(y|x) + ln α(x→y) = ln π(y) + ln q(x|y) + ln α(y→x)`,
//! checked at given pairs. For moves that draw auxiliary variables `v` (a stochastic inverse, a
//! lobe choice), write the identity on the extended space — `q(y, v | x)` forward and `q(x, v' | y)`
//! for the auxiliaries `v'` the reverse move would draw — and check it with [`identity_gap`].

use super::CheckReport;
use crate::kernel::acceptance;
use crate::{ChainRng, Proposal, Target};

/// One side of the identity: `ln π(from)`, `ln q(to, aux | from)` and the acceptance probability
/// the implementation uses for this move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    /// `ln π` at the move's start.
    pub ln_pi: f64,
    /// Log density of drawing the move (candidate and auxiliaries).
    pub ln_q: f64,
    /// The implementation's acceptance probability.
    pub acceptance: f64,
}

/// `|forward − backward|` of the identity in log space; zero when both sides vanish; `+inf` when
/// exactly one side vanishes (a move that can happen but whose reverse cannot).
pub fn identity_gap(forward: Side, backward: Side) -> f64 {
    let f = forward.ln_pi + forward.ln_q + forward.acceptance.ln();
    let b = backward.ln_pi + backward.ln_q + backward.acceptance.ln();
    if f == f64::NEG_INFINITY && b == f64::NEG_INFINITY {
        0.0
    } else if f.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        (f - b).abs()
    }
}

/// Check a Metropolis–Hastings proposal at `pairs` drawn from `starts`: for each start `x`, draw
/// `y` with [`Proposal::propose`], evaluate `q(y|x)` and `q(x|y)` for a move of the reported kind
/// with [`Proposal::ln_move_density`] (the extended space when the kind is an auxiliary variable,
/// as in per-component mixtures), and verify (a) the reported ratio equals
/// `ln q(x|y) − ln q(y|x)` and (b) the identity holds with the kernel's acceptance function, taking
/// the reverse move's report to be the negated forward report. `tolerance` is in log space.
pub fn check_proposal<S: Clone, T: Target<S>, P: Proposal<S>>(
    target: &T,
    proposal: &P,
    starts: &[S],
    tolerance: f64,
    rng: &mut ChainRng,
) -> Result<CheckReport, crate::McmcError> {
    let mut worst = 0.0f64;
    let mut detail = String::from("all pairs consistent");
    let mut checked = 0usize;
    for (i, x) in starts.iter().enumerate() {
        let mut y = x.clone();
        let p = proposal.propose(x, &mut y, rng);
        let (Some(q_xy), Some(q_yx)) = (
            proposal.ln_move_density(x, &y, p.kind),
            proposal.ln_move_density(&y, x, p.kind),
        ) else {
            return Err(crate::McmcError::Check(
                "the proposal cannot evaluate its transition density".into(),
            ));
        };
        let (pi_x, pi_y) = (target.ln_density(x), target.ln_density(&y));
        if pi_x == f64::NEG_INFINITY {
            continue; // the identity concerns moves from the support
        }
        checked += 1;
        let true_ratio = q_yx - q_xy;
        let ratio_gap = if true_ratio == p.ln_ratio {
            0.0
        } else {
            (true_ratio - p.ln_ratio).abs()
        };
        let gap = identity_gap(
            Side {
                ln_pi: pi_x,
                ln_q: q_xy,
                acceptance: acceptance(pi_x, pi_y, p.ln_ratio).0,
            },
            Side {
                ln_pi: pi_y,
                ln_q: q_yx,
                acceptance: acceptance(pi_y, pi_x, -p.ln_ratio).0,
            },
        );
        let g = if gap.is_nan() || ratio_gap.is_nan() {
            f64::INFINITY
        } else {
            gap.max(ratio_gap)
        };
        if g > worst {
            worst = g;
            detail = format!(
                "start #{i}: reported ratio {:.6e}, ln q(x|y) − ln q(y|x) = {:.6e}, identity gap {:.3e}",
                p.ln_ratio, true_ratio, gap
            );
        }
    }
    if checked == 0 {
        return Err(crate::McmcError::Check(
            "no start lies in the support of the target".into(),
        ));
    }
    Ok(CheckReport {
        check: "pointwise detailed balance",
        passed: worst <= tolerance,
        statistic: worst,
        threshold: tolerance,
        detail,
    })
}
