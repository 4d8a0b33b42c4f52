//! Targets with exact samplers, proposals, and one-step closures shared by the tests — correct
//! kernels and deliberately broken ones.

use mcmc_core::proposals::{
    CubeWalk, GaussianRandomWalk, Independence, Mixture, MixtureRule, SmallStep, UniformCube,
};
use mcmc_core::rng::uniform;
use mcmc_core::{Chain, ChainRng, Density, Kernel, MetropolisHastings, Proposal, Proposed, Target};
use rand::RngExt;
use rand_distr::StandardNormal;

/// A Gaussian mixture on R^d with isotropic components: an exactly sampleable target.
#[derive(Clone, Debug)]
pub struct GaussianMixture {
    pub weights: Vec<f64>,
    pub means: Vec<Vec<f64>>,
    pub sigmas: Vec<f64>,
}

impl GaussianMixture {
    pub fn dim(&self) -> usize {
        self.means[0].len()
    }
    pub fn sample(&self, rng: &mut ChainRng) -> Vec<f64> {
        let total: f64 = self.weights.iter().sum();
        let mut u = uniform(rng) * total;
        let mut k = self.weights.len() - 1;
        for (i, w) in self.weights.iter().enumerate() {
            if u < *w {
                k = i;
                break;
            }
            u -= w;
        }
        self.means[k]
            .iter()
            .map(|m| m + self.sigmas[k] * rng.sample::<f64, _>(StandardNormal))
            .collect()
    }
    /// Normalised log density.
    pub fn ln_pdf(&self, x: &[f64]) -> f64 {
        let total: f64 = self.weights.iter().sum();
        let d = x.len() as f64;
        let terms: Vec<f64> = (0..self.weights.len())
            .map(|k| {
                let s = self.sigmas[k];
                let r2: f64 = x
                    .iter()
                    .zip(&self.means[k])
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
                (self.weights[k] / total).ln()
                    - 0.5 * r2 / (s * s)
                    - d * (s.ln() + 0.5 * (2.0 * std::f64::consts::PI).ln())
            })
            .collect();
        mcmc_core::proposals::log_sum_exp(&terms)
    }
}

impl Target<Vec<f64>> for GaussianMixture {
    fn ln_density(&self, x: &Vec<f64>) -> f64 {
        self.ln_pdf(x)
    }
}

/// A piecewise-constant density on [0,1)^d with `bins` cells per axis.
#[derive(Clone, Debug)]
pub struct PiecewiseConstant {
    pub dim: usize,
    pub bins: usize,
    pub weights: Vec<f64>,
}

impl PiecewiseConstant {
    fn cell(&self, x: &[f64]) -> Option<usize> {
        let mut idx = 0;
        for &v in x {
            if !(0.0..1.0).contains(&v) {
                return None;
            }
            idx = idx * self.bins + ((v * self.bins as f64) as usize).min(self.bins - 1);
        }
        Some(idx)
    }
    pub fn sample(&self, rng: &mut ChainRng) -> Vec<f64> {
        let total: f64 = self.weights.iter().sum();
        let mut u = uniform(rng) * total;
        let mut c = self.weights.len() - 1;
        for (i, w) in self.weights.iter().enumerate() {
            if u < *w {
                c = i;
                break;
            }
            u -= w;
        }
        let mut coords = vec![0.0; self.dim];
        for i in (0..self.dim).rev() {
            let b = c % self.bins;
            c /= self.bins;
            coords[i] = (b as f64 + uniform(rng)) / self.bins as f64;
        }
        coords
    }
}

impl Target<Vec<f64>> for PiecewiseConstant {
    fn ln_density(&self, x: &Vec<f64>) -> f64 {
        match self.cell(x) {
            Some(c) => self.weights[c].ln(),
            None => f64::NEG_INFINITY,
        }
    }
}

/// An isotropic Gaussian density (for independence proposals).
#[derive(Clone, Debug)]
pub struct GaussianDensity {
    pub mean: Vec<f64>,
    pub sigma: f64,
}

impl Density<Vec<f64>> for GaussianDensity {
    fn sample(&self, rng: &mut ChainRng, out: &mut Vec<f64>) {
        for (o, m) in out.iter_mut().zip(&self.mean) {
            *o = m + self.sigma * rng.sample::<f64, _>(StandardNormal);
        }
    }
    fn ln_pdf(&self, x: &Vec<f64>) -> f64 {
        let s = self.sigma;
        x.iter()
            .zip(&self.mean)
            .map(|(a, b)| {
                let z = (a - b) / s;
                -0.5 * z * z - s.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln()
            })
            .sum()
    }
}

/// One Metropolis–Hastings step of `kernel` from `x` in place (the chain is rebuilt around `x`).
pub fn mh_step<T: Target<Vec<f64>>, K: Kernel<Vec<f64>>>(
    target: &T,
    kernel: &mut K,
    x: &mut Vec<f64>,
    rng: &mut ChainRng,
) {
    let l = target.ln_density(x);
    let mut c = Chain::unchecked(std::mem::take(x), l);
    kernel.step(&mut c, rng, &mut ());
    *x = c.state;
}

pub type BoxedProposal = Box<dyn Proposal<Vec<f64>> + Send + Sync>;

/// Correct proposals for a target on R^d of typical scale `scale`.
pub fn real_proposals(scale: f64, dim: usize) -> Vec<(&'static str, BoxedProposal)> {
    let rw = || -> BoxedProposal { Box::new(GaussianRandomWalk::new(scale).unwrap()) };
    let big = || -> BoxedProposal { Box::new(GaussianRandomWalk::new(3.0 * scale).unwrap()) };
    let ind = || -> BoxedProposal {
        Box::new(Independence::new(GaussianDensity {
            mean: vec![0.0; dim],
            sigma: 3.0,
        }))
    };
    vec![
        ("random walk", rw()),
        ("independence", ind()),
        (
            "biased walk (exact ratio)",
            Box::new(BiasedWalk::new(scale, 0.5 * scale, false)),
        ),
        (
            "log-scale walk on |x| (exact ratio)",
            Box::new(ScaleWalk::new(0.4, false)),
        ),
        (
            "mixture per-component",
            Box::new(
                Mixture::new(
                    vec![(0.6, rw()), (0.3, big()), (0.1, ind())],
                    MixtureRule::PerComponent,
                )
                .unwrap(),
            ),
        ),
        (
            "mixture combined",
            Box::new(
                Mixture::new(
                    vec![(0.6, rw()), (0.3, big()), (0.1, ind())],
                    MixtureRule::Combined,
                )
                .unwrap(),
            ),
        ),
        (
            "directional pair, combined",
            directional_pair(scale, MixtureRule::Combined),
        ),
    ]
}

/// Correct proposals on the unit cube.
pub fn cube_proposals() -> Vec<(&'static str, BoxedProposal)> {
    let exp = || -> BoxedProposal { Box::new(CubeWalk::new(SmallStep::default()).unwrap()) };
    let wide = || -> BoxedProposal {
        Box::new(
            CubeWalk::new(SmallStep::Exponential {
                s1: 1.0 / 64.0,
                s2: 0.3,
            })
            .unwrap(),
        )
    };
    let gauss = || -> BoxedProposal {
        Box::new(CubeWalk::new(SmallStep::Gaussian { sigma: 0.1 }).unwrap())
    };
    let large = || -> BoxedProposal { Box::new(Independence::new(UniformCube)) };
    vec![
        ("kelemen wide small step", wide()),
        ("gaussian small step", gauss()),
        ("large step", large()),
        (
            "pssmlt mixture (0.7 small, 0.3 large)",
            Box::new(
                Mixture::new(
                    vec![(0.7, exp()), (0.3, large())],
                    MixtureRule::PerComponent,
                )
                .unwrap(),
            ),
        ),
        (
            "cube mixture combined",
            Box::new(
                Mixture::new(
                    vec![(0.5, gauss()), (0.3, wide()), (0.2, large())],
                    MixtureRule::Combined,
                )
                .unwrap(),
            ),
        ),
    ]
}

/// `y = x + shift + σ ε`: asymmetric. Reports its exact ratio, or zero when `as_symmetric`
/// (broken: an asymmetric proposal treated as symmetric).
pub struct BiasedWalk {
    sigma: f64,
    shift: f64,
    as_symmetric: bool,
}

impl BiasedWalk {
    pub fn new(sigma: f64, shift: f64, as_symmetric: bool) -> Self {
        Self {
            sigma,
            shift,
            as_symmetric,
        }
    }
}

impl Proposal<Vec<f64>> for BiasedWalk {
    fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = xi + self.shift + self.sigma * rng.sample::<f64, _>(StandardNormal);
        }
        if self.as_symmetric {
            Proposed::SYMMETRIC
        } else {
            Proposed::with_ratio(
                self.ln_transition_density(y, x).unwrap()
                    - self.ln_transition_density(x, y).unwrap(),
            )
        }
    }
    fn ln_transition_density(&self, from: &Vec<f64>, to: &Vec<f64>) -> Option<f64> {
        Some(
            from.iter()
                .zip(to)
                .map(|(a, b)| {
                    let z = (b - a - self.shift) / self.sigma;
                    -0.5 * z * z - self.sigma.ln() - 0.5 * (2.0 * std::f64::consts::PI).ln()
                })
                .sum(),
        )
    }
}

/// Multiplies the state by `f = exp(σ ε)`: its ratio needs the Jacobian `f^d`. Reports it,
/// or zero when `forget_jacobian` (broken: missing Jacobian).
pub struct ScaleWalk {
    sigma: f64,
    forget_jacobian: bool,
}

impl ScaleWalk {
    pub fn new(sigma: f64, forget_jacobian: bool) -> Self {
        Self {
            sigma,
            forget_jacobian,
        }
    }
}

impl Proposal<Vec<f64>> for ScaleWalk {
    fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
        let f = (self.sigma * rng.sample::<f64, _>(StandardNormal)).exp();
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = xi * f;
        }
        // The map x -> f x has Jacobian f^d and ln f is symmetric about 0, so
        // q(x|y) / q(y|x) = f^d with respect to Lebesgue measure on R^d.
        if self.forget_jacobian {
            Proposed::SYMMETRIC
        } else {
            Proposed::with_ratio(x.len() as f64 * f.ln())
        }
    }
}

/// Two directional moves, `+|ε|` with probability 0.7 and `−|ε|` with 0.3, each reporting a zero
/// ratio because only the pair can reverse a move. With the combined rule the mixture is correct;
/// with the per-component rule it is broken.
pub fn directional_pair(scale: f64, rule: MixtureRule) -> BoxedProposal {
    Box::new(
        Mixture::new(
            vec![
                (
                    0.7,
                    Box::new(Directional {
                        sigma: scale,
                        up: true,
                    }) as BoxedProposal,
                ),
                (
                    0.3,
                    Box::new(Directional {
                        sigma: scale,
                        up: false,
                    }) as BoxedProposal,
                ),
            ],
            rule,
        )
        .unwrap(),
    )
}

pub struct Directional {
    sigma: f64,
    up: bool,
}

impl Proposal<Vec<f64>> for Directional {
    fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
        let sign = if self.up { 1.0 } else { -1.0 };
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = xi + sign * self.sigma * rng.sample::<f64, _>(StandardNormal).abs();
        }
        Proposed::SYMMETRIC // only true of the pair with equal weights
    }
    fn ln_transition_density(&self, from: &Vec<f64>, to: &Vec<f64>) -> Option<f64> {
        let sign = if self.up { 1.0 } else { -1.0 };
        let mut l = 0.0;
        for (a, b) in from.iter().zip(to) {
            let d = sign * (b - a);
            if d < 0.0 {
                return Some(f64::NEG_INFINITY);
            }
            let z = d / self.sigma;
            l += -0.5 * z * z - self.sigma.ln() + (2.0 / std::f64::consts::PI).sqrt().ln();
        }
        Some(l)
    }
}

/// Independence sampler that reports `ln q(y) − ln q(x)` (sign flipped: a wrong log ratio).
pub struct FlippedIndependence(pub GaussianDensity);

impl Proposal<Vec<f64>> for FlippedIndependence {
    fn propose(&self, x: &Vec<f64>, y: &mut Vec<f64>, rng: &mut ChainRng) -> Proposed {
        self.0.sample(rng, y);
        Proposed::with_ratio(self.0.ln_pdf(y) - self.0.ln_pdf(x))
    }
    fn ln_transition_density(&self, _from: &Vec<f64>, to: &Vec<f64>) -> Option<f64> {
        Some(self.0.ln_pdf(to))
    }
}

/// A correct kernel as a one-step closure.
pub fn stepper<T: Target<Vec<f64>> + Clone>(
    target: &T,
    proposal: BoxedProposal,
) -> impl FnMut(&mut Vec<f64>, &mut ChainRng) + use<T> {
    let t = target.clone();
    let mut k = MetropolisHastings::new(target.clone(), proposal);
    move |x, rng| mh_step(&t, &mut k, x, rng)
}
