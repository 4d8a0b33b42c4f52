//! An atlas: the family of charts a charted chain may move between, optionally with the identity
//! chart (`U = Ω`, `p = 1`), which lets target-space moves (e.g. path-space mutations) join the
//! family; then `p = 1` also enters the denominator of the weighted targets (paper §4).
//!
//! An atlas holds charts of one type `C`: boxed trait objects by default (any mix of charts), or a
//! concrete chart type, which lets chart swaps use the charts' [`Chart::partial_inverse`].

use crate::Chart;
use mcmc_core::ChainRng;

/// A chain state of charted Metropolis–Hastings: a chart index, its primary coordinates, and the
/// cached target-space point with what was evaluated there.
#[derive(Debug, Default, PartialEq)]
pub struct ChartState<X> {
    /// Index of the chart the state lives in ([`Atlas::identity`] for target space).
    pub chart: usize,
    /// Primary coordinates (empty in the identity chart).
    pub u: Vec<f64>,
    /// The point `T_chart(u)` (only meaningful when `valid`).
    pub x: X,
    /// Whether `x` is a point (the forward map succeeded).
    pub valid: bool,
    /// Whether `x`, `importance` and `ln_p` are up to date with `u`.
    pub fresh: bool,
    /// The scalar importance `f*(x)` the chain samples.
    pub importance: f64,
    /// `ln p_k(x)` for every chart `k` of the atlas (0 for the identity chart).
    pub ln_p: Vec<f64>,
}

impl<X: Clone> Clone for ChartState<X> {
    fn clone(&self) -> Self {
        Self {
            chart: self.chart,
            u: self.u.clone(),
            x: self.x.clone(),
            valid: self.valid,
            fresh: self.fresh,
            importance: self.importance,
            ln_p: self.ln_p.clone(),
        }
    }

    /// Field by field, so that a move copying the current state into the chain's candidate
    /// reuses the candidate's storage (`u`, `ln_p` and whatever `X::clone_from` keeps).
    fn clone_from(&mut self, source: &Self) {
        self.chart = source.chart;
        self.u.clone_from(&source.u);
        self.x.clone_from(&source.x);
        self.valid = source.valid;
        self.fresh = source.fresh;
        self.importance = source.importance;
        self.ln_p.clone_from(&source.ln_p);
    }
}

impl<X: Default> ChartState<X> {
    /// A state in chart `chart` at primary coordinates `u` (evaluated on first use).
    pub fn in_chart(chart: usize, u: Vec<f64>) -> Self {
        Self {
            chart,
            u,
            ..Default::default()
        }
    }
}

impl<X> ChartState<X> {
    /// Become the state [`ChartState::in_chart`]`(chart, u)` would make, keeping this state's
    /// storage: its vectors, and its point `x`, which is stale until the state is next evaluated
    /// (a caller evaluating many independent states one after another allocates once).
    pub fn move_to(&mut self, chart: usize, u: impl IntoIterator<Item = f64>) {
        self.chart = chart;
        self.u.clear();
        self.u.extend(u);
        self.valid = false;
        self.fresh = false;
        self.importance = 0.0;
        self.ln_p.clear();
    }

    /// A state in target space (the identity chart of `atlas`) at `x`.
    pub fn at_point<Y, C: Chart<Y>>(atlas: &Atlas<Y, C>, x: X) -> Self {
        Self {
            chart: atlas.identity(),
            u: Vec::new(),
            x,
            valid: true,
            fresh: false,
            importance: 0.0,
            ln_p: Vec::new(),
        }
    }
}

/// A family of sampling charts of one target space.
pub struct Atlas<X, C = Box<dyn Chart<X>>> {
    charts: Vec<C>,
    with_identity: bool,
    _point: std::marker::PhantomData<fn(&X)>,
}

impl<X, C: Chart<X>> std::fmt::Debug for Atlas<X, C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Atlas")
            .field(
                "charts",
                &self.charts.iter().map(|c| c.name()).collect::<Vec<_>>(),
            )
            .field("with_identity", &self.with_identity)
            .finish()
    }
}

impl<X> Atlas<X> {
    /// An atlas of boxed `charts` of any types (no identity chart).
    pub fn new(charts: Vec<Box<dyn Chart<X>>>) -> Self {
        Self::of(charts)
    }
}

impl<X, C: Chart<X>> Atlas<X, C> {
    /// An atlas of `charts` of one type (no identity chart); charts of a concrete type can use
    /// their [`Chart::partial_inverse`] in swaps.
    pub fn of(charts: Vec<C>) -> Self {
        Self {
            charts,
            with_identity: false,
            _point: std::marker::PhantomData,
        }
    }

    /// Add the identity chart as level [`Atlas::identity`] (= number of charts).
    pub fn with_identity(mut self) -> Self {
        self.with_identity = true;
        self
    }

    /// Number of levels: charts, plus one for the identity chart if present.
    pub fn levels(&self) -> usize {
        self.charts.len() + self.with_identity as usize
    }

    /// Number of (non-identity) charts.
    pub fn charts(&self) -> usize {
        self.charts.len()
    }

    /// The chart at `index` (`None` for the identity level).
    pub fn chart(&self, index: usize) -> Option<&C> {
        self.charts.get(index)
    }

    /// Whether the identity chart is part of the atlas.
    pub fn has_identity(&self) -> bool {
        self.with_identity
    }

    /// The index of the identity chart (equal to [`Atlas::charts`]; valid as a level only when the
    /// atlas has it, but always usable as the index of target-space states).
    pub fn identity(&self) -> usize {
        self.charts.len()
    }

    /// Name of a level.
    pub fn name(&self, level: usize) -> String {
        self.chart(level)
            .map(|c| c.name())
            .unwrap_or_else(|| "identity".into())
    }

    /// Primary dimension of a level (0 for the identity chart).
    pub fn dim(&self, level: usize) -> usize {
        self.chart(level).map(|c| c.dim()).unwrap_or(0)
    }

    /// `ln p_level(x)` (0 for the identity chart).
    pub fn ln_density(&self, level: usize, x: &X) -> f64 {
        self.chart(level).map(|c| c.ln_density(x)).unwrap_or(0.0)
    }

    /// Fill `ln_p` with `ln p_k(x)` for every level.
    pub fn ln_densities(&self, x: &X, ln_p: &mut Vec<f64>) {
        ln_p.clear();
        ln_p.extend(self.charts.iter().map(|c| c.ln_density(x)));
        if self.with_identity {
            ln_p.push(0.0);
        }
    }

    /// Draw the coordinates of point `x` in level `to` into `u` (resized; emptied for the
    /// identity), given that level `from` reaches it with coordinates `u_from`: through
    /// [`Chart::partial_inverse`] when both levels are charts, else the full inverse. `false`
    /// when `x` is not in the image of `to`.
    pub fn inverse_from(
        &self,
        to: usize,
        x: &X,
        from: usize,
        u_from: &[f64],
        u: &mut Vec<f64>,
        rng: &mut ChainRng,
    ) -> bool {
        u.resize(self.dim(to), 0.0);
        match (self.chart(to), self.chart(from)) {
            (Some(c), Some(f)) => c.partial_inverse(x, f, u_from, u, rng),
            (Some(c), None) => c.invert(x, u, rng),
            (None, _) => true,
        }
    }

    /// `ln λ_level(u)` (the level's inverse bias at `x`; 0 for the identity).
    pub fn ln_inverse_bias(&self, level: usize, x: &X, u: &[f64]) -> f64 {
        self.chart(level).map_or(0.0, |c| c.ln_inverse_bias(x, u))
    }

    /// Re-parameterise the point of `from` in chart `to`: `to.u ~ R_to(x)` (through
    /// [`Chart::partial_inverse`] when both levels are charts), copying the cached evaluation.
    /// Returns the Green ratio `ln p_to(x) − ln p_from(x) + ln λ_from(u) − ln λ_to(u')`
    /// (λ: the charts' inverse biases), or `-inf` when the point is not in the image of `to`.
    pub fn reparameterise(
        &self,
        from: &ChartState<X>,
        to_chart: usize,
        to: &mut ChartState<X>,
        rng: &mut ChainRng,
    ) -> f64
    where
        X: Clone,
    {
        to.chart = to_chart;
        to.x.clone_from(&from.x);
        to.valid = from.valid;
        to.fresh = from.fresh;
        to.importance = from.importance;
        to.ln_p.clone_from(&from.ln_p);
        to.u.resize(self.dim(to_chart), 0.0);
        if !from.valid {
            return f64::NEG_INFINITY;
        }
        let ln_p_to = self.ln_density(to_chart, &from.x);
        let ln_p_from = self.ln_density(from.chart, &from.x);
        if ln_p_to == f64::NEG_INFINITY
            || !self.inverse_from(to_chart, &from.x, from.chart, &from.u, &mut to.u, rng)
        {
            to.valid = false;
            return f64::NEG_INFINITY;
        }
        let bias_from = self.ln_inverse_bias(from.chart, &from.x, &from.u);
        let bias_to = self.ln_inverse_bias(to_chart, &from.x, &to.u);
        ln_p_to - ln_p_from + bias_from - bias_to
    }
}

#[cfg(test)]
mod tests {
    use super::ChartState;

    /// Copying the current state into a candidate is a clone that keeps the candidate's storage.
    #[test]
    fn clone_from_is_clone_in_the_candidates_storage() {
        let x = ChartState {
            chart: 2,
            u: vec![0.1, 0.2, 0.3],
            x: vec![4.0, 5.0],
            valid: true,
            fresh: true,
            importance: 0.7,
            ln_p: vec![-1.0, -2.0, -3.0],
        };
        let mut y = ChartState::<Vec<f64>>::in_chart(1, vec![0.9; 8]);
        y.x = vec![0.0; 6];
        y.ln_p = vec![0.0; 5];
        let (u, p, ln_p) = (y.u.as_ptr(), y.x.as_ptr(), y.ln_p.as_ptr());
        y.clone_from(&x);
        assert_eq!(y, x.clone());
        assert_eq!((y.u.as_ptr(), y.x.as_ptr(), y.ln_p.as_ptr()), (u, p, ln_p));
    }

    /// A moved state is the fresh state `in_chart` makes, whatever it held before, but for its
    /// (stale) point.
    #[test]
    fn a_moved_state_is_a_fresh_state_but_for_its_point() {
        let mut used = ChartState {
            chart: 3,
            u: vec![0.1, 0.2, 0.3],
            x: 7.5,
            valid: true,
            fresh: true,
            importance: 2.0,
            ln_p: vec![-1.0, -2.0],
        };
        used.move_to(1, [0.4, 0.6]);
        let fresh = ChartState::<f64>::in_chart(1, vec![0.4, 0.6]);
        assert_eq!(ChartState { x: fresh.x, ..used }, fresh);
    }
}
