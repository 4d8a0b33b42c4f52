//! A small RGB image in f64 for the toy experiment: accumulation, RMSE, and PNG output.

use image::{Rgb, RgbImage};
use std::path::Path as FsPath;

/// Resolution of the toy images.
pub const SIZE: usize = 128;

#[derive(Clone, Debug)]
pub struct Image {
    pub data: Vec<[f64; 3]>,
}

impl Image {
    pub fn new() -> Self {
        Self {
            data: vec![[0.0; 3]; SIZE * SIZE],
        }
    }

    /// The pixel of a ground point (row 0 at the top, `y` up).
    pub fn pixel(g: &[f64; 2]) -> Option<usize> {
        let i = (g[0] * SIZE as f64) as usize;
        let j = (g[1] * SIZE as f64) as usize;
        (i < SIZE && j < SIZE).then(|| (SIZE - 1 - j) * SIZE + i)
    }

    pub fn add(&mut self, g: &[f64; 2], rgb: [f64; 3], w: f64) {
        if let Some(p) = Self::pixel(g) {
            for c in 0..3 {
                self.data[p][c] += w * rgb[c];
            }
        }
    }

    pub fn add_image(&mut self, o: &Image) {
        for (a, b) in self.data.iter_mut().zip(&o.data) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
    }

    /// Root mean square error over pixels and channels.
    pub fn rmse(&self, reference: &Image) -> f64 {
        let n = (self.data.len() * 3) as f64;
        (self
            .data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>())
            .sum::<f64>()
            / n)
            .sqrt()
    }

    /// RMSE of one channel.
    pub fn rmse_channel(&self, reference: &Image, c: usize) -> f64 {
        (self
            .data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (a[c] - b[c]).powi(2))
            .sum::<f64>()
            / self.data.len() as f64)
            .sqrt()
    }

    /// sRGB PNG with the given exposure and a Reinhard curve `v / (1 + v)`.
    pub fn to_png(&self, exposure: f64) -> RgbImage {
        let srgb = |v: f64| {
            let v = v * exposure;
            let v = (v / (1.0 + v)).clamp(0.0, 1.0);
            let s = if v <= 0.003_130_8 {
                12.92 * v
            } else {
                1.055 * v.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0).round() as u8
        };
        RgbImage::from_fn(SIZE as u32, SIZE as u32, |x, y| {
            let p = self.data[y as usize * SIZE + x as usize];
            Rgb([srgb(p[0]), srgb(p[1]), srgb(p[2])])
        })
    }

    /// False-colour image of the per-pixel RMS error over channels against `reference`, with `scale`
    /// mapped to the top of the colour ramp.
    pub fn error_png(&self, reference: &Image, scale: f64) -> RgbImage {
        RgbImage::from_fn(SIZE as u32, SIZE as u32, |x, y| {
            let k = y as usize * SIZE + x as usize;
            let e = ((0..3)
                .map(|c| (self.data[k][c] - reference.data[k][c]).powi(2))
                .sum::<f64>()
                / 3.0)
                .sqrt();
            super::support::colour(e / scale)
        })
    }

    /// An exposure mapping the 90th percentile of the largest channel to 1.5 (0.6 after the curve).
    pub fn auto_exposure(&self) -> f64 {
        let mut v: Vec<f64> = self.data.iter().map(|p| p[0].max(p[1]).max(p[2])).collect();
        v.sort_by(f64::total_cmp);
        1.5 / v[(v.len() * 90) / 100].max(1e-12)
    }
}

/// Tile images into a grid with `cols` columns and a 4-pixel white gap.
pub fn mosaic(tiles: &[RgbImage], cols: usize) -> RgbImage {
    let gap = 4u32;
    let (w, h) = (SIZE as u32, SIZE as u32);
    let rows = tiles.len().div_ceil(cols) as u32;
    let mut out = RgbImage::from_pixel(
        cols as u32 * (w + gap) - gap,
        rows * (h + gap) - gap,
        Rgb([255; 3]),
    );
    for (i, t) in tiles.iter().enumerate() {
        let (cx, cy) = ((i % cols) as u32 * (w + gap), (i / cols) as u32 * (h + gap));
        image::imageops::overlay(&mut out, t, cx as i64, cy as i64);
    }
    out
}

pub fn save(img: &RgbImage, path: &FsPath) -> Result<(), String> {
    img.save(path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}
