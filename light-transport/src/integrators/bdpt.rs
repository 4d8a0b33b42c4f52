//! Bidirectional path tracing with all strategies (Veach 1997 ch. 10), MIS by the balance or
//! power heuristic. Strategy `(1, 1)` is left to `(0, 2)` as in pbrt; `(s, 1)` strategies splat.
//!
//! Each strategy's MIS weight is computed before its shadow ray, which is traced only for a
//! contribution that is not zero; with [`Bdpt::shadow_roulette`], small contributions trace it
//! only by Russian roulette ([`super::shadow_roulette`]).

use super::shadow_roulette::ShadowRoulette;
use super::{Estimator, Splat};
use crate::path::{
    MisHeuristic, Roulette, Vertex, WalkSettings, camera_subpath_with, connect_unoccluded,
    light_subpath_with, mis_weight, unoccluded,
};
use crate::sampler::IndependentStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::ChainRng;
use std::cell::RefCell;

thread_local! {
    static SUBPATHS: RefCell<(Vec<Vertex>, Vec<Vertex>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// BDPT settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bdpt {
    /// Path length limit.
    pub walk: WalkSettings,
    /// MIS heuristic.
    pub heuristic: MisHeuristic,
    /// Russian roulette in both subpath walks (`None`: every walk runs to the length limit).
    pub roulette: Option<Roulette>,
    /// Russian roulette on the shadow rays of weighted contributions below its threshold
    /// (`None`: every shadow ray is traced). Used by BDPT's own samples, never by PSSMLT's
    /// evaluation of a state (which must be a deterministic function of its numbers).
    pub shadow_roulette: Option<ShadowRoulette>,
}

impl Bdpt {
    /// Sum of the MIS-weighted contributions of every strategy of a pair of subpaths: the pixel
    /// estimate is returned, `(s, 1)` contributions are pushed to `splats`. With `rng`, shadow
    /// rays follow [`Bdpt::shadow_roulette`] (module docs); without, every one is traced.
    pub fn evaluate(
        &self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        splats: &mut Vec<Splat>,
        mut rng: Option<&mut ChainRng>,
    ) -> Rgb {
        let mut l = Rgb::BLACK;
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let edges = s + t - 1;
                if (s == 1 && t == 1) || edges < 1 || edges > self.walk.max_edges {
                    continue;
                }
                let Some(c) = connect_unoccluded(scene, light, camera, s, t) else {
                    continue;
                };
                let w = mis_weight(scene, light, camera, s, t, self.heuristic);
                if w == 0.0 {
                    continue;
                }
                let mut value = c.value * w;
                if s > 0 {
                    if let (Some(roulette), Some(rng)) = (self.shadow_roulette, rng.as_deref_mut())
                    {
                        let Some(boost) = roulette.survive(value.luminance(), rng) else {
                            continue;
                        };
                        value *= boost;
                    }
                    if !unoccluded(scene, &light[s - 1], &camera[t - 1]) {
                        continue;
                    }
                }
                match c.raster {
                    Some(r) => splats.push((r, value)),
                    None => l += value,
                }
            }
        }
        l
    }
}

impl Estimator for Bdpt {
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut IndependentStream,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            camera_subpath_with(
                scene,
                stream,
                self.walk.max_camera_vertices(),
                Some(pixel),
                self.roulette,
                cam,
            );
            light_subpath_with(
                scene,
                stream,
                self.walk.max_light_vertices(),
                self.roulette,
                light,
            );
            self.evaluate(scene, light, cam, splats, Some(&mut stream.rng))
        })
    }
    fn splats(&self) -> bool {
        true
    }
}
