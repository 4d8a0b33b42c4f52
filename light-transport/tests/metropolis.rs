//! The Metropolis driver and the primary-sample-space integrators.
//!
//! * Seeding is unbiased: on a 1D toy (a 32×1 film whose pixel values are the integrals of a known
//!   function), the average image of many short independent runs equals the exact integral; the
//!   same test fails when chains are seeded uniformly instead of by resampling.
//! * Large steps combined with the chain by the balance heuristic keep the toy unbiased, with one
//!   group and two; a wrong probability, the wrong move kind or one group's `b_g` for all is
//!   caught. The normalisation refined by the large steps keeps it unbiased and steadies its
//!   scale; small steps taken for independent samples are caught. Path-space MLT's normalisation
//!   refined by its new paths agrees with independent bootstraps, and charted MLT's, refined
//!   chart by chart by its large steps; bidirectional mutations (path-space) and small steps
//!   (charted) taken for independent samples are caught.
//! * A sampler that is not a deterministic function of its numbers is refused (replay check).
//! * PSSMLT, MMLT, path-space MLT, MEMLT and CMLT with direct lighting rendered apart converge to
//!   BDPT too; direct light counted twice is caught (MMLT, MLT); a render stopped in the direct
//!   pass keeps its work.
//! * PSSMLT and MMLT converge to the BDPT image on every built-in scene, and a PSSMLT whose
//!   recording uses another importance than its chains (a known cause of too-dark MLT images) is
//!   caught.
//!
//! Statistical verdicts: Welch t-tests per pixel or 6×6 block over independent runs,
//! Holm-corrected, α = 1e-4 per comparison; seeds fixed.

mod common;

use common::{
    ALPHA, H, MAX_EDGES, W, bdpt_batches, blocks, metropolis_runs, min_p, settings, with_threads,
};
use light_transport::Budget;
use light_transport::cmlt::{Cmlt, CmltSettings};
use light_transport::film::{FilmView, Image};
use light_transport::integrators::Bdpt;
use light_transport::metropolis::{
    self, Contribution, DIRECT_EDGES, ImportanceKind, Method, MetropolisSettings, Mmlt,
    PrimaryState, Pssmlt, Seeding, SeparateDirect, mutate_primary,
};
use light_transport::path::{MisHeuristic, Roulette, WalkSettings};
use light_transport::pathspace::{MutationProbabilities, Mutations, PathMlt};
use light_transport::renderer::{Control, Metropolis, Progress, Renderer};
use light_transport::scene::{Scene, builtin};
use light_transport::spectrum::Rgb;
use mcmc_core::kernel::Observer;
use mcmc_core::primary_sample::{Kelemen, LARGE_STEP, PrimarySample, SMALL_STEP};
use mcmc_core::{Chain, ChainRng};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

// ---------------------------------------------------------------------------------------------
// A 1D toy: pixel j of a 32×1 film should equal the mean of f over [j/32, (j+1)/32).

fn f(u: f64) -> f64 {
    0.2 + (7.0 * u).sin().powi(2) * 3.0 + if (0.6..0.65).contains(&u) { 20.0 } else { 0.0 }
}

fn f_integral(a: f64, b: f64) -> f64 {
    // ∫ 0.2 + 3 sin²(7u) du = 0.2 u + 1.5 u − 1.5 sin(14u)/14, plus the spike.
    let g = |u: f64| 1.7 * u - 1.5 * (14.0 * u).sin() / 14.0;
    let spike = (b.min(0.65) - a.max(0.6)).max(0.0) * 20.0;
    g(b) - g(a) + spike
}

/// The toy's method; `large_steps` is what it declares to the driver as its large steps
/// ([`Method::large_steps`]; its kernel's are Kelemen's default, probability 0.3). With two
/// groups (as MMLT's path lengths), group 1 samples `10 f` into the same pixels (its state's
/// `length` is 2), so the image is 11 times the one-group toy's.
struct Toy {
    large_steps: Option<(usize, f64)>,
    /// The move kind it declares as drawing independent samples, which refine its normalisation
    /// ([`Method::independent_proposals`]; `None`: the bootstrap's alone).
    independent: Option<usize>,
    groups: usize,
}

/// The toy recorded by expected values alone.
const TOY: Toy = Toy {
    large_steps: None,
    independent: None,
    groups: 1,
};

impl Toy {
    fn evaluate(s: &mut PrimaryState) {
        let u = s.sample.get(0, 0);
        let v = f(u) * if s.length == 2 { 10.0 } else { 1.0 };
        s.contribution = Contribution {
            splats: vec![([u * 32.0, 0.5], Rgb::splat(v))],
            importance: v,
        };
    }
}

impl Method for Toy {
    type State = PrimaryState;
    fn groups(&self) -> usize {
        self.groups
    }
    fn independent(&self, _scene: &Scene, g: usize, seed: u64) -> (PrimaryState, f64) {
        let mut s = PrimaryState {
            sample: PrimarySample::new(1, Default::default(), seed).unwrap(),
            contribution: Contribution::default(),
            length: if self.groups > 1 { g + 1 } else { 0 },
        };
        Toy::evaluate(&mut s);
        let w = s.contribution.importance;
        (s, w)
    }
    fn ln_density(&self, _scene: &Scene, s: &PrimaryState) -> f64 {
        s.contribution.importance.ln()
    }
    fn mutate<O: Observer<PrimaryState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<PrimaryState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        mutate_primary(
            scene,
            Kelemen::default(),
            |_, s| Toy::evaluate(s),
            chain,
            n,
            rng,
            observer,
        )
    }
    fn kinds(&self) -> Vec<String> {
        vec!["small".into(), "large".into()]
    }
    fn large_steps(&self) -> Option<(usize, f64)> {
        self.large_steps
    }
    fn independent_proposals(&self) -> Option<usize> {
        self.independent
    }
}

fn toy_runs(toy: &Toy, seeding: Seeding) -> Vec<Vec<f64>> {
    toy_runs_of(toy, seeding, 1.0)
}

/// 300 runs of `toy` with 16 chains, a bootstrap of 256 and `spp` mutations per pixel.
fn toy_runs_of(toy: &Toy, seeding: Seeding, spp: f64) -> Vec<Vec<f64>> {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((32, 1))).unwrap();
    (0..300)
        .map(|r| {
            // Few mutations per chain: the image is dominated by where the chains start.
            let settings = MetropolisSettings {
                chains: 16,
                bootstrap: 256,
                budget: Budget::SamplesPerPixel(spp),
                seed: 1000 + r,
                seeding,
                refine_normalisation: true,
            };
            let (film, _) = metropolis::run(&scene, toy, &settings, |_, _, _| true).unwrap();
            Image::from_film(&film)
                .pixels
                .iter()
                .map(|p| p[0])
                .collect()
        })
        .collect()
}

#[test]
fn seeding_is_unbiased_on_a_1d_toy_and_uniform_seeding_is_caught() {
    let exact = toy_exact(&TOY);
    let p = min_p(
        &toy_runs(&TOY, Seeding::Resample),
        std::slice::from_ref(&exact),
    );
    println!("resampled seeds: p = {p:.3e}");
    assert!(p > ALPHA, "resampled seeding is biased (p = {p:.2e})");
    let q = min_p(&toy_runs(&TOY, Seeding::UniformBiased), &[exact]);
    println!("uniform seeds: p = {q:.3e}");
    assert!(q < ALPHA, "uniform seeding was not caught (p = {q:.2e})");
}

fn toy_exact(toy: &Toy) -> Vec<f64> {
    let scale = if toy.groups > 1 { 11.0 } else { 1.0 };
    (0..32)
        .map(|j| f_integral(j as f64 / 32.0, (j + 1) as f64 / 32.0) * 32.0 * scale)
        .collect()
}

/// Per-pixel variance over the runs.
fn variances(runs: &[Vec<f64>]) -> Vec<f64> {
    let n = runs.len() as f64;
    (0..runs[0].len())
        .map(|j| {
            let mean = runs.iter().map(|r| r[j]).sum::<f64>() / n;
            runs.iter().map(|r| (r[j] - mean).powi(2)).sum::<f64>() / (n - 1.0)
        })
        .collect()
}

/// Large steps counted as independent samples too, combined with the chain by the balance
/// heuristic (Kelemen et al. 2002 §4; `metropolis::record::LargeStepMis`), leave the 1D toy's
/// image unbiased (Welch tests per pixel against the exact integral, Holm-corrected, α = 1e-4,
/// so a false alarm has probability ≤ 1e-4 per verdict), with one group and with two groups of
/// different normalisations (each group's large steps weighed with its own `b_g`), and with
/// less variance where `f` is low. Two wrong declarations are caught: a probability other than
/// the kernel's (0.1 for 0.3: the two estimators' weights no longer sum to one) and the small
/// steps declared as the large steps. Weighing every group's large steps with group 0's `b_0`
/// (a `PrimaryState::group` that returns 0) makes the two-group verdict fail (p = 8.8e-12, run by
/// hand).
#[test]
fn large_steps_combined_by_the_balance_heuristic_are_unbiased_on_the_1d_toy() {
    let combined = |groups| Toy {
        large_steps: Some((LARGE_STEP, 0.3)),
        independent: Some(LARGE_STEP),
        groups,
    };
    let exact = toy_exact(&TOY);
    let runs = toy_runs(&combined(1), Seeding::Resample);
    let p = min_p(&runs, std::slice::from_ref(&exact));
    println!("large steps combined: p = {p:.3e}");
    assert!(p > ALPHA, "combined large steps are biased (p = {p:.2e})");
    let two = combined(2);
    let p2 = min_p(
        &toy_runs(&two, Seeding::Resample),
        std::slice::from_ref(&toy_exact(&two)),
    );
    println!("large steps combined, two groups: p = {p2:.3e}");
    assert!(
        p2 > ALPHA,
        "combined large steps are biased with two groups (p = {p2:.2e})"
    );
    let (v_plain, v_combined) = (
        variances(&toy_runs(&TOY, Seeding::Resample)),
        variances(&runs),
    );
    let ratio: Vec<String> = v_combined
        .iter()
        .zip(&v_plain)
        .map(|(c, p)| format!("{:.2}", c / p))
        .collect();
    println!(
        "variance combined / expected values alone, per pixel: {}",
        ratio.join(" ")
    );
    for (declared, what) in [
        ((LARGE_STEP, 0.1), "a wrong probability"),
        ((SMALL_STEP, 0.3), "the small steps"),
    ] {
        let q = min_p(
            &toy_runs(
                &Toy {
                    large_steps: Some(declared),
                    independent: Some(declared.0),
                    groups: 1,
                },
                Seeding::Resample,
            ),
            std::slice::from_ref(&exact),
        );
        println!("{what} declared as large steps: p = {q:.3e}");
        assert!(
            q < ALPHA,
            "{what} declared as large steps was not caught (p = {q:.2e})"
        );
    }
}

/// The normalisation refined by the chains' large steps (Kelemen et al. 2002 §4;
/// `MetropolisSettings::refine_normalisation`): 64 mutations per pixel, so a run's 2048
/// mutations draw about 600 large-step candidates against a bootstrap of 256. The image stays
/// unbiased (Welch tests per pixel, Holm-corrected, α = 1e-4), with one group and with two, and
/// the variance of the image's total over 300 runs falls against the bootstrap's normalisation
/// alone (measured: 0.39× with one group, 0.42× with two). Declaring the small steps as
/// independent proposals (their candidates lie near states drawn in proportion to `I`, so their
/// mean importance is too high) is caught.
#[test]
fn the_normalisation_refined_by_the_large_steps_is_unbiased_and_steadier_on_the_1d_toy() {
    let toy = |independent, groups| Toy {
        large_steps: Some((LARGE_STEP, 0.3)),
        independent,
        groups,
    };
    let total_variance = |runs: &[Vec<f64>]| {
        let totals: Vec<f64> = runs.iter().map(|r| r.iter().sum()).collect();
        let n = totals.len() as f64;
        let mean = totals.iter().sum::<f64>() / n;
        totals.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0)
    };
    for groups in [1, 2] {
        let refined = toy(Some(LARGE_STEP), groups);
        let exact = toy_exact(&refined);
        let runs = toy_runs_of(&refined, Seeding::Resample, 64.0);
        let p = min_p(&runs, std::slice::from_ref(&exact));
        let fixed = toy_runs_of(&toy(None, groups), Seeding::Resample, 64.0);
        let ratio = total_variance(&runs) / total_variance(&fixed);
        println!(
            "{groups} group(s): refined p = {p:.3e}, variance of the total refined / bootstrap alone {ratio:.2}"
        );
        assert!(
            p > ALPHA,
            "the refined normalisation is biased (p = {p:.2e})"
        );
        assert!(
            ratio < 0.6,
            "refining did not steady the image's scale ({ratio:.2})"
        );
        let broken = toy_runs_of(&toy(Some(SMALL_STEP), groups), Seeding::Resample, 64.0);
        let q = min_p(&broken, &[exact]);
        println!("{groups} group(s): small steps as independent proposals p = {q:.3e}");
        assert!(
            q < ALPHA,
            "small steps taken as independent samples were not caught (p = {q:.2e})"
        );
    }
}

/// `method` with its independent proposals declared as move kind `declared`, and, unless
/// `stratified`, its bootstrap declared as one stratum per group: broken versions of the
/// normalisation's refinement when the kind's candidates are not bootstrap samples (they lie
/// near the current state, drawn in proportion to `I`, so their mean bootstrap weight is too
/// high), or when samples of strata the chains visit unevenly are averaged as one.
struct Declared<M> {
    method: M,
    declared: Option<usize>,
    stratified: bool,
}

impl<M: Method> Method for Declared<M> {
    type State = M::State;
    fn groups(&self) -> usize {
        self.method.groups()
    }
    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> (Self::State, f64) {
        self.method.independent(scene, g, seed)
    }
    fn ln_density(&self, scene: &Scene, state: &Self::State) -> f64 {
        self.method.ln_density(scene, state)
    }
    fn mutate<O: Observer<Self::State>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<Self::State>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        self.method.mutate(scene, chain, n, rng, observer)
    }
    fn kinds(&self) -> Vec<String> {
        self.method.kinds()
    }
    fn bootstrap_done(&self, group_normalisation: &[f64]) {
        self.method.bootstrap_done(group_normalisation)
    }
    fn independent_proposals(&self) -> Option<usize> {
        self.declared
    }
    fn chains_span_groups(&self) -> bool {
        self.method.chains_span_groups()
    }
    fn strata(&self, g: usize) -> usize {
        if self.stratified {
            self.method.strata(g)
        } else {
            1
        }
    }
    fn independent_weight(&self, scene: &Scene, g: usize, seed: u64) -> f64 {
        self.method.independent_weight(scene, g, seed)
    }
    fn independent_in_stratum(&self, scene: &Scene, g: usize, seed: u64) -> (usize, f64) {
        let (stratum, w) = self.method.independent_in_stratum(scene, g, seed);
        (if self.stratified { stratum } else { 0 }, w)
    }
}

/// Runs on each side of the refinement tests' comparison.
const REFINEMENT_RUNS: u64 = 40;

/// The refined normalisation `b` of [`REFINEMENT_RUNS`] runs of `m` on `scene` (a bootstrap of
/// 1000 samples per group, `mutations` per pixel, seeds from 300), checking that the chains drew
/// more than `at_least` independent samples in each.
fn refined_b<M: Method>(scene: &Scene, m: &M, mutations: f64, at_least: u64) -> Vec<Vec<f64>> {
    (0..REFINEMENT_RUNS)
        .map(|r| {
            let s = MetropolisSettings {
                seed: 300 + r,
                ..settings(1000, mutations, 0)
            };
            let stats = metropolis::run(scene, m, &s, |_, _, _| true).unwrap().1;
            assert!(
                stats.independent_samples > at_least,
                "{}",
                stats.independent_samples
            );
            vec![stats.refined_normalisation.iter().sum::<f64>()]
        })
        .collect()
}

/// The bootstrap's `b` alone in [`REFINEMENT_RUNS`] other runs of `m` (seeds from 600), each
/// with 4000 samples per group: unbiased by construction, and a quarter of the refined runs'
/// bootstrap variance, so that the comparison's noise is mostly the refined side's.
fn bootstrap_b<M: Method>(scene: &Scene, m: &M) -> Vec<Vec<f64>> {
    (0..REFINEMENT_RUNS)
        .map(|r| {
            let s = MetropolisSettings {
                seed: 600 + r,
                refine_normalisation: false,
                ..settings(4000, 0.01, 0)
            };
            vec![
                metropolis::run(scene, m, &s, |_, _, _| true)
                    .unwrap()
                    .1
                    .normalisation,
            ]
        })
        .collect()
}

/// The relative standard deviation of one-number runs.
fn relative_sd(v: &[Vec<f64>]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().map(|x| x[0]).sum::<f64>() / n;
    (v.iter().map(|x| (x[0] - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() / m
}

/// `m`'s refined normalisation agrees with independent bootstraps (Welch test, α = 1e-4), and
/// `broken`'s does not.
fn refinement_agrees_with_bootstraps<M: Method>(
    name: &str,
    scene: &Scene,
    m: &M,
    broken: &Declared<M>,
    mutations: f64,
    at_least: u64,
) {
    let runs = refined_b(scene, m, mutations, at_least);
    let bootstraps = bootstrap_b(scene, m);
    let p = min_p(&runs, &bootstraps);
    println!(
        "{name}: refined b p = {p:.3e}, relative sd {:.4} against the bootstrap's {:.4} ({:.2}x)",
        relative_sd(&runs),
        relative_sd(&bootstraps),
        relative_sd(&runs) / relative_sd(&bootstraps)
    );
    assert!(
        p > ALPHA,
        "{name}: the refined normalisation is biased (p = {p:.2e})"
    );
    let q = min_p(&refined_b(scene, broken, mutations, at_least), &bootstraps);
    println!("{name}, broken: p = {q:.3e}");
    assert!(
        q < ALPHA,
        "{name}: the broken refinement was not caught (p = {q:.2e})"
    );
}

/// Path-space MLT refines its normalisation with its new-path candidates, each a bootstrap
/// sample of its own length (weight `(k + 1) I`, `PathState::independent_weight`). On cornell
/// (36×30, 6 edges, a bootstrap of 1000 paths per length, 128 mutations per pixel: about 14 000
/// new paths per run), the refined `b` of 40 runs agrees with the bootstrap's `b` of 40 other
/// runs (Welch test, α = 1e-4; the bootstrap is unbiased by construction). The bidirectional
/// mutation declared as the independent proposals is caught. (At 32 mutations per pixel and 20
/// runs a side it was caught only at p = 2.2e-3 once new paths drew from `FastRng`; 40 runs and
/// 64 mutations gave 1.8e-5, 128 mutations 2.3e-6, while the sound refinement read 0.41–0.79.)
/// How much the refinement steadies `b` is printed, not asserted: the weights are heavy-tailed
/// here, and the runs' standard deviations put the ratio anywhere from 0.74× to 1.56× as the
/// settings change (measured); the README's figures come from full renders.
#[test]
fn path_space_mlt_refines_its_normalisation_with_its_new_paths() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let mlt = || PathMlt::new(Mutations::new(MAX_EDGES)).unwrap();
    let broken = Declared {
        method: mlt(),
        declared: light_transport::pathspace::mutations::index_of("bidirectional"),
        stratified: true,
    };
    refinement_agrees_with_bootstraps("path-space MLT", &scene, &mlt(), &broken, 128.0, 8000);
}

/// Charted MLT refines its normalisation with its large steps, uniform in the chain's technique
/// chart: each a bootstrap sample of that chart's stratum (the bootstrap picks the chart
/// uniformly), combined stratum by stratum (`NormalisationTally`). Same protocol as path-space
/// MLT's above (cornell, 36×30, 6 edges, 16 mutations per pixel: about 3000 large steps per
/// run, 40 runs a side; measured: the refined `b` scatters 0.38× as much as a bootstrap of 1000
/// per group, 0.62× as much as the comparison's bootstrap of 4000). The same large
/// steps averaged as one stratum are caught: the chains visit a chart in proportion to its
/// share of `b`, so the plain mean of their candidates' weights is too high. (Small steps
/// declared as the independent proposals are not reliably caught here, p = 0.05–0.08: in the
/// closed Cornell box their candidates' weights differ little from uniform samples'.)
#[test]
fn charted_mlt_refines_its_normalisation_with_its_large_steps() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let cmlt = || {
        Cmlt::new(
            &scene,
            CmltSettings {
                max_edges: MAX_EDGES,
                pilot: 500,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let broken = Declared {
        method: cmlt(),
        declared: Some(light_transport::cmlt::LARGE_STEP),
        stratified: false,
    };
    refinement_agrees_with_bootstraps("charted MLT", &scene, &cmlt(), &broken, 16.0, 2000);
}

/// Importance changes on every call: replaying a seed cannot reproduce its bootstrap value.
struct NotReplayable(AtomicU64);

impl Method for NotReplayable {
    type State = PrimaryState;
    fn groups(&self) -> usize {
        1
    }
    fn independent(&self, s: &Scene, g: usize, seed: u64) -> (PrimaryState, f64) {
        let (st, w) = TOY.independent(s, g, seed);
        (
            st,
            w * (1.0 + self.0.fetch_add(1, Ordering::Relaxed) as f64 * 1e-6),
        )
    }
    fn ln_density(&self, s: &Scene, st: &PrimaryState) -> f64 {
        TOY.ln_density(s, st)
    }
    fn mutate<O: Observer<PrimaryState>>(
        &self,
        s: &Scene,
        c: &mut Chain<PrimaryState>,
        n: u64,
        r: &mut ChainRng,
        o: &mut O,
    ) {
        TOY.mutate(s, c, n, r, o)
    }
    fn kinds(&self) -> Vec<String> {
        TOY.kinds()
    }
}

#[test]
fn a_sampler_that_cannot_replay_its_seeds_is_refused() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((32, 1))).unwrap();
    let settings = MetropolisSettings {
        chains: 4,
        bootstrap: 64,
        ..Default::default()
    };
    let err = metropolis::run(
        &scene,
        &NotReplayable(AtomicU64::new(0)),
        &settings,
        |_, _, _| true,
    )
    .expect_err("refused");
    assert!(err.to_string().contains("replay"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Convergence to BDPT on the built-in scenes.

fn mlt_runs<M: Method>(scene: &Scene, m: &M, runs: u64) -> Vec<Vec<f64>> {
    metropolis_runs(scene, m, settings(20_000, 32.0, 77), runs)
        .into_iter()
        .map(|(film, stats)| {
            assert_eq!(film.discarded, 0);
            assert!(stats.stats.total().acceptance_rate() > 0.05);
            blocks(&Image::from_film(&film))
        })
        .collect()
}

fn pssmlt(importance: ImportanceKind) -> Pssmlt {
    Pssmlt {
        bdpt: Bdpt {
            walk: WalkSettings {
                max_edges: MAX_EDGES,
            },
            heuristic: MisHeuristic::Power,
            roulette: None,
            shadow_roulette: None,
        },
        kelemen: Kelemen::default(),
        importance,
        large_step_mis: true,
        direct_apart: false,
    }
}

/// MMLT with the defaults of these tests (luminance importance, power heuristic).
fn mmlt() -> Mmlt {
    Mmlt {
        walk: WalkSettings {
            max_edges: MAX_EDGES,
        },
        heuristic: MisHeuristic::Power,
        kelemen: Kelemen::default(),
        importance: ImportanceKind::Luminance,
        large_step_mis: true,
        direct_apart: false,
    }
}

/// PSSMLT whose BDPT walks stop by Russian roulette from the first surface vertex on (the most
/// aggressive setting), in both walks and in light walks only (the CLI's default), converges to
/// BDPT without roulette on every built-in scene. Per-block Welch tests with Holm's correction at
/// `ALPHA` (false-positive rate ≤ 1e-4 per scene and setting); the version that forgets the
/// survivors' `1/q` fails it on the first scene, cornell, with p = 3.4e-5 in both walks (run by
/// hand). In light walks only this test is too weak to catch that version (cornell p = 2.9e-2,
/// run by hand); `tests/agreement.rs` catches it (BDPT, cornell, p = 5.4e-10), and PSSMLT
/// evaluates its target with that same BDPT.
#[test]
fn pssmlt_with_russian_roulette_converges_to_bdpt() {
    for name in builtin::BUILTIN {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap();
        let reference = bdpt_batches(&scene);
        for camera in [true, false] {
            let mut m = pssmlt(ImportanceKind::Luminance);
            m.bdpt.roulette = Some(Roulette { from: 1, camera });
            let p = min_p(&mlt_runs(&scene, &m, 8), &reference);
            println!("{name}: PSSMLT with roulette (camera walks too: {camera}) p = {p:.3e}");
            assert!(
                p > ALPHA,
                "{name}: PSSMLT with roulette (camera walks too: {camera}) disagrees with BDPT \
                 (p = {p:.2e})"
            );
        }
    }
}

#[test]
fn pssmlt_and_mmlt_converge_to_bdpt_on_every_builtin_scene() {
    let mmlt = mmlt();
    for name in builtin::BUILTIN {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap();
        let reference = bdpt_batches(&scene);
        let p1 = min_p(
            &mlt_runs(&scene, &pssmlt(ImportanceKind::Luminance), 8),
            &reference,
        );
        let p2 = min_p(&mlt_runs(&scene, &mmlt, 8), &reference);
        println!("{name}: PSSMLT p = {p1:.3e}, MMLT p = {p2:.3e}");
        assert!(
            p1 > ALPHA,
            "{name}: PSSMLT disagrees with BDPT (p = {p1:.2e})"
        );
        assert!(
            p2 > ALPHA,
            "{name}: MMLT disagrees with BDPT (p = {p2:.2e})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Direct lighting apart from MMLT's chains (`SeparateDirect`).

/// `runs` renders of `renderer` with 32 mutations per pixel, seeds 77, 78, …, as 6×6 blocks.
fn renderer_runs(scene: &Scene, renderer: &dyn Renderer, runs: u64) -> Vec<Vec<f64>> {
    common::renderer_runs(scene, renderer, Budget::SamplesPerPixel(32.0), 77, runs)
}

/// A broken `renderer` (`what`) disagrees with BDPT on cornell (8 runs as in [`renderer_runs`]).
fn assert_caught_on_cornell(renderer: &dyn Renderer, what: &str) {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let p = min_p(&renderer_runs(&scene, renderer, 8), &bdpt_batches(&scene));
    println!("cornell: {what} p = {p:.3e}");
    assert!(p < ALPHA, "{what} was not caught (p = {p:.2e})");
}

/// PSSMLT and MMLT with the paths of at most two edges rendered apart by the direct-lighting
/// pass converge to BDPT on every built-in scene
/// (Welch per 6×6 block, Holm, `ALPHA` per scene and method). The test of the test: MMLT chains
/// that keep every path while the pass renders direct lighting too (counted twice) are caught on
/// cornell.
#[test]
fn pssmlt_and_mmlt_with_direct_lighting_apart_converge_to_bdpt() {
    let settings = settings(20_000, 32.0, 77);
    let separate =
        SeparateDirect::new(mmlt(), settings, MisHeuristic::Power, 4, 0.2).expect("a direct pass");
    assert!(separate.chains.method.direct_apart);
    let pssmlt = SeparateDirect::new(
        pssmlt(ImportanceKind::Luminance),
        settings,
        MisHeuristic::Power,
        4,
        0.2,
    )
    .expect("a direct pass");
    for name in builtin::BUILTIN {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap();
        let reference = bdpt_batches(&scene);
        let p1 = min_p(&renderer_runs(&scene, &pssmlt, 8), &reference);
        let p2 = min_p(&renderer_runs(&scene, &separate, 8), &reference);
        println!("{name}: with direct lighting apart PSSMLT p = {p1:.3e}, MMLT p = {p2:.3e}");
        assert!(
            p1 > ALPHA,
            "{name}: PSSMLT with direct lighting apart disagrees with BDPT (p = {p1:.2e})"
        );
        assert!(
            p2 > ALPHA,
            "{name}: MMLT with direct lighting apart disagrees with BDPT (p = {p2:.2e})"
        );
    }
    let twice = SeparateDirect {
        chains: Metropolis {
            method: Mmlt {
                direct_apart: false,
                ..mmlt()
            },
            settings,
        },
        ..separate
    };
    assert_caught_on_cornell(&twice, "MMLT chains with direct light counted twice");
}

/// Path-space MLT (the default mutations), MEMLT (the manifold-exploration mixture) and charted
/// MLT with the paths of at most two edges rendered apart by the direct-lighting pass converge to
/// BDPT on every built-in scene (Welch per 6×6 block, Holm, `ALPHA` per scene and method). Their
/// chains sample longer paths only (no bootstrap weight on the short lengths, and path-space
/// proposals of a short path rejected). The test of the test: path-space chains that keep every
/// path while the pass renders direct lighting too are caught on cornell.
#[test]
fn path_space_methods_with_direct_lighting_apart_converge_to_bdpt() {
    let settings = settings(4000, 32.0, 91);
    let apart = |m| SeparateDirect::new(m, settings, MisHeuristic::Power, 4, 0.2);
    let mlt = apart(PathMlt::new(Mutations::new(MAX_EDGES)).unwrap()).expect("a direct pass");
    assert_eq!(mlt.chains.method.mutations.min_edges, DIRECT_EDGES + 1);
    let memlt = apart(
        PathMlt::new(Mutations {
            probabilities: MutationProbabilities::manifold_exploration(),
            ..Mutations::new(MAX_EDGES)
        })
        .unwrap(),
    )
    .expect("a direct pass");
    for name in builtin::BUILTIN {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap();
        let reference = bdpt_batches(&scene);
        let cmlt = Cmlt::new(
            &scene,
            CmltSettings {
                max_edges: MAX_EDGES,
                ..CmltSettings::default()
            },
        )
        .unwrap();
        let cmlt = SeparateDirect::new(cmlt, settings, MisHeuristic::Power, 4, 0.2).unwrap();
        let p: Vec<f64> = [&mlt as &dyn Renderer, &memlt, &cmlt]
            .iter()
            .map(|r| min_p(&renderer_runs(&scene, *r, 8), &reference))
            .collect();
        println!(
            "{name}: with direct lighting apart MLT p = {:.3e}, MEMLT p = {:.3e}, CMLT p = {:.3e}",
            p[0], p[1], p[2]
        );
        for (method, p) in ["MLT", "MEMLT", "CMLT"].iter().zip(p) {
            assert!(
                p > ALPHA,
                "{name}: {method} with direct lighting apart disagrees with BDPT (p = {p:.2e})"
            );
        }
    }
    let mut twice = mlt;
    twice.chains.method.mutations.min_edges = 1;
    assert_caught_on_cornell(&twice, "path-space chains with direct light counted twice");
}

/// The direct pass keeps pace with the chains. Under a samples-per-pixel budget its passes run
/// between the chains' rounds, yet the image does not depend on when they ran: one thread and
/// two render the same image. A render stopped during the chains holds both estimates: some of
/// the direct pass's samples per pixel (not all) and some of the chains' mutations.
#[test]
fn the_direct_pass_keeps_pace_with_the_chains() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let separate = SeparateDirect::new(
        mmlt(),
        settings(2000, 16.0, 5),
        MisHeuristic::Power,
        16,
        0.2,
    )
    .expect("a direct pass");
    let render = |threads: usize| {
        with_threads(threads, || {
            let mut go_on = |_: FilmView<'_>, _: &Progress| true;
            let mut control = Control {
                progress: &mut go_on,
                stop: None,
            };
            let (film, report) = separate
                .render(&scene, Budget::SamplesPerPixel(16.0), 5, &mut control)
                .unwrap();
            assert_eq!(film.camera_samples(), (16 * W * H) as f64);
            assert!(!report.interrupted);
            Image::from_film(&film).pixels
        })
    };
    assert_eq!(render(1), render(2));

    let stop = AtomicBool::new(false);
    let mut rounds = 0;
    let mut stop_after_two = |_: FilmView<'_>, _: &Progress| {
        rounds += 1;
        if rounds == 2 {
            stop.store(true, Ordering::Relaxed);
        }
        true
    };
    let mut control = Control {
        progress: &mut stop_after_two,
        stop: Some(&stop),
    };
    let (film, report) = separate
        .render(&scene, Budget::SamplesPerPixel(16.0), 5, &mut control)
        .unwrap();
    let passes = film.camera_samples() / (W * H) as f64;
    println!(
        "stopped after two rounds: {passes} direct samples per pixel, {:.2} mutations per pixel",
        report.samples_per_pixel
    );
    assert!(report.interrupted);
    assert!(report.samples > 0, "the chains ran");
    assert!(report.samples_per_pixel < 16.0);
    assert!(
        (2.0..16.0).contains(&passes),
        "{passes} direct passes: more than the first, not all"
    );
}

/// A direct pass needs longer paths left for the chains.
#[test]
fn a_direct_pass_without_longer_paths_is_refused() {
    let short = Mmlt {
        walk: WalkSettings {
            max_edges: DIRECT_EDGES,
        },
        ..mmlt()
    };
    let err = SeparateDirect::new(short, settings(100, 1.0, 1), MisHeuristic::Power, 16, 0.2)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("longer than 2 edges"), "{err}");
    for (spp, share) in [(0, 0.2), (16, 0.0), (16, 1.0), (16, f64::NAN)] {
        assert!(
            SeparateDirect::new(
                mmlt(),
                settings(100, 1.0, 1),
                MisHeuristic::Power,
                spp,
                share
            )
            .is_err(),
            "{spp} samples per pixel, share {share}"
        );
    }
}

/// A render stopped during the direct pass returns the pass's film, marked interrupted, without
/// running the chains.
#[test]
fn a_render_stopped_in_the_direct_pass_keeps_its_work() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let separate =
        SeparateDirect::new(mmlt(), settings(1000, 4.0, 1), MisHeuristic::Power, 64, 0.2)
            .expect("a direct pass");
    let stop = AtomicBool::new(true);
    let mut go_on = |_: FilmView<'_>, _: &Progress| true;
    let mut control = Control {
        progress: &mut go_on,
        stop: Some(&stop),
    };
    let (film, report) = separate
        .render(&scene, Budget::SamplesPerPixel(4.0), 1, &mut control)
        .unwrap();
    assert!(report.interrupted);
    assert_eq!(report.samples, 0, "no chain ran");
    let samples = film.camera_samples();
    assert!(
        samples >= (W * H) as f64 && samples < (64 * W * H) as f64,
        "{samples} camera samples: one pass or more, not all 64"
    );
    assert!(Image::from_film(&film).mean().luminance() > 0.0);
}

/// A scene lit only directly (a point light over a single floor: no path of three edges) renders
/// with the direct pass alone, saying so, where the chains alone find no light to run on.
#[test]
fn a_scene_without_longer_paths_renders_with_the_direct_pass_alone() {
    let text = r#"
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 45
WorldBegin
LightSource "point" "point from" [ 0 0 3 ] "rgb I" [ 10 10 10 ]
Material "matte"
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ] "point P" [ -5 -5 0 5 -5 0 5 5 0 -5 5 0 ]
WorldEnd
"#;
    let desc =
        light_transport::scene::pbrt::load_str(text, std::path::Path::new("."), "floor.pbrt")
            .unwrap();
    let scene = Scene::new(&desc, Some((W, H))).unwrap();
    let mut go_on = |_: FilmView<'_>, _: &Progress| true;
    let mut control = Control {
        progress: &mut go_on,
        stop: None,
    };
    let chains_alone = Metropolis {
        method: mmlt(),
        settings: settings(1000, 1.0, 1),
    };
    let separate = SeparateDirect::new(mmlt(), settings(1000, 1.0, 1), MisHeuristic::Power, 4, 0.2)
        .expect("a direct pass");
    let (film, report) = separate
        .render(&scene, Budget::SamplesPerPixel(1.0), 1, &mut control)
        .unwrap();
    assert!(Image::from_film(&film).mean().luminance() > 0.0);
    assert!(
        report.details.iter().any(|l| l.contains("chains     none")),
        "{:?}",
        report.details
    );
    let without_chains = Metropolis {
        method: Mmlt {
            direct_apart: true,
            ..mmlt()
        },
        settings: settings(1000, 1.0, 1),
    };
    let err = without_chains
        .render(&scene, Budget::SamplesPerPixel(1.0), 1, &mut control)
        .expect_err("no light for the chains");
    assert!(
        matches!(err, light_transport::Error::NoLight { .. }),
        "{err}"
    );
    // The chains on every path length do find the direct light.
    assert!(
        chains_alone
            .render(&scene, Budget::SamplesPerPixel(1.0), 1, &mut control)
            .is_ok()
    );
}

/// Bootstrap with the max-component importance, chains and recording with luminance: the
/// normalisation belongs to another importance than the chains sample (a bug that renders
/// coloured scenes too bright or too dark).
struct MismatchedImportance(Pssmlt);

impl Method for MismatchedImportance {
    type State = PrimaryState;
    fn groups(&self) -> usize {
        1
    }
    fn independent(&self, s: &Scene, g: usize, seed: u64) -> (PrimaryState, f64) {
        let (st, _) = self.0.independent(s, g, seed);
        // The bootstrap weighs by the max component; the state (chains, recording) is luminance.
        let w = st
            .contribution
            .splats
            .iter()
            .map(|v| v.1.max_component())
            .sum();
        (st, w)
    }
    fn ln_density(&self, s: &Scene, st: &PrimaryState) -> f64 {
        self.0.ln_density(s, st)
    }
    fn mutate<O: Observer<PrimaryState>>(
        &self,
        s: &Scene,
        c: &mut Chain<PrimaryState>,
        n: u64,
        r: &mut ChainRng,
        o: &mut O,
    ) {
        self.0.mutate(s, c, n, r, o)
    }
    fn kinds(&self) -> Vec<String> {
        self.0.kinds()
    }
}

#[test]
fn mismatched_importance_is_caught() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let p = min_p(
        &mlt_runs(
            &scene,
            &MismatchedImportance(pssmlt(ImportanceKind::Luminance)),
            8,
        ),
        &bdpt_batches(&scene),
    );
    println!("mismatched importance: p = {p:.3e}");
    assert!(
        p < ALPHA,
        "the mismatched importance was not caught (p = {p:.2e})"
    );
}

/// `count` on every built-in scene (at `W`×`H`), summed per entry: how many of the samples a
/// check compared carry light, printed per scene.
fn nonzero_over_builtins<const N: usize>(count: impl Fn(&Scene) -> [usize; N]) -> [usize; N] {
    let mut total = [0; N];
    for name in builtin::BUILTIN {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap();
        let n = count(&scene);
        println!("{name}: nonzero weights {n:?}");
        for (t, k) in total.iter_mut().zip(n) {
            *t += k;
        }
    }
    total
}

/// The bootstrap's weights, computed in per-thread storage that each sample reuses
/// (`Method::independent_weight`), are bit for bit those of the independent samples the seeding
/// replays (`Method::independent`), for PSSMLT (with and without roulette), MMLT, path-space
/// MLT and charted MLT, on every built-in scene, with samples of different path lengths interleaved so that each
/// reuse starts from another sample's leftovers. The test of the test, run by hand: with
/// `PrimarySample::reset` keeping the old coordinates, PSSMLT's second sample differs; with
/// charted MLT's reused state keeping its old cached evaluation (`fresh` not cleared), its
/// second sample differs.
#[test]
fn bootstrap_weights_in_reused_storage_equal_fresh_samples() {
    let mmlt = mmlt();
    let mut with_roulette = pssmlt(ImportanceKind::Luminance);
    with_roulette.bdpt.roulette = Some(Roulette {
        from: 1,
        camera: true,
    });
    let mlt = light_transport::pathspace::PathMlt::new(light_transport::pathspace::Mutations::new(
        MAX_EDGES,
    ))
    .unwrap();
    fn check<M: Method>(method: &M, scene: &Scene, what: &str) -> usize {
        let mut nonzero = 0;
        for i in 0..2000u64 {
            let g = (i as usize * 7) % method.groups();
            let seed = 0x5EED ^ i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let reused = method.independent_weight(scene, g, seed);
            let fresh = method.independent(scene, g, seed).1;
            assert_eq!(
                reused.to_bits(),
                fresh.to_bits(),
                "{what}: group {g}, sample {i}"
            );
            nonzero += (fresh > 0.0) as usize;
        }
        nonzero
    }
    let total = nonzero_over_builtins(|scene| {
        let cmlt = light_transport::cmlt::Cmlt::new(scene, Default::default()).unwrap();
        [
            check(&pssmlt(ImportanceKind::Luminance), scene, "pssmlt"),
            check(&with_roulette, scene, "pssmlt with roulette"),
            check(&mmlt, scene, "mmlt"),
            check(&mlt, scene, "path-space mlt"),
            check(&cmlt, scene, "charted mlt"),
        ]
    });
    assert!(
        total.iter().all(|&k| k > 500),
        "too few samples carry light to compare: {total:?}"
    );
}

/// A bootstrap that walks once for every path length (`Method::independent_all`, for the methods
/// whose bootstrap shares its keys across lengths) gives each length bit for bit the weight and
/// stratum of the sample that length draws alone from the same key (`independent_in_stratum`,
/// and `independent`, which the seeding replays), for MMLT, path-space MLT and charted MLT, with
/// and without the short paths left to a direct pass, on every built-in scene. The tests of the test, run
/// by hand: the light subpath walked one vertex short (`max_edges − 1`), and MMLT's technique
/// number read from the camera substream, each fail here.
#[test]
fn a_bootstrap_walked_once_for_every_length_is_each_length_alone() {
    use light_transport::metropolis::DirectApart;
    fn check<M: Method>(method: &M, scene: &Scene, what: &str) -> usize {
        assert!(method.shares_bootstrap_keys(), "{what}");
        let mut all = vec![(0, 0.0); method.groups()];
        let mut nonzero = 0;
        for i in 0..400u64 {
            let seed = 0xA11 ^ i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            method.independent_all(scene, seed, &mut all);
            for (g, &(stratum, weight)) in all.iter().enumerate() {
                let alone = method.independent_in_stratum(scene, g, seed);
                assert_eq!(stratum, alone.0, "{what}: group {g}, sample {i}");
                assert_eq!(
                    weight.to_bits(),
                    alone.1.to_bits(),
                    "{what}: group {g}, sample {i}"
                );
                let replayed = method.independent(scene, g, seed).1;
                assert_eq!(
                    weight.to_bits(),
                    replayed.to_bits(),
                    "{what}: group {g}, sample {i}"
                );
                nonzero += (weight > 0.0) as usize;
            }
        }
        nonzero
    }
    let mlt = PathMlt::new(Mutations::new(MAX_EDGES)).unwrap();
    let mlt_apart = PathMlt::new(Mutations::new(MAX_EDGES))
        .unwrap()
        .without_direct();
    let total = nonzero_over_builtins(|scene| {
        let cmlt = Cmlt::new(scene, Default::default()).unwrap();
        let cmlt_apart = Cmlt::new(scene, Default::default())
            .unwrap()
            .without_direct();
        [
            check(&mmlt(), scene, "mmlt"),
            check(&mmlt().without_direct(), scene, "mmlt, direct apart"),
            check(&mlt, scene, "path-space mlt"),
            check(&mlt_apart, scene, "path-space mlt, direct apart"),
            check(&cmlt, scene, "charted mlt"),
            check(&cmlt_apart, scene, "charted mlt, direct apart"),
        ]
    });
    assert!(
        total.iter().all(|&k| k > 300),
        "too few samples carry light to compare: {total:?}"
    );
}

/// A sink that keeps, per absorbed chunk, how many deposits it held and their weights in order;
/// its chunks count every deposit they receive in `RECORDED` too.
#[derive(Default)]
struct Ledger {
    absorbed: Vec<(usize, f64)>,
}

/// Deposits since the chunk was last absorbed, and the stop flag to raise after `stop_after`
/// deposits in all (0: never).
struct LedgerChunk {
    weights: Vec<f64>,
}

static RECORDED: AtomicU64 = AtomicU64::new(0);
static STOP_AFTER: AtomicU64 = AtomicU64::new(0);
static STOP: AtomicBool = AtomicBool::new(false);

impl metropolis::Recorder<PrimaryState> for LedgerChunk {
    fn record(&mut self, _: &PrimaryState, weight: f64) {
        self.weights.push(weight);
        let n = RECORDED.fetch_add(1, Ordering::Relaxed) + 1;
        if n == STOP_AFTER.load(Ordering::Relaxed) {
            STOP.store(true, Ordering::Relaxed);
        }
    }
}

impl metropolis::Sink<PrimaryState> for Ledger {
    type Chunk = LedgerChunk;
    fn chunk(&self) -> LedgerChunk {
        LedgerChunk {
            weights: Vec::new(),
        }
    }
    fn absorb(&mut self, chunk: &mut LedgerChunk) {
        let sum: f64 = chunk.weights.iter().sum();
        self.absorbed.push((chunk.weights.len(), sum));
        chunk.weights.clear();
    }
    fn mutations_done(&mut self, _: u64, _: f64) {}
}

/// The driver hands every deposit the chains make to the sink exactly once, in an order that does
/// not depend on the thread count: it absorbs one slice's deposits while the chains make the
/// next, so this checks the last slice of every round and of a render stopped between slices.
/// MMLT on `cornell`, many slices per round (1 000 chains, 8 rounds); the same sequence of
/// absorbed chunks (deposit count and weight sum) on 1, 2 and 3 threads, and as many deposits
/// absorbed as recorded, also when a stop is raised half-way through a round.
#[test]
fn every_deposit_reaches_the_sink_once_in_an_order_independent_of_threads() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let m = mmlt();
    let mut s = settings(1000, 24.0, 5);
    s.chains = 1000;
    let run = |threads: usize, stop_after: u64| {
        with_threads(threads, || {
            RECORDED.store(0, Ordering::Relaxed);
            STOP_AFTER.store(stop_after, Ordering::Relaxed);
            STOP.store(false, Ordering::Relaxed);
            let mut ledger = Ledger::default();
            let stats =
                metropolis::run_with(&scene, &m, &s, &mut ledger, Some(&STOP), |_, _, _| true)
                    .unwrap();
            let recorded = RECORDED.load(Ordering::Relaxed);
            let absorbed: u64 = ledger.absorbed.iter().map(|(n, _)| *n as u64).sum();
            assert_eq!(
                absorbed, recorded,
                "{threads} threads, stop after {stop_after}"
            );
            (ledger.absorbed, stats.interrupted)
        })
    };
    let (one, interrupted) = run(1, 0);
    assert!(!interrupted);
    assert!(
        one.len() > 64 * 16,
        "{} chunks absorbed: too few slices",
        one.len()
    );
    assert_eq!(run(2, 0).0, one);
    assert_eq!(run(3, 0).0, one);
    let total: u64 = one.iter().map(|(n, _)| *n as u64).sum();
    let (stopped, interrupted) = run(2, total / 2);
    assert!(interrupted);
    assert!(stopped.len() < one.len());
}
