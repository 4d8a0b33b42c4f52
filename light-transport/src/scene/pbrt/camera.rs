//! `Camera "perspective"` and `Film "image"` (pbrt-v4 `"rgb"`).
//!
//! The CTM at `Camera` is pbrt's world-to-camera transform; the camera stores its inverse. pbrt's
//! camera space has `+x` towards the image's right edge, `+y` towards its top edge and `+z` forward
//! (a left-handed frame); keeping exactly that frame in `camera_to_world` is what makes our images
//! match pbrt's instead of mirroring them (see [`CameraDesc`]).

use super::params::ParamList;
use super::transform;
use crate::error::{Error, Result};
use crate::math::DMat4;
use crate::scene::description::{CameraDesc, FilmDesc, Projection};

/// Largest accepted image side.
pub const MAX_RESOLUTION: i64 = 16384;

/// pbrt's default film size.
pub(crate) const DEFAULT_FILM: (usize, usize) = (1280, 720);

/// pbrt's camera when the file has no `Camera`: perspective, 90°, at the world origin.
pub(crate) fn default_camera(world_to_camera: &DMat4) -> Option<CameraDesc> {
    Some(CameraDesc {
        camera_to_world: transform::checked_inverse(world_to_camera)?,
        projection: Projection::Perspective {
            fov: 90f64.to_radians(),
            lens_radius: 0.0,
            focal_distance: 1e6,
        },
    })
}

/// `Camera kind params…` with `world_to_camera` the CTM.
pub(crate) fn camera(
    kind: &str,
    params: &ParamList,
    world_to_camera: &DMat4,
) -> Result<CameraDesc> {
    if kind != "perspective" {
        return Err(Error::scene(
            &params.directive,
            format!("unsupported camera type \"{kind}\" (only \"perspective\")"),
        ));
    }
    let camera_to_world = transform::checked_inverse(world_to_camera)
        .filter(|_| transform::is_affine(world_to_camera))
        .ok_or_else(|| {
            Error::scene(
                &params.directive,
                "the transform at Camera (world to camera) is not an invertible affine transform",
            )
        })?;
    let fov_deg = match (params.float("fov")?, params.float("halffov")?) {
        (Some(_), Some(_)) => {
            return Err(params.error("halffov", "give either \"fov\" or \"halffov\""));
        }
        (_, Some(h)) => 2.0 * h,
        (f, None) => f.unwrap_or(90.0),
    };
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(params.error(
            if params.has("halffov") {
                "halffov"
            } else {
                "fov"
            },
            format!("field of view {fov_deg}° must lie strictly between 0° and 180°"),
        ));
    }
    let lens_radius = params.float("lensradius")?.unwrap_or(0.0);
    if lens_radius < 0.0 {
        return Err(params.error("lensradius", "\"lensradius\" must not be negative"));
    }
    let focal_distance = params.float("focaldistance")?.unwrap_or(1e6);
    if focal_distance <= 0.0 {
        return Err(params.error("focaldistance", "\"focaldistance\" must be positive"));
    }
    for key in ["screenwindow", "frameaspectratio"] {
        if params.has(key) {
            return Err(params.error(
                key,
                format!("\"{key}\" is not supported: the image aspect comes from the film"),
            ));
        }
    }
    params.finish("Camera \"perspective\"", &["shutteropen", "shutterclose"])?;
    Ok(CameraDesc {
        camera_to_world,
        projection: Projection::Perspective {
            fov: fov_deg.to_radians(),
            lens_radius,
            focal_distance,
        },
    })
}

/// `Film kind params…`.
pub(crate) fn film(kind: &str, params: &ParamList) -> Result<FilmDesc> {
    if kind != "image" && kind != "rgb" {
        return Err(Error::scene(
            &params.directive,
            format!("unsupported film type \"{kind}\" (\"image\", or pbrt-v4 \"rgb\")"),
        ));
    }
    let res = |name: &str, default: usize| -> Result<usize> {
        let Some(v) = params.int(name)? else {
            return Ok(default);
        };
        if !(1..=MAX_RESOLUTION).contains(&v) {
            return Err(params.error(
                name,
                format!(
                    "absurd film resolution \"{name}\" = {v} (must be between 1 and \
                     {MAX_RESOLUTION})"
                ),
            ));
        }
        Ok(v as usize)
    };
    let width = res("xresolution", DEFAULT_FILM.0)?;
    let height = res("yresolution", DEFAULT_FILM.1)?;
    let filename = params.string("filename")?.map(str::to_string);
    params.finish(&format!("Film \"{kind}\""), &["diagonal"])?;
    Ok(FilmDesc {
        width,
        height,
        filename,
    })
}
