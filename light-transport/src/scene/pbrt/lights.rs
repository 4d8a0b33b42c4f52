//! `LightSource "point"|"infinite"` and `AreaLightSource "diffuse"`.
//!
//! A point light sits at `CTM · from` (pbrt-v3's documented meaning and pbrt-v4's behaviour;
//! pbrt-v3's code adds `from` after the transform, so the two differ when the CTM rotates or
//! scales — a warning says so) and has intensity `I · scale`. An infinite light is uniform with
//! radiance `L · scale`; environment maps are not supported. A diffuse area light emits `L · scale`
//! from the front side of the shapes that follow it in its attribute block (both sides with
//! `twosided`). `scale` may be an RGB or (pbrt-v4 style) a float.

use super::params::ParamList;
use super::transform;
use crate::error::{Error, Location, Result};
use crate::math::{DMat4, DVec3};
use crate::scene::description::{AreaLightDesc, LightDesc};
use crate::spectrum::Rgb;

/// Sample counts only steer pbrt's estimators.
const HARMLESS: &[&str] = &["nsamples", "samples"];

fn non_negative(params: &ParamList, name: &str, c: Rgb) -> Result<Rgb> {
    if c.0.iter().any(|&v| v < 0.0) {
        return Err(params.error(name, format!("\"{name}\" must not be negative")));
    }
    Ok(c)
}

fn scaled(params: &ParamList, name: &str) -> Result<Rgb> {
    let v = non_negative(params, name, params.spectrum(name)?.unwrap_or(Rgb::WHITE))?;
    let s = non_negative(
        params,
        "scale",
        params.spectrum_or_float("scale")?.unwrap_or(Rgb::WHITE),
    )?;
    Ok(v * s)
}

/// `LightSource kind params…` under transform `ctm`; may push a warning.
pub(crate) fn light_source(
    kind: &str,
    params: &ParamList,
    ctm: &DMat4,
    warnings: &mut Vec<(String, Location)>,
) -> Result<LightDesc> {
    let what = format!("LightSource \"{kind}\"");
    let light = match kind {
        "point" => {
            let intensity = scaled(params, "I")?;
            if params.has("power") {
                return Err(params.error(
                    "power",
                    "point light \"power\" is not supported; give \"I\"",
                ));
            }
            let from = params.point("from")?.unwrap_or(DVec3::ZERO);
            if !transform::is_affine(ctm) {
                return Err(Error::scene(
                    &params.directive,
                    "point light under a projective transform",
                ));
            }
            let position = ctm.transform_point3(from);
            let v3_position = ctm.transform_point3(DVec3::ZERO) + from;
            if (position - v3_position).length() > 1e-9 * (1.0 + position.length()) {
                warnings.push((
                    format!(
                        "point light placed at CTM·from = {position:?}; pbrt-v3 itself would \
                         place it at CTM·0 + from = {v3_position:?}"
                    ),
                    params.directive.clone(),
                ));
            }
            if !position.is_finite() {
                return Err(Error::scene(
                    &params.directive,
                    "point light position is not finite",
                ));
            }
            LightDesc::Point {
                position,
                intensity,
            }
        }
        "infinite" => {
            for key in ["mapname", "filename"] {
                if params.has(key) {
                    return Err(params.error(
                        key,
                        format!(
                            "infinite light with an environment map (\"{key}\") is not supported; \
                             only a uniform \"L\""
                        ),
                    ));
                }
            }
            LightDesc::Infinite {
                radiance: scaled(params, "L")?,
            }
        }
        _ => {
            return Err(Error::scene(
                &params.directive,
                format!(
                    "unsupported light type \"{kind}\" (supported: point, infinite; area lights via AreaLightSource \"diffuse\")"
                ),
            ));
        }
    };
    params.finish(&what, HARMLESS)?;
    Ok(light)
}

/// `AreaLightSource kind params…`.
pub(crate) fn area_light(kind: &str, params: &ParamList) -> Result<AreaLightDesc> {
    if kind != "diffuse" {
        return Err(Error::scene(
            &params.directive,
            format!("unsupported area light type \"{kind}\" (only \"diffuse\")"),
        ));
    }
    if params.has("filename") {
        return Err(params.error("filename", "textured area lights are not supported"));
    }
    let radiance = scaled(params, "L")?;
    let two_sided = params.bool("twosided")?.unwrap_or(false);
    params.finish("AreaLightSource \"diffuse\"", HARMLESS)?;
    Ok(AreaLightDesc {
        radiance,
        two_sided,
    })
}
