//! Charted MLT converges to BDPT.
//!
//! * The default configuration (small and large steps in technique charts, serial-tempering chart
//!   swaps on average every 16 mutations) on every built-in scene.
//! * With inverse primary-space perturbations, and with path-space mutations joining the chain
//!   (the identity chart), on the Cornell box (specular spheres) and the door (layered table).
//! * Swaps are accepted at a healthy rate and never fail to invert.
//! * A chart swap that forgets the proposal ratio `q(s)/q(s')` is caught.
//!
//! Statistical verdicts as in `metropolis.rs`: Welch t-tests per 6×6 block between 8 independent
//! runs and 16 BDPT batches, Holm-corrected, α = 1e-4 per comparison (8 comparisons here).

mod common;

use common::{
    ALPHA, H, MAX_EDGES, W, bdpt_batches, blocks, blocks_and_stats, metropolis_runs, min_p,
    settings,
};
use light_transport::cmlt::{Cmlt, CmltState, TechniqueChart};
use light_transport::film::Image;
use light_transport::metropolis::{ImportanceKind, Method};
use light_transport::pathspace::{MutationProbabilities, Mutations};
use light_transport::scene::{Scene, builtin};
use mcmc_charts::Chart;
use mcmc_core::kernel::Observer;
use mcmc_core::proposals::SmallStep;
use mcmc_core::rng::uniform;
use mcmc_core::{Chain, ChainRng, Failure, Stats};

fn scene(name: &str) -> Scene {
    Scene::new(&builtin::builtin(name).unwrap(), Some((W, H))).unwrap()
}

fn cmlt(scene: &Scene, ipsm: f64, pathspace: f64) -> Cmlt {
    Cmlt::new(
        scene,
        MAX_EDGES,
        ImportanceKind::Luminance,
        SmallStep::default(),
        0.3,
        16.0,
        ipsm,
        pathspace,
        Mutations {
            max_edges: MAX_EDGES,
            importance: ImportanceKind::Luminance,
            probabilities: MutationProbabilities::default(),
            perturbation: Default::default(),
        },
        500,
    )
    .unwrap()
}

fn runs(scene: &Scene, m: &Cmlt) -> (Vec<Vec<f64>>, Stats) {
    blocks_and_stats(metropolis_runs(scene, m, settings(4000, 32.0, 131), 8))
}

fn rate(stats: &Stats, kind: usize) -> f64 {
    stats
        .kinds
        .get(kind)
        .map_or(f64::NAN, |k| k.acceptance_rate())
}

#[test]
fn cmlt_converges_to_bdpt_on_every_builtin_scene() {
    for name in builtin::BUILTIN {
        let scene = scene(name);
        let m = cmlt(&scene, 0.0, 0.0);
        let (images, stats) = runs(&scene, &m);
        let p = min_p(&images, &bdpt_batches(&scene));
        let swaps = &stats.kinds[2];
        println!(
            "{name}: p = {p:.3e}, small {:.1}%, large {:.1}%, swap {:.1}% ({} proposed, {} failed)",
            100.0 * rate(&stats, 0),
            100.0 * rate(&stats, 1),
            100.0 * rate(&stats, 2),
            swaps.proposed,
            swaps.failed
        );
        assert!(swaps.proposed > 0 && swaps.accepted > 0);
        assert_eq!(swaps.failed, 0, "{name}: an inversion failed");
        assert!(p > ALPHA, "{name}: CMLT disagrees with BDPT (p = {p:.2e})");
    }
}

#[test]
fn cmlt_with_ipsm_and_path_space_mutations_converges_to_bdpt() {
    for name in ["cornell", "door"] {
        let scene = scene(name);
        let reference = bdpt_batches(&scene);
        for (ipsm, pathspace) in [(0.3, 0.0), (0.0, 0.3)] {
            let (images, stats) = runs(&scene, &cmlt(&scene, ipsm, pathspace));
            let p = min_p(&images, &reference);
            println!(
                "{name} ipsm {ipsm} pathspace {pathspace}: p = {p:.3e}, ipsm acceptance {:.1}%",
                100.0 * rate(&stats, 3)
            );
            assert!(
                p > ALPHA,
                "{name}: CMLT with ipsm {ipsm}, path-space {pathspace} disagrees with BDPT (p = {p:.2e})"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A chart swap that forgets the proposal ratio q(s)/q(s') in its acceptance.

struct SwapWithoutProposalRatio(Cmlt);

impl Method for SwapWithoutProposalRatio {
    type State = CmltState;
    fn groups(&self) -> usize {
        self.0.groups()
    }
    fn independent(&self, scene: &Scene, g: usize, seed: u64) -> CmltState {
        self.0.independent(scene, g, seed)
    }
    fn mutate<O: Observer<CmltState>>(
        &self,
        scene: &Scene,
        chain: &mut Chain<CmltState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        // Let the real integrator undo the bootstrap scaling and set the density.
        self.0.mutate(scene, chain, 0, rng, observer);
        for _ in 0..n {
            if uniform(rng) >= 0.5 {
                self.0.in_chart(scene, chain, rng, observer);
                continue;
            }
            let (k, i) = (chain.state.k, chain.state.chart);
            let q = &self.0.swap_proposal[k - 1];
            let mut v = uniform(rng);
            let j = q
                .iter()
                .position(|p| {
                    let hit = v < *p;
                    v -= p;
                    hit
                })
                .unwrap_or(k);
            let (pi, pj) = (
                chain.state.x.strategy_importance(i),
                chain.state.x.strategy_importance(j),
            );
            let chart = TechniqueChart::new(scene, k, j, ImportanceKind::Luminance).unwrap();
            chain.candidate.clone_from(&chain.state);
            chain.candidate.u.resize(chart.dim(), 0.0);
            if !(pj > 0.0) || !chart.invert(&chain.state.x, &mut chain.candidate.u, rng) {
                chain.fail(2, Failure::NotApplicable, observer);
                continue;
            }
            chain.candidate.chart = j;
            let ln = chain.ln_density;
            // Missing: + ln q(i) − ln q(j).
            chain.decide(ln, pi.ln() - pj.ln(), 2, rng, observer);
        }
    }
    fn kinds(&self) -> Vec<String> {
        self.0.kinds()
    }
}

/// Swap proposals far from the technique energies, `q(s) ∝ 32^s`: any proposal is valid when its
/// ratio is in the acceptance, and the further it is from the balance weights, the larger the
/// error of a swap that forgets it.
fn skewed(mut m: Cmlt) -> Cmlt {
    for q in &mut m.swap_proposal {
        let total: f64 = (0..q.len()).map(|s| 32f64.powi(s as i32)).sum();
        for (s, p) in q.iter_mut().enumerate() {
            *p = 32f64.powi(s as i32) / total;
        }
    }
    m
}

fn images<M: Method>(scene: &Scene, m: &M) -> Vec<Vec<f64>> {
    metropolis_runs(scene, m, settings(4000, 128.0, 171), 8)
        .iter()
        .map(|(film, _)| blocks(&Image::from_film(film)))
        .collect()
}

#[test]
fn a_swap_without_the_proposal_ratio_is_caught() {
    let scene = scene("cornell");
    let reference = bdpt_batches(&scene);
    let mut correct = skewed(cmlt(&scene, 0.0, 0.0));
    correct.swap_every = 2.0;
    let p = min_p(&images(&scene, &correct), &reference);
    println!("skewed swap proposal: p = {p:.3e}");
    assert!(
        p > ALPHA,
        "CMLT with a skewed swap proposal disagrees (p = {p:.2e})"
    );
    let broken = SwapWithoutProposalRatio(skewed(cmlt(&scene, 0.0, 0.0)));
    let p = min_p(&images(&scene, &broken), &reference);
    println!("swap without q ratio: p = {p:.3e}");
    assert!(p < ALPHA, "the broken swap was not caught (p = {p:.2e})");
}
