//! Russian roulette on shadow rays (the classical unbiased roulette of Arvo & Kirk 1990, applied
//! to the visibility test of a connection or a next-event estimate).
//!
//! A contribution `c` whose luminance is below a threshold `τ` has its shadow ray traced with
//! probability `q = lum(c)/τ` and counts `c/q` when unoccluded, so the estimate stays unbiased
//! (`E = q · c/q · V = c V`), and the variance it adds per connection is at most `lum(c) τ`. The
//! connections that carry almost nothing (small MIS weights, dim subpaths, deep vertices) then
//! mostly skip their ray. `τ` is a fraction of the image's mean luminance, which
//! [`mean_luminance`] estimates with a pilot of the estimator's own samples.
//!
//! Only estimators with independent samples (PT, BDPT) use it: a Metropolis target must be a
//! deterministic function of its state.

use super::{Estimator, Splat};
use crate::sampler::PixelStream;
use crate::scene::Scene;
use mcmc_core::rng::{fast_stream, stream, uniform};

/// Roulette on shadow rays of contributions below a luminance threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowRoulette {
    /// `τ`: contributions of at least this luminance always trace their ray.
    pub threshold: f64,
}

impl ShadowRoulette {
    /// For a contribution of luminance `lum` about to be tested for visibility: the factor to
    /// multiply it by when its ray is traced (`1/q`, or 1 at or above the threshold), or `None`
    /// when the ray is skipped (the contribution counts 0). Draws a number only below the
    /// threshold.
    #[inline]
    pub fn survive<R: rand::Rng + ?Sized>(&self, lum: f64, rng: &mut R) -> Option<f64> {
        let q = lum / self.threshold;
        if q >= 1.0 {
            return Some(1.0);
        }
        if q.is_nan() || uniform(rng) >= q {
            return None;
        }
        // τ/lum rather than 1/q; a boost that overflows (a subnormal luminance) skips the ray.
        let boost = self.threshold / lum;
        boost.is_finite().then_some(boost)
    }
}

/// An estimate of the mean luminance of the image `estimator` renders, from `samples` of its
/// samples at pixels drawn uniformly (splats included; non-finite values left out, as the film
/// leaves them out): seeded, so the same for any thread count. 0 when nothing is seen.
pub fn mean_luminance<E: Estimator>(
    estimator: &E,
    scene: &Scene,
    samples: usize,
    seed: u64,
) -> f64 {
    let pixels = scene.camera.width * scene.camera.height;
    if samples == 0 || pixels == 0 {
        return 0.0;
    }
    let mut choose = stream(seed, u64::MAX);
    let mut splats: Vec<Splat> = Vec::new();
    let mut sum = 0.0;
    for i in 0..samples {
        let pixel = ((uniform(&mut choose) * pixels as f64) as usize).min(pixels - 1);
        let mut sampler = PixelStream::independent(fast_stream(seed, i as u64));
        splats.clear();
        let v = estimator.sample(scene, pixel, &mut sampler, &mut splats);
        let finite = |l: f64| if l.is_finite() { l } else { 0.0 };
        sum += finite(v.luminance())
            + splats
                .iter()
                .map(|(_, c)| finite(c.luminance()))
                .sum::<f64>();
    }
    let mean = sum / samples as f64;
    if mean.is_finite() && mean > 0.0 {
        mean
    } else {
        0.0
    }
}
