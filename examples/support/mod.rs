//! Helpers shared by the examples: the `--quick` flag and a PNG with two heatmaps side by side,
//! a 2D histogram of samples (left) and the exact unnormalised density on the same grid (right).

use std::error::Error;
use std::path::PathBuf;

use image::{Rgb, RgbImage};

/// `true` when `--quick` was passed; any other argument is an error.
pub fn quick_flag() -> Result<bool, String> {
    let mut quick = false;
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--quick" => quick = true,
            other => {
                return Err(format!(
                    "unknown argument {other:?} (only --quick is accepted)"
                ));
            }
        }
    }
    Ok(quick)
}

/// A rectangle `[x0, x1] × [y0, y1]` of the plane cut into `nx × ny` cells.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub nx: usize,
    pub ny: usize,
}

impl Grid {
    /// Column and row (row 0 at the bottom) of the cell holding `p`, if inside.
    fn cell(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let u = (p[0] - self.x.0) / (self.x.1 - self.x.0);
        let v = (p[1] - self.y.0) / (self.y.1 - self.y.0);
        let inside = (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v);
        inside.then_some(((u * self.nx as f64) as usize, (v * self.ny as f64) as usize))
    }

    fn centre(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.x.0 + (i as f64 + 0.5) / self.nx as f64 * (self.x.1 - self.x.0),
            self.y.0 + (j as f64 + 0.5) / self.ny as f64 * (self.y.1 - self.y.0),
        ]
    }
}

/// Screen pixels per grid cell, and the gap between the two panels.
const CELL_PIXELS: usize = 2;
const GAP_PIXELS: usize = 8;

/// Write `out/<file_name>` (creating `out/` in the workspace root) with the histogram of `samples`
/// on the left and `exp(ln_density)` on the right, each normalised to its own maximum. Returns the
/// path written.
pub fn write_heatmaps(
    file_name: &str,
    grid: Grid,
    samples: impl IntoIterator<Item = [f64; 2]>,
    ln_density: impl Fn([f64; 2]) -> f64,
) -> Result<PathBuf, Box<dyn Error>> {
    let mut counts = vec![0.0; grid.nx * grid.ny];
    for p in samples {
        if let Some((i, j)) = grid.cell(p) {
            counts[j * grid.nx + i] += 1.0;
        }
    }
    // Subtract the largest log density before exponentiating so peaks far below 1 stay visible.
    let mut density: Vec<f64> = (0..grid.nx * grid.ny)
        .map(|c| ln_density(grid.centre(c % grid.nx, c / grid.nx)))
        .collect();
    let top = density.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    density.iter_mut().for_each(|l| *l = (*l - top).exp());

    let (w, h) = (grid.nx * CELL_PIXELS, grid.ny * CELL_PIXELS);
    let mut img = RgbImage::from_pixel((2 * w + GAP_PIXELS) as u32, h as u32, Rgb([255; 3]));
    for (panel, values) in [&counts, &density].into_iter().enumerate() {
        let max = values.iter().copied().fold(0.0, f64::max);
        let x_offset = panel * (w + GAP_PIXELS);
        for py in 0..h {
            for px in 0..w {
                let (i, j) = (px / CELL_PIXELS, grid.ny - 1 - py / CELL_PIXELS);
                let v = values[j * grid.nx + i];
                let t = if max > 0.0 && v.is_finite() {
                    v / max
                } else {
                    0.0
                };
                img.put_pixel((x_offset + px) as u32, py as u32, colour(t));
            }
        }
    }

    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/out"));
    std::fs::create_dir_all(&dir)?;
    let path = dir.join(file_name);
    img.save(&path)?;
    Ok(path)
}

/// The renderer's perceptual false-colour ramp (dark purple → teal → yellow) as an image pixel.
pub fn colour(t: f64) -> Rgb<u8> {
    Rgb(light_transport::film::false_colour(t))
}
