//! Mixtures of proposals `q(y|x) = Σ_k P_k q_k(y|x)` with the two transition rules of the papers.
//!
//! * [`MixtureRule::PerComponent`]: accept with the chosen component's own ratio
//!   `q_k(x|y) / q_k(y|x)`. The step is then a random-scan mixture of Metropolis–Hastings kernels,
//!   each reversible on its own, so the mixture is reversible — provided every component reports
//!   its own exact ratio. It never evaluates the other components (cheap).
//! * [`MixtureRule::Combined`]: accept with `Σ_k P_k q_k(x|y) / Σ_k P_k q_k(y|x)` (Veach's expected
//!   transition density; Fan et al.'s Metropolis photon sampling eq. 4). Needed when a component
//!   cannot reverse its own move — a user-path proposal that could never regenerate the current
//!   path, or a pair of directional moves that are only symmetric together — because the other
//!   components may generate the reverse move. Every component must then evaluate
//!   [`Proposal::ln_transition_density`] (or [`Proposal::ln_pair_densities`] when candidates carry
//!   a record of how they were made).
//!
//! Selection probabilities are fixed ([`Selection::Fixed`]) or weighted by each component's
//! [`Proposal::suitability`] for the current state ([`Selection::Suitability`]):
//! `P_k(x) = w_k s_k(x) / Σ_j w_j s_j(x)`, so moves that cannot apply to `x` are never chosen.
//! The probabilities then depend on the state and enter the ratio exactly: per component
//! `P_k(y) q_k(x|y) / (P_k(x) q_k(y|x))` (Metropolis–Hastings on the space extended by the
//! component index), combined `Σ_k P_k(y) q_k(x|y) / Σ_k P_k(x) q_k(y|x)`.

use crate::error::check_positive;
use crate::{ChainRng, Failure, McmcError, Outcome, Proposal, Proposed, rng::uniform};
use smallvec::SmallVec;

/// One number per component, on the stack for mixtures of up to 16 (a proposal's selection
/// probabilities and density terms are computed at every step; on the heap they cost an
/// allocation each).
type PerComponent = SmallVec<[f64; INLINE_COMPONENTS]>;

/// Components whose numbers stay on the stack ([`PerComponent`], [`Scratch`]).
const INLINE_COMPONENTS: usize = 16;

/// Room for one number per component, filled by [`Mixture::suited`]: on the stack for mixtures
/// of up to 16 components, on the heap beyond. (The selection weights are computed twice at
/// every step; returned as a small vector they cost a capacity check per component and a copy
/// of the whole vector out of the call.)
struct Scratch {
    inline: [f64; INLINE_COMPONENTS],
    heap: Vec<f64>,
}

impl Scratch {
    fn new() -> Self {
        Self {
            inline: [0.0; INLINE_COMPONENTS],
            heap: Vec::new(),
        }
    }

    /// `n` zeros to fill.
    #[inline]
    fn zeros(&mut self, n: usize) -> &mut [f64] {
        if n <= self.inline.len() {
            &mut self.inline[..n]
        } else {
            self.heap.resize(n, 0.0);
            &mut self.heap
        }
    }
}

/// Which transition-density rule a [`Mixture`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MixtureRule {
    /// The chosen component's own ratio.
    PerComponent,
    /// The ratio of the full mixture densities `Σ P_k q_k`.
    Combined,
}

/// How a [`Mixture`] chooses its component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Selection {
    /// With the fixed normalised weights `w_k`, whatever the state.
    #[default]
    Fixed,
    /// With probability `w_k s_k(x) / Σ_j w_j s_j(x)`, `s_k` the component's
    /// [`Proposal::suitability`] (exact: the probabilities enter the ratio).
    Suitability,
}

type Component<'a, S> = Box<dyn Proposal<S> + Send + Sync + 'a>;

/// A mixture of proposals.
pub struct Mixture<'a, S> {
    components: Vec<Component<'a, S>>,
    ln_weights: Vec<f64>,
    /// `exp(ln_weights)`, computed once (suitability selection weighs every component at every
    /// proposal, for the current state and the candidate).
    weights: Vec<f64>,
    cumulative: Vec<f64>,
    kind_offsets: Vec<usize>,
    rule: MixtureRule,
    selection: Selection,
}

impl<S> std::fmt::Debug for Mixture<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mixture")
            .field("kinds", &self.kinds_inner())
            .field("weights", &self.weights())
            .field("rule", &self.rule)
            .field("selection", &self.selection)
            .finish()
    }
}

impl<'a, S> Mixture<'a, S> {
    /// A mixture of `(weight, proposal)` pairs; weights are normalised. With the combined rule every
    /// component must evaluate its transition density (checked on a probe state is impossible in
    /// general, so it is checked on first use and reported as [`McmcError::MissingTransitionDensity`]
    /// by [`Mixture::check_combined`]).
    pub fn new(
        components: Vec<(f64, Component<'a, S>)>,
        rule: MixtureRule,
    ) -> Result<Self, McmcError> {
        if components.is_empty() {
            return Err(McmcError::InvalidParameter {
                name: "components",
                reason: "a mixture needs at least one component".into(),
            });
        }
        let total: f64 = components.iter().map(|c| c.0).sum();
        for c in &components {
            if !(c.0.is_finite() && c.0 >= 0.0) {
                return Err(McmcError::InvalidParameter {
                    name: "weight",
                    reason: format!(
                        "mixture weights must be finite and non-negative, got {}",
                        c.0
                    ),
                });
            }
        }
        check_positive("total weight", total)?;
        let mut cumulative = Vec::with_capacity(components.len());
        let mut ln_weights = Vec::with_capacity(components.len());
        let mut kind_offsets = Vec::with_capacity(components.len());
        let mut acc = 0.0;
        let mut offset = 0;
        let mut comps = Vec::with_capacity(components.len());
        for (w, p) in components {
            acc += w / total;
            cumulative.push(acc);
            ln_weights.push((w / total).ln());
            kind_offsets.push(offset);
            offset += p.kind_count();
            comps.push(p);
        }
        Ok(Self {
            components: comps,
            weights: ln_weights.iter().map(|l| l.exp()).collect(),
            ln_weights,
            cumulative,
            kind_offsets,
            rule,
            selection: Selection::Fixed,
        })
    }

    /// Choose components as `selection` says (default [`Selection::Fixed`]).
    pub fn with_selection(mut self, selection: Selection) -> Self {
        self.selection = selection;
        self
    }

    /// The selection rule.
    pub fn selection(&self) -> Selection {
        self.selection
    }

    /// Check, on a pair of states, that every component evaluates its transition density, as the
    /// combined rule requires.
    pub fn check_combined(&self, x: &S, y: &S) -> Result<(), McmcError> {
        for c in &self.components {
            if c.ln_transition_density(x, y).is_none() {
                return Err(McmcError::MissingTransitionDensity {
                    component: c.kinds().join("+"),
                });
            }
        }
        Ok(())
    }

    /// Normalised selection probabilities `P_k`.
    pub fn weights(&self) -> Vec<f64> {
        self.weights.clone()
    }

    /// The rule.
    pub fn rule(&self) -> MixtureRule {
        self.rule
    }

    fn kinds_inner(&self) -> Vec<String> {
        self.components.iter().flat_map(|c| c.kinds()).collect()
    }

    /// `ln P_k(x)` for every component (all `-inf` when no component suits `x`).
    pub fn ln_selection(&self, x: &S) -> Vec<f64> {
        self.ln_selection_in(x).into_vec()
    }

    /// `ln P_k(x)` of the component `k` whose move kinds include `kind` (as [`Proposal::kinds`]
    /// numbers them): the probability that a proposal from `x` is made by that component. Under
    /// suitability selection it depends on `x`; an observer that weighs a component's candidates
    /// by the inverse of their chance of being drawn needs it. `−∞` for a kind out of range.
    pub fn ln_selection_of_kind(&self, x: &S, kind: usize) -> f64 {
        let total: usize = self.kind_count();
        if kind >= total {
            return f64::NEG_INFINITY;
        }
        let k = self.kind_offsets.partition_point(|&o| o <= kind) - 1;
        // `ln_selection_in(x)[k]`, without the other components' logarithms.
        let mut scratch = Scratch::new();
        let Some(w) = self.suited(x, &mut scratch) else {
            return self.ln_weights[k];
        };
        let total: f64 = w.iter().sum();
        if total > 0.0 {
            (w[k] / total).ln()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// [`Mixture::ln_selection`] on the stack (the acceptance ratio asks for it twice a step).
    fn ln_selection_in(&self, x: &S) -> PerComponent {
        let mut scratch = Scratch::new();
        let Some(w) = self.suited(x, &mut scratch) else {
            return PerComponent::from_slice(&self.ln_weights);
        };
        let total: f64 = w.iter().sum();
        w.iter()
            .map(|&v| {
                if total > 0.0 {
                    (v / total).ln()
                } else {
                    f64::NEG_INFINITY
                }
            })
            .collect()
    }

    /// `w_k s_k(x)` for every component under suitability selection (`None` under fixed
    /// selection, where the normalised base weights are the probabilities).
    fn suited<'s>(&self, x: &S, scratch: &'s mut Scratch) -> Option<&'s [f64]> {
        match self.selection {
            Selection::Fixed => None,
            Selection::Suitability => {
                let suited = scratch.zeros(self.components.len());
                let slots = suited.iter_mut().zip(&self.components).zip(&self.weights);
                for ((slot, c), &w) in slots {
                    // A component without weight is never chosen: its suitability is not asked
                    // (it may be costly, e.g. a path mutation finding its strategies).
                    if w != 0.0 {
                        *slot = w * suitability(c.as_ref(), x);
                    }
                }
                Some(suited)
            }
        }
    }

    /// The component chosen by `u` given `suited(x)`.
    fn choose(&self, suited: Option<&[f64]>, u: f64) -> Option<usize> {
        match suited {
            None => Some(
                self.cumulative
                    .iter()
                    .position(|&c| u < c)
                    .unwrap_or(self.components.len() - 1),
            ),
            Some(w) => crate::rng::categorical(w, u),
        }
    }

    /// `ln Σ_k P_k(from) q_k(to|from)`, or `None` when a component cannot evaluate it.
    pub fn ln_mixture_density(&self, from: &S, to: &S) -> Option<f64> {
        let ln_p = self.ln_selection_in(from);
        let mut terms = PerComponent::new();
        for (c, lw) in self.components.iter().zip(&ln_p) {
            terms.push(lw + c.ln_transition_density(from, to)?);
        }
        Some(log_sum_exp(&terms))
    }

    /// `(ln Σ_k P_k(x) q_k(y|x), ln Σ_k P_k(y) q_k(x|y))` for a candidate `y` proposed from `x`
    /// (through [`Proposal::ln_pair_densities`], so records carried by `y` are honoured).
    pub fn ln_mixture_pair(&self, x: &S, y: &S) -> Option<(f64, f64)> {
        let (px, py) = (self.ln_selection_in(x), self.ln_selection_in(y));
        let (mut fwd, mut rev) = (PerComponent::new(), PerComponent::new());
        for (k, c) in self.components.iter().enumerate() {
            // A component that is never chosen in a direction contributes nothing there, and
            // need not be evaluated (it may not even apply to the state).
            if px[k] == f64::NEG_INFINITY && py[k] == f64::NEG_INFINITY {
                continue;
            }
            let (f, r) = c.ln_pair_densities(x, y)?;
            fwd.push(px[k] + f);
            rev.push(py[k] + r);
        }
        Some((log_sum_exp(&fwd), log_sum_exp(&rev)))
    }
}

/// A component's suitability, with negative and NaN values treated as 0.
fn suitability<S>(c: &(dyn Proposal<S> + Send + Sync + '_), x: &S) -> f64 {
    let s = c.suitability(x);
    // `s.is_finite()` classified the number's bits; two comparisons say the same here.
    if s > 0.0 && s < f64::INFINITY { s } else { 0.0 }
}

/// `ln Σ exp(t_i)`, exact for `-inf` terms.
pub fn log_sum_exp(terms: &[f64]) -> f64 {
    let m = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY || m.is_nan() {
        return m;
    }
    if m == f64::INFINITY {
        return m;
    }
    m + terms.iter().map(|t| (t - m).exp()).sum::<f64>().ln()
}

impl<S> Mixture<'_, S> {
    /// What the mixture reports for a candidate `y` drawn from `x` by component `k`
    /// (`suited_x`: [`Mixture::suited`] of `x`, computed once per proposal).
    fn report(&self, k: usize, x: &S, y: &S, p: Proposed, suited_x: Option<&[f64]>) -> Proposed {
        let kind = self.kind_offsets[k] + p.kind;
        if p.failure.is_some() {
            return Proposed { kind, ..p };
        }
        let ln_ratio = match self.rule {
            // A candidate its own component rejects outright is rejected whatever the selection
            // probabilities: `y`'s suitabilities (every component's, some costly) are not asked.
            MixtureRule::PerComponent if p.ln_ratio == f64::NEG_INFINITY => p.ln_ratio,
            MixtureRule::PerComponent => match (suited_x, self.suited(y, &mut Scratch::new())) {
                (Some(sx), Some(sy)) => {
                    // ln P_k(y) − ln P_k(x); the base weight cancels. One logarithm of the
                    // ratio, exactly 0 when both states suit the same components (the usual
                    // case); four where the ratio leaves the normal range.
                    let (tx, ty): (f64, f64) = (sx.iter().sum(), sy.iter().sum());
                    let r = (sy[k] * tx) / (sx[k] * ty);
                    let ln_selection = if r == 1.0 {
                        0.0
                    } else if r.is_normal() {
                        r.ln()
                    } else {
                        sy[k].ln() - ty.ln() - sx[k].ln() + tx.ln()
                    };
                    p.ln_ratio + ln_selection
                }
                _ => p.ln_ratio,
            },
            MixtureRule::Combined => match self.ln_mixture_pair(x, y) {
                // No component could have made `y` (a candidate carrying nothing): rejected.
                Some((fwd, _)) if fwd == f64::NEG_INFINITY => f64::NEG_INFINITY,
                Some((fwd, rev)) => rev - fwd,
                None => f64::NAN, // counted and rejected by the kernel; see `check_combined`
            },
        };
        Proposed::new(ln_ratio, kind)
    }

    /// `Σ_k w_k s_k(x)` (1 under fixed selection).
    fn total_suitability(&self, x: &S) -> f64 {
        self.suited(x, &mut Scratch::new())
            .map_or(1.0, |w| w.iter().sum())
    }
}

impl<S> Proposal<S> for Mixture<'_, S> {
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        let mut scratch = Scratch::new();
        let suited = self.suited(x, &mut scratch);
        let Some(k) = self.choose(suited, uniform(rng)) else {
            // No component suits x (possible only with suitability selection): counted against
            // the first component that has weight, so statistics name a move that was wanted.
            let first = self
                .ln_weights
                .iter()
                .position(|w| *w > f64::NEG_INFINITY)
                .unwrap_or(0);
            return Proposed::failed(self.kind_offsets[first], Failure::NotApplicable);
        };
        let p = self.components[k].propose(x, y, rng);
        self.report(k, x, y, p, suited)
    }

    fn ln_move_density(&self, from: &S, to: &S, kind: usize) -> Option<f64> {
        match self.rule {
            MixtureRule::Combined => self.ln_mixture_density(from, to),
            MixtureRule::PerComponent => {
                let k = self.kind_offsets.partition_point(|&o| o <= kind) - 1;
                let own =
                    self.components[k].ln_move_density(from, to, kind - self.kind_offsets[k])?;
                Some(self.ln_selection_in(from)[k] + own)
            }
        }
    }

    fn outcomes(&self, x: &S) -> Option<Vec<Outcome<S>>> {
        let mut out = Vec::new();
        let mut scratch = Scratch::new();
        let suited = self.suited(x, &mut scratch);
        for (k, (c, lw)) in self.components.iter().zip(self.ln_selection(x)).enumerate() {
            if lw == f64::NEG_INFINITY {
                continue;
            }
            for o in c.outcomes(x)? {
                let proposed = self.report(k, x, &o.state, o.proposed, suited);
                out.push(Outcome {
                    probability: lw.exp() * o.probability,
                    state: o.state,
                    proposed,
                });
            }
        }
        Some(out)
    }

    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        self.ln_mixture_density(from, to)
    }

    fn ln_pair_densities(&self, x: &S, y: &S) -> Option<(f64, f64)> {
        self.ln_mixture_pair(x, y)
    }

    /// Fixed selection: 1 (some component is always tried). Suitability selection: `Σ_k w_k s_k(x)`
    /// with normalised base weights, so a mixture nested in another suitability-weighted mixture
    /// is chosen as its components would be in the flattened mixture.
    fn suitability(&self, x: &S) -> f64 {
        self.total_suitability(x)
    }

    fn kinds(&self) -> Vec<String> {
        self.kinds_inner()
    }

    fn kind_count(&self) -> usize {
        self.components.iter().map(|c| c.kind_count()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proposals::GaussianRandomWalk;

    #[test]
    fn log_sum_exp_handles_infinities() {
        assert_eq!(
            log_sum_exp(&[f64::NEG_INFINITY, f64::NEG_INFINITY]),
            f64::NEG_INFINITY
        );
        assert!((log_sum_exp(&[0.0, 0.0]) - 2f64.ln()).abs() < 1e-15);
        assert!((log_sum_exp(&[-1000.0, -1000.0]) - (-1000.0 + 2f64.ln())).abs() < 1e-12);
    }

    #[test]
    fn kinds_are_concatenated_and_weights_normalised() {
        let m: Mixture<'_, Vec<f64>> = Mixture::new(
            vec![
                (3.0, Box::new(GaussianRandomWalk::new(0.1).unwrap())),
                (1.0, Box::new(GaussianRandomWalk::new(1.0).unwrap())),
            ],
            MixtureRule::Combined,
        )
        .unwrap();
        assert_eq!(m.kinds().len(), 2);
        let w = m.weights();
        assert!((w[0] - 0.75).abs() < 1e-15 && (w[1] - 0.25).abs() < 1e-15);
        assert!(m.check_combined(&vec![0.0], &vec![1.0]).is_ok());
    }

    /// A move that suits states with a positive first coordinate only.
    struct PositiveOnly;

    impl Proposal<Vec<f64>> for PositiveOnly {
        fn propose(&self, _: &Vec<f64>, _: &mut Vec<f64>, _: &mut ChainRng) -> Proposed {
            Proposed::SYMMETRIC
        }
        fn suitability(&self, x: &Vec<f64>) -> f64 {
            if x[0] > 0.0 { 1.0 } else { 0.0 }
        }
    }

    /// The selection probability of a kind is its component's: fixed, or under suitability
    /// selection renormalised over the components that suit the state; kinds of a nested
    /// mixture map to the nested mixture's component; kinds out of range have none.
    #[test]
    fn selection_of_a_kind_is_its_components() {
        let nested = || -> Box<dyn Proposal<Vec<f64>> + Send + Sync> {
            Box::new(
                Mixture::new(
                    vec![
                        (1.0, Box::new(GaussianRandomWalk::new(0.1).unwrap())),
                        (1.0, Box::new(GaussianRandomWalk::new(1.0).unwrap())),
                    ],
                    MixtureRule::Combined,
                )
                .unwrap(),
            )
        };
        for selection in [Selection::Fixed, Selection::Suitability] {
            let m: Mixture<'_, Vec<f64>> = Mixture::new(
                vec![
                    (2.0, nested()),
                    (1.0, Box::new(PositiveOnly)),
                    (1.0, Box::new(GaussianRandomWalk::new(0.5).unwrap())),
                ],
                MixtureRule::PerComponent,
            )
            .unwrap()
            .with_selection(selection);
            let p = |x: f64, kind| m.ln_selection_of_kind(&vec![x], kind).exp();
            // Kinds 0 and 1 are the nested mixture's, 2 the positive-only move's, 3 the last.
            let (nested_p, last_p) = match selection {
                Selection::Fixed => (0.5, 0.25),
                Selection::Suitability => (2.0 / 3.0, 1.0 / 3.0),
            };
            for kind in [0, 1] {
                assert!((p(1.0, kind) - 0.5).abs() < 1e-15, "{selection:?}");
                assert!((p(-1.0, kind) - nested_p).abs() < 1e-15, "{selection:?}");
            }
            assert!((p(1.0, 2) - 0.25).abs() < 1e-15);
            let unsuited = if selection == Selection::Fixed {
                0.25
            } else {
                0.0
            };
            assert_eq!(p(-1.0, 2), unsuited);
            assert!((p(-1.0, 3) - last_p).abs() < 1e-15);
            assert_eq!(p(1.0, 4), 0.0);
        }
    }

    /// A move whose candidates are rejected outright (ratio `−∞`) when they land at a negative
    /// first coordinate, and that counts how often its suitability is asked.
    struct Counting(std::sync::Arc<std::sync::atomic::AtomicUsize>);

    impl Proposal<Vec<f64>> for Counting {
        fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
            y.clone_from(x);
            y[0] = x[0] + uniform(rng) - 0.5;
            if y[0] < 0.0 {
                Proposed::new(f64::NEG_INFINITY, 0)
            } else {
                Proposed::SYMMETRIC
            }
        }
        fn suitability(&self, _: &Vec<f64>) -> f64 {
            self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            1.0
        }
    }

    /// Under suitability selection, a candidate its component rejects outright is reported as
    /// rejected (ratio `−∞`) without asking any component how well it suits the candidate; the
    /// other candidates' suitabilities are asked as before.
    #[test]
    fn outright_rejections_skip_the_candidates_suitabilities() {
        let asked = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let component =
            || -> Box<dyn Proposal<Vec<f64>> + Send + Sync> { Box::new(Counting(asked.clone())) };
        let m: Mixture<'_, Vec<f64>> = Mixture::new(
            vec![(1.0, component()), (1.0, component())],
            MixtureRule::PerComponent,
        )
        .unwrap()
        .with_selection(Selection::Suitability);
        let mut rng = crate::rng::stream(1, 0);
        let (x, mut y) = (vec![0.0], vec![0.0]);
        let (mut rejected, mut kept) = (0, 0);
        for _ in 0..200 {
            let p = m.propose(&x, &mut y, &mut rng);
            if y[0] < 0.0 {
                assert_eq!(p.ln_ratio, f64::NEG_INFINITY);
                rejected += 1;
            } else {
                assert_eq!(p.ln_ratio, 0.0);
                kept += 1;
            }
        }
        assert!(rejected > 50 && kept > 50, "{rejected} {kept}");
        // Both components asked about x at every proposal, about y only when it was kept.
        let asked = asked.load(std::sync::atomic::Ordering::Relaxed);
        assert_eq!(asked, 2 * 200 + 2 * kept);
    }

    /// A symmetric step of ±0.5 that suits states with a positive first coordinate only.
    struct PositiveWalk;

    impl Proposal<Vec<f64>> for PositiveWalk {
        fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
            y.clone_from(x);
            y[0] = x[0] + uniform(rng) - 0.5;
            Proposed::SYMMETRIC
        }
        fn suitability(&self, x: &Vec<f64>) -> f64 {
            if x[0] > 0.0 { 1.0 } else { 0.0 }
        }
    }

    /// Under suitability selection each component's ratio gains `ln P_k(y) − ln P_k(x)`: `ln 4`
    /// for the walk that suits both sides of 0 (weight 1 of 4 on the positive half, all of it on
    /// the other) when the candidate leaves the positive half, `−∞` for the positive-only walk,
    /// and exactly 0 when both states suit the same moves.
    #[test]
    fn suitability_selection_adds_the_selection_ratio() {
        let m: Mixture<'_, Vec<f64>> = Mixture::new(
            vec![
                (3.0, Box::new(PositiveWalk)),
                (1.0, Box::new(GaussianRandomWalk::new(0.3).unwrap())),
            ],
            MixtureRule::PerComponent,
        )
        .unwrap()
        .with_selection(Selection::Suitability);
        let mut rng = crate::rng::stream(2, 0);
        let mut y = vec![0.0];
        let mut crossed = [0; 2];
        for i in 0..2000 {
            let x = vec![0.05 + 0.2 * (i % 3) as f64];
            let p = m.propose(&x, &mut y, &mut rng);
            let expected = m.ln_selection_of_kind(&y, p.kind) - m.ln_selection_of_kind(&x, p.kind);
            if y[0] > 0.0 {
                assert_eq!(p.ln_ratio, 0.0, "{x:?} → {y:?}");
            } else if p.kind == 0 {
                assert_eq!(p.ln_ratio, f64::NEG_INFINITY);
                crossed[0] += 1;
            } else {
                assert!(
                    (p.ln_ratio - expected).abs() < 1e-15 && (expected - 4f64.ln()).abs() < 1e-15
                );
                crossed[1] += 1;
            }
        }
        assert!(crossed[0] > 20 && crossed[1] > 20, "{crossed:?}");
    }

    #[test]
    fn invalid_weights_are_refused() {
        let bad: Result<Mixture<'_, Vec<f64>>, _> = Mixture::new(
            vec![(f64::NAN, Box::new(GaussianRandomWalk::new(0.1).unwrap()))],
            MixtureRule::PerComponent,
        );
        assert!(bad.is_err());
        assert!(Mixture::<'_, Vec<f64>>::new(vec![], MixtureRule::Combined).is_err());
    }
}
