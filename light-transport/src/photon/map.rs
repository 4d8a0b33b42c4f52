//! A photon map (Jensen 2001, ch. 7; Fan, Chenney & Lai 2005, §3): photons — position, the
//! direction toward where the light came from, RGB power and the surface normal at the storage
//! point — in an immutable k-d tree (kiddo 6, which keeps many photons at one position; the paper's
//! Metropolis sampler accumulates repeated paths into one photon, but distinct photons may still
//! share a point), and the density estimate of reflected radiance
//!
//! `L(x, ω_o) ≈ Σ_p f_s(x, ω_p → ω_o) Φ_p w(d_p / r) / (c π r²)`
//!
//! over the `k` nearest photons within the maximum radius whose normals face like the query's (a
//! normal filter against light leaking around thin objects and corners).
//!
//! **Kernel.** The cone filter `w(t) = 1 − t` (Jensen's with `k = 1`), normalised by its integral
//! over the disk, `c = 1/3`. The radius `r` is the distance to the `k`-th nearest photon, which the
//! kernel weighs 0; with fewer than `k` photons in reach, `r` is the maximum radius. Then, for
//! photons of power `Φ` laid on a plane by a Poisson process of density `ρ` (irradiance `E = ρΦ`),
//! the estimate is **unbiased**: given `r`, the `k − 1` photons inside are uniform in the disk and
//! `E[w] = 1/3`, so the estimate is `(k − 1)Φ/(πr²)`, and `πr²ρ` has the Gamma(k, 1) law, whose
//! inverse has mean `1/(k − 1)`; with the maximum radius, the count inside is Poisson(ρπR²). The
//! familiar `k/(πr²)` estimate is biased by `k/(k − 1)` in the same setting. On curved surfaces, at
//! edges and where the irradiance varies within `r`, the usual smoothing bias remains.

use crate::math::DVec3;
use crate::spectrum::Rgb;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::num::NonZero;

/// One photon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    /// Where it is stored.
    pub p: DVec3,
    /// Unit direction toward where the light came from (the previous vertex).
    pub wi: DVec3,
    /// RGB power (flux).
    pub power: Rgb,
    /// Unit surface normal at `p` (the geometric normal, on the side the light arrived from).
    pub n: DVec3,
}

/// How a radiance estimate gathers photons.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// At most this many nearest photons (`n = 60` in Fan et al. 2005, §6).
    pub k: usize,
    /// The largest search radius (scene units).
    pub max_radius: f64,
    /// A photon counts only when its normal and the query's have at least this cosine (0.9).
    pub min_normal_cos: f64,
}

impl Lookup {
    /// `k` photons within `max_radius`, normals within 25.8° (cosine 0.9).
    pub fn new(k: usize, max_radius: f64) -> Self {
        Self {
            k,
            max_radius,
            min_normal_cos: 0.9,
        }
    }

    /// Whether the parameters make sense: `k ≥ 2` (the kernel weighs the `k`-th photon 0), a
    /// positive finite radius, a cosine in `[−1, 1]`.
    pub fn is_valid(&self) -> bool {
        self.k >= 2
            && self.max_radius > 0.0
            && self.max_radius.is_finite()
            && (-1.0..=1.0).contains(&self.min_normal_cos)
    }
}

/// Photons in a k-d tree.
pub struct PhotonMap {
    photons: Vec<Photon>,
    tree: ImmutableKdTree<f64, 3>,
}

impl std::fmt::Debug for PhotonMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PhotonMap")
            .field("photons", &self.photons.len())
            .finish()
    }
}

/// Why a photon map could not be built.
#[derive(Debug, thiserror::Error)]
pub enum PhotonMapError {
    /// More photons than the tree's `u32` items can name.
    #[error("{0} photons exceed the photon map's limit of {max}", max = u32::MAX)]
    TooMany(usize),
    /// A photon with a non-finite position or power.
    #[error("photon {index} has a non-finite position or power")]
    NonFinite {
        /// Its index.
        index: usize,
    },
    /// The k-d tree could not be built.
    #[error("the photon k-d tree could not be built: {0}")]
    Tree(String),
}

impl PhotonMap {
    /// A map of `photons` (possibly none).
    pub fn new(photons: Vec<Photon>) -> Result<Self, PhotonMapError> {
        if photons.len() > u32::MAX as usize {
            return Err(PhotonMapError::TooMany(photons.len()));
        }
        if let Some(index) = photons
            .iter()
            .position(|ph| !(ph.p.is_finite() && ph.power.is_finite()))
        {
            return Err(PhotonMapError::NonFinite { index });
        }
        let points: Vec<[f64; 3]> = photons.iter().map(|ph| ph.p.to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&points)
            .map_err(|e| PhotonMapError::Tree(format!("{e:?}")))?;
        Ok(Self { photons, tree })
    }

    /// Photons stored.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether the map is empty.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The photons.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Bytes per photon: the photon record plus the tree's copy of its position and its index
    /// (the tree's inner nodes add a small fraction more).
    pub fn bytes_per_photon() -> usize {
        std::mem::size_of::<Photon>() + std::mem::size_of::<[f64; 3]>() + std::mem::size_of::<u32>()
    }

    /// The squared distance from `x` to its `k`-th nearest photon (counting a photon at `x`), or
    /// `None` when the map holds fewer than `k` photons.
    pub fn kth_nearest_distance2(&self, x: DVec3, k: usize) -> Option<f64> {
        let k = NonZero::new(k)?;
        if self.photons.len() < k.get() {
            return None;
        }
        let found = self
            .tree
            .query(&x.to_array())
            .nearest_n::<SquaredEuclidean<f64>>(k)
            .execute();
        (found.len() == k.get())
            .then(|| found.last().map(|q| q.distance))
            .flatten()
    }

    /// The cone-filtered estimate at `x` (normal `n`): `Σ f(ω_p) Φ_p w(d_p/r) / (π r²/3)`, with
    /// `f` the BSDF value for light arriving from `ω_p` (a function of the photon's `wi`).
    pub fn estimate(
        &self,
        x: DVec3,
        n: DVec3,
        lookup: &Lookup,
        mut f: impl FnMut(DVec3) -> Rgb,
    ) -> Rgb {
        let (Some(k), true) = (NonZero::new(lookup.k), lookup.is_valid()) else {
            return Rgb::BLACK;
        };
        if self.photons.is_empty() {
            return Rgb::BLACK;
        }
        let r_max2 = lookup.max_radius * lookup.max_radius;
        let found = self
            .tree
            .query(&x.to_array())
            .nearest_n::<SquaredEuclidean<f64>>(k)
            .within(r_max2)
            .execute();
        // The radius: the k-th photon's distance, or the maximum when fewer are in reach.
        let r2 = if found.len() == lookup.k {
            found.last().map_or(r_max2, |q| q.distance)
        } else {
            r_max2
        };
        if !(r2 > 0.0) {
            return Rgb::BLACK;
        }
        let r = r2.sqrt();
        let mut sum = Rgb::BLACK;
        for q in &found {
            let ph = &self.photons[q.item as usize];
            if ph.n.dot(n) < lookup.min_normal_cos {
                continue;
            }
            let w = 1.0 - q.distance.sqrt() / r;
            if w > 0.0 {
                sum += f(ph.wi) * ph.power * w;
            }
        }
        let out = sum * (3.0 / (std::f64::consts::PI * r2));
        if out.is_finite() { out } else { Rgb::BLACK }
    }
}
