//! Image error metrics against a reference: MSE, relative MSE and RMSE, and a false-colour error
//! image.

use super::{Image, false_colour};
use crate::{Error, Result};

/// Errors of an image against a reference, averaged over pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorMetrics {
    /// Mean squared error.
    pub mse: f64,
    /// Root mean squared error.
    pub rmse: f64,
    /// Relative MSE: mean of `(x − r)² / (r² + 0.01)` (the offset keeps dark pixels from
    /// dominating).
    pub rel_mse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// The RMS over pixels of the relative luminance error `E = (I − I_ref)/I_ref` (Fan, Chenney &
    /// Lai 2005, §6), over the pixels whose reference luminance is positive.
    pub rel_luminance_rms: f64,
}

fn check(a: &Image, r: &Image) -> Result<()> {
    if a.width != r.width || a.height != r.height {
        return Err(Error::InvalidParameter {
            name: "reference".into(),
            reason: format!(
                "size {}×{} differs from the image's {}×{}",
                r.width, r.height, a.width, a.height
            ),
        });
    }
    Ok(())
}

/// Error metrics of `image` against `reference` (same size).
pub fn metrics(image: &Image, reference: &Image) -> Result<ErrorMetrics> {
    check(image, reference)?;
    let n = (image.pixels.len() * 3) as f64;
    let (mut se, mut rel, mut ae) = (0.0, 0.0, 0.0);
    let (mut lum, mut lit) = (0.0, 0usize);
    for (a, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let d = a[c] - r[c];
            se += d * d;
            rel += d * d / (r[c] * r[c] + 0.01);
            ae += d.abs();
        }
        let yr = r.luminance();
        if yr > 0.0 {
            lum += ((a.luminance() - yr) / yr).powi(2);
            lit += 1;
        }
    }
    Ok(ErrorMetrics {
        mse: se / n,
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        mae: ae / n,
        rel_luminance_rms: (lum / lit.max(1) as f64).sqrt(),
    })
}

/// A false-colour image of the per-pixel relative error `|x − r| / (|r| + 0.1)` (mean over
/// channels), with `scale` at the top of the ramp. Returns sRGB bytes, row-major.
pub fn error_image(image: &Image, reference: &Image, scale: f64) -> Result<Vec<[u8; 3]>> {
    check(image, reference)?;
    Ok(image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, r)| {
            let e = (0..3)
                .map(|c| (a[c] - r[c]).abs() / (r[c].abs() + 0.1))
                .sum::<f64>()
                / 3.0;
            false_colour(e / scale)
        })
        .collect())
}
