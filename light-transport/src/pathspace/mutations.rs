//! The mutation set of path-space MLT and one Metropolis–Hastings step over it: a mutation is
//! chosen with fixed probabilities (independent of the state, so each mutation's own balance
//! makes the mixture balanced), proposes a candidate with the log of its acceptance ratio, and the
//! chain decides. Mutations that do not apply to the current path, or whose construction fails,
//! count as rejected proposals (the current path is recorded with weight 1) and are counted.

use super::bidirectional::{Bidirectional, NewPath};
use super::lens_subpath::lens_subpath;
use super::perturbation::{CameraSide, PerturbationSettings, camera_side, caustic};
use super::state::PathState;
use crate::metropolis::ImportanceKind;
use crate::scene::Scene;
use crate::{Error, Result};
use mcmc_core::kernel::Observer;
use mcmc_core::rng::{categorical, uniform};
use mcmc_core::{Chain, ChainRng};
use std::fmt;
use std::str::FromStr;

/// The mutations of Veach & Guibas plus the new-path mutation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MutationKind {
    /// Replace a subpath by a bidirectionally sampled one, possibly of another length.
    Bidirectional,
    /// Replace the lens subpath `[^S] S* E`.
    LensSubpath,
    /// Offset the image position and follow the eye's specular chain.
    Lens,
    /// Offset the direction leaving the last non-specular vertex before the eye's.
    Caustic,
    /// Lens perturbation continued through further specular chains.
    MultiChain,
    /// A whole new path (independence sampler).
    NewPath,
}

impl MutationKind {
    /// All kinds, in statistics order.
    pub const ALL: [MutationKind; 6] = [
        MutationKind::Bidirectional,
        MutationKind::LensSubpath,
        MutationKind::Lens,
        MutationKind::Caustic,
        MutationKind::MultiChain,
        MutationKind::NewPath,
    ];

    /// The name used on the command line and in statistics.
    pub fn name(&self) -> &'static str {
        match self {
            MutationKind::Bidirectional => "bidirectional",
            MutationKind::LensSubpath => "lens-subpath",
            MutationKind::Lens => "lens",
            MutationKind::Caustic => "caustic",
            MutationKind::MultiChain => "multi-chain",
            MutationKind::NewPath => "new-path",
        }
    }
}

/// Selection probabilities of the mutations (normalised when used).
///
/// Defaults: bidirectional 0.25, lens subpath 0.1, lens 0.2, caustic 0.2, multi-chain 0.15, new
/// path 0.1 — the bidirectional and new-path mutations keep the chain ergodic, the perturbations
/// explore locally (their shares follow the practical-MLT paper's equal use of perturbations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MutationProbabilities(pub [f64; 6]);

impl Default for MutationProbabilities {
    fn default() -> Self {
        Self([0.25, 0.1, 0.2, 0.2, 0.15, 0.1])
    }
}

impl MutationProbabilities {
    /// Only `kind` and the new-path mutation, half each (the per-mutation convergence tests).
    pub fn with_new_path(kind: MutationKind) -> Self {
        let mut p = [0.0; 6];
        p[kind as usize] += 0.5;
        p[MutationKind::NewPath as usize] += 0.5;
        Self(p)
    }

    /// The perturbations only (energy redistribution path tracing): lens 0.4, caustic 0.3,
    /// multi-chain 0.3.
    pub fn perturbations() -> Self {
        Self([0.0, 0.0, 0.4, 0.3, 0.3, 0.0])
    }

    /// The probability of `kind`, normalised.
    pub fn of(&self, kind: MutationKind) -> f64 {
        self.0[kind as usize] / self.0.iter().sum::<f64>()
    }

    /// Check: non-negative, finite, not all zero.
    pub fn validate(&self) -> Result<()> {
        let total: f64 = self.0.iter().sum();
        if self.0.iter().all(|p| p.is_finite() && *p >= 0.0) && total > 0.0 {
            Ok(())
        } else {
            Err(Error::InvalidParameter {
                name: "mutation probabilities".into(),
                reason: format!("need non-negative finite values, not all zero; got {self}"),
            })
        }
    }

    /// Draw a mutation kind with these probabilities.
    pub fn pick(&self, rng: &mut ChainRng) -> MutationKind {
        categorical(&self.0, uniform(rng)).map_or(MutationKind::NewPath, |i| MutationKind::ALL[i])
    }
}

impl fmt::Display for MutationProbabilities {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts: Vec<String> = MutationKind::ALL
            .iter()
            .map(|k| format!("{}={}", k.name(), self.0[*k as usize]))
            .collect();
        f.write_str(&parts.join(","))
    }
}

impl FromStr for MutationProbabilities {
    type Err = Error;

    /// `name=p,name=p,…` with the names of [`MutationKind::name`]; unnamed kinds get 0.
    fn from_str(s: &str) -> Result<Self> {
        let mut p = [0.0; 6];
        for part in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
            let bad = |reason: String| Error::InvalidParameter {
                name: "mutations".into(),
                reason,
            };
            let (name, value) = part
                .split_once('=')
                .ok_or_else(|| bad(format!("expected name=probability, got '{part}'")))?;
            let kind = MutationKind::ALL
                .into_iter()
                .find(|k| k.name() == name.trim())
                .ok_or_else(|| {
                    let names: Vec<&str> = MutationKind::ALL.iter().map(|k| k.name()).collect();
                    bad(format!(
                        "unknown mutation '{}' (known: {})",
                        name.trim(),
                        names.join(", ")
                    ))
                })?;
            p[kind as usize] = value
                .trim()
                .parse()
                .map_err(|_| bad(format!("'{}' is not a number", value.trim())))?;
        }
        let out = Self(p);
        out.validate()?;
        Ok(out)
    }
}

/// Everything a path-space chain step needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mutations {
    /// Longest path (edges).
    pub max_edges: usize,
    /// Colour to scalar.
    pub importance: ImportanceKind,
    /// Mutation selection.
    pub probabilities: MutationProbabilities,
    /// Offsets of the perturbations.
    pub perturbation: PerturbationSettings,
}

impl Mutations {
    /// Propose `y` from `x` by `kind`: the log acceptance ratio, or why no candidate was made.
    pub fn propose(
        &self,
        scene: &Scene,
        kind: MutationKind,
        new_path: &NewPath,
        x: &PathState,
        rng: &mut ChainRng,
        y: &mut PathState,
    ) -> std::result::Result<f64, mcmc_core::Failure> {
        let p = &self.perturbation;
        let imp = self.importance;
        match kind {
            MutationKind::Bidirectional => Bidirectional {
                max_edges: self.max_edges,
            }
            .propose(scene, imp, x, rng, y),
            MutationKind::LensSubpath => lens_subpath(scene, self.max_edges, imp, x, rng, y),
            MutationKind::Lens => camera_side(scene, CameraSide::Lens, p, imp, x, rng, y),
            MutationKind::MultiChain => {
                camera_side(scene, CameraSide::MultiChain, p, imp, x, rng, y)
            }
            MutationKind::Caustic => caustic(scene, p, imp, x, rng, y),
            MutationKind::NewPath => new_path.propose(scene, imp, x, rng, y),
        }
    }

    /// `n` Metropolis–Hastings steps of `chain`. Path-space chains carry no absolute density
    /// (paths with specular vertices have none): `chain.ln_density` is held at 0 and each
    /// mutation hands the whole log acceptance ratio to [`Chain::decide`].
    pub fn run<O: Observer<PathState>>(
        &self,
        scene: &Scene,
        new_path: &NewPath,
        chain: &mut Chain<PathState>,
        n: u64,
        rng: &mut ChainRng,
        observer: &mut O,
    ) {
        chain.ln_density = 0.0;
        for _ in 0..n {
            let kind = self.probabilities.pick(rng);
            match self.propose(
                scene,
                kind,
                new_path,
                &chain.state,
                rng,
                &mut chain.candidate,
            ) {
                Ok(ln_ratio) => {
                    chain.decide(0.0, ln_ratio, kind as usize, rng, observer);
                    chain.ln_density = 0.0;
                }
                Err(why) => chain.fail(kind as usize, why, observer),
            }
        }
    }

    /// Statistics names.
    pub fn kinds() -> Vec<String> {
        MutationKind::ALL
            .iter()
            .map(|k| k.name().to_string())
            .collect()
    }
}
