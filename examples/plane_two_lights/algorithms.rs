//! The six algorithms of the paper's Table 1, each built from `mcmc-charts` and `mcmc-core`.
//!
//! Samples: `n` counts primary-space (or target-space) perturbation steps in total; chart swaps are
//! extra (they evaluate no integrand). Every chain uses the PSSMLT kernel — Kelemen's small step
//! (`s1 = 1/1024`, `s2 = 1/64`) with probability 0.7, a large step with probability 0.3 — and records
//! the expected value of every proposal (current weighted `1 − a`, candidate `a`).
//!
//! Normalisation: one shared bootstrap estimates `b = ∫ f*` and the per-chart masses
//! `b_i = ∫ w_i f*` of the weighted targets with the balance heuristic over both charts; chains
//! start from a state drawn from a bootstrap population of their own target by resampling.

use super::charts::{Cosine, NextEvent};
use super::image::{Image, SIZE};
use super::scene::{Path, importance};
use mcmc_charts::moves::{InChart, InversePerturbation};
use mcmc_charts::{Atlas, ChartState, ChartedTarget, TargetKind};
use mcmc_core::population::systematic_resample;
use mcmc_core::proposals::{CubeWalk, Independence, Mixture, MixtureRule, SmallStep, UniformCube};
use mcmc_core::rng::uniform;
use mcmc_core::tempering::{
    LevelObserver, LevelProposal, ReplicaExchange, SerialTempering, SwapSchedule,
};
use mcmc_core::{Chain, ChainRng, Family, Kernel, Level, MetropolisHastings, Observer};

pub type State = ChartState<Path>;
type Importance = fn(&Path) -> f64;
pub type Target<'a> = ChartedTarget<'a, Path, Importance>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    Pssmlt1,
    Pssmlt2,
    PssmltAvg,
    PssmltMix,
    CmltIpsm,
    Cmlt,
    /// Not in the paper's table: one chain over (chart, u) with chart swaps by serial tempering
    /// (equal pseudo-priors), so time is split between the charts in proportion to their energy
    /// instead of evenly.
    CmltSt,
    /// CMLT whose chart swaps forget the chart densities `p_j/p_i` (deliberately broken). Its
    /// image stays nearly unbiased: accepting every swap makes both chains sample about the same
    /// mixture, and the recording weights `b_i` of the two chains sum to `∫ f*`; the per-chart
    /// marginals are wrong, which the balance tests of `mcmc-charts` catch.
    CmltBrokenSwap,
    /// CMLT-IPSM whose perturbations forget the `p_i(x)/p_i(y)` factor (deliberately broken: a
    /// test of the convergence test).
    CmltIpsmBroken,
}

impl Algorithm {
    /// The six algorithms of the paper's Table 1.
    pub const ALL: [Algorithm; 6] = [
        Algorithm::Pssmlt1,
        Algorithm::Pssmlt2,
        Algorithm::PssmltAvg,
        Algorithm::PssmltMix,
        Algorithm::CmltIpsm,
        Algorithm::Cmlt,
    ];
    /// The paper's six and the serial-tempering variant.
    pub const WITH_ST: [Algorithm; 7] = [
        Algorithm::Pssmlt1,
        Algorithm::Pssmlt2,
        Algorithm::PssmltAvg,
        Algorithm::PssmltMix,
        Algorithm::CmltIpsm,
        Algorithm::Cmlt,
        Algorithm::CmltSt,
    ];
    pub fn name(&self) -> &'static str {
        match self {
            Algorithm::Pssmlt1 => "PSSMLT-1",
            Algorithm::Pssmlt2 => "PSSMLT-2",
            Algorithm::PssmltAvg => "PSSMLT-AVG",
            Algorithm::PssmltMix => "PSSMLT-MIX",
            Algorithm::CmltIpsm => "CMLT-IPSM",
            Algorithm::Cmlt => "CMLT",
            Algorithm::CmltSt => "CMLT-ST",
            Algorithm::CmltBrokenSwap => "CMLT-BROKEN-SWAP",
            Algorithm::CmltIpsmBroken => "CMLT-IPSM-BROKEN",
        }
    }
}

/// Both charts, with and without the identity chart.
pub fn atlas(identity: bool) -> Atlas<Path> {
    let a = Atlas::new(vec![Box::new(NextEvent::new()), Box::new(Cosine)]);
    if identity { a.with_identity() } else { a }
}

fn pssmlt_kernel() -> Mixture<'static, Vec<f64>> {
    Mixture::new(
        vec![
            (
                0.7,
                Box::new(CubeWalk::new(SmallStep::default()).expect("valid step")) as _,
            ),
            (0.3, Box::new(Independence::new(UniformCube)) as _),
        ],
        MixtureRule::PerComponent,
    )
    .expect("valid mixture")
}

/// Normalisation constants from a shared bootstrap.
#[derive(Clone, Copy, Debug)]
pub struct Normalisation {
    /// `∫ f*`.
    pub b: f64,
    /// `∫ w_i f*` for the two charts.
    pub b_chart: [f64; 2],
    /// Relative standard error of `b`.
    pub rel_se: f64,
}

/// Estimate the normalisation with `n` samples of each chart, combined by the balance heuristic.
pub fn bootstrap(n: usize, rng: &mut ChainRng) -> Normalisation {
    let atlas = atlas(false);
    let mut x = Path::default();
    let (mut s, mut s2, mut sa) = (0.0, 0.0, [0.0; 2]);
    for _ in 0..n {
        let mut term = 0.0;
        let mut terms = [0.0; 2];
        for k in 0..2 {
            let u: Vec<f64> = (0..4).map(|_| uniform(rng)).collect();
            let chart = atlas.chart(k).expect("two charts");
            if !chart.forward(&u, &mut x) {
                continue;
            }
            let f = importance(&x);
            if f == 0.0 {
                continue;
            }
            let p = [atlas.ln_density(0, &x).exp(), atlas.ln_density(1, &x).exp()];
            let tot = p[0] + p[1];
            term += f / tot;
            for i in 0..2 {
                terms[i] += f * p[i] / tot / tot;
            }
        }
        s += term;
        s2 += term * term;
        sa[0] += terms[0];
        sa[1] += terms[1];
    }
    let nf = n as f64;
    let b = s / nf;
    Normalisation {
        b,
        b_chart: [sa[0] / nf, sa[1] / nf],
        rel_se: ((s2 / nf - b * b) / nf).sqrt() / b,
    }
}

/// Records the expected value of every proposal into an image, scaled by `scale` and weighted by
/// `weight(state)` (the balance weight for PSSMLT-AVG, 1 otherwise).
pub struct Recorder<'a> {
    pub image: Image,
    pub scale: [f64; 2],
    pub weight: Option<&'a Atlas<Path>>,
    pub chart: usize,
}

impl<'a> Recorder<'a> {
    fn new(scale: [f64; 2], weight: Option<&'a Atlas<Path>>, chart: usize) -> Self {
        Self {
            image: Image::new(),
            scale,
            weight,
            chart,
        }
    }

    fn record(&mut self, level: usize, s: &State, a: f64) {
        if a <= 0.0 || !s.valid || s.importance <= 0.0 {
            return;
        }
        let f = s.x.contribution();
        let mut w = a * self.scale[level] / s.importance;
        if let Some(atlas) = self.weight {
            let p = [
                atlas.ln_density(0, &s.x).exp(),
                atlas.ln_density(1, &s.x).exp(),
            ];
            w *= p[self.chart] / (p[0] + p[1]);
        }
        // Pixel values are averages over the pixel's footprint: divide by its area 1/SIZE².
        self.image.add(&s.x.g, f, w * (SIZE * SIZE) as f64);
    }
}

impl Observer<State> for Recorder<'_> {
    fn observe(&mut self, current: &State, proposed: &State, a: f64, _kind: usize) {
        self.record(0, current, 1.0 - a);
        self.record(0, proposed, a);
    }
}

impl LevelObserver<State> for Recorder<'_> {
    fn observe(&mut self, level: usize, current: &State, proposed: &State, a: f64, _kind: usize) {
        self.record(level, current, 1.0 - a);
        self.record(level, proposed, a);
    }
}

/// A starting state for a chain at `level` of `target`, drawn from `m` bootstrap samples of that
/// level by resampling in proportion to the target (no start-up bias for one chain in expectation).
fn seed_state(target: &Target, level: usize, m: usize, rng: &mut ChainRng) -> State {
    let atlas = target.atlas;
    let mut pop = Vec::with_capacity(m);
    let mut w = Vec::with_capacity(m);
    for _ in 0..m {
        let mut s = if level == atlas.identity() {
            // Target space: draw a path from chart (1,1) and weight by 1/p.
            let u: Vec<f64> = (0..4).map(|_| uniform(rng)).collect();
            let mut x = Path::default();
            atlas.chart(0).expect("chart").forward(&u, &mut x);
            let mut s = State::at_point(atlas, x);
            let l = target.ln_density(level, &mut s) - atlas.ln_density(0, &s.x);
            w.push(if l.is_finite() { l.exp() } else { 0.0 });
            s
        } else {
            let mut s = State::in_chart(level, (0..4).map(|_| uniform(rng)).collect());
            let l = target.ln_density(level, &mut s);
            w.push(if l.is_finite() { l.exp() } else { 0.0 });
            s
        };
        s.fresh = true;
        pop.push(s);
    }
    let pick = systematic_resample(&w, 1, rng).expect("the bootstrap found light");
    pop.swap_remove(pick[0])
}

/// Result of one run.
pub struct Run {
    pub image: Image,
    /// Acceptance of perturbations, and of chart swaps where there are any.
    pub acceptance: f64,
    pub swap_acceptance: Option<f64>,
}

/// One chain of `steps` perturbations in `level` of `target`, recorded with `scale`.
fn single_chain(
    target: &Target,
    level: usize,
    steps: usize,
    recorder: &mut Recorder,
    rng: &mut ChainRng,
) -> f64 {
    let s = seed_state(target, level, 100_000, rng);
    let mut chain = Chain::start(
        &Level {
            family: target,
            level,
        },
        s,
    )
    .expect("seed has positive density");
    let mut mh = MetropolisHastings::new(
        Level {
            family: target,
            level,
        },
        InChart::new(pssmlt_kernel()),
    );
    for _ in 0..steps {
        mh.step(&mut chain, rng, recorder);
    }
    chain.stats.total().acceptance_rate()
}

pub fn run(alg: Algorithm, n: usize, norm: &Normalisation, rng: &mut ChainRng) -> Run {
    let plain = atlas(false);
    let with_id = atlas(true);
    let is = ChartedTarget::new(
        &plain,
        importance as Importance,
        TargetKind::ImportanceSampled,
    );
    let weighted = ChartedTarget::new(&plain, importance as Importance, TargetKind::Weighted);
    match alg {
        Algorithm::Pssmlt1 | Algorithm::Pssmlt2 => {
            let k = (alg == Algorithm::Pssmlt2) as usize;
            let mut r = Recorder::new([norm.b / n as f64; 2], None, k);
            let acc = single_chain(&is, k, n, &mut r, rng);
            Run {
                image: r.image,
                acceptance: acc,
                swap_acceptance: None,
            }
        }
        Algorithm::PssmltAvg | Algorithm::PssmltMix => {
            let mut image = Image::new();
            let mut acc = 0.0;
            for k in 0..2 {
                let (target, scale, weight) = if alg == Algorithm::PssmltAvg {
                    (&is, norm.b, Some(&plain))
                } else {
                    (&weighted, norm.b_chart[k], None)
                };
                let mut r = Recorder::new([scale / (n / 2) as f64; 2], weight, k);
                acc += 0.5 * single_chain(target, k, n / 2, &mut r, rng);
                image.add_image(&r.image);
            }
            Run {
                image,
                acceptance: acc,
                swap_acceptance: None,
            }
        }
        Algorithm::CmltIpsm | Algorithm::CmltIpsmBroken => {
            let target = ChartedTarget::new(
                &with_id,
                importance as Importance,
                TargetKind::ImportanceSampled,
            );
            let id = with_id.identity();
            let s = seed_state(&target, id, 100_000, rng);
            let mut chain = Chain::start(
                &Level {
                    family: &target,
                    level: id,
                },
                s,
            )
            .expect("seed");
            let mut through = [0, 1].map(|k| {
                let mut p = InversePerturbation::new(&target, k, pssmlt_kernel());
                p.forget_density_ratio = alg == Algorithm::CmltIpsmBroken;
                MetropolisHastings::new(
                    Level {
                        family: &target,
                        level: id,
                    },
                    p,
                )
            });
            let mut r = Recorder::new([norm.b / n as f64; 2], None, 0);
            for i in 0..n {
                through[i % 2].step(&mut chain, rng, &mut r);
            }
            Run {
                image: r.image,
                acceptance: chain.stats.total().acceptance_rate(),
                swap_acceptance: None,
            }
        }
        Algorithm::CmltSt => {
            // Start in a chart chosen in proportion to its energy.
            let k = (uniform(rng) * norm.b > norm.b_chart[0]) as usize;
            let init = seed_state(&weighted, k, 100_000, rng);
            let kernels: Vec<_> = (0..2)
                .map(|k| {
                    MetropolisHastings::new(
                        Level {
                            family: &weighted,
                            level: k,
                        },
                        InChart::new(pssmlt_kernel()),
                    )
                })
                .collect();
            let mut st = SerialTempering::new(
                &weighted,
                kernels,
                init,
                k,
                None,
                LevelProposal::Independent(vec![0.5, 0.5]),
            )
            .expect("two charts");
            st.local_steps = 4;
            // The joint target Σ_i π̄_i = f: every step records with the full normalisation.
            let mut r = Recorder::new([norm.b / n as f64; 2], None, 0);
            for _ in 0..n / 4 {
                st.step(rng, &mut r);
            }
            let moves: (u64, u64) = st
                .level_moves
                .iter()
                .fold((0, 0), |a, m| (a.0 + m.attempted, a.1 + m.accepted));
            Run {
                image: r.image,
                acceptance: st.chain.stats.total().acceptance_rate(),
                swap_acceptance: Some(moves.1 as f64 / moves.0 as f64),
            }
        }
        Algorithm::Cmlt | Algorithm::CmltBrokenSwap => {
            let init = vec![
                seed_state(&weighted, 0, 100_000, rng),
                seed_state(&weighted, 1, 100_000, rng),
            ];
            let kernels: Vec<_> = (0..2)
                .map(|k| {
                    MetropolisHastings::new(
                        Level {
                            family: &weighted,
                            level: k,
                        },
                        InChart::new(pssmlt_kernel()),
                    )
                })
                .collect();
            let family = SwapFamily {
                target: &weighted,
                forget_densities: alg == Algorithm::CmltBrokenSwap,
            };
            let mut re =
                ReplicaExchange::new(&family, kernels, init, SwapSchedule::StochasticEvenOdd)
                    .expect("two chains");
            re.local_steps = 4;
            let mut r = Recorder::new(
                [
                    norm.b_chart[0] / (n / 2) as f64,
                    norm.b_chart[1] / (n / 2) as f64,
                ],
                None,
                0,
            );
            for _ in 0..n / 8 {
                re.sweep(rng, &mut r);
            }
            let acc = 0.5
                * re.chains
                    .iter()
                    .map(|c| c.stats.total().acceptance_rate())
                    .sum::<f64>();
            Run {
                image: r.image,
                acceptance: acc,
                swap_acceptance: Some(re.swaps[0].rate()),
            }
        }
    }
}

/// The weighted targets, optionally with chart swaps that forget the Green ratio `ln p_j − ln p_i`.
struct SwapFamily<'a> {
    target: &'a Target<'a>,
    forget_densities: bool,
}

impl Family<State> for SwapFamily<'_> {
    fn levels(&self) -> usize {
        self.target.levels()
    }
    fn ln_density(&self, level: usize, x: &mut State) -> f64 {
        self.target.ln_density(level, x)
    }
    fn transfer(
        &self,
        from: usize,
        to: usize,
        x: &State,
        y: &mut State,
        rng: &mut ChainRng,
    ) -> f64 {
        let g = self.target.transfer(from, to, x, y, rng);
        if self.forget_densities && g.is_finite() {
            0.0
        } else {
            g
        }
    }
}

/// A plain Monte Carlo reference, independent of the charts' code: per pixel, `spp` stratified
/// ground points; for light 1, one emission-sampled and one cosine-sampled point combined by the
/// balance heuristic; for light 2, one point uniform in the square seen through the hole (which
/// covers everything of light 2 that is visible). Returns the image, the RMS of the per-pixel
/// standard errors, and each pixel's variance of the mean of the channel sum.
pub fn reference(spp: usize, seed: u64) -> (Image, f64, Vec<f64>) {
    use super::scene::{RATE, visible_square};
    use rayon::prelude::*;
    use std::f64::consts::PI;
    let pdf_emission = |x: f64| RATE * (RATE * x).exp() / (RATE.exp() - 1.0);
    let pdf_cosine = |p: &Path| {
        let (r2, cg, cl) = p.geometry();
        if cg <= 0.0 || cl <= 0.0 {
            0.0
        } else {
            cg / PI * cl / r2
        }
    };
    let rows: Vec<(Vec<[f64; 3]>, f64, Vec<f64>)> = (0..SIZE)
        .into_par_iter()
        .map(|row| {
            let mut rng = mcmc_core::rng::substream(seed, 7, row as u64);
            let mut out = Vec::with_capacity(SIZE);
            let mut var_sum = 0.0;
            let mut var_total = Vec::with_capacity(SIZE);
            for col in 0..SIZE {
                let (mut s, mut s2, mut t2) = ([0.0; 3], [0.0; 3], 0.0);
                for _ in 0..spp {
                    let g = [
                        (col as f64 + uniform(&mut rng)) / SIZE as f64,
                        ((SIZE - 1 - row) as f64 + uniform(&mut rng)) / SIZE as f64,
                    ];
                    let mut est = [0.0; 3];
                    let mut add = |f: [f64; 3], w: f64| {
                        for c in 0..3 {
                            est[c] += f[c] * w;
                        }
                    };
                    // Light 1 by emission sampling.
                    let v = uniform(&mut rng);
                    let x1 = Path {
                        g,
                        light: 1,
                        l: [
                            (1.0 + v * (RATE.exp() - 1.0)).ln() / RATE,
                            uniform(&mut rng),
                        ],
                    };
                    let pe = pdf_emission(x1.l[0]);
                    add(x1.contribution(), 1.0 / (pe + pdf_cosine(&x1)));
                    // Light 1 by cosine sampling (hits of light 2 are left to the next strategy).
                    let (phi, u) = (2.0 * PI * uniform(&mut rng), uniform(&mut rng));
                    let d = [
                        (1.0 - u).sqrt() * phi.cos(),
                        (1.0 - u).sqrt() * phi.sin(),
                        u.sqrt(),
                    ];
                    if d[1] < 0.0 {
                        let t = -g[1] / d[1];
                        let x2 = Path {
                            g,
                            light: 1,
                            l: [g[0] + t * d[0], t * d[2]],
                        };
                        if (0.0..1.0).contains(&x2.l[0]) && (0.0..1.0).contains(&x2.l[1]) {
                            add(
                                x2.contribution(),
                                1.0 / (pdf_emission(x2.l[0]) + pdf_cosine(&x2)),
                            );
                        }
                    }
                    // Light 2 through the hole.
                    let (c, h) = visible_square(&g);
                    let x3 = Path {
                        g,
                        light: 2,
                        l: [
                            c[0] + h * (2.0 * uniform(&mut rng) - 1.0),
                            c[1] + h * (2.0 * uniform(&mut rng) - 1.0),
                        ],
                    };
                    add(x3.contribution(), 4.0 * h * h);
                    for c in 0..3 {
                        s[c] += est[c];
                        s2[c] += est[c] * est[c];
                    }
                    let t = est[0] + est[1] + est[2];
                    t2 += t * t;
                }
                let nf = spp as f64;
                let mean = s.map(|v| v / nf);
                for c in 0..3 {
                    var_sum += (s2[c] / nf - mean[c] * mean[c]).max(0.0) / nf;
                }
                let total = mean[0] + mean[1] + mean[2];
                var_total.push((t2 / nf - total * total).max(0.0) / nf);
                out.push(mean);
            }
            (out, var_sum, var_total)
        })
        .collect();
    let mut img = Image::new();
    let mut var = 0.0;
    let mut var_total = Vec::with_capacity(SIZE * SIZE);
    for (row, (vals, v, vt)) in rows.into_iter().enumerate() {
        img.data[row * SIZE..(row + 1) * SIZE].copy_from_slice(&vals);
        var += v;
        var_total.extend(vt);
    }
    (img, (var / (SIZE * SIZE * 3) as f64).sqrt(), var_total)
}
