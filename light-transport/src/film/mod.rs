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
///
/// Each buffer is allocated by its first deposit, so a film that only splats (a Metropolis
/// render's chains) or only takes camera samples (path tracing, the Metropolis methods' direct
/// pass) holds 24 or 32 bytes a pixel instead of 56 (docs/performance.md).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Sums of camera-sample estimates (empty until the first sample).
    pixel_sum: Vec<Rgb>,
    /// Camera samples per pixel (empty until the first sample).
    pixel_count: Vec<f64>,
    /// Sums of splats (empty until the first splat).
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
/// most of a Metropolis render's memory at high resolution (docs/performance.md).
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
            pixel_sum: Vec::new(),
            pixel_count: Vec::new(),
            splat_sum: Vec::new(),
            splat_scale: 0.0,
            discarded: 0,
            layers: Vec::new(),
        }
    }

    /// The splat buffer, allocated if it is not yet.
    #[inline]
    fn splats_mut(&mut self) -> &mut [Rgb] {
        if self.splat_sum.is_empty() {
            self.splat_sum = vec![Rgb::BLACK; self.width * self.height];
        }
        &mut self.splat_sum
    }

    /// The camera-sample buffers (sums, counts), allocated if they are not yet.
    #[inline]
    fn samples_mut(&mut self) -> (&mut [Rgb], &mut [f64]) {
        if self.pixel_count.is_empty() {
            let n = self.width * self.height;
            self.pixel_sum = vec![Rgb::BLACK; n];
            self.pixel_count = vec![0.0; n];
        }
        (&mut self.pixel_sum, &mut self.pixel_count)
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
            self.splats_mut()[i] += v;
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
        let (sum, count) = self.samples_mut();
        count[index] += 1.0;
        if v.is_finite() {
            sum[index] += v;
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
            self.splats_mut()[i] += v;
        }
    }

    /// Add another film's accumulation (same size); its splat layers enter this film's splat
    /// buffer as they count now (times their scale). Merging in a fixed order keeps results
    /// independent of the thread count.
    pub fn merge(&mut self, o: &Film) {
        if !o.pixel_count.is_empty() {
            let (sum, count) = self.samples_mut();
            for i in 0..sum.len() {
                sum[i] += o.pixel_sum[i];
                count[i] += o.pixel_count[i];
            }
        }
        if !o.splat_sum.is_empty() {
            for (a, b) in self.splats_mut().iter_mut().zip(&o.splat_sum) {
                *a += *b;
            }
        }
        for l in o.corrected_layers() {
            for (i, a) in self.splats_mut().iter_mut().enumerate() {
                *a += l.correction(i);
            }
        }
        self.splat_scale += o.splat_scale;
        self.discarded += o.discarded;
    }

    /// [`Film::merge`] of a film no longer needed: a buffer this film does not have yet is taken
    /// over rather than allocated and added to (the same sums, since `0 + x = x`), so merging a
    /// Metropolis render's chains into its direct pass needs no third splat buffer.
    pub fn merge_owned(&mut self, mut o: Film) {
        if self.pixel_count.is_empty() {
            std::mem::swap(&mut self.pixel_sum, &mut o.pixel_sum);
            std::mem::swap(&mut self.pixel_count, &mut o.pixel_count);
        }
        if self.splat_sum.is_empty() {
            std::mem::swap(&mut self.splat_sum, &mut o.splat_sum);
        }
        // What is left of `o`: its buffers where this film had its own, its layers' corrections.
        self.merge(&o);
    }

    /// The layers whose correction is not zero.
    fn corrected_layers(&self) -> impl Iterator<Item = &Layer> {
        self.layers
            .iter()
            .filter(|l| !l.sum.is_empty() && l.scale != 1.0)
    }

    /// Pixel `i`'s camera-sample sum and count and its splat sum with this film's layer
    /// corrections, as [`Film::image`] reads them.
    #[inline]
    fn parts(&self, i: usize) -> (Rgb, f64, Rgb) {
        let (sum, count) = match self.pixel_count.is_empty() {
            true => (Rgb::BLACK, 0.0),
            false => (self.pixel_sum[i], self.pixel_count[i]),
        };
        let mut splats = self.splat_sum.get(i).copied().unwrap_or(Rgb::BLACK);
        for l in self.corrected_layers() {
            splats += l.correction(i);
        }
        (sum, count, splats)
    }

    /// A pixel's value from its parts.
    #[inline]
    fn value(sum: Rgb, count: f64, splats: Rgb, splat_scale: f64) -> Rgb {
        let mut v = if count > 0.0 { sum / count } else { Rgb::BLACK };
        if splat_scale > 0.0 {
            v += splats / splat_scale;
        }
        v
    }

    /// The current estimate of every pixel, row-major, top row first.
    pub fn image(&self) -> Vec<Rgb> {
        (0..self.width * self.height)
            .map(|i| {
                let (sum, count, splats) = self.parts(i);
                Self::value(sum, count, splats, self.splat_scale)
            })
            .collect()
    }

    /// The image of this film with `o` merged into it, bit for bit what `merge` then `image`
    /// give, without the merged film's buffers: a render's progress report shows two films
    /// (the Metropolis methods' direct pass and their chains) as one this way.
    pub fn merged_image(&self, o: &Film) -> Vec<Rgb> {
        assert_eq!((self.width, self.height), (o.width, o.height), "film sizes");
        let scale = self.splat_scale + o.splat_scale;
        (0..self.width * self.height)
            .map(|i| {
                // The order of `merge` (this film's buffers plus the other's, its splats with
                // its layer corrections), then this film's layer corrections as `image` adds
                // them.
                let (mut sum, mut count, mut splats) = match self.pixel_count.is_empty() {
                    true => (Rgb::BLACK, 0.0, Rgb::BLACK),
                    false => (self.pixel_sum[i], self.pixel_count[i], Rgb::BLACK),
                };
                if !o.pixel_count.is_empty() {
                    sum += o.pixel_sum[i];
                    count += o.pixel_count[i];
                }
                if let Some(&s) = self.splat_sum.get(i) {
                    splats = s;
                }
                if let Some(&s) = o.splat_sum.get(i) {
                    splats += s;
                    for l in o.corrected_layers() {
                        splats += l.correction(i);
                    }
                }
                for l in self.corrected_layers() {
                    splats += l.correction(i);
                }
                Self::value(sum, count, splats, scale)
            })
            .collect()
    }

    /// Camera samples accumulated over the whole film.
    pub fn camera_samples(&self) -> f64 {
        self.pixel_count.iter().sum()
    }
}

/// A render's film as a progress report shows it: one film, or two (a Metropolis method's
/// direct pass and its chains) counted as their merge, which is built only when asked for.
#[derive(Clone, Copy, Debug)]
pub enum FilmView<'a> {
    /// One film.
    One(&'a Film),
    /// Two films counted as the first with the second merged into it ([`Film::merge`]).
    Merged(&'a Film, &'a Film),
}

impl FilmView<'_> {
    /// The current image.
    pub fn image(&self) -> Image {
        match *self {
            FilmView::One(f) => Image::from_film(f),
            FilmView::Merged(a, b) => Image {
                width: a.width,
                height: a.height,
                pixels: a.merged_image(b),
            },
        }
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

    /// The bytes a film's buffers hold.
    fn heap_bytes(f: &Film) -> usize {
        f.pixel_sum.capacity() * size_of::<Rgb>()
            + f.pixel_count.capacity() * size_of::<f64>()
            + f.splat_sum.capacity() * size_of::<Rgb>()
            + f.layers
                .iter()
                .map(|l| l.sum.capacity() * 12)
                .sum::<usize>()
    }

    /// Buffers come with their first deposit: a splatting film holds 24 bytes a pixel, a
    /// sampling one 32, both 56, and merging an empty film allocates nothing.
    #[test]
    fn buffers_are_allocated_by_their_first_deposit() {
        let (w, h) = (8, 4);
        let mut f = Film::new(w, h);
        assert_eq!(heap_bytes(&f), 0);
        f.merge(&Film::new(w, h));
        assert_eq!(heap_bytes(&f), 0);
        assert_eq!(f.image(), vec![Rgb::BLACK; w * h]);
        f.add_splat([100.0, 0.5], Rgb::splat(1.0)); // off the film: nothing to hold
        assert_eq!(heap_bytes(&f), 0);
        f.add_splat([1.5, 0.5], Rgb::splat(1.0));
        assert_eq!(heap_bytes(&f), 24 * w * h);
        let mut g = Film::new(w, h);
        g.add_sample(3, Rgb::splat(1.0));
        assert_eq!(heap_bytes(&g), 32 * w * h);
        assert_eq!(g.camera_samples(), 1.0);
        g.merge(&f);
        assert_eq!(heap_bytes(&g), 56 * w * h);
    }

    /// `merged_image` is `merge` then `image`, bit for bit, whichever buffers and layers the two
    /// films have (a changed summation order shows in the last bits of these values).
    #[test]
    fn merged_image_is_merge_then_image() {
        let (w, h) = (3, 2);
        let mut films = Vec::new();
        for kind in 0..5 {
            let mut f = Film::new(w, h);
            let mut x = 0.1 + 0.07 * kind as f64;
            let mut next = || {
                x = 3.9 * x * (1.0 - x);
                x
            };
            for i in 0..w * h {
                if kind == 1 || kind == 3 {
                    f.add_sample(i, Rgb::new(next(), next(), next()));
                }
                if kind >= 2 {
                    f.add_splat([i as f64 % 3.0 + 0.5, 0.5], Rgb::splat(next()));
                }
                if kind >= 3 {
                    for layer in 0..2 {
                        f.add_layer_splat(layer, [0.5, i as f64 % 2.0 + 0.5], Rgb::splat(next()));
                    }
                }
            }
            if kind >= 3 {
                f.set_layer_scale(0, 1.0 + next() * 0.1);
                f.set_layer_scale(1, 1.0 - next() * 0.1);
            }
            f.splat_scale = if kind >= 2 { 0.3 * kind as f64 } else { 0.0 };
            films.push(f);
        }
        for a in &films {
            for b in &films {
                let mut m = a.clone();
                m.merge(b);
                let (want, got) = (m.image(), a.merged_image(b));
                for (x, y) in want.iter().zip(&got) {
                    assert_eq!(x.0.map(f64::to_bits), y.0.map(f64::to_bits));
                }
            }
        }
    }

    /// `merge_owned` is `merge`, bit for bit, whichever buffers either film has.
    #[test]
    fn merge_owned_is_merge() {
        let (w, h) = (3, 2);
        let make = |samples: bool, splats: bool, layer: bool| {
            let mut f = Film::new(w, h);
            for i in 0..w * h {
                let x = 0.1 + 0.37 * i as f64;
                if samples {
                    f.add_sample(i, Rgb::new(x, 2.0 * x, 0.3));
                }
                if splats {
                    f.add_splat([(i % w) as f64 + 0.5, 0.5], Rgb::splat(x / 3.0));
                }
                if layer {
                    f.add_layer_splat(0, [0.5, (i % h) as f64 + 0.5], Rgb::splat(x / 7.0));
                }
            }
            f.set_layer_scale(0, 1.07);
            f.splat_scale = if splats || layer { 1.5 } else { 0.0 };
            f.discarded = u64::from(samples) + 2 * u64::from(splats);
            f
        };
        let kinds = [
            (false, false, false),
            (true, false, false),
            (false, true, false),
            (false, true, true),
            (true, true, true),
        ];
        for &a in &kinds {
            for &b in &kinds {
                let mut want = make(a.0, a.1, a.2);
                want.merge(&make(b.0, b.1, b.2));
                let mut got = make(a.0, a.1, a.2);
                got.merge_owned(make(b.0, b.1, b.2));
                assert_eq!(got.image(), want.image(), "{a:?} {b:?}");
                assert_eq!(
                    (got.splat_scale, got.discarded),
                    (want.splat_scale, want.discarded)
                );
                assert_eq!(got.camera_samples(), want.camera_samples());
            }
        }
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
