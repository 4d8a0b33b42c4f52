//! Bidirectional path tracing with all strategies (Veach 1997 ch. 10), MIS by the balance or
//! power heuristic. Strategy `(1, 1)` is left to `(0, 2)` as in pbrt; `(s, 1)` strategies splat.
//!
//! A strategy's shadow ray is traced before its MIS weight is computed: the weight's density
//! evaluations cost about as much as a ray, and many connections are occluded (computing the
//! weight first made BDPT 0.80× as fast on `door`). With [`Bdpt::shadow_roulette`], the
//! unweighted contribution (an upper bound of the weighted one, `w ≤ 1`) decides the roulette
//! before the ray ([`super::shadow_roulette`]); deciding on the weighted one skips more rays but
//! needs the weight of every connection, occluded or not, and lost on `door` (0.79× the samples).

use super::shadow_roulette::ShadowRoulette;
use super::{Estimator, Splat};
use crate::path::{
    MisHeuristic, Roulette, Subpath, Vertex, WalkSettings, camera_subpath_with, connect_unoccluded,
    light_subpath_with, mis_weight, unoccluded,
};
use crate::sampler::{PixelStream, SampleStream};
use crate::scene::Scene;
use crate::spectrum::Rgb;
use mcmc_core::rng::FastRng;
use std::cell::RefCell;

thread_local! {
    static SUBPATHS: RefCell<(Subpath, Subpath)> = const { RefCell::new((Subpath::new(), Subpath::new())) };
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
    /// Russian roulette on the shadow rays of contributions whose unweighted value is below its
    /// threshold (`None`: every shadow ray is traced). Used by BDPT's own samples, never by PSSMLT's
    /// evaluation of a state (which must be a deterministic function of its numbers).
    pub shadow_roulette: Option<ShadowRoulette>,
}

impl Bdpt {
    /// Both subpaths of one sample drawn from `stream` into `camera` and `light`, with this
    /// estimator's length limits and roulette (`pixel`: as in [`camera_subpath_with`]).
    pub fn trace_subpaths<S: SampleStream>(
        &self,
        scene: &Scene,
        stream: &mut S,
        pixel: Option<usize>,
        camera: &mut Subpath,
        light: &mut Subpath,
    ) {
        camera_subpath_with(
            scene,
            stream,
            self.walk.max_camera_vertices(),
            pixel,
            Roulette::for_camera(self.roulette),
            camera,
        );
        light_subpath_with(
            scene,
            stream,
            self.walk.max_light_vertices(),
            self.roulette,
            light,
        );
    }

    /// Sum of the MIS-weighted contributions of every strategy of a pair of subpaths: the pixel
    /// estimate is returned, `(s, 1)` contributions are pushed to `splats`. With `rng`, shadow
    /// rays follow [`Bdpt::shadow_roulette`] (module docs); without, every one is traced.
    pub fn evaluate(
        &self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        splats: &mut Vec<Splat>,
        rng: Option<&mut FastRng>,
    ) -> Rgb {
        let mut l = Rgb::BLACK;
        self.strategies(scene, light, camera, rng, |c| match c.raster {
            Some(r) => splats.push((r, c.value)),
            None => l += c.value,
        });
        l
    }

    /// Every strategy of a pair of subpaths with a nonzero contribution, in the order
    /// [`Bdpt::evaluate`] sums them, handed to `visit` (for per-strategy statistics, as
    /// `examples/firefly_hunt.rs` gathers them). `rng` as in [`Bdpt::evaluate`].
    #[inline(always)]
    pub fn strategies(
        &self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        mut rng: Option<&mut FastRng>,
        mut visit: impl FnMut(Strategy),
    ) {
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let edges = s + t - 1;
                if (s == 1 && t == 1) || edges < 1 || edges > self.walk.max_edges {
                    continue;
                }
                let Some(c) = connect_unoccluded(scene, light, camera, s, t) else {
                    continue;
                };
                // Russian roulette on the unweighted contribution (an upper bound of the
                // weighted one), then the ray, then the weight: no weight is computed for an
                // occluded connection.
                let mut boost = 1.0;
                if s > 0 {
                    if let (Some(roulette), Some(rng)) = (self.shadow_roulette, rng.as_deref_mut())
                    {
                        let Some(b) = roulette.survive(c.value.luminance(), rng) else {
                            continue;
                        };
                        boost = b;
                    }
                    if !unoccluded(scene, &light[s - 1], &camera[t - 1]) {
                        continue;
                    }
                }
                let weight = mis_weight(scene, light, camera, s, t, self.heuristic, c.ends);
                if weight == 0.0 {
                    continue;
                }
                visit(Strategy {
                    s,
                    t,
                    raster: c.raster,
                    unweighted: c.value,
                    weight,
                    value: c.value * (weight * boost),
                });
            }
        }
    }
}

/// One strategy's contribution to a BDPT sample ([`Bdpt::strategies`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strategy {
    /// Light subpath vertices it uses.
    pub s: usize,
    /// Camera subpath vertices it uses.
    pub t: usize,
    /// Raster position for `t = 1` (splatted); `None`: the sample's own pixel.
    pub raster: Option<[f64; 2]>,
    /// Contribution over density, before the MIS weight.
    pub unweighted: Rgb,
    /// MIS weight.
    pub weight: f64,
    /// What the estimate adds: `unweighted · weight`, divided by the shadow-ray roulette's
    /// survival probability where it ran.
    pub value: Rgb,
}

impl Estimator for Bdpt {
    fn sample(
        &self,
        scene: &Scene,
        pixel: usize,
        stream: &mut PixelStream,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            self.trace_subpaths(scene, stream, Some(pixel), cam, light);
            self.evaluate(scene, light, cam, splats, Some(stream.rng()))
        })
    }
    fn splats(&self) -> bool {
        true
    }
}
