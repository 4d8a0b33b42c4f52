//! Sampling charts (Pantaleoni 2017, "Charted Metropolis light transport", §4).
//!
//! A sampling chart `(U_i, V_i, T_i, R_i)` parameterises the target space `Ω` by a primary space
//! `U_i = [0,1)^{d_i}`: a forward map `T_i : U_i → Ω` (which may fail), the density `p_i` of
//! `T_i(U)` for `U` uniform (with respect to `Ω`'s reference measure), and a stochastic right
//! inverse `R_i(x, v)` with `T_i(R_i(x, v)) = x`.
//!
//! **The contract.** `R_i(x, ·)` draws `u` from the exact conditional law `κ_i(·|x)` of `U` given
//! `T_i(U) = x`. Where `T_i` is not injective — a layered BSDF choosing a lobe with one coordinate,
//! several strata mapping onto the same region — the inverse picks a preimage branch with
//! probability proportional to that branch's share of `p_i(x)`, then fills the branch's free
//! coordinates uniformly. Under this contract every chart move has a simple exact acceptance rule
//! (see [`crate::moves`]). A chart that cannot sample `κ_i` exactly must say by how much its inverse
//! deviates, through [`Chart::ln_inverse_bias`]; the moves then include that ratio.

use mcmc_core::ChainRng;

/// A sampling chart of a target space whose points are of type `X`.
pub trait Chart<X>: Send + Sync {
    /// Dimension `d_i` of the primary space `[0,1)^{d_i}`.
    fn dim(&self) -> usize;

    /// `x = T_i(u)`, written into `x`; `false` when the map fails (no point: zero contribution).
    fn forward(&self, u: &[f64], x: &mut X) -> bool;

    /// `ln p_i(x)`: log density of `T_i(U)` at `x`; `-inf` outside the image of `T_i`.
    fn ln_density(&self, x: &X) -> f64;

    /// Draw `u ~ κ_i(·|x)` into `u` (of length [`Chart::dim`]); `false` when `x` is not in the
    /// image of `T_i`.
    fn invert(&self, x: &X, u: &mut [f64], rng: &mut ChainRng) -> bool;

    /// Draw `u ~ κ_i(·|x)` for a point `x` that chart `from` reaches with coordinates `u_from`
    /// (drawn from `from`'s inverse): the hook for charts whose coordinates share parts with other
    /// charts of their family (charted-MLT paper §6.1: two technique charts of one path share the
    /// numbers of every vertex both sample the same way). Such a chart may keep those parts of
    /// `u_from` and invert only the rest. **Contract:** the pair `(u_from, u)` must have the same
    /// law as `(u, u_from)` would when the roles of the two charts are exchanged, e.g. shared parts
    /// copied and the rest drawn from its exact conditional law; then `u` follows `κ_i(·|x)` and
    /// every swap built on it stays exact. The default ignores `from` and inverts in full.
    fn partial_inverse(
        &self,
        x: &X,
        from: &Self,
        u_from: &[f64],
        u: &mut [f64],
        rng: &mut ChainRng,
    ) -> bool
    where
        Self: Sized,
    {
        let _ = (from, u_from);
        self.invert(x, u, rng)
    }

    /// `ln (dρ_i/dκ_i)(u)` where `ρ_i(·|x)` is the law [`Chart::invert`] actually samples and `κ_i`
    /// the exact conditional law; zero (the default) for a chart that honours the contract. For a
    /// finite choice of branches this is `ln(P_used(branch) / P_exact(branch))`.
    fn ln_inverse_bias(&self, x: &X, u: &[f64]) -> f64 {
        let _ = (x, u);
        0.0
    }

    /// A short name for reports.
    fn name(&self) -> String {
        "chart".into()
    }
}

impl<X, C: Chart<X> + ?Sized> Chart<X> for Box<C> {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn forward(&self, u: &[f64], x: &mut X) -> bool {
        (**self).forward(u, x)
    }
    fn ln_density(&self, x: &X) -> f64 {
        (**self).ln_density(x)
    }
    fn invert(&self, x: &X, u: &mut [f64], rng: &mut ChainRng) -> bool {
        (**self).invert(x, u, rng)
    }
    fn ln_inverse_bias(&self, x: &X, u: &[f64]) -> f64 {
        (**self).ln_inverse_bias(x, u)
    }
    fn name(&self) -> String {
        (**self).name()
    }
}
