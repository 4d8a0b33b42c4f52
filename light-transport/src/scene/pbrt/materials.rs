//! pbrt materials → [`MaterialDesc`], with pbrt-v3's defaults and roughness remapping.
//!
//! | pbrt | becomes |
//! |---|---|
//! | `matte` (`Kd`, `sigma` = 0 only) · v4 `diffuse` (`reflectance`) | [`MaterialDesc::Matte`] |
//! | `metal` (`eta`, `k`, `roughness`/`uroughness`/`vroughness`, `remaproughness`) · v4 `conductor` | [`MaterialDesc::Metal`] |
//! | `mirror` (`Kr`) | [`MaterialDesc::Mirror`] |
//! | `glass` (`eta`/`index`, `Kr`, `Kt`, roughnesses, `remaproughness`) · v4 `dielectric` | [`MaterialDesc::Glass`] |
//! | `plastic` (`Kd`, `Ks`, `roughness`, `remaproughness`) | [`MaterialDesc::Layered`], coating η = 1.5 |
//! | `substrate` (`Kd`, `Ks`, `uroughness`, `vroughness`, `remaproughness`) | [`MaterialDesc::Layered`], coating η = 1.5 |
//! | `mix` (`namedmaterial1`, `namedmaterial2`, `amount`) | [`MaterialDesc::Mix`] (`amount` weighs material 1, as in pbrt-v3) |
//! | `uber` reducible exactly to matte (only `Kd`) or smooth glass (only `Kr`, `Kt`) | those |
//!
//! `plastic` and `substrate` are pbrt's additive Lambert + microfacet models (Fresnel-blend for
//! `substrate`); the layered coating is this renderer's model of the same materials (DESIGN §4), not
//! a bit-exact copy. `remaproughness` uses pbrt-v3's Trowbridge–Reitz polynomial for v3 materials and
//! pbrt-v4's `√roughness` for v4 materials. The default `metal` is pbrt's copper, reduced to RGB.
//! Anything else — bump maps, Oren–Nayar `sigma`, textured roughness, spectral values — is an error.

use super::params::{FloatArg, ParamList, SpectrumArg};
use crate::error::{Error, Result};
use crate::scene::description::{MaterialDesc, RgbTexture};
use crate::spectrum::Rgb;
use std::collections::HashMap;

/// Copper's index of refraction, RGB reduction of pbrt's default `metal` spectrum.
pub(crate) const COPPER_ETA: Rgb = Rgb::new(0.200438, 0.924033, 1.10221);
/// Copper's absorption coefficient, RGB reduction of pbrt's default `metal` spectrum.
pub(crate) const COPPER_K: Rgb = Rgb::new(3.91295, 2.45285, 2.14219);

/// pbrt-v3's `TrowbridgeReitzDistribution::RoughnessToAlpha`: a fitted quartic in `ln r` with
/// `r` clamped below at 1e-3.
pub fn roughness_to_alpha_v3(roughness: f64) -> f64 {
    let x = roughness.max(1e-3).ln();
    1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x * x * x + 0.000640711 * x * x * x * x
}

/// pbrt-v4's `TrowbridgeReitzDistribution::RoughnessToAlpha`.
pub fn roughness_to_alpha_v4(roughness: f64) -> f64 {
    roughness.max(0.0).sqrt()
}

/// Names visible where a material is declared.
pub(crate) struct MaterialScope<'a> {
    /// Named materials.
    pub named: &'a HashMap<String, usize>,
    /// Spectrum textures.
    pub rgb_textures: &'a HashMap<String, RgbTexture>,
    /// Float textures (constants).
    pub float_textures: &'a HashMap<String, f64>,
}

struct Ctx<'a> {
    params: &'a ParamList,
    scope: &'a MaterialScope<'a>,
    what: &'a str,
}

impl Ctx<'_> {
    fn resolve_rgb(&self, name: &str, arg: SpectrumArg) -> Result<RgbTexture> {
        match arg {
            SpectrumArg::Rgb(c) => {
                if c.0.iter().any(|&v| v < 0.0) {
                    return Err(self.params.error(
                        name,
                        format!("parameter \"{name}\" of {} must not be negative", self.what),
                    ));
                }
                Ok(RgbTexture::Constant(c))
            }
            SpectrumArg::Texture(t) => {
                if let Some(tex) = self.scope.rgb_textures.get(&t) {
                    Ok(tex.clone())
                } else if self.scope.float_textures.contains_key(&t) {
                    Err(self.params.error(
                        name,
                        format!(
                            "texture \"{t}\" given for \"{name}\" is a float texture; a spectrum \
                             texture is needed"
                        ),
                    ))
                } else {
                    Err(self.params.error(
                        name,
                        format!("unknown texture \"{t}\" given for \"{name}\""),
                    ))
                }
            }
        }
    }

    /// A spectrum that may be textured.
    fn rgb_texture(&self, name: &str, default: f64) -> Result<RgbTexture> {
        match self.params.spectrum_arg(name, false)? {
            None => Ok(RgbTexture::Constant(Rgb::splat(default))),
            Some(arg) => self.resolve_rgb(name, arg),
        }
    }

    /// A spectrum that must be constant.
    fn rgb(&self, name: &str, default: Rgb) -> Result<Rgb> {
        match self.params.spectrum_arg(name, false)? {
            None => Ok(default),
            Some(arg) => match self.resolve_rgb(name, arg)? {
                RgbTexture::Constant(c) => Ok(c),
                RgbTexture::Image { .. } => Err(self.params.error(
                    name,
                    format!(
                        "image textures are not supported for \"{name}\" of {} (only for the \
                         diffuse reflectance)",
                        self.what
                    ),
                )),
            },
        }
    }

    /// A float that may be given as a constant float texture.
    fn float_opt(&self, name: &str) -> Result<Option<f64>> {
        match self.params.float_arg(name)? {
            None => Ok(None),
            Some(FloatArg::Value(v)) => Ok(Some(v)),
            Some(FloatArg::Texture(t)) => match self.scope.float_textures.get(&t) {
                Some(&v) => Ok(Some(v)),
                None => Err(self.params.error(
                    name,
                    if self.scope.rgb_textures.contains_key(&t) {
                        format!("texture \"{t}\" is not a float texture (or is an image, which is not supported for \"{name}\")")
                    } else {
                        format!("unknown float texture \"{t}\" given for \"{name}\"")
                    },
                )),
            },
        }
    }

    fn float(&self, name: &str, default: f64) -> Result<f64> {
        Ok(self.float_opt(name)?.unwrap_or(default))
    }

    fn non_negative(&self, name: &str, v: f64) -> Result<f64> {
        if v < 0.0 {
            return Err(self.params.error(
                name,
                format!("parameter \"{name}\" of {} must not be negative", self.what),
            ));
        }
        Ok(v)
    }

    /// `(uroughness, vroughness)` with `roughness` (and pbrt's default) as the fallback.
    fn roughness_pair(&self, default: f64) -> Result<(f64, f64)> {
        let r = self.float("roughness", default)?;
        let u = self.float("uroughness", r)?;
        let v = self.float("vroughness", r)?;
        self.non_negative("roughness", r)?;
        Ok((
            self.non_negative("uroughness", u)?,
            self.non_negative("vroughness", v)?,
        ))
    }

    fn remap(&self) -> Result<bool> {
        Ok(self.params.bool("remaproughness")?.unwrap_or(true))
    }

    fn eta(&self, default: f64) -> Result<f64> {
        if self.params.has("eta") && self.params.has("index") {
            return Err(self
                .params
                .error("index", "give either \"eta\" or \"index\", not both"));
        }
        let eta = match self.float_opt("eta")? {
            Some(e) => e,
            None => self.float("index", default)?,
        };
        if eta <= 0.0 {
            return Err(self.params.error(
                if self.params.has("eta") {
                    "eta"
                } else {
                    "index"
                },
                format!("the index of refraction of {} must be positive", self.what),
            ));
        }
        Ok(eta)
    }
}

/// Build the material of type `kind`; `what` names the directive in errors.
pub(crate) fn material(
    kind: &str,
    params: &ParamList,
    scope: &MaterialScope,
    what: &str,
) -> Result<MaterialDesc> {
    let c = Ctx {
        params,
        scope,
        what,
    };
    for map in ["bumpmap", "normalmap", "displacement"] {
        if params.has(map) {
            return Err(params.error(
                map,
                format!(
                    "{what}: \"{map}\" is not supported: bump, normal and displacement maps are \
                     out of scope (shading normals come from the meshes' vertex normals \"N\")"
                ),
            ));
        }
    }
    let m = match kind {
        "matte" => {
            let kd = c.rgb_texture("Kd", 0.5)?;
            let sigma = c.float("sigma", 0.0)?;
            if sigma != 0.0 {
                return Err(params.error(
                    "sigma",
                    format!(
                        "matte with sigma = {sigma} is the Oren–Nayar model, which is not \
                         supported (only sigma 0, Lambertian)"
                    ),
                ));
            }
            MaterialDesc::Matte { kd }
        }
        "diffuse" => MaterialDesc::Matte {
            kd: c.rgb_texture("reflectance", 0.5)?,
        },
        "metal" | "conductor" => {
            let v4 = kind == "conductor";
            if v4 && params.has("reflectance") {
                return Err(params.error(
                    "reflectance",
                    "conductor given by \"reflectance\" is not supported; give \"eta\" and \"k\"",
                ));
            }
            let eta = c.rgb("eta", COPPER_ETA)?;
            let k = c.rgb("k", COPPER_K)?;
            if eta.0.iter().any(|&v| v <= 0.0) {
                return Err(params.error("eta", "metal \"eta\" must be positive"));
            }
            c.non_negative("k", k.0.iter().copied().fold(f64::INFINITY, f64::min))?;
            let (u, v) = c.roughness_pair(if v4 { 0.0 } else { 0.01 })?;
            let remap = c.remap()?;
            let f = |r: f64| match (remap, v4) {
                (false, _) => r,
                (true, false) => roughness_to_alpha_v3(r),
                (true, true) => roughness_to_alpha_v4(r),
            };
            MaterialDesc::Metal {
                eta,
                k,
                alpha_u: f(u),
                alpha_v: f(v),
            }
        }
        "mirror" => MaterialDesc::Mirror {
            kr: c.rgb("Kr", Rgb::splat(0.9))?,
        },
        "glass" | "dielectric" => {
            let v4 = kind == "dielectric";
            let (kr, kt) = if v4 {
                (Rgb::WHITE, Rgb::WHITE)
            } else {
                (c.rgb("Kr", Rgb::WHITE)?, c.rgb("Kt", Rgb::WHITE)?)
            };
            let eta = c.eta(1.5)?;
            let (u, v) = c.roughness_pair(0.0)?;
            let remap = c.remap()?;
            // pbrt keeps a glass with both roughnesses zero smooth and remaps otherwise.
            let (alpha_u, alpha_v) = if (u == 0.0 && v == 0.0) || !remap {
                (u, v)
            } else if v4 {
                (roughness_to_alpha_v4(u), roughness_to_alpha_v4(v))
            } else {
                (roughness_to_alpha_v3(u), roughness_to_alpha_v3(v))
            };
            MaterialDesc::Glass {
                eta,
                alpha_u,
                alpha_v,
                kr,
                kt,
            }
        }
        "plastic" => {
            let kd = c.rgb_texture("Kd", 0.25)?;
            let ks = c.rgb("Ks", Rgb::splat(0.25))?;
            let r = c.non_negative("roughness", c.float("roughness", 0.1)?)?;
            let alpha = if c.remap()? {
                roughness_to_alpha_v3(r)
            } else {
                r
            };
            MaterialDesc::Layered {
                kd,
                ks,
                alpha_u: alpha,
                alpha_v: alpha,
                eta: 1.5,
            }
        }
        "substrate" => {
            let kd = c.rgb_texture("Kd", 0.5)?;
            let ks = c.rgb("Ks", Rgb::splat(0.5))?;
            let u = c.non_negative("uroughness", c.float("uroughness", 0.1)?)?;
            let v = c.non_negative("vroughness", c.float("vroughness", 0.1)?)?;
            let remap = c.remap()?;
            let f = |r| if remap { roughness_to_alpha_v3(r) } else { r };
            MaterialDesc::Layered {
                kd,
                ks,
                alpha_u: f(u),
                alpha_v: f(v),
                eta: 1.5,
            }
        }
        "mix" => mix(&c)?,
        "uber" => uber(&c)?,
        "" | "none" | "interface" => {
            return Err(Error::scene(
                &params.directive,
                format!(
                    "{what}: material \"{kind}\" (an invisible interface for participating media) \
                     is not supported"
                ),
            ));
        }
        _ => {
            return Err(Error::scene(
                &params.directive,
                format!(
                    "{what}: unsupported material type \"{kind}\" (supported: matte, metal, mirror, \
                     glass, plastic, substrate, mix, uber reducible to matte or glass; pbrt-v4 \
                     diffuse, conductor, dielectric)"
                ),
            ));
        }
    };
    params.finish(what, &[])?;
    Ok(m)
}

fn mix(c: &Ctx) -> Result<MaterialDesc> {
    let lookup = |key: &str| -> Result<usize> {
        let name = c.params.string(key)?.ok_or_else(|| {
            Error::scene(&c.params.directive, format!("mix needs \"string {key}\""))
        })?;
        c.scope.named.get(name).copied().ok_or_else(|| {
            c.params
                .error(key, format!("mix: unknown named material \"{name}\""))
        })
    };
    let a = lookup("namedmaterial1")?;
    let b = lookup("namedmaterial2")?;
    let amount = match c.params.spectrum_arg("amount", true)? {
        None => Rgb::splat(0.5),
        Some(SpectrumArg::Rgb(v)) => v,
        Some(SpectrumArg::Texture(t)) => {
            match (c.scope.float_textures.get(&t), c.scope.rgb_textures.get(&t)) {
                (Some(&v), _) => Rgb::splat(v),
                (None, Some(RgbTexture::Constant(v))) => *v,
                _ => {
                    return Err(c.params.error(
                    "amount",
                    format!("mix: \"amount\" must be constant; texture \"{t}\" is not a constant texture"),
                ));
                }
            }
        }
    };
    if amount.0.iter().any(|v| !(0.0..=1.0).contains(v)) {
        return Err(c
            .params
            .error("amount", "mix: \"amount\" must lie in [0, 1]"));
    }
    Ok(MaterialDesc::Mix { a, b, amount })
}

/// `uber` where it reduces exactly to a supported model.
fn uber(c: &Ctx) -> Result<MaterialDesc> {
    let kd = c.rgb_texture("Kd", 0.25)?;
    let ks = c.rgb("Ks", Rgb::splat(0.25))?;
    let kr = c.rgb("Kr", Rgb::BLACK)?;
    let kt = c.rgb("Kt", Rgb::BLACK)?;
    let opacity = c.rgb("opacity", Rgb::WHITE)?;
    let eta = c.eta(1.5)?;
    c.roughness_pair(0.1)?;
    c.remap()?;
    let kd_black = kd == RgbTexture::Constant(Rgb::BLACK);
    if opacity != Rgb::WHITE {
        return Err(c
            .params
            .error("opacity", "uber with opacity ≠ 1 is not supported"));
    }
    if ks.is_black() && kr.is_black() && kt.is_black() {
        return Ok(MaterialDesc::Matte { kd });
    }
    if kd_black && ks.is_black() {
        return Ok(MaterialDesc::Glass {
            eta,
            alpha_u: 0.0,
            alpha_v: 0.0,
            kr,
            kt,
        });
    }
    Err(Error::scene(
        &c.params.directive,
        format!(
            "{}: uber is supported only where it is exactly matte (Ks = Kr = Kt = 0) or smooth \
             glass (Kd = Ks = 0); use plastic, substrate or glass",
            c.what
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remapping_matches_pbrt() {
        // Values of pbrt-v3's polynomial.
        assert!((roughness_to_alpha_v3(1.0) - 1.62142).abs() < 1e-12);
        assert!((roughness_to_alpha_v3(0.0) - roughness_to_alpha_v3(1e-3)).abs() < 1e-15);
        assert!((roughness_to_alpha_v3(0.1) - 0.46176).abs() < 1e-4);
        assert!((roughness_to_alpha_v4(0.25) - 0.5).abs() < 1e-15);
    }
}
