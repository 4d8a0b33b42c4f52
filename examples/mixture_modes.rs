//! Well-separated modes: plain Metropolis–Hastings against replica exchange (both swap schedules)
//! and serial tempering, at an equal number of target evaluations.
//!
//! The target is a mixture of four Gaussians (σ = 0.5) at (±4, ±4) with weights 0.4, 0.3, 0.2, 0.1.
//! Between two modes the density drops by e^-32, so a random walk of scale 0.5 never leaves the mode
//! it first finds. The tempered methods run the same walk, scaled by 1/√β, on a geometric ladder of
//! six inverse temperatures down to β = 0.02, where the modes merge.
//!
//! Every method runs four independent chains (streams 0–3 of one master seed, started uniformly in
//! [-6, 6]²), each with the same budget of target evaluations, the first 20% of which are warm-up
//! and discarded (serial tempering adapts its level weights during that warm-up, then freezes them).
//! Swap attempts and level moves evaluate the target too and count against the budget. Level-0
//! draws are recorded (replica exchange: the state at level 0 after every sweep; serial tempering:
//! the state after every step spent at level 0). ESS and R-hat are rank-normalised bulk ESS and
//! split R-hat over the four chains; "time" is the sampling time summed over the chains. One PNG
//! per method goes to `out/` (histogram left, exact density right).
//!
//! Run with `cargo run --release --example mixture_modes` (add `-- --quick` for a short run).

#[path = "support/mod.rs"]
mod support;

use std::cell::Cell;
use std::error::Error;
use std::time::Instant;

use mcmc_core::diagnostics::{ess_bulk, split_rhat};
use mcmc_core::proposals::GaussianRandomWalk;
use mcmc_core::rng::uniform;
use mcmc_core::tempering::{
    Adaptation, LevelProposal, PairStats, ReplicaExchange, SerialTempering, SwapSchedule,
};
use mcmc_core::{
    Chain, ChainRng, Ensemble, Kernel, Level, McmcError, MetropolisHastings, Target, Tempered,
};
use support::{Grid, write_heatmaps};

type State = [f64; 2];

/// Mode centres and weights.
const MODES: [(State, f64); 4] = [
    ([4.0, 4.0], 0.4),
    ([-4.0, 4.0], 0.3),
    ([-4.0, -4.0], 0.2),
    ([4.0, -4.0], 0.1),
];
const SIGMA: f64 = 0.5;
/// Random-walk scale at β = 1 (scaled by 1/√β on the other levels).
const WALK: f64 = 0.5;
const LEVELS: usize = 6;
const BETA_MIN: f64 = 0.02;
const CHAINS: usize = 4;
const SEED: u64 = 7;
const WARMUP_FRACTION: f64 = 0.2;

/// The normalised mixture density `ln Σ w_i N(x; μ_i, σ² I)`, computed stably.
fn ln_mixture(x: &State) -> f64 {
    let norm = (2.0 * std::f64::consts::PI * SIGMA * SIGMA).ln();
    let terms = MODES.map(|(m, w)| {
        let r2 = (x[0] - m[0]).powi(2) + (x[1] - m[1]).powi(2);
        w.ln() - r2 / (2.0 * SIGMA * SIGMA) - norm
    });
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
}

/// The mode a point belongs to (its quadrant).
fn mode_of(x: f64, y: f64) -> usize {
    MODES
        .iter()
        .position(|(m, _)| (m[0] > 0.0) == (x > 0.0) && (m[1] > 0.0) == (y > 0.0))
        .expect("the modes cover the four quadrants")
}

#[derive(Clone, Copy, Debug)]
enum Method {
    Plain,
    Replica(SwapSchedule),
    Serial,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Plain => "plain MH",
            Method::Replica(SwapSchedule::StochasticEvenOdd) => "RE stochastic",
            Method::Replica(SwapSchedule::DeterministicEvenOdd) => "RE deterministic",
            Method::Serial => "serial tempering",
        }
    }

    fn file(self) -> &'static str {
        match self {
            Method::Plain => "mixture_plain_mh.png",
            Method::Replica(SwapSchedule::StochasticEvenOdd) => "mixture_re_stochastic.png",
            Method::Replica(SwapSchedule::DeterministicEvenOdd) => "mixture_re_deterministic.png",
            Method::Serial => "mixture_serial_tempering.png",
        }
    }
}

/// What one chain of one method produced.
#[derive(Default)]
struct Run {
    xs: Vec<f64>,
    ys: Vec<f64>,
    /// MH steps, RE sweeps or ST steps.
    steps: u64,
    evaluations: u64,
    seconds: f64,
    round_trips: u64,
    swaps: Vec<PairStats>,
    time_per_level: Vec<f64>,
    ln_weights: Vec<f64>,
}

impl Run {
    fn record(&mut self, x: &State) {
        self.xs.push(x[0]);
        self.ys.push(x[1]);
    }
}

/// One local random-walk kernel per level of a tempered family.
#[allow(clippy::type_complexity)]
fn local_kernels<T: Target<State>>(
    family: &Tempered<T>,
) -> Result<Vec<MetropolisHastings<Level<'_, Tempered<T>>, GaussianRandomWalk>>, McmcError> {
    (0..family.betas.len())
        .map(|level| {
            let walk = GaussianRandomWalk::new(WALK / family.betas[level].sqrt())?;
            Ok(MetropolisHastings::new(Level { family, level }, walk))
        })
        .collect()
}

/// Run one chain of `method` until it has spent `budget` target evaluations.
fn run(method: Method, budget: u64, rng: &mut ChainRng) -> Result<Run, McmcError> {
    let evaluations = Cell::new(0u64);
    let target = |x: &State| {
        evaluations.set(evaluations.get() + 1);
        ln_mixture(x)
    };
    let warmup = (WARMUP_FRACTION * budget as f64) as u64;
    let x0 = [12.0 * uniform(rng) - 6.0, 12.0 * uniform(rng) - 6.0];
    let mut out = Run::default();
    let start = Instant::now();
    match method {
        Method::Plain => {
            let mut mh = MetropolisHastings::new(&target, GaussianRandomWalk::new(WALK)?);
            let mut chain = Chain::start(&target, x0)?;
            while evaluations.get() < budget {
                mh.step(&mut chain, rng, &mut ());
                out.steps += 1;
                if evaluations.get() > warmup {
                    out.record(&chain.state);
                }
            }
        }
        Method::Replica(schedule) => {
            let family = Tempered::geometric(&target, LEVELS, BETA_MIN)?;
            let kernels = local_kernels(&family)?;
            let mut re = ReplicaExchange::new(&family, kernels, vec![x0; LEVELS], schedule)?;
            while evaluations.get() < budget {
                re.sweep(rng, &mut ());
                out.steps += 1;
                if evaluations.get() > warmup {
                    out.record(&re.chains[0].state);
                }
            }
            out.round_trips = re.round_trips.total();
            out.swaps = re.swaps.clone();
        }
        Method::Serial => {
            let family = Tempered::geometric(&target, LEVELS, BETA_MIN)?;
            let kernels = local_kernels(&family)?;
            let mut st =
                SerialTempering::new(&family, kernels, x0, 0, None, LevelProposal::Neighbour)?;
            // A step costs one local evaluation plus one for the level move, except for the 1/K of
            // level proposals that fall off the ladder: 2 − 1/K evaluations on average.
            let per_step = 2.0 - 1.0 / LEVELS as f64;
            // A short full-gain phase, then gain 100/t: large enough to move the weights from zero to
            // their targets, small enough at the end that the frozen weights are accurate.
            st.adaptation = Some(Adaptation {
                gamma0: 1.0,
                t0: 100.0,
                warmup: (warmup as f64 / per_step) as u64,
            });
            while evaluations.get() < budget {
                st.step(rng, &mut ());
                out.steps += 1;
                if !st.warming_up() && st.level == 0 {
                    out.record(&st.chain.state);
                }
            }
            out.round_trips = st.round_trips.total();
            out.time_per_level = st.time_per_level();
            out.ln_weights = st.ln_weights.iter().map(|w| w - st.ln_weights[0]).collect();
        }
    }
    out.seconds = start.elapsed().as_secs_f64();
    out.evaluations = evaluations.get();
    Ok(out)
}

/// `ln Z_β = ln ∫ π(x)^β dx` of the normalised mixture by the midpoint rule, on a box and grid
/// scaled to the tempered width `σ/√β` (accurate to many digits for these smooth Gaussians).
fn ln_partition(beta: f64) -> f64 {
    let width = SIGMA / beta.sqrt();
    let half = 4.0 + 12.0 * width;
    let h = width / 20.0;
    let n = (2.0 * half / h).ceil() as usize;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = [-half + (i as f64 + 0.5) * h, -half + (j as f64 + 0.5) * h];
            sum += (beta * ln_mixture(&x)).exp();
        }
    }
    (sum * h * h).ln()
}

/// Sum the per-chain vectors of `f` element-wise and divide by the number of chains.
fn mean_over(runs: &[Run], f: impl Fn(&Run) -> &[f64]) -> Vec<f64> {
    let mut m = vec![0.0; f(&runs[0]).len()];
    for r in runs {
        m.iter_mut().zip(f(r)).for_each(|(a, b)| *a += b);
    }
    m.iter().map(|v| v / runs.len() as f64).collect()
}

fn fmt_list(v: &[f64], digits: usize) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:.digits$}")).collect();
    items.join(" ")
}

fn main() -> Result<(), Box<dyn Error>> {
    let quick = support::quick_flag()?;
    let budget: u64 = if quick { 200_000 } else { 2_000_000 };
    let methods = [
        Method::Plain,
        Method::Replica(SwapSchedule::StochasticEvenOdd),
        Method::Replica(SwapSchedule::DeterministicEvenOdd),
        Method::Serial,
    ];
    println!(
        "4-mode Gaussian mixture; {CHAINS} chains per method, {budget} target evaluations each \
         ({:.0}% warm-up); ladder of {LEVELS} levels, β_min = {BETA_MIN}\n",
        100.0 * WARMUP_FRACTION
    );

    let ensemble = Ensemble::new(CHAINS, SEED);
    let mut results = Vec::new();
    for method in methods {
        let runs = ensemble
            .run(|_, rng| run(method, budget, rng))
            .into_iter()
            .collect::<Result<Vec<_>, _>>()?;
        results.push((method, runs));
    }

    println!(
        "{:<17} {:>9} {:>9} {:>9} {:>8} {:>7} {:>7} {:>7} {:>6} {:>6}",
        "method", "evals", "steps", "draws", "time[s]", "ESS x", "ESS y", "ESS/s", "R-hat", "trips"
    );
    for (method, runs) in &results {
        let xs: Vec<&[f64]> = runs.iter().map(|r| r.xs.as_slice()).collect();
        let ys: Vec<&[f64]> = runs.iter().map(|r| r.ys.as_slice()).collect();
        let (ess_x, ess_y) = (ess_bulk(&xs), ess_bulk(&ys));
        let rhat = split_rhat(&xs).max(split_rhat(&ys));
        let seconds: f64 = runs.iter().map(|r| r.seconds).sum();
        let evaluations: u64 = runs.iter().map(|r| r.evaluations).sum();
        let steps: u64 = runs.iter().map(|r| r.steps).sum();
        let draws: usize = runs.iter().map(|r| r.xs.len()).sum();
        let trips: u64 = runs.iter().map(|r| r.round_trips).sum();
        let trips = match method {
            Method::Plain => "-".to_string(),
            _ => trips.to_string(),
        };
        println!(
            "{:<17} {:>9} {:>9} {:>9} {:>8.2} {:>7.0} {:>7.0} {:>7.0} {:>6.2} {:>6}",
            method.name(),
            evaluations,
            steps,
            draws,
            seconds,
            ess_x,
            ess_y,
            ess_x.min(ess_y) / seconds,
            rhat,
            trips
        );
    }
    println!(
        "(evals: target evaluations, steps: MH steps / RE sweeps / ST steps, draws: level-0 draws \
         kept, all summed over chains; ESS/s uses the smaller ESS)"
    );

    println!("\nprobability mass per mode (level-0 draws pooled over chains)");
    print!("{:<12} {:>7}", "mode", "exact");
    for (method, _) in &results {
        print!(" {:>17}", method.name());
    }
    println!();
    let masses: Vec<[f64; 4]> = results
        .iter()
        .map(|(_, runs)| {
            let mut counts = [0.0; 4];
            for r in runs {
                for (&x, &y) in r.xs.iter().zip(&r.ys) {
                    counts[mode_of(x, y)] += 1.0;
                }
            }
            let total: f64 = counts.iter().sum();
            counts.map(|c| c / total)
        })
        .collect();
    for (i, (m, w)) in MODES.iter().enumerate() {
        print!("({:+.0}, {:+.0})   {:>7.3}", m[0], m[1], w);
        for mass in &masses {
            print!(" {:>17.3}", mass[i]);
        }
        println!();
    }

    println!("\nreplica exchange: swap acceptance per pair (k, k+1), pooled over chains");
    for (method, runs) in &results {
        if let Method::Replica(_) = method {
            let pairs: Vec<f64> = (0..LEVELS - 1)
                .map(|k| {
                    let (acc, att) = runs.iter().fold((0, 0), |(a, t), r| {
                        (a + r.swaps[k].accepted, t + r.swaps[k].attempted)
                    });
                    acc as f64 / att as f64
                })
                .collect();
            println!("  {:<18} {}", method.name(), fmt_list(&pairs, 3));
        }
    }

    if let Some((_, runs)) = results.iter().find(|(m, _)| matches!(m, Method::Serial)) {
        let family = Tempered::geometric(ln_mixture, LEVELS, BETA_MIN)?;
        let exact: Vec<f64> = family.betas.iter().map(|&b| -ln_partition(b)).collect();
        let exact: Vec<f64> = exact.iter().map(|w| w - exact[0]).collect();
        println!("\nserial tempering (means over chains; weights relative to level 0)");
        println!("  betas               {}", fmt_list(&family.betas, 3));
        let time = mean_over(runs, |r| &r.time_per_level);
        println!("  time per level      {}", fmt_list(&time, 3));
        let weights = mean_over(runs, |r| &r.ln_weights);
        println!("  final ln weights    {}", fmt_list(&weights, 3));
        println!("  exact −ln Z_k       {}", fmt_list(&exact, 3));
    }

    let grid = Grid {
        x: (-7.0, 7.0),
        y: (-7.0, 7.0),
        nx: 175,
        ny: 175,
    };
    println!();
    for (method, runs) in &results {
        let samples = runs
            .iter()
            .flat_map(|r| r.xs.iter().zip(&r.ys).map(|(&x, &y)| [x, y]));
        let path = write_heatmaps(method.file(), grid, samples, |p| ln_mixture(&p))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
