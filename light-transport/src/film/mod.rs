//! The film: f64 accumulation of per-pixel estimates and of splats, merged deterministically.
//!
//! Camera-based estimators (path tracing, the `t ≥ 2` strategies of BDPT) add one estimate per
//! camera sample to its pixel; the pixel's value is the mean of its estimates. Light-based
//! estimators (light tracing, `t = 1` strategies, Metropolis recording) *splat* anywhere; the splat
//! buffer is divided by [`Film::splat_scale`], the number of splatting samples per pixel
//! (`total samples / (W·H)`), which matches the camera importance's normalisation (a pixel's value
//! is `W·H` times its share of the film's measurement). Non-finite values are rejected and counted,
//! never accumulated.

mod colormap;
mod metrics;
mod output;

pub use colormap::false_colour;
pub use metrics::{ErrorMetrics, error_image, metrics};
pub use output::{read_image, srgb_encode, write_bytes_png, write_exr, write_png};

use crate::spectrum::Rgb;

/// A splat: raster position (pixels from the left and top edges) and value.
pub type Splat = ([f64; 2], Rgb);

/// An image under accumulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    pixel_sum: Vec<Rgb>,
    pixel_count: Vec<f64>,
    splat_sum: Vec<Rgb>,
    /// Number of splatting samples per pixel the splat buffer is divided by (0: no splats).
    pub splat_scale: f64,
    /// Samples rejected because they were NaN or infinite.
    pub discarded: u64,
    /// Splat layers whose scale is settled later, each counted as `scale · sum` (empty unless
    /// splatted into).
    layers: Vec<Layer>,
}

/// Splats whose common factor is known only as the render goes on (a Metropolis chain's
/// normalisation, refined by its large steps: [`crate::metropolis`]).
///
/// A layer's splats enter the f64 splat buffer at once, as if its scale were 1, and are summed
/// once more in f32 here, for the correction `(scale − 1) · sum` that settles the scale. The
/// refined scale differs from 1 by the normalisation's relative refinement (a few percent), so
/// the f32 sum's rounding reaches the image damped by that factor, and a layer costs 12 bytes
/// a pixel instead of 24: with one layer per path length (MMLT, path-space MLT) the layers are
/// most of a Metropolis render's memory at high resolution (README, issue 17).
#[derive(Clone, Debug, PartialEq)]
struct Layer {
    scale: f64,
    sum: Vec<[f32; 3]>,
}

impl Layer {
    /// The correction of pixel `i`: `(scale − 1) · sum`.
    #[inline]
    fn correction(&self, i: usize) -> Rgb {
        let [r, g, b] = self.sum[i];
        Rgb::new(r as f64, g as f64, b as f64) * (self.scale - 1.0)
    }
}

impl Film {
    /// An empty film.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixel_sum: vec![Rgb::BLACK; width * height],
            pixel_count: vec![0.0; width * height],
            splat_sum: vec![Rgb::BLACK; width * height],
            splat_scale: 0.0,
            discarded: 0,
            layers: Vec::new(),
        }
    }

    /// Splat layer `layer`, its pixels allocated if `pixels` (layers up to it made as needed).
    fn layer(&mut self, layer: usize, pixels: bool) -> &mut Layer {
        if self.layers.len() <= layer {
            let empty = Layer {
                scale: 1.0,
                sum: Vec::new(),
            };
            self.layers.resize(layer + 1, empty);
        }
        let n = self.width * self.height;
        let l = &mut self.layers[layer];
        if pixels && l.sum.is_empty() {
            l.sum = vec![[0.0; 3]; n];
        }
        l
    }

    /// Splat a value at raster position `r` into splat layer `layer`, which counts as the splat
    /// buffer does but multiplied by the layer's scale ([`Film::set_layer_scale`]; 1 until set).
    /// A layer's pixels are allocated by its first splat.
    #[inline]
    pub fn add_layer_splat(&mut self, layer: usize, r: [f64; 2], v: Rgb) {
        if !v.is_finite() {
            self.discarded += 1;
            return;
        }
        if let Some(i) = self.pixel_of(r) {
            self.splat_sum[i] += v;
            let s = &mut self.layer(layer, true).sum[i];
            for (s, v) in s.iter_mut().zip(v.0) {
                *s += v as f32;
            }
        }
    }

    /// Set the factor splat layer `layer` is counted with (a finite value ≥ 0).
    pub fn set_layer_scale(&mut self, layer: usize, scale: f64) {
        debug_assert!(scale.is_finite() && scale >= 0.0, "layer scale {scale}");
        self.layer(layer, false).scale = scale;
    }

    /// The pixel containing raster position `r`.
    pub fn pixel_of(&self, r: [f64; 2]) -> Option<usize> {
        let (x, y) = (r[0].floor(), r[1].floor());
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.width && (y as usize) < self.height)
            .then(|| y as usize * self.width + x as usize)
    }

    /// Add one camera-sample estimate to pixel `index`.
    #[inline]
    pub fn add_sample(&mut self, index: usize, v: Rgb) {
        self.pixel_count[index] += 1.0;
        if v.is_finite() {
            self.pixel_sum[index] += v;
        } else {
            self.discarded += 1;
        }
    }

    /// Splat a value at raster position `r`.
    #[inline]
    pub fn add_splat(&mut self, r: [f64; 2], v: Rgb) {
        if !v.is_finite() {
            self.discarded += 1;
            return;
        }
        if let Some(i) = self.pixel_of(r) {
            self.splat_sum[i] += v;
        }
    }

    /// Add another film's accumulation (same size); its splat layers enter this film's splat
    /// buffer as they count now (times their scale). Merging in a fixed order keeps results
    /// independent of the thread count.
    pub fn merge(&mut self, o: &Film) {
        for i in 0..self.pixel_sum.len() {
            self.pixel_sum[i] += o.pixel_sum[i];
            self.pixel_count[i] += o.pixel_count[i];
            self.splat_sum[i] += o.splat_sum[i];
        }
        for l in o
            .layers
            .iter()
            .filter(|l| !l.sum.is_empty() && l.scale != 1.0)
        {
            for (i, a) in self.splat_sum.iter_mut().enumerate() {
                *a += l.correction(i);
            }
        }
        self.splat_scale += o.splat_scale;
        self.discarded += o.discarded;
    }

    /// The current estimate of every pixel, row-major, top row first.
    pub fn image(&self) -> Vec<Rgb> {
        (0..self.pixel_sum.len())
            .map(|i| {
                let mut v = if self.pixel_count[i] > 0.0 {
                    self.pixel_sum[i] / self.pixel_count[i]
                } else {
                    Rgb::BLACK
                };
                if self.splat_scale > 0.0 {
                    let mut splats = self.splat_sum[i];
                    for l in self
                        .layers
                        .iter()
                        .filter(|l| !l.sum.is_empty() && l.scale != 1.0)
                    {
                        splats += l.correction(i);
                    }
                    v += splats / self.splat_scale;
                }
                v
            })
            .collect()
    }

    /// Camera samples accumulated over the whole film.
    pub fn camera_samples(&self) -> f64 {
        self.pixel_count.iter().sum()
    }
}

/// A finished image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pixels, row-major, top row first.
    pub pixels: Vec<Rgb>,
}

impl Image {
    /// The film's current estimate.
    pub fn from_film(film: &Film) -> Self {
        Self {
            width: film.width,
            height: film.height,
            pixels: film.image(),
        }
    }

    /// Box-filter down by an integer factor `k` (each output pixel averages a `k×k` block, which
    /// is exactly a pixel-area average at the lower resolution). `None` unless `k` divides both
    /// dimensions.
    pub fn downsample(&self, k: usize) -> Option<Image> {
        if k == 0 || !self.width.is_multiple_of(k) || !self.height.is_multiple_of(k) {
            return None;
        }
        let (w, h) = (self.width / k, self.height / k);
        let mut pixels = vec![Rgb::BLACK; w * h];
        for y in 0..self.height {
            for x in 0..self.width {
                pixels[(y / k) * w + x / k] += self.pixels[y * self.width + x];
            }
        }
        let n = (k * k) as f64;
        Some(Image {
            width: w,
            height: h,
            pixels: pixels.into_iter().map(|p| p / n).collect(),
        })
    }

    /// Average of all pixels.
    pub fn mean(&self) -> Rgb {
        let n = self.pixels.len().max(1) as f64;
        self.pixels.iter().fold(Rgb::BLACK, |a, &p| a + p) / n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_values_are_counted_not_accumulated() {
        let mut f = Film::new(2, 2);
        f.add_sample(0, Rgb::new(1.0, f64::NAN, 0.0));
        f.add_sample(0, Rgb::splat(2.0));
        f.add_splat([1.5, 0.5], Rgb::splat(f64::INFINITY));
        f.add_splat([1.5, 0.5], Rgb::splat(4.0));
        f.splat_scale = 2.0;
        let img = f.image();
        assert_eq!(img[0], Rgb::splat(1.0)); // (0 + 2) / 2 samples
        assert_eq!(img[1], Rgb::splat(2.0));
        assert_eq!(f.discarded, 2);
        assert!(img.iter().all(|p| p.is_finite()));
    }

    /// A splat layer counts times its scale, set before or after its splats; a merge adds
    /// another film's layers as they count at the merge.
    #[test]
    fn splat_layers_count_times_their_scale() {
        let mut a = Film::new(2, 1);
        a.splat_scale = 2.0;
        a.add_splat([0.5, 0.5], Rgb::splat(2.0));
        a.add_layer_splat(1, [0.5, 0.5], Rgb::splat(4.0));
        a.add_layer_splat(1, [1.5, 0.5], Rgb::splat(f64::NAN));
        assert_eq!(a.image(), [Rgb::splat(3.0), Rgb::BLACK]);
        a.set_layer_scale(1, 0.5);
        assert_eq!(a.image(), [Rgb::splat(2.0), Rgb::BLACK]);
        assert_eq!(a.discarded, 1);
        let mut b = Film::new(2, 1);
        b.merge(&a);
        b.splat_scale = 2.0;
        assert_eq!(b.image(), a.image());
        let mut c = Film::new(2, 1);
        c.add_layer_splat(1, [1.5, 0.5], Rgb::splat(8.0));
        c.set_layer_scale(1, 0.25);
        b.merge(&c);
        b.splat_scale = 2.0;
        assert_eq!(b.image(), [Rgb::splat(2.0), Rgb::splat(1.0)]);
        // Merged layers entered as they counted: a later scale of this film's own layer 1
        // (it has none) changes nothing.
        b.set_layer_scale(1, 4.0);
        assert_eq!(b.image(), [Rgb::splat(2.0), Rgb::splat(1.0)]);
    }

    /// The f32 sums of a layer reach the image only through `(scale − 1)`: 100 000 splats of
    /// varied size into one pixel, with a refined scale 3% above 1, give the f64 sum's image to
    /// within a relative 1e-8 (3.2e-9; the f32 sum alone is off by 1.1e-7 here, so a layer
    /// counted as `scale · f32 sum` fails).
    #[test]
    fn layer_rounding_is_damped_by_the_scale_correction() {
        let mut f = Film::new(1, 1);
        f.splat_scale = 1.0;
        let (mut exact, mut x) = (0.0_f64, 0.5_f64);
        for _ in 0..100_000 {
            x = (x * 3.9 * (1.0 - x)).clamp(1e-3, 1.0 - 1e-3); // logistic map: values in (0, 1)
            exact += x;
            f.add_layer_splat(0, [0.5, 0.5], Rgb::splat(x));
        }
        f.set_layer_scale(0, 1.03);
        let got = f.image()[0].0[0];
        let rel = (got - 1.03 * exact).abs() / (1.03 * exact);
        assert!(rel < 1e-8, "relative error {rel:e}");
    }

    #[test]
    fn merge_adds_everything() {
        let mut a = Film::new(1, 1);
        let mut b = Film::new(1, 1);
        a.add_sample(0, Rgb::splat(1.0));
        b.add_sample(0, Rgb::splat(3.0));
        a.merge(&b);
        assert_eq!(a.image()[0], Rgb::splat(2.0));
    }
}
