//! Options of the path-space integrators (`--algo mlt|erpt|memlt|mept`): mutation probabilities,
//! the perturbations' offsets, the manifold perturbation's λ and walk, and ERPT's chains.

use super::CliError;
use super::metropolis::MetropolisArgs;
use super::registry::Common;
use clap::{Args, ValueEnum};
use light_transport::manifold::{ManifoldSettings, SpecularProbability};
use light_transport::pathspace::{
    ManifoldPerturbationSettings, MutationProbabilities, Mutations, PerturbationSettings,
};
use mcmc_core::proposals::{MixtureRule, Selection};

fn parse_probabilities(s: &str) -> Result<MutationProbabilities, String> {
    s.parse().map_err(|e: light_transport::Error| e.to_string())
}

/// How a mixture of mutations reports its transition density.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Rule {
    /// Each mutation's own ratio (Tierney 1998; seed 002 eq. 5).
    PerComponent,
    /// The ratio of the whole mixture's densities `Σ_k P_k T_k` (seed 002 eq. 4).
    Combined,
}

/// How mutations are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Choice {
    /// With their weights, restricted to those that apply to the current path (exact: the
    /// selection probabilities enter the acceptance).
    Suitable,
    /// With fixed weights; mutations that do not apply count as rejected proposals.
    Fixed,
}

/// Path-space MLT and ERPT options.
#[derive(Args, Debug, Clone)]
pub struct PathSpaceArgs {
    /// Mutation probabilities of `mlt` (and of cmlt's path-space moves), `name=p,...` over
    /// bidirectional, lens-subpath, lens, caustic, multi-chain, new-path (unnamed kinds get 0;
    /// normalised).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "bidirectional=0.25,lens-subpath=0.1,lens=0.2,caustic=0.2,multi-chain=0.15,new-path=0.1"
    )]
    pub mutations: MutationProbabilities,
    /// Mutation probabilities of `erpt` (default: the perturbations only).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "lens=0.4,caustic=0.3,multi-chain=0.3"
    )]
    pub erpt_mutations: MutationProbabilities,
    /// Transition densities of the mutation mixture: each mutation's own, or the combined
    /// `Σ P_k T_k` of all of them.
    #[arg(long, value_enum, default_value_t = Rule::PerComponent)]
    pub mixture_rule: Rule,
    /// How mutations are chosen: among those that apply to the current path, or blindly.
    #[arg(long, value_enum, default_value_t = Choice::Suitable)]
    pub mutation_choice: Choice,
    /// Smallest pixel offset of the lens and multi-chain perturbations (pixels).
    #[arg(long, default_value_t = 0.1)]
    pub r1: f64,
    /// Largest pixel offset, as a fraction of the image width.
    #[arg(long, default_value_t = 0.1)]
    pub r2: f64,
    /// Smallest angular offset of the caustic and multi-chain perturbations (radians).
    #[arg(long, default_value_t = 1e-4)]
    pub theta1: f64,
    /// Largest angular offset (radians).
    #[arg(long, default_value_t = 0.1)]
    pub theta2: f64,
    /// Mutation probabilities of `memlt` (manifold exploration MLT).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "bidirectional=0.3,manifold-light=0.3,manifold-eye=0.3,new-path=0.1"
    )]
    pub memlt_mutations: MutationProbabilities,
    /// Mutation probabilities of `mept` (manifold exploration path tracing).
    #[arg(
        long,
        value_parser = parse_probabilities,
        default_value = "manifold-light=0.5,manifold-eye=0.5"
    )]
    pub mept_mutations: MutationProbabilities,
    /// Manifold perturbation: its density at the current direction is λ² times the sampling
    /// density there (larger: smaller steps; the paper uses 50–500).
    #[arg(long, default_value_t = 50.0)]
    pub lambda: f64,
    /// Tune λ in a warm-up (not recorded) toward this acceptance of the manifold perturbation,
    /// starting from --lambda, then freeze it (memlt, mept).
    #[arg(long)]
    pub lambda_target: Option<f64>,
    /// Manifold walk: most iterations.
    #[arg(long, default_value_t = 20)]
    pub manifold_iterations: usize,
    /// Manifold walk: convergence tolerance relative to the scene's diagonal.
    #[arg(long, default_value_t = 1e-7)]
    pub manifold_epsilon: f64,
    /// Manifold perturbation: let glossy vertices join specular chains, walked on offset manifolds,
    /// with the specular probability ψ of Jakob & Marschner 2012, eq. 28 (false: glossy vertices
    /// are always the chains' free ends).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub manifold_glossy: bool,
    /// ψ: the quantile q of the microfacet normals' angle that marks a glossy lobe's
    /// high-density cone.
    #[arg(long, default_value_t = 0.9)]
    pub specular_quantile: f64,
    /// ψ: Δθ, the expected change (radians) of a free glossy vertex's microfacet normal in one
    /// perturbation. Default: measured by a pilot before rendering (memlt, mlt and mept with
    /// manifold moves), as the paper does; 0.05 where no pilot runs (cmlt).
    #[arg(long)]
    pub normal_change: Option<f64>,
    /// ERPT: mutations per chain.
    #[arg(long, default_value_t = 100)]
    pub erpt_chain_length: u64,
    /// ERPT: chains started per pixel sample on average (sets the energy quantum).
    #[arg(long, default_value_t = 1.0)]
    pub erpt_chains: f64,
    /// ERPT: most chains one seed starts; a brighter seed's chains share its energy (README).
    #[arg(long, default_value_t = 100)]
    pub erpt_max_chains: u64,
}

impl PathSpaceArgs {
    /// The perturbations' offsets.
    pub fn perturbation(&self) -> PerturbationSettings {
        PerturbationSettings {
            r1: self.r1,
            r2_fraction: self.r2,
            theta1: self.theta1,
            theta2: self.theta2,
        }
    }

    /// The manifold perturbation's settings.
    pub fn manifold(&self) -> ManifoldPerturbationSettings {
        ManifoldPerturbationSettings {
            lambda: self.lambda,
            walk: ManifoldSettings {
                max_iterations: self.manifold_iterations,
                epsilon: self.manifold_epsilon,
            },
            specular: SpecularProbability {
                glossy: self.manifold_glossy,
                quantile: self.specular_quantile,
                normal_change: self.normal_change,
            },
            target_acceptance: self.lambda_target,
            tuning: None,
            pilot: None,
            defect: None,
        }
    }

    /// A mutation set with `probabilities` (validated).
    pub fn mutations(
        &self,
        c: &Common,
        m: &MetropolisArgs,
        probabilities: &MutationProbabilities,
    ) -> Result<Mutations, CliError> {
        let mutations = Mutations {
            max_edges: c.max_edges,
            min_edges: 1,
            importance: m.importance(),
            probabilities: probabilities.clone(),
            perturbation: self.perturbation(),
            manifold: self.manifold(),
            rule: match self.mixture_rule {
                Rule::PerComponent => MixtureRule::PerComponent,
                Rule::Combined => MixtureRule::Combined,
            },
            selection: match self.mutation_choice {
                Choice::Suitable => Selection::Suitability,
                Choice::Fixed => Selection::Fixed,
            },
            photon: Default::default(),
        };
        mutations.validate()?;
        Ok(mutations)
    }
}
