//! Random charts of `Ω = [0,1)²` (Lebesgue measure): bijective warps, non-injective strata (the
//! layered-BSDF situation), charts with free coordinates, charts whose image misses part of `Ω`,
//! and charts whose forward map fails on part of `U`.

use mcmc_charts::Chart;
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;
use proptest::prelude::*;

pub type P2 = [f64; 2];

/// A smooth bijection of the unit square: `x0 = u0^a`, `x1 = u1^(b + c·x0)`.
#[derive(Clone, Debug)]
pub struct Warp {
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

impl Warp {
    fn e1(&self, x0: f64) -> f64 {
        self.b + self.c * x0
    }
    pub fn map(&self, u0: f64, u1: f64) -> P2 {
        let x0 = u0.powf(self.a);
        [x0, u1.powf(self.e1(x0))]
    }
    pub fn inv(&self, x: &P2) -> [f64; 2] {
        [x[0].powf(1.0 / self.a), x[1].powf(1.0 / self.e1(x[0]))]
    }
    /// `ln p(x) = −ln |∂x/∂u|`.
    pub fn ln_density(&self, x: &P2) -> f64 {
        if !inside(x) || x[0] <= 0.0 || x[1] <= 0.0 {
            return f64::NEG_INFINITY;
        }
        let e = self.e1(x[0]);
        let d0 = self.a.ln() + (self.a - 1.0) / self.a * x[0].ln();
        let d1 = e.ln() + (e - 1.0) / e * x[1].ln();
        -(d0 + d1)
    }
}

pub fn inside(x: &P2) -> bool {
    (0.0..1.0).contains(&x[0]) && (0.0..1.0).contains(&x[1])
}

pub fn warp() -> impl Strategy<Value = Warp> {
    (0.5f64..2.0, 0.6f64..1.5, -0.4f64..0.4).prop_map(|(a, b, c)| Warp { a, b, c })
}

/// `T(u) = warp(u)`.
#[derive(Clone, Debug)]
pub struct WarpChart(pub Warp);

impl Chart<P2> for WarpChart {
    fn dim(&self) -> usize {
        2
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        *x = self.0.map(u[0], u[1]);
        true
    }
    fn ln_density(&self, x: &P2) -> f64 {
        self.0.ln_density(x)
    }
    fn invert(&self, x: &P2, u: &mut [f64], _rng: &mut ChainRng) -> bool {
        u.copy_from_slice(&self.0.inv(x));
        inside(x)
    }
    fn name(&self) -> String {
        "warp".into()
    }
}

/// How a [`StrataChart`] picks a branch when inverting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Branching {
    /// In proportion to each branch's share of `p(x)` (the contract).
    Exact,
    /// Uniformly, without saying so (broken).
    UniformSilently,
    /// Uniformly, reporting the bias through `ln_inverse_bias` (valid, though not exact).
    UniformReported,
}

/// `u[0]` picks stratum `k` with probability `w_k`; `(u[1], u[2])` map through warp `k` onto the
/// whole square: non-injective, with `u[0]`'s position inside the stratum a free coordinate.
#[derive(Clone, Debug)]
pub struct StrataChart {
    pub weights: Vec<f64>,
    pub warps: Vec<Warp>,
    pub branching: Branching,
}

impl StrataChart {
    fn start(&self, k: usize) -> f64 {
        self.weights[..k].iter().sum()
    }
    fn shares(&self, x: &P2) -> Vec<f64> {
        self.weights
            .iter()
            .zip(&self.warps)
            .map(|(w, m)| w * m.ln_density(x).exp())
            .collect()
    }
    fn branch_of(&self, u0: f64) -> usize {
        let mut acc = 0.0;
        for (k, w) in self.weights.iter().enumerate() {
            acc += w;
            if u0 < acc {
                return k;
            }
        }
        self.weights.len() - 1
    }
}

impl Chart<P2> for StrataChart {
    fn dim(&self) -> usize {
        3
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        *x = self.warps[self.branch_of(u[0])].map(u[1], u[2]);
        true
    }
    fn ln_density(&self, x: &P2) -> f64 {
        self.shares(x).iter().sum::<f64>().ln()
    }
    fn invert(&self, x: &P2, u: &mut [f64], rng: &mut ChainRng) -> bool {
        if !inside(x) {
            return false;
        }
        let s = self.shares(x);
        let n = s.len();
        let k = match self.branching {
            Branching::Exact => {
                let mut t = uniform(rng) * s.iter().sum::<f64>();
                let mut k = n - 1;
                for (i, v) in s.iter().enumerate() {
                    if t < *v {
                        k = i;
                        break;
                    }
                    t -= v;
                }
                k
            }
            _ => ((uniform(rng) * n as f64) as usize).min(n - 1),
        };
        u[0] = self.start(k) + self.weights[k] * uniform(rng);
        let v = self.warps[k].inv(x);
        u[1] = v[0];
        u[2] = v[1];
        true
    }
    fn ln_inverse_bias(&self, x: &P2, u: &[f64]) -> f64 {
        if self.branching != Branching::UniformReported {
            return 0.0;
        }
        let s = self.shares(x);
        let k = self.branch_of(u[0]);
        (1.0 / s.len() as f64).ln() - (s[k] / s.iter().sum::<f64>()).ln()
    }
    fn name(&self) -> String {
        format!("strata({:?})", self.branching)
    }
}

/// A warp of `(u[0], u[1])` that ignores `u[2]`: the inverse fills it uniformly.
#[derive(Clone, Debug)]
pub struct FreeChart(pub Warp);

impl Chart<P2> for FreeChart {
    fn dim(&self) -> usize {
        3
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        *x = self.0.map(u[0], u[1]);
        true
    }
    fn ln_density(&self, x: &P2) -> f64 {
        self.0.ln_density(x)
    }
    fn invert(&self, x: &P2, u: &mut [f64], rng: &mut ChainRng) -> bool {
        let v = self.0.inv(x);
        u[0] = v[0];
        u[1] = v[1];
        u[2] = uniform(rng);
        inside(x)
    }
    fn name(&self) -> String {
        "free coordinate".into()
    }
}

/// Maps onto `[0, s) × [0, 1)` only: its image misses part of `Ω`.
#[derive(Clone, Debug)]
pub struct PartialChart {
    pub warp: Warp,
    pub s: f64,
}

impl Chart<P2> for PartialChart {
    fn dim(&self) -> usize {
        2
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        let w = self.warp.map(u[0], u[1]);
        *x = [self.s * w[0], w[1]];
        true
    }
    fn ln_density(&self, x: &P2) -> f64 {
        if x[0] >= self.s {
            return f64::NEG_INFINITY;
        }
        self.warp.ln_density(&[x[0] / self.s, x[1]]) - self.s.ln()
    }
    fn invert(&self, x: &P2, u: &mut [f64], _rng: &mut ChainRng) -> bool {
        if !inside(x) || x[0] >= self.s {
            return false;
        }
        u.copy_from_slice(&self.warp.inv(&[x[0] / self.s, x[1]]));
        true
    }
    fn name(&self) -> String {
        "partial image".into()
    }
}

/// Fails (no point) when `u[1] > cut`, like a ray that misses the scene.
#[derive(Clone, Debug)]
pub struct FailingChart {
    pub warp: Warp,
    pub cut: f64,
}

impl Chart<P2> for FailingChart {
    fn dim(&self) -> usize {
        2
    }
    fn forward(&self, u: &[f64], x: &mut P2) -> bool {
        *x = self.warp.map(u[0], u[1]);
        u[1] <= self.cut
    }
    fn ln_density(&self, x: &P2) -> f64 {
        if !inside(x) || self.warp.inv(x)[1] > self.cut {
            return f64::NEG_INFINITY;
        }
        self.warp.ln_density(x)
    }
    fn invert(&self, x: &P2, u: &mut [f64], _rng: &mut ChainRng) -> bool {
        let v = self.warp.inv(x);
        u.copy_from_slice(&v);
        inside(x) && v[1] <= self.cut
    }
    fn name(&self) -> String {
        "failing forward".into()
    }
}

/// One chart of each kind, with random parameters.
#[derive(Clone, Debug)]
pub enum AnyChart {
    Warp(WarpChart),
    Strata(StrataChart),
    Free(FreeChart),
    Partial(PartialChart),
    Failing(FailingChart),
}

impl AnyChart {
    pub fn boxed(&self) -> Box<dyn Chart<P2>> {
        match self {
            AnyChart::Warp(c) => Box::new(c.clone()),
            AnyChart::Strata(c) => Box::new(c.clone()),
            AnyChart::Free(c) => Box::new(c.clone()),
            AnyChart::Partial(c) => Box::new(c.clone()),
            AnyChart::Failing(c) => Box::new(c.clone()),
        }
    }
}

pub fn strata(branching: Branching) -> impl Strategy<Value = StrataChart> {
    (2usize..=3).prop_flat_map(move |k| {
        (
            prop::collection::vec(0.2f64..1.0, k),
            prop::collection::vec(warp(), k),
        )
            .prop_map(move |(w, warps)| {
                let t: f64 = w.iter().sum();
                StrataChart {
                    weights: w.iter().map(|v| v / t).collect(),
                    warps,
                    branching,
                }
            })
    })
}

pub fn any_chart() -> impl Strategy<Value = AnyChart> {
    prop_oneof![
        warp().prop_map(|w| AnyChart::Warp(WarpChart(w))),
        strata(Branching::Exact).prop_map(AnyChart::Strata),
        warp().prop_map(|w| AnyChart::Free(FreeChart(w))),
        (warp(), 0.5f64..0.9).prop_map(|(warp, s)| AnyChart::Partial(PartialChart { warp, s })),
        (warp(), 0.6f64..0.95)
            .prop_map(|(warp, cut)| AnyChart::Failing(FailingChart { warp, cut })),
    ]
}

/// A piecewise-constant target on `[0,1)²` with `b × b` cells.
#[derive(Clone, Debug)]
pub struct Cells {
    pub b: usize,
    pub w: Vec<f64>,
}

impl Cells {
    pub fn value(&self, x: &P2) -> f64 {
        if !inside(x) {
            return 0.0;
        }
        let i = ((x[0] * self.b as f64) as usize).min(self.b - 1);
        let j = ((x[1] * self.b as f64) as usize).min(self.b - 1);
        self.w[i * self.b + j]
    }
    pub fn sample(&self, rng: &mut ChainRng) -> P2 {
        let t: f64 = self.w.iter().sum();
        let mut r = uniform(rng) * t;
        let mut c = self.w.len() - 1;
        for (i, v) in self.w.iter().enumerate() {
            if r < *v {
                c = i;
                break;
            }
            r -= v;
        }
        let (i, j) = (c / self.b, c % self.b);
        [
            (i as f64 + uniform(rng)) / self.b as f64,
            (j as f64 + uniform(rng)) / self.b as f64,
        ]
    }
}

pub fn cells() -> impl Strategy<Value = Cells> {
    (2usize..=3).prop_flat_map(|b| {
        prop::collection::vec(0.2f64..4.0, b * b).prop_map(move |w| Cells { b, w })
    })
}
