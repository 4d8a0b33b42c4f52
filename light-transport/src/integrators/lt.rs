//! Light tracing: light subpaths whose every vertex is connected to the lens (strategies `(s, 1)`),
//! each splatted with weight 1. It cannot see surfaces through delta lobes from the camera (such
//! paths need `t ≥ 2`).

use super::{Estimator, Splat};
use crate::path::{Subpath, WalkSettings, camera_subpath, connect, light_subpath};
use crate::sampler::PixelStream;
use crate::scene::Scene;
use crate::spectrum::Rgb;
use std::cell::RefCell;

thread_local! {
    static SUBPATHS: RefCell<(Subpath, Subpath)> = const { RefCell::new((Subpath::new(), Subpath::new())) };
}

/// Light tracing settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightTracer {
    /// Path length limit.
    pub walk: WalkSettings,
}

impl Estimator for LightTracer {
    fn sample(
        &self,
        scene: &Scene,
        _pixel: usize,
        stream: &mut PixelStream,
        splats: &mut Vec<Splat>,
    ) -> Rgb {
        SUBPATHS.with(|b| {
            let (cam, light) = &mut *b.borrow_mut();
            // The lens point only: film numbers are not used by (s, 1) strategies.
            camera_subpath(scene, stream, 1, None, cam);
            light_subpath(scene, stream, self.walk.max_light_vertices(), light);
            for s in 1..=light.len() {
                if let Some(c) = connect(scene, light, cam, s, 1)
                    && let Some(r) = c.raster
                {
                    splats.push((r, c.value));
                }
            }
        });
        Rgb::BLACK
    }
    fn has_pixel_estimate(&self) -> bool {
        false
    }
    fn splats(&self) -> bool {
        true
    }
}
