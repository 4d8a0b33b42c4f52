//! Image files: EXR (linear, f32) and PNG (exposure, sRGB, clamped); reading EXR/PNG references.

use super::Image;
use crate::spectrum::Rgb;
use crate::{Error, Result};
use std::path::Path;

fn image_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Write a linear EXR.
pub fn write_exr(image: &Image, path: &Path) -> Result<()> {
    let w = image.width;
    exr::prelude::write_rgb_file(path, image.width, image.height, |x, y| {
        let p = image.pixels[y * w + x];
        (p[0] as f32, p[1] as f32, p[2] as f32)
    })
    .map_err(|e| image_error(path, e))
}

/// The sRGB encoding of a linear value in `[0, 1]`.
pub fn srgb_encode(v: f64) -> f64 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Write a PNG: multiply by `2^exposure`, clamp, sRGB-encode.
pub fn write_png(image: &Image, exposure: f64, path: &Path) -> Result<()> {
    let scale = 2f64.powf(exposure);
    let to8 = |v: f64| (srgb_encode((v * scale).clamp(0.0, 1.0)) * 255.0).round() as u8;
    let buf = image::RgbImage::from_fn(image.width as u32, image.height as u32, |x, y| {
        let p = image.pixels[y as usize * image.width + x as usize];
        image::Rgb([to8(p[0]), to8(p[1]), to8(p[2])])
    });
    buf.save(path).map_err(|e| image_error(path, e))
}

/// Write sRGB bytes (e.g. an error image) as PNG.
pub fn write_bytes_png(width: usize, height: usize, pixels: &[[u8; 3]], path: &Path) -> Result<()> {
    let buf = image::RgbImage::from_fn(width as u32, height as u32, |x, y| {
        image::Rgb(pixels[y as usize * width + x as usize])
    });
    buf.save(path).map_err(|e| image_error(path, e))
}

/// Read an image as linear RGB: EXR as stored, PNG/TGA decoded from sRGB.
pub fn read_image(path: &Path) -> Result<Image> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if ext.as_deref() == Some("exr") {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| {
                let (w, h) = (res.width(), res.height());
                (w, h, vec![Rgb::BLACK; w * h])
            },
            |(w, _, px): &mut (usize, usize, Vec<Rgb>),
             pos,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = Rgb::new(r as f64, g as f64, b as f64);
            },
        )
        .map_err(|e| image_error(path, e))?;
        let (w, h, pixels) = img.layer_data.channel_data.pixels;
        return Ok(Image {
            width: w,
            height: h,
            pixels,
        });
    }
    let decoded = image::open(path)
        .map_err(|e| image_error(path, e))?
        .to_rgb32f();
    let (w, h) = (decoded.width() as usize, decoded.height() as usize);
    let lin = |v: f32| {
        let v = v as f64;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let pixels = decoded
        .pixels()
        .map(|p| Rgb::new(lin(p[0]), lin(p[1]), lin(p[2])))
        .collect();
    Ok(Image {
        width: w,
        height: h,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip() {
        let img = Image {
            width: 3,
            height: 2,
            pixels: (0..6).map(|i| Rgb::new(i as f64, 0.5, 1e3)).collect(),
        };
        let path =
            std::env::temp_dir().join(format!("charted-film-test-{}.exr", std::process::id()));
        write_exr(&img, &path).unwrap();
        let back = read_image(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!((back.width, back.height), (3, 2));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * a[c].abs().max(1.0));
            }
        }
    }
}
