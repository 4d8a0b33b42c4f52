//! The largest lookup radius `d_max` of a photon map's radiance estimate (Fan, Chenney & Lai 2005,
//! §6, who take it from Suykens' 2002 thesis with `α = 0.1`).
//!
//! Suykens' own formula (his thesis, p. 159) was not available to us. The rule here is ours, in the
//! spirit of his density control (Suykens & Willems 2000: a photon map should hold some required
//! density of photons, and an estimate should not reach beyond it). With `ρ̃` the map's *typical*
//! photon density and `k` the photons per estimate,
//!
//! `d_max = √(k / (π α ρ̃))`,
//!
//! the radius of a disk that holds `k` photons where the density is `α ρ̃`. An estimate therefore
//! reaches its `k` photons wherever the local density is at least `α` times the typical one, and
//! where the map is sparser than that (light that barely reaches a region, stray photons behind a
//! wall) it stops at `d_max` and uses fewer photons, instead of blurring light in from far away.
//! As the map grows, `d_max` shrinks like `1/√N`, so the smoothing bias vanishes with the photon
//! count (fixed radii leave it in place).
//!
//! **Typical density.** The median over up to [`DENSITY_SAMPLES`] photons (evenly spaced in the
//! map's order) of `m_k / (π r_k²)`, `r_k` the distance from the photon to its `k`-th nearest
//! other photon and `m_k ≈ k − 1/3 + 8/(405 k)` the median of the Gamma(k, 1) law (Choi 1994). On
//! a plane holding a Poisson process of density `ρ`, seen from one of its points the others are
//! still Poisson (Slivnyak), `π r_k² ρ` is Gamma(k, 1), and the median of the estimate is `ρ`. It
//! is the density *as photons see it*: dense regions, where most photons are, set it.
//!
//! **Bounded above.** The rule never gives more than a fixed fraction of the scene's size (the
//! caller's cap: Mitsuba 0.6's defaults, 5% of the bounding-sphere radius for the global map and
//! 1.25% for the caustic map), which also stands in when the map holds `k` photons or fewer or they
//! all coincide. Without the cap, a sparse map's `d_max` blurs its estimates over a large part of
//! the scene: on `box` the caustic map's photons (mostly light from the mirror wall, spread over
//! the room) gave 11% of the scene's radius and, at equal photons, `E_rms` 0.577 against 0.235
//! with the cap, which binds there. So the density rule shrinks radii where maps are dense and
//! as they grow; the cap keeps sparse maps from blurring shadows and caustics away.

use super::map::PhotonMap;

/// Photons whose neighbourhoods set the typical density (at most).
pub const DENSITY_SAMPLES: usize = 1024;

/// How a photon map's largest lookup radius is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaxRadius {
    /// A fixed fraction of the scene's bounding-sphere radius (Mitsuba 0.6's defaults are 0.05
    /// for the global map and 0.0125 for the caustic map).
    Fraction(f64),
    /// From the map's typical density: `d_max = √(k / (π α ρ̃))` (module docs; `α = 0.1` by
    /// default, the paper's).
    Density {
        /// The fraction of the typical density below which estimates stop growing.
        alpha: f64,
    },
}

impl MaxRadius {
    /// The default: the density rule with `α = 0.1`.
    pub const DEFAULT: MaxRadius = MaxRadius::Density { alpha: 0.1 };

    /// Whether the parameter is valid: a positive finite fraction, or `α` in `(0, 1]`.
    pub fn is_valid(&self) -> bool {
        match *self {
            MaxRadius::Fraction(f) => f > 0.0 && f.is_finite(),
            MaxRadius::Density { alpha } => alpha > 0.0 && alpha <= 1.0,
        }
    }

    /// The radius in scene units for `map` read `k` photons at a time, in a scene whose bounding
    /// sphere has radius `scene_radius`. The density rule gives at most `cap` (a fraction of
    /// that radius), and `cap` itself when it has no density to read.
    pub fn resolve(&self, map: &PhotonMap, k: usize, scene_radius: f64, cap: f64) -> Resolved {
        let fixed = |fraction: f64| Resolved {
            radius: fraction * scene_radius,
            density: None,
            capped: false,
        };
        match *self {
            MaxRadius::Fraction(f) => fixed(f),
            MaxRadius::Density { alpha } => match typical_density(map, k) {
                Some(rho) => {
                    let rule = (k as f64 / (std::f64::consts::PI * alpha * rho)).sqrt();
                    Resolved {
                        radius: rule.min(cap * scene_radius),
                        density: Some(rho),
                        capped: rule > cap * scene_radius,
                    }
                }
                None => Resolved {
                    capped: true,
                    ..fixed(cap)
                },
            },
        }
    }
}

/// A resolved maximum radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolved {
    /// `d_max` in scene units.
    pub radius: f64,
    /// The typical density the density rule read (photons per unit area).
    pub density: Option<f64>,
    /// Whether the density rule gave its cap: it asked for more, or had no density to read
    /// (then `density` is `None`).
    pub capped: bool,
}

/// The median of the Gamma(k, 1) law (Choi 1994's expansion to `k⁻³`: 1.67843 for the exact
/// 1.67835 at `k = 2`, relative error below 1e-4 for `k ≥ 2`).
pub fn gamma_median(k: usize) -> f64 {
    let k = k as f64;
    k - 1.0 / 3.0 + 8.0 / (405.0 * k) + 184.0 / (25515.0 * k * k) + 2248.0 / (3444525.0 * k * k * k)
}

/// The map's typical photon density `ρ̃` seen from its photons (module docs), or `None` with `k`
/// photons or fewer, or when the median neighbourhood has radius 0 (more than half the sampled
/// photons sit on piles of over `k`: they count as the densest, not as missing).
pub fn typical_density(map: &PhotonMap, k: usize) -> Option<f64> {
    let n = map.len();
    if k < 1 || n <= k {
        return None;
    }
    let samples = n.min(DENSITY_SAMPLES);
    let m_k = gamma_median(k);
    let mut rho: Vec<f64> = (0..samples)
        .filter_map(|i| {
            let photon = &map.photons()[i * n / samples];
            // The photon itself is its own nearest: the k-th other one is the (k + 1)-th.
            let r2 = map.kth_nearest_distance2(photon.p, k + 1)?;
            (r2 >= 0.0).then(|| m_k / (std::f64::consts::PI * r2))
        })
        .collect();
    if rho.is_empty() {
        return None;
    }
    let mid = rho.len() / 2;
    let (_, median, _) = rho.select_nth_unstable_by(mid, f64::total_cmp);
    (median.is_finite() && *median > 0.0).then_some(*median)
}
