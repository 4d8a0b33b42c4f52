//! The von Mises–Fisher distribution on the sphere, which the manifold perturbation samples its
//! new direction from (Jakob & Marschner 2012, §5.1): concentrated around the current direction
//! so that its density there is `λ² p(ω_i → ω_o)`.
//!
//! Density `κ exp(κ (μ·ω − 1)) / (2π (1 − e^{−2κ}))`; sampling by inverting the law of `cos θ`,
//! `cos θ = 1 + ln(u + (1 − u) e^{−2κ}) / κ`, written with `ln_1p`/`exp_m1` so that it stays exact
//! for concentrations from 0 to 1e12.

use crate::math::{DVec3, Frame};
use std::f64::consts::{PI, TAU};

/// A von Mises–Fisher distribution: mean direction `mean` (unit), concentration `kappa ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VonMisesFisher {
    /// Mean direction.
    pub mean: DVec3,
    /// Concentration (0: uniform on the sphere).
    pub kappa: f64,
}

/// The concentration from which [`VonMisesFisher::kappa_for_peak`] is `2π peak` in closed form:
/// there `e^{−2κ} ≤ 4.3e-18`, under half an ulp of 1.
const KAPPA_CLOSED: f64 = 20.0;

/// `(1 − e^{−2κ}) / κ`, continuous at `κ = 0` (where it is 2).
fn norm(kappa: f64) -> f64 {
    if kappa < 1e-12 {
        2.0 - 2.0 * kappa
    } else {
        -(-2.0 * kappa).exp_m1() / kappa
    }
}

impl VonMisesFisher {
    /// The density at the mean direction: `κ / (2π (1 − e^{−2κ}))` (`1/4π` at `κ = 0`).
    pub fn peak_density(kappa: f64) -> f64 {
        1.0 / (TAU * norm(kappa))
    }

    /// The concentration whose density at the mean is `peak` (0 when `peak ≤ 1/4π`, which the
    /// uniform distribution already exceeds): the peak density increases with `κ` from `1/4π`
    /// toward `κ/2π`. From `2π peak ≥ KAPPA_CLOSED` on, `κ = 2π peak` exactly (to f64
    /// precision: the factor `1 − e^{−2κ}` is 1 within 4e-18); below, bisection on `ln κ` to
    /// relative precision 1e-12.
    pub fn kappa_for_peak(peak: f64) -> f64 {
        if !(peak > 1.0 / (4.0 * PI)) || !peak.is_finite() {
            return 0.0;
        }
        if TAU * peak >= KAPPA_CLOSED {
            // The manifold perturbation's usual case (λ² p with λ = 50), where the bisection
            // took some 35 `exp_m1`s per distribution.
            return TAU * peak;
        }
        // Bracket: f(κ) ≥ κ/2π, so κ ≤ 2π peak; and f(κ) ≤ (κ + 1)/2π... so κ ≥ 2π peak − 1.
        let (mut lo, mut hi) = ((TAU * peak - 1.0).max(1e-12), TAU * peak);
        for _ in 0..200 {
            let mid = (lo * hi).sqrt();
            if Self::peak_density(mid) < peak {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-12 * hi {
                break;
            }
        }
        0.5 * (lo + hi)
    }

    /// The distribution around `mean` whose density at `mean` is `peak`.
    pub fn with_peak(mean: DVec3, peak: f64) -> Self {
        Self {
            mean,
            kappa: Self::kappa_for_peak(peak),
        }
    }

    /// Solid-angle density at the unit direction `w`.
    pub fn pdf(&self, w: DVec3) -> f64 {
        let c = self.mean.dot(w).clamp(-1.0, 1.0);
        (self.kappa * (c - 1.0)).exp() / (TAU * norm(self.kappa))
    }

    /// `cos θ` from a uniform number `u` (the inverse of the law of `cos θ`).
    pub fn cos_theta(&self, u: f64) -> f64 {
        let k = self.kappa;
        if k < 1e-12 {
            return 2.0 * u - 1.0;
        }
        // ln(u + (1 − u) e^{−2κ}) = ln(1 + (1 − u)(e^{−2κ} − 1)).
        (1.0 + ((1.0 - u) * (-2.0 * k).exp_m1()).ln_1p() / k).clamp(-1.0, 1.0)
    }

    /// A direction from two uniform numbers.
    pub fn sample(&self, u: [f64; 2]) -> DVec3 {
        let c = self.cos_theta(u[0]);
        let s = (1.0 - c * c).max(0.0).sqrt();
        let phi = TAU * u[1];
        Frame::from_normal(self.mean).to_world(DVec3::new(s * phi.cos(), s * phi.sin(), c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_density_integrates_to_one_and_matches_the_mean_cosine() {
        for kappa in [0.0, 1e-6, 0.5, 3.0, 50.0, 2e3, 1e6] {
            let v = VonMisesFisher {
                mean: DVec3::Z,
                kappa,
            };
            // ∫ pdf dω = 2π ∫ pdf(cos θ) d cos θ, by the midpoint rule on a grid fine near 1.
            let n = 1_000_000;
            let (mut total, mut first) = (0.0, 0.0);
            for i in 0..n {
                // Substitute cos θ = 1 − t², t ∈ [0, √2], to resolve the peak.
                let t = (i as f64 + 0.5) / n as f64 * 2f64.sqrt();
                let c = 1.0 - t * t;
                let w = DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
                let p = v.pdf(w) * TAU * 2.0 * t * (2f64.sqrt() / n as f64);
                total += p;
                first += p * c;
            }
            assert!((total - 1.0).abs() < 1e-6, "κ = {kappa}: ∫ = {total}");
            // E[cos θ] = coth κ − 1/κ.
            let exact = if kappa < 1e-3 {
                kappa / 3.0
            } else {
                1.0 / kappa.tanh() - 1.0 / kappa
            };
            assert!(
                (first - exact).abs() < 1e-5,
                "κ = {kappa}: {first} vs {exact}"
            );
            // The sampler's cos θ at the quantiles reproduces its own law: u = P(cos θ ≤ c).
            for u in [0.01, 0.3, 0.77, 0.999] {
                let c = v.cos_theta(u);
                // P(cos θ ≤ c) = (e^{κ(c−1)} − e^{−2κ}) / (1 − e^{−2κ}).
                let cdf = if kappa < 1e-12 {
                    (1.0 + c) / 2.0
                } else {
                    ((kappa * (c - 1.0)).exp() - (-2.0 * kappa).exp()) / -(-2.0 * kappa).exp_m1()
                };
                assert!((cdf - u).abs() < 1e-9, "κ = {kappa}, u = {u}: {cdf}");
            }
        }
    }

    #[test]
    fn the_concentration_reproduces_the_peak_density() {
        for peak in [0.1, 1.0, 10.0, 1e4, 1e9] {
            let k = VonMisesFisher::kappa_for_peak(peak);
            let got = VonMisesFisher::peak_density(k);
            assert!((got / peak - 1.0).abs() < 1e-9, "{peak}: κ = {k}, {got}");
        }
        assert_eq!(VonMisesFisher::kappa_for_peak(0.05), 0.0);
    }

    /// From `κ = KAPPA_CLOSED` on, `2π peak` reproduces the peak density to the last bit or
    /// two, and agrees with the bisection the smaller concentrations use (to its 1e-12) on both
    /// sides of the switch.
    #[test]
    fn large_concentrations_are_closed_form() {
        for kappa in [KAPPA_CLOSED, 20.5, 100.0, 1570.0, 1e7] {
            let peak = kappa / TAU;
            let k = VonMisesFisher::kappa_for_peak(peak);
            let got = VonMisesFisher::peak_density(k);
            assert!(
                (got / peak - 1.0).abs() < 4e-16,
                "κ {kappa}: {k}, {got} vs {peak}"
            );
        }
        let below = VonMisesFisher::kappa_for_peak(KAPPA_CLOSED / TAU * (1.0 - 1e-9));
        let at = VonMisesFisher::kappa_for_peak(KAPPA_CLOSED / TAU);
        assert!(below < at && (at - below) / at < 2e-9, "{below} {at}");
    }
}
