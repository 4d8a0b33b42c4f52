//! Bidirectional path tracing with all strategies (Veach 1997 ch. 10), MIS by the balance or
//! power heuristic. Strategy `(1, 1)` is left to `(0, 2)` as in pbrt; `(s, 1)` strategies splat.

use super::{Estimator, Splat};
use crate::path::{
    MisHeuristic, Roulette, Vertex, WalkSettings, camera_subpath_with, connect, light_subpath_with,
    mis_weight,
};
use crate::sampler::IndependentStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
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
}

impl Bdpt {
    /// Sum of the MIS-weighted contributions of every strategy of a pair of subpaths: the pixel
    /// estimate is returned, `(s, 1)` contributions are pushed to `splats`.
    pub fn evaluate(
        &self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        let mut l = Rgb::BLACK;
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let edges = s + t - 1;
                if (s == 1 && t == 1) || edges < 1 || edges > self.walk.max_edges {
                    continue;
                }
                let Some(c) = connect(scene, light, camera, s, t) else {
                    continue;
                };
                let w = mis_weight(scene, light, camera, s, t, self.heuristic);
                if w == 0.0 {
                    continue;
                }
                match c.raster {
                    Some(r) => splats.push((r, c.value * w)),
                    None => l += c.value * w,
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
            self.evaluate(scene, light, cam, splats)
        })
    }
    fn splats(&self) -> bool {
        true
    }
}
