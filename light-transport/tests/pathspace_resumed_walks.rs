//! A candidate that keeps vertices of its source path resumes the source's walks
//! (`FullPath::strategies_resumed`) instead of walking its whole path anew. This file checks, for
//! every registered path-space mutation on every built-in scene, that a candidate's evaluation —
//! its strategies' importances, its splat, and the walks its own candidates will resume — is bit
//! for bit that of evaluating the same path from scratch.
//!
//! Chains run with the default mixture plus the manifold perturbations (accepting by the reported
//! ratio, so the states are those a render meets); every evaluated candidate is compared. The
//! check is exact, so it has no false positives. It fails when the walks resume one step too late
//! (entry `kept` taken from the source too; tried by hand: a manifold perturbation's candidate on
//! `cornell` differs). The check of kept vertices against the source's positions and delta flags
//! is a guard this file cannot exercise: every mutation's record of what it kept is exact (no kept
//! vertex changed its delta flag in these chains).

use light_transport::metropolis::ImportanceKind;
use light_transport::pathspace::{Mutations, NewPath, PathState, Traced, Walks};
use light_transport::sampler::IndependentStream;
use light_transport::scene::{Scene, builtin};
use mcmc_core::rng::{stream, uniform};

const MAX_EDGES: usize = 7;
const STEPS: usize = 20_000;

/// One walk entry, bit for bit.
type EntryBits = [u64; 10];

fn bits(t: &Traced) -> EntryBits {
    let [a, b, c] = t.wo.to_array();
    let d = t.beta;
    let e = t.f_next;
    [a, b, c, d[0], d[1], d[2], t.pdf_fwd, e[0], e[1], e[2]].map(f64::to_bits)
}

/// The walks' valid entries, as bits.
fn walk_bits(w: &Walks) -> Option<(Vec<EntryBits>, Vec<EntryBits>)> {
    let (l, c) = w.valid()?;
    Some((
        w.light[..l].iter().map(bits).collect(),
        w.camera[..c].iter().map(bits).collect(),
    ))
}

fn state_bits(s: &PathState) -> (Vec<u64>, Vec<[u64; 3]>, u64) {
    (
        s.strategy.iter().map(|v| v.to_bits()).collect(),
        s.contribution
            .splats
            .iter()
            .map(|(r, c)| [r[0].to_bits(), r[1].to_bits(), c.luminance().to_bits()])
            .collect(),
        s.contribution.importance.to_bits(),
    )
}

#[test]
fn resumed_walks_equal_walking_anew() {
    let importance = ImportanceKind::Luminance;
    let mut mutations = Mutations::new(MAX_EDGES);
    mutations.importance = importance;
    let names: Vec<String> = light_transport::pathspace::mutations::names();
    let mut resumed_total = 0usize;
    for (scene_index, name) in builtin::all().into_iter().enumerate() {
        let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((48, 32))).unwrap();
        let settings = mutations.settings(NewPath::uniform(MAX_EDGES));
        let kinds: Vec<_> = names
            .iter()
            .map(|n| Mutations::mutation(&scene, &settings, n).expect("registered"))
            .collect();
        let mut rng = stream(31, scene_index as u64);
        // A first state carrying light.
        let mut sampler = IndependentStream::new(stream(32, scene_index as u64));
        let mut x = PathState::default();
        let mut found = false;
        for i in 0..100_000 {
            sampler.new_sample();
            let k = 1 + i % MAX_EDGES;
            if NewPath::sample(&scene, importance, k, &mut sampler, &mut x) && x.carries_light() {
                found = true;
                break;
            }
        }
        assert!(found, "{name}: no path carries light");
        let mut y = PathState::default();
        let (mut compared, mut resumed) = (0usize, 0usize);
        let mut per_kind = vec![0usize; kinds.len()];
        for _ in 0..STEPS {
            let pick = ((uniform(&mut rng) * kinds.len() as f64) as usize).min(kinds.len() - 1);
            let m = &kinds[pick];
            if m.suitability(&x) == 0.0 {
                continue;
            }
            let Ok(ratio) = m.propose_ratio(&x, &mut rng, &mut y) else {
                continue;
            };
            if y.walks.valid().is_some() {
                let mut fresh = PathState {
                    path: y.path.clone(),
                    ..Default::default()
                };
                fresh.evaluate(&scene, importance, 1.0);
                assert_eq!(
                    state_bits(&y),
                    state_bits(&fresh),
                    "{name}: {} candidate's evaluation differs",
                    names[pick]
                );
                assert_eq!(
                    walk_bits(&y.walks),
                    walk_bits(&fresh.walks),
                    "{name}: {} candidate's walks differ",
                    names[pick]
                );
                compared += 1;
                if let Some(c) = y.change {
                    let kept_camera = x.path.vertices.len().saturating_sub(c.m);
                    if c.l >= 1 || kept_camera >= 2 {
                        resumed += 1;
                        per_kind[pick] += 1;
                    }
                }
            }
            if ratio > f64::NEG_INFINITY && uniform(&mut rng).ln() < ratio {
                std::mem::swap(&mut x, &mut y);
            }
        }
        println!(
            "{name}: {compared} candidates compared, {resumed} resumed walks ({})",
            names
                .iter()
                .zip(&per_kind)
                .filter(|(_, n)| **n > 0)
                .map(|(n, c)| format!("{n} {c}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        assert!(
            resumed > 200,
            "{name}: only {resumed} of {compared} candidates resumed walks"
        );
        resumed_total += resumed;
    }
    assert!(resumed_total > 2_000);
}
