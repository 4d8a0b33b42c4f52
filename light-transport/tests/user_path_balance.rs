//! The user-path proposal of Metropolis photon sampling (Fan, Chenney & Lai 2005, §5), mixed with
//! the bidirectional mutation as the hybrid of eq. 7, keeps the path-space target invariant —
//! `mcmc-core`'s invariance check on a small path space where the target can be drawn exactly.
//!
//! The scene: a diffuse floor lit only through a diffuse ceiling, by a small square emitter
//! facing up; the camera sees the floor (and the emitter's black underside), so with at most three
//! edges only paths `light → ceiling → floor → lens` carry light. Exact draws by rejection:
//! strategy `s = 1` — a light point uniform on the emitter, a camera ray through a uniform raster
//! position to the floor, a cosine-sampled bounce to the ceiling — accepted with
//! `I(C*_1)/M = I(f)/(M p_1)`, `M` twice the largest value in a pilot of 100 000 draws (every value
//! met is checked against it). Two user paths from the emitter to the ceiling, cones of 30°: a
//! user-path move replaces the light and ceiling points and keeps the floor point.
//!
//! Checks (seeded; α = 1e-4, Bonferroni over the five features: light point x and z, ceiling
//! point x and z, raster x): invariance after 2 steps of the hybrid (bidirectional 0.5, user path
//! 0.5). Test of the test: user-path candidates accepted with the bidirectional mutation's ratio
//! (`UserPathRule::BidirectionalRatio`, "the bidirectional mutation can make any path") are
//! caught. The
//! per-component rule is exact but useless (its moves are never accepted from paths away from the
//! user paths; see `pathspace_densities.rs`), so it passes here.

use light_transport::bsdf::TransportMode;
use light_transport::math::DVec3;
use light_transport::metropolis::ImportanceKind;
use light_transport::path::{Vertex, VertexKind, unoccluded};
use light_transport::pathspace::walk::{lens_endpoint, light_endpoint, trace};
use light_transport::pathspace::{
    FullPath, MutationProbabilities, Mutations, NewPath, PathState, PhotonProposals, UserPathRule,
    UserPaths,
};
use light_transport::scene::Scene;
use light_transport::scene::builtin::SceneBuilder;
use light_transport::spectrum::Rgb;
use mcmc_core::balance::invariance::{InvarianceConfig, invariance};
use mcmc_core::rng::{stream, uniform};
use mcmc_core::{Chain, ChainRng};
use std::sync::{Arc, OnceLock};

const ALPHA: f64 = 1e-4;
const K: usize = 3;
const USER_PATHS: &str = "\
# two paths from the emitter to the ceiling
path beta=30
0.05 1.0 -0.08
0.5 2.0 0.3
path beta=30
-0.1 1.0 0.05
-0.6 2.0 -0.5
";

fn scene() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| {
        let mut b = SceneBuilder::new(
            48,
            36,
            DVec3::new(0.0, 0.9, 2.5),
            DVec3::new(0.0, 0.0, 0.0),
            40.0,
        );
        let floor = b.matte(0.7, 0.6, 0.5);
        let ceiling = b.matte(0.6, 0.6, 0.6);
        let black = b.matte(0.0, 0.0, 0.0);
        b.quad(
            DVec3::new(-1.5, 0.0, -1.5),
            DVec3::Z * 3.0,
            DVec3::X * 3.0,
            floor,
            None,
        );
        b.quad(
            DVec3::new(-1.5, 2.0, -1.5),
            DVec3::X * 3.0,
            DVec3::Z * 3.0,
            ceiling,
            None,
        );
        // The emitter faces up (normal Z × X = +y).
        b.quad(
            DVec3::new(-0.2, 1.0, -0.2),
            DVec3::Z * 0.4,
            DVec3::X * 0.4,
            black,
            Some(Rgb::new(8.0, 7.0, 6.0)),
        );
        Scene::new(&b.finish(), None).expect("scene")
    })
}

/// A candidate for the rejection sampler: a path of 3 edges by strategy `s = 1`, and
/// `I(C*_1)` (0 when the connection to the light is blocked or nothing is carried).
fn candidate(rng: &mut ChainRng) -> Option<(PathState, f64)> {
    let scene = scene();
    let k = 3;
    let x0 = light_endpoint(scene, rng)?;
    let mut lens = lens_endpoint(scene, rng)?;
    lens.kind = VertexKind::Camera;
    let raster = [
        uniform(rng) * scene.camera.width as f64,
        uniform(rng) * scene.camera.height as f64,
    ];
    let w = scene.camera.ray_through(lens.p(), raster)?.ray.d;
    let mut camera: Vec<Vertex> = vec![lens];
    let first = trace(scene, &camera[0], w)?;
    camera.push(first);
    if k == 3 {
        let v = &camera[1];
        let b = v.bsdf.as_ref()?;
        let s = b.sample(
            v.wo,
            uniform(rng),
            [uniform(rng), uniform(rng)],
            TransportMode::Radiance,
        )?;
        let next = trace(scene, v, s.wi)?;
        camera.push(next);
    }
    if !unoccluded(scene, &x0, &camera[camera.len() - 1]) {
        return Some((PathState::default(), 0.0));
    }
    let mut vertices: Vec<Vertex> = vec![x0];
    vertices.extend(camera.into_iter().rev());
    for i in 1..vertices.len() {
        vertices[i].wo = (vertices[i - 1].p() - vertices[i].p()).normalize();
    }
    let mut s = PathState {
        path: FullPath { vertices },
        ..Default::default()
    };
    if !s.evaluate(scene, ImportanceKind::Luminance, 1.0) {
        return Some((s, 0.0));
    }
    let v = s.strategy_importance(1);
    Some((s, v))
}

fn bound() -> f64 {
    static B: OnceLock<f64> = OnceLock::new();
    *B.get_or_init(|| {
        let mut rng = stream(0xB1, 0);
        let top = (0..100_000)
            .filter_map(|_| candidate(&mut rng))
            .map(|c| c.1)
            .fold(0.0f64, f64::max);
        assert!(top > 0.0, "no light in the pilot");
        2.0 * top
    })
}

fn exact_draw(rng: &mut ChainRng) -> PathState {
    let m = bound();
    loop {
        let Some((s, v)) = candidate(rng) else {
            continue;
        };
        assert!(v <= m, "rejection bound violated: {v} > {m}");
        if v > 0.0 && uniform(rng) * m < v {
            return s;
        }
    }
}

fn features(s: &PathState) -> Vec<f64> {
    let v = &s.path.vertices;
    let r = s.raster().unwrap_or([f64::NAN; 2]);
    vec![v[0].p().x, v[0].p().z, v[1].p().x, v[1].p().z, r[0]]
}

fn mutations(rule: UserPathRule) -> Mutations {
    let paths = UserPaths::parse(USER_PATHS, "user_path_balance.rs", scene()).expect("user paths");
    Mutations {
        probabilities: MutationProbabilities::of(&[("bidirectional", 0.5), ("user-path", 0.5)])
            .expect("probabilities"),
        photon: PhotonProposals {
            user_paths: Arc::new(paths),
            user_path_rule: rule,
            ..Default::default()
        },
        importance: ImportanceKind::Luminance,
        ..Mutations::new(K)
    }
}

/// The invariance check of `rule`'s kernel; also the user-path acceptance it saw.
fn check(rule: UserPathRule, seed: u64) -> (bool, String, f64) {
    let m = mutations(rule);
    m.validate().expect("valid");
    let proposal = m.proposal(scene(), NewPath::uniform(K)).expect("mixture");
    let mut stats = mcmc_core::Stats::default();
    let r = invariance(
        exact_draw,
        |s: &mut PathState, rng: &mut ChainRng| {
            let mut c = Chain::unchecked(std::mem::take(s), 0.0);
            m.run(&proposal, &mut c, 1, rng, &mut ());
            stats.merge(&c.stats);
            *s = c.state;
        },
        features,
        &InvarianceConfig {
            replicates: 6000,
            steps: 2,
            alpha: ALPHA,
            categorical: vec![],
        },
        &mut stream(seed, 0),
    )
    .expect("check runs");
    let up = &stats.kinds[1];
    let acceptance = up.accepted as f64 / up.proposed.max(1) as f64;
    (r.passed, r.to_string(), acceptance)
}

#[test]
fn the_user_path_hybrid_keeps_the_target() {
    let (ok, report, acceptance) = check(UserPathRule::Hybrid, 1);
    println!(
        "hybrid (eq. 7): user-path acceptance {:.1}%\n{report}",
        100.0 * acceptance
    );
    assert!(acceptance > 0.05, "user-path moves are hardly accepted");
    assert!(ok, "{report}");
}

#[test]
fn user_path_moves_accepted_with_the_bidirectional_ratio_are_caught() {
    let (ok, report, acceptance) = check(UserPathRule::BidirectionalRatio, 1);
    println!(
        "the bidirectional ratio: user-path acceptance {:.1}%\n{report}",
        100.0 * acceptance
    );
    assert!(!ok, "the wrong mix went unnoticed: {report}");
}
