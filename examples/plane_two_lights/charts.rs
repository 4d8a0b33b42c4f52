//! The two sampling charts of the paper's simplified test, both with exact inverses.
//!
//! * [`NextEvent`] — technique (1,1): uniform ground point `(u0, u1)`; `u2` chooses the light by
//!   power and, remapped, the `x` of the light point (light 1 by inverting the CDF of its
//!   exponential intensity, light 2 uniformly); `u3` is the light point's `z`.
//!   `p(g, l) = P_light · pdf_light(l)`.
//! * [`Cosine`] — technique (0,2): uniform ground point `(u0, u1)`; a cosine-distributed direction
//!   `(φ, θ) = (2π u2, acos √u3)` traced to the first surface; fails unless it reaches a light.
//!   `p(g, l) = (cos θ_g / π) · cos θ_l / r²` where the light point is visible, zero elsewhere (its
//!   image misses the occluded paths).

use super::scene::{Path, RATE, power1, power2};
use mcmc_charts::Chart;
use mcmc_core::ChainRng;
use std::f64::consts::PI;

fn on_ground(g: &[f64; 2]) -> bool {
    (0.0..1.0).contains(&g[0]) && (0.0..1.0).contains(&g[1])
}

fn on_light(l: &[f64; 2]) -> bool {
    (0.0..1.0).contains(&l[0]) && (0.0..1.0).contains(&l[1])
}

/// Technique (1,1): next-event estimation.
pub struct NextEvent {
    p1: f64,
}

impl NextEvent {
    pub fn new() -> Self {
        Self {
            p1: power1() / (power1() + power2()),
        }
    }
    fn cdf1(x: f64) -> f64 {
        ((RATE * x).exp() - 1.0) / (RATE.exp() - 1.0)
    }
    fn inv_cdf1(v: f64) -> f64 {
        (1.0 + v * (RATE.exp() - 1.0)).ln() / RATE
    }
    fn pdf1(x: f64) -> f64 {
        RATE * (RATE * x).exp() / (RATE.exp() - 1.0)
    }
}

impl Chart<Path> for NextEvent {
    fn dim(&self) -> usize {
        4
    }
    fn forward(&self, u: &[f64], x: &mut Path) -> bool {
        x.g = [u[0], u[1]];
        if u[2] < self.p1 {
            x.light = 1;
            x.l = [Self::inv_cdf1(u[2] / self.p1).min(1.0 - 1e-12), u[3]];
        } else {
            x.light = 2;
            x.l = [((u[2] - self.p1) / (1.0 - self.p1)).min(1.0 - 1e-12), u[3]];
        }
        true
    }
    fn ln_density(&self, x: &Path) -> f64 {
        if !on_ground(&x.g) || !on_light(&x.l) {
            return f64::NEG_INFINITY;
        }
        if x.light == 1 {
            (self.p1 * Self::pdf1(x.l[0])).ln()
        } else {
            (1.0 - self.p1).ln()
        }
    }
    fn invert(&self, x: &Path, u: &mut [f64], _rng: &mut ChainRng) -> bool {
        if !on_ground(&x.g) || !on_light(&x.l) {
            return false;
        }
        u[0] = x.g[0];
        u[1] = x.g[1];
        u[2] = if x.light == 1 {
            self.p1 * Self::cdf1(x.l[0])
        } else {
            self.p1 + (1.0 - self.p1) * x.l[0]
        };
        u[3] = x.l[1];
        u[2] = u[2].min(1.0 - 1e-16);
        true
    }
    fn name(&self) -> String {
        "(1,1) next event".into()
    }
}

/// Technique (0,2): cosine-distributed direction from the ground, traced to a light.
pub struct Cosine;

impl Chart<Path> for Cosine {
    fn dim(&self) -> usize {
        4
    }
    fn forward(&self, u: &[f64], x: &mut Path) -> bool {
        let g = [u[0], u[1]];
        let phi = 2.0 * PI * u[2];
        let cos_t = u[3].sqrt();
        let sin_t = (1.0 - u[3]).max(0.0).sqrt();
        let d = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
        if d[1] == 0.0 || cos_t <= 0.0 {
            return false;
        }
        let (light, plane) = if d[1] < 0.0 { (1u8, 0.0) } else { (2u8, 1.0) };
        let t = (plane - g[1]) / d[1];
        let l = [g[0] + t * d[0], t * d[2]];
        if !on_light(&l) {
            return false; // escapes between or over the lights
        }
        *x = Path { g, light, l };
        x.visible()
    }
    fn ln_density(&self, x: &Path) -> f64 {
        if !on_ground(&x.g) || !on_light(&x.l) || !x.visible() {
            return f64::NEG_INFINITY;
        }
        let (r2, cg, cl) = x.geometry();
        if cg <= 0.0 || cl <= 0.0 {
            return f64::NEG_INFINITY;
        }
        (cg / PI * cl / r2).ln()
    }
    fn invert(&self, x: &Path, u: &mut [f64], _rng: &mut ChainRng) -> bool {
        if self.ln_density(x) == f64::NEG_INFINITY {
            return false;
        }
        let p = x.light_point();
        let d = [p[0] - x.g[0], p[1] - x.g[1], p[2]];
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let mut phi = d[1].atan2(d[0]);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        u[0] = x.g[0];
        u[1] = x.g[1];
        u[2] = (phi / (2.0 * PI)).min(1.0 - 1e-16);
        u[3] = (d[2] / r).powi(2).min(1.0 - 1e-16);
        true
    }
    fn name(&self) -> String {
        "(0,2) cosine".into()
    }
}
