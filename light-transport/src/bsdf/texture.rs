//! Image-texture lookup for reflectances: `uv` mapped by the texture's scale and offset,
//! `(u·su + du, v·sv + dv)`, wrapped around (repeat), then bilinear interpolation between texel
//! centres (row 0 at the top, `v = 1`).

use crate::error::{Error, Result};
use crate::scene::{RgbTexture, TextureDesc};
use crate::spectrum::Rgb;

fn invalid(reason: String) -> Error {
    Error::InvalidParameter {
        name: "texture".into(),
        reason,
    }
}

/// Check that a texture's texel array matches its size.
pub fn validate(tex: &TextureDesc) -> Result<()> {
    if tex.width == 0
        || tex.height == 0
        || tex.width.checked_mul(tex.height) != Some(tex.texels.len())
    {
        return Err(invalid(format!(
            "{}: {}×{} texels expected, {} given",
            tex.name,
            tex.width,
            tex.height,
            tex.texels.len()
        )));
    }
    Ok(())
}

/// Bilinear lookup at `uv` with wrap-around (the texture must have passed [`validate`]).
pub fn lookup(tex: &TextureDesc, uv: [f64; 2]) -> Rgb {
    let wrap = |v: f64| {
        if v.is_finite() {
            v.rem_euclid(1.0)
        } else {
            0.0
        }
    };
    let u = wrap(uv[0] * tex.uv_scale[0] + tex.uv_offset[0]);
    let v = wrap(uv[1] * tex.uv_scale[1] + tex.uv_offset[1]);
    let (w, h) = (tex.width, tex.height);
    // Continuous texel coordinates with texel centres at integers.
    let x = u * w as f64 - 0.5;
    let y = (1.0 - v) * h as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let ix = |i: f64| (i as i64).rem_euclid(w as i64) as usize;
    let iy = |i: f64| (i as i64).rem_euclid(h as i64) as usize;
    let texel = |x: usize, y: usize| tex.texels.get(y * w + x).copied().unwrap_or(Rgb::BLACK);
    let (xa, xb, ya, yb) = (ix(x0), ix(x0 + 1.0), iy(y0), iy(y0 + 1.0));
    texel(xa, ya) * ((1.0 - tx) * (1.0 - ty))
        + texel(xb, ya) * (tx * (1.0 - ty))
        + texel(xa, yb) * ((1.0 - tx) * ty)
        + texel(xb, yb) * (tx * ty)
}

/// The value of a reflectance at `uv`.
pub fn evaluate(value: &RgbTexture, textures: &[TextureDesc], uv: [f64; 2]) -> Result<Rgb> {
    match value {
        RgbTexture::Constant(c) => Ok(*c),
        RgbTexture::Image { texture, scale } => {
            let tex = textures.get(*texture).ok_or_else(|| {
                invalid(format!(
                    "texture index {texture} out of range ({} textures)",
                    textures.len()
                ))
            })?;
            validate(tex)?;
            Ok(lookup(tex, uv) * *scale)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> TextureDesc {
        TextureDesc {
            texels: vec![
                Rgb::splat(1.0),
                Rgb::splat(0.0),
                Rgb::splat(0.0),
                Rgb::splat(1.0),
            ],
            width: 2,
            height: 2,
            uv_scale: [1.0, 1.0],
            uv_offset: [0.0, 0.0],
            name: "checker".into(),
        }
    }

    #[test]
    fn texel_centres_are_exact_and_wrap() {
        let t = checker();
        // Texel (0, 0) is the top-left: u = 0.25, v = 0.75.
        assert_eq!(lookup(&t, [0.25, 0.75]), Rgb::splat(1.0));
        assert_eq!(lookup(&t, [0.75, 0.75]), Rgb::splat(0.0));
        assert_eq!(lookup(&t, [1.25, -0.25]), Rgb::splat(1.0));
        assert!((lookup(&t, [0.5, 0.75])[0] - 0.5).abs() < 1e-12);
        assert!(
            (lookup(&t, [0.0, 0.75])[0] - 0.5).abs() < 1e-12,
            "wraps horizontally"
        );
        assert!(lookup(&t, [f64::NAN, 0.3]).is_finite());
    }
}
