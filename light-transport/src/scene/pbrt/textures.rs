//! The `Texture` directive: spectrum textures `imagemap` (PNG, TGA, EXR through the `image` crate),
//! `constant` and `scale` (a constant times at most one image), and float textures `constant` and
//! `scale` (their uses — roughness, mix amounts — must be constant in this renderer).
//!
//! Image textures follow pbrt-v3: 8-bit PNG/TGA are sRGB-encoded and decoded to linear unless
//! `"bool gamma" "false"` (EXR is linear unless `"bool gamma" "true"`); `uscale`, `vscale`,
//! `udelta`, `vdelta` give `(u·su + du, v·sv + dv)`; `"float scale"` multiplies the texels; the
//! image's top row is `v = 1`. Repeat wrapping and the `uv` mapping only.

use super::params::{FloatArg, ParamList, SpectrumArg};
use crate::error::{Error, Location, Result};
use crate::scene::description::{RgbTexture, TextureDesc};
use crate::spectrum::Rgb;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A texture as the named-texture table keeps it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum NamedTexture {
    /// A spectrum texture.
    Rgb(RgbTexture),
    /// A constant float texture.
    Float(f64),
}

/// The images loaded so far, shared by textures that use the same file the same way.
#[derive(Default)]
pub(crate) struct TextureStore {
    /// The scene's textures.
    pub textures: Vec<TextureDesc>,
    cache: HashMap<(PathBuf, bool, [u64; 4]), usize>,
}

/// pbrt-v3's `InverseGammaCorrect` (the sRGB transfer function).
fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

fn has_extension(path: &Path, ext: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ext.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Decode an image file to linear RGB texels, row 0 at the top.
fn load_image(path: &Path, gamma: bool, at: &Location) -> Result<(Vec<Rgb>, usize, usize)> {
    let fail = |e: &dyn std::fmt::Display| {
        Error::scene(
            at,
            format!("cannot read texture image {}: {e}", path.display()),
        )
    };
    let img = image::ImageReader::open(path)
        .map_err(|e| fail(&e))?
        .with_guessed_format()
        .map_err(|e| fail(&e))?
        .decode()
        .map_err(|e| fail(&e))?;
    let rgb = img.to_rgb32f();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    if w == 0 || h == 0 {
        return Err(fail(&"the image is empty"));
    }
    let texels = rgb
        .pixels()
        .map(|p| {
            let c = Rgb::new(p.0[0] as f64, p.0[1] as f64, p.0[2] as f64);
            let c = if gamma { c.map(srgb_to_linear) } else { c };
            c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })
        })
        .collect();
    Ok((texels, w, h))
}

fn imagemap(params: &ParamList, dir: &Path, store: &mut TextureStore) -> Result<RgbTexture> {
    let file = params
        .string("filename")?
        .ok_or_else(|| Error::scene(&params.directive, "imagemap needs \"string filename\""))?;
    let path = dir.join(file);
    let gamma = match (params.bool("gamma")?, params.string("encoding")?) {
        (Some(_), Some(_)) => {
            return Err(params.error("encoding", "give either \"gamma\" or \"encoding\""));
        }
        (Some(g), None) => g,
        (None, Some("sRGB")) => true,
        (None, Some("linear")) => false,
        (None, Some(e)) => {
            return Err(params.error(
                "encoding",
                format!("unsupported texture encoding \"{e}\" (sRGB or linear)"),
            ));
        }
        (None, None) => has_extension(&path, &["png", "tga"]),
    };
    let su = params.float("uscale")?.unwrap_or(1.0);
    let sv = params.float("vscale")?.unwrap_or(1.0);
    let du = params.float("udelta")?.unwrap_or(0.0);
    let dv = params.float("vdelta")?.unwrap_or(0.0);
    let scale = params.float("scale")?.unwrap_or(1.0);
    if params.bool("invert")? == Some(true) {
        return Err(params.error("invert", "\"invert\" image textures are not supported"));
    }
    if let Some(w) = params.string("wrap")?
        && w != "repeat"
    {
        return Err(params.error(
            "wrap",
            format!("texture wrap mode \"{w}\" is not supported (only \"repeat\")"),
        ));
    }
    let key = (path.clone(), gamma, [su, sv, du, dv].map(f64::to_bits));
    let texture = match store.cache.get(&key) {
        Some(&i) => i,
        None => {
            let (texels, width, height) = load_image(&path, gamma, &params.location("filename"))?;
            store.textures.push(TextureDesc {
                texels,
                width,
                height,
                uv_scale: [su, sv],
                uv_offset: [du, dv],
                name: path.display().to_string(),
            });
            let i = store.textures.len() - 1;
            store.cache.insert(key, i);
            i
        }
    };
    Ok(RgbTexture::Image {
        texture,
        scale: Rgb::splat(scale),
    })
}

/// `Texture "name" type class params…`.
pub(crate) fn texture(
    ty: &str,
    class: &str,
    params: &ParamList,
    dir: &Path,
    rgb_textures: &HashMap<String, RgbTexture>,
    float_textures: &HashMap<String, f64>,
    store: &mut TextureStore,
) -> Result<NamedTexture> {
    let what = format!("Texture \"{ty}\" \"{class}\"");
    let unsupported = || {
        Error::scene(
            &params.directive,
            format!(
                "unsupported texture: {what} (supported: spectrum imagemap/constant/scale, float \
                 constant/scale)"
            ),
        )
    };
    // Mapping parameters shared by every texture class.
    if let Some(m) = params.string("mapping")?
        && m != "uv"
    {
        return Err(params.error(
            "mapping",
            format!("texture mapping \"{m}\" is not supported (only \"uv\")"),
        ));
    }
    let out = match ty {
        "spectrum" | "color" | "rgb" => {
            let arg = |name: &str| -> Result<RgbTexture> {
                match params.spectrum_arg(name, false)? {
                    None => Ok(RgbTexture::Constant(Rgb::WHITE)),
                    Some(SpectrumArg::Rgb(c)) => Ok(RgbTexture::Constant(c)),
                    Some(SpectrumArg::Texture(t)) => {
                        rgb_textures.get(&t).cloned().ok_or_else(|| {
                            params.error(name, format!("unknown spectrum texture \"{t}\""))
                        })
                    }
                }
            };
            NamedTexture::Rgb(match class {
                "imagemap" => imagemap(params, dir, store)?,
                "constant" => arg("value")?,
                "scale" => match (arg("tex1")?, arg("tex2")?) {
                    (RgbTexture::Constant(a), RgbTexture::Constant(b)) => {
                        RgbTexture::Constant(a * b)
                    }
                    (RgbTexture::Image { texture, scale }, RgbTexture::Constant(c))
                    | (RgbTexture::Constant(c), RgbTexture::Image { texture, scale }) => {
                        RgbTexture::Image {
                            texture,
                            scale: scale * c,
                        }
                    }
                    _ => {
                        return Err(params.error(
                            "tex2",
                            "a \"scale\" texture of two image textures is not supported",
                        ));
                    }
                },
                _ => return Err(unsupported()),
            })
        }
        "float" => {
            let arg = |name: &str| -> Result<f64> {
                match params.float_arg(name)? {
                    None => Ok(1.0),
                    Some(FloatArg::Value(v)) => Ok(v),
                    Some(FloatArg::Texture(t)) => {
                        float_textures.get(&t).copied().ok_or_else(|| {
                            params.error(name, format!("unknown float texture \"{t}\""))
                        })
                    }
                }
            };
            NamedTexture::Float(match class {
                "constant" => arg("value")?,
                "scale" => arg("tex1")? * arg("tex2")?,
                _ => return Err(unsupported()),
            })
        }
        _ => {
            return Err(Error::scene(
                &params.directive,
                format!("unknown texture type \"{ty}\" (expected \"spectrum\" or \"float\")"),
            ));
        }
    };
    params.finish(&what, &["maxanisotropy", "trilinear", "filter"])?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    }
}
