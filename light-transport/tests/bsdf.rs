//! The four faces of every BSDF — `sample`, `eval`, `pdf`, `invert` — tested together, at the
//! extremes (roughness 1e-4 and 1, grazing `wo` with `cos θ = 1e-3`, `wo` below the surface,
//! total internal reflection, `η = 1.0001`, anisotropy, textured reflectance, nested mixes).
//!
//! Every statistical test is seeded (the outcome is deterministic) and states its false-positive
//! rate, i.e. the probability that it would fail on a correct BSDF for a random seed:
//!
//! * furnace: sampling estimate against deterministic quadrature (tolerance 6σ of the sampling
//!   estimate plus 0.2% quadrature error) and against uniform-sphere Monte Carlo for broad lobes
//!   (6σ): ≈ 2e-9 per comparison, < 1e-5 over the ≈ 1300 comparisons;
//! * chi-square of sampled directions against `pdf` (109 configurations): level
//!   `1 − (1 − 1e-3)^(1/109)` ≈ 9.2e-6 each (Šidák), family-wise 1e-3;
//! * chart checker (mcmc-charts, 85 configurations): each of its statistical checks (uniformity of
//!   `R(T(U))`, density) at family-wise level 1e-4, so ≤ 2·85·1e-4 ≈ 1.7e-2 over the file
//!   (Bonferroni bound).
//!
//! Directions are binned, and cell integrals computed, in *unstretched microfacet-normal* space
//! ([`HalfGrid`]): there every GGX lobe — α = 1e-4, anisotropic, or refracting with η = 1.0001 —
//! looks like the broad α = 1 lobe, so Gauss–Legendre quadrature per cell is accurate and a simple
//! reference law importance-samples it.
//!
//! Wall time: ≈ 8 s for the whole file with `cargo test --release` on two busy cores.

use light_transport::bsdf::{Bsdf, TransportMode};
use light_transport::math::{DVec3, Frame};
use light_transport::scene::{MaterialDesc, RgbTexture, TextureDesc};
use light_transport::spectrum::Rgb;
use mcmc_charts::Chart;
use mcmc_charts::checker::{CheckerConfig, DensityReference, check_chart};
use mcmc_core::ChainRng;
use mcmc_core::balance::chi_square_sf;
use mcmc_core::rng::{stream, uniform};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Materials and configurations
// ---------------------------------------------------------------------------------------------

const GOLD_ETA: Rgb = Rgb::new(0.143, 0.374, 1.442);
const GOLD_K: Rgb = Rgb::new(3.983, 2.385, 1.603);

fn matte(kd: f64) -> MaterialDesc {
    MaterialDesc::Matte {
        kd: RgbTexture::Constant(Rgb::splat(kd)),
    }
}
fn metal(au: f64, av: f64) -> MaterialDesc {
    MaterialDesc::Metal {
        eta: GOLD_ETA,
        k: GOLD_K,
        alpha_u: au,
        alpha_v: av,
    }
}
fn glass(eta: f64, au: f64, av: f64) -> MaterialDesc {
    MaterialDesc::Glass {
        eta,
        alpha_u: au,
        alpha_v: av,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    }
}
fn layered(kd: RgbTexture, au: f64, av: f64) -> MaterialDesc {
    MaterialDesc::Layered {
        kd,
        ks: Rgb::splat(0.5),
        alpha_u: au,
        alpha_v: av,
        eta: 1.5,
    }
}
fn mix(a: usize, b: usize, amount: Rgb) -> MaterialDesc {
    MaterialDesc::Mix { a, b, amount }
}

/// A 4×4 texture with reflectances in [0.1, 0.9].
fn texture() -> TextureDesc {
    let texels = (0..16)
        .map(|i| {
            let v = i as f64 / 15.0;
            Rgb::new(
                0.1 + 0.8 * v,
                0.9 - 0.8 * v,
                0.1 + 0.8 * ((i * 7) % 16) as f64 / 15.0,
            )
        })
        .collect();
    TextureDesc {
        texels,
        width: 4,
        height: 4,
        uv_scale: [2.0, 1.0],
        uv_offset: [0.1, 0.0],
        name: "test".into(),
    }
}

fn textured() -> RgbTexture {
    RgbTexture::Image {
        texture: 0,
        scale: Rgb::new(1.0, 0.9, 0.8),
    }
}

/// A BSDF under test with the parameters the tests need.
struct Case {
    name: &'static str,
    bsdf: Bsdf,
    /// Roughness `(α_x, α_y)` whose stretch makes the glossy lobes broad in the test grids (the
    /// smallest of the lobes; `(1, 1)` without glossy lobes).
    alpha: (f64, f64),
    /// Dielectric index (inside over outside).
    eta: Option<f64>,
    /// Whether uniform sampling of the sphere integrates `f` well (no sharp peaks).
    broad: bool,
    /// Local `wo` directions to test.
    wos: Vec<DVec3>,
}

fn frame() -> Frame {
    Frame::from_normal_tangent(
        DVec3::new(0.3, -0.2, 0.9).normalize(),
        DVec3::new(1.0, 0.5, 0.0),
    )
}

fn dir(cos_theta: f64, phi: f64) -> DVec3 {
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), cos_theta)
}

fn normal() -> DVec3 {
    DVec3::Z
}
fn oblique() -> DVec3 {
    dir(0.5f64.sqrt(), 0.7)
}
fn grazing() -> DVec3 {
    dir(1e-3, 2.1)
}
fn below() -> DVec3 {
    dir(-0.6, 4.0)
}
/// From inside a glass of index 1.5 beyond the critical angle.
fn tir() -> DVec3 {
    dir(-0.5, 1.3)
}

fn build(materials: &[MaterialDesc], root: usize, uv: [f64; 2]) -> Bsdf {
    Bsdf::from_material(materials, &[texture()], root, uv, frame()).expect("valid material")
}

struct Spec {
    alpha: (f64, f64),
    eta: Option<f64>,
    broad: bool,
}

const BROAD: Spec = Spec {
    alpha: (1.0, 1.0),
    eta: None,
    broad: true,
};

fn rough(a: f64, b: f64) -> Spec {
    Spec {
        alpha: (a, b),
        eta: None,
        broad: a.min(b) >= 0.2,
    }
}

fn case(name: &'static str, materials: Vec<MaterialDesc>, spec: Spec, wos: Vec<DVec3>) -> Case {
    let root = materials.len() - 1;
    let bsdf = build(&materials, root, [0.37, 0.81]);
    Case {
        name,
        bsdf,
        alpha: spec.alpha,
        eta: spec.eta,
        broad: spec.broad,
        wos,
    }
}

fn standard() -> Vec<DVec3> {
    vec![normal(), oblique(), grazing(), below()]
}
fn with_tir() -> Vec<DVec3> {
    vec![normal(), oblique(), grazing(), below(), tir()]
}

/// Every configuration.
fn cases() -> Vec<Case> {
    let t = textured();
    let c = RgbTexture::Constant(Rgb::splat(0.5));
    let dielectric = |eta: f64, a: f64, b: f64, broad: bool| Spec {
        alpha: (a, b),
        eta: Some(eta),
        broad,
    };
    vec![
        case("lambert", vec![matte(1.0)], BROAD, standard()),
        case(
            "lambert textured",
            vec![MaterialDesc::Matte { kd: t.clone() }],
            BROAD,
            standard(),
        ),
        case(
            "conductor a=0.3",
            vec![metal(0.3, 0.3)],
            rough(0.3, 0.3),
            standard(),
        ),
        case(
            "conductor a=1e-4",
            vec![metal(1e-4, 1e-4)],
            rough(1e-4, 1e-4),
            standard(),
        ),
        case(
            "conductor a=1",
            vec![metal(1.0, 1.0)],
            rough(1.0, 1.0),
            standard(),
        ),
        case(
            "conductor a=(0.05,0.5)",
            vec![metal(0.05, 0.5)],
            rough(0.05, 0.5),
            standard(),
        ),
        case(
            "conductor a=(1e-4,0.5)",
            vec![metal(1e-4, 0.5)],
            rough(1e-4, 0.5),
            standard(),
        ),
        case(
            "mirror",
            vec![MaterialDesc::Mirror { kr: Rgb::WHITE }],
            BROAD,
            standard(),
        ),
        case("smooth conductor", vec![metal(0.0, 0.0)], BROAD, standard()),
        case(
            "glass 1.5",
            vec![glass(1.5, 0.0, 0.0)],
            dielectric(1.5, 1.0, 1.0, false),
            with_tir(),
        ),
        case(
            "glass 1.0001",
            vec![glass(1.0001, 0.0, 0.0)],
            dielectric(1.0001, 1.0, 1.0, false),
            with_tir(),
        ),
        case(
            "rough glass a=0.3",
            vec![glass(1.5, 0.3, 0.3)],
            dielectric(1.5, 0.3, 0.3, true),
            with_tir(),
        ),
        case(
            "rough glass a=1e-4",
            vec![glass(1.5, 1e-4, 1e-4)],
            dielectric(1.5, 1e-4, 1e-4, false),
            with_tir(),
        ),
        case(
            "rough glass a=1",
            vec![glass(1.5, 1.0, 1.0)],
            dielectric(1.5, 1.0, 1.0, true),
            with_tir(),
        ),
        case(
            "rough glass 1.0001",
            vec![glass(1.0001, 0.3, 0.3)],
            dielectric(1.0001, 0.3, 0.3, false),
            with_tir(),
        ),
        case(
            "rough glass a=(0.1,0.4)",
            vec![glass(1.33, 0.1, 0.4)],
            dielectric(1.33, 0.1, 0.4, false),
            with_tir(),
        ),
        case(
            "layered a=0.2",
            vec![layered(c.clone(), 0.2, 0.2)],
            rough(0.2, 0.2),
            standard(),
        ),
        case(
            "layered a=1e-4",
            vec![layered(c.clone(), 1e-4, 1e-4)],
            rough(1e-4, 1e-4),
            standard(),
        ),
        case(
            "layered textured a=(0.05,0.3)",
            vec![layered(t.clone(), 0.05, 0.3)],
            rough(0.05, 0.3),
            standard(),
        ),
        case(
            "layered smooth coat",
            vec![layered(c.clone(), 0.0, 0.0)],
            BROAD,
            standard(),
        ),
        case(
            "mix layered+conductor",
            vec![
                layered(c.clone(), 0.2, 0.2),
                metal(0.1, 0.1),
                mix(0, 1, Rgb::new(0.3, 0.5, 0.7)),
            ],
            rough(0.1, 0.1),
            standard(),
        ),
        case(
            "mix mirror+matte",
            vec![
                MaterialDesc::Mirror {
                    kr: Rgb::splat(0.9),
                },
                matte(0.8),
                mix(0, 1, Rgb::splat(0.4)),
            ],
            BROAD,
            standard(),
        ),
        case(
            // Two delta lobes produce the same mirror direction.
            "mix mirror+glass",
            vec![
                MaterialDesc::Mirror {
                    kr: Rgb::splat(0.8),
                },
                glass(1.5, 0.0, 0.0),
                mix(0, 1, Rgb::splat(0.5)),
            ],
            dielectric(1.5, 1.0, 1.0, false),
            with_tir(),
        ),
        case(
            "mix rough glass+matte",
            vec![glass(1.5, 0.2, 0.2), matte(0.8), mix(0, 1, Rgb::splat(0.6))],
            dielectric(1.5, 0.2, 0.2, true),
            with_tir(),
        ),
        case(
            "nested mix",
            vec![
                layered(t, 0.3, 0.3),
                metal(0.2, 0.2),
                mix(0, 1, Rgb::splat(0.5)),
                matte(0.7),
                glass(1.5, 0.3, 0.3),
                mix(3, 4, Rgb::new(0.2, 0.4, 0.6)),
                mix(2, 5, Rgb::splat(0.7)),
            ],
            dielectric(1.5, 0.2, 0.2, true),
            standard(),
        ),
    ]
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers
// ---------------------------------------------------------------------------------------------

fn mirror_z(w: DVec3) -> DVec3 {
    DVec3::new(-w.x, -w.y, w.z)
}

/// Snell refraction of local `wo` through the macro surface of a dielectric (index inside over
/// outside), independent of the crate's implementation.
fn refraction(wo: DVec3, eta: f64) -> Option<DVec3> {
    let e = if wo.z > 0.0 { eta } else { 1.0 / eta };
    let sin_o = (1.0 - wo.z * wo.z).max(0.0).sqrt();
    let sin_t = sin_o / e;
    if sin_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let h = DVec3::new(-wo.x, -wo.y, 0.0);
    let h = if sin_o > 0.0 { h / sin_o } else { DVec3::X };
    Some(h * sin_t - DVec3::Z * cos_t * wo.z.signum())
}

fn theta_of(w: DVec3) -> f64 {
    (w.x * w.x + w.y * w.y).sqrt().atan2(w.z)
}

fn phi_of(w: DVec3) -> f64 {
    w.y.atan2(w.x).rem_euclid(2.0 * PI)
}

/// Sorted, deduplicated edges in `[lo, hi]` including both ends.
fn edges(mut v: Vec<f64>, lo: f64, hi: f64) -> Vec<f64> {
    v.retain(|x| *x > lo && *x < hi);
    v.push(lo);
    v.push(hi);
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() < 1e-13);
    v
}

/// Refraction of `wo` (oriented, on `m`'s side) about the microfacet normal `m`, relative index
/// `eta = η_i/η_o` (test-side implementation of Snell's law).
fn refract_about(wo: DVec3, m: DVec3, eta: f64) -> Option<DVec3> {
    let c = wo.dot(m);
    let s2 = (1.0 - c * c).max(0.0) / (eta * eta);
    if s2 >= 1.0 {
        return None;
    }
    Some((-wo / eta + m * (c / eta - (1.0 - s2).sqrt())).normalize())
}

/// Partitions of the sphere of `wi` for one `(BSDF, wo)` in which glossy lobes are broad: a
/// direction is mapped to its microfacet normal `m` (half vector above the surface of `wo`,
/// generalised half vector below it), `m` is *unstretched* by the lobe's roughness,
/// `m' = normalize(m.x/α_x, m.y/α_y, m.z)`, and cells are a `(θ', φ')` grid of `m'` for each side.
/// In these coordinates a GGX lobe of any roughness (1e-4 included), anisotropy or index
/// (η = 1.0001 included) becomes the α = 1 lobe, so cell integrals by Gauss–Legendre quadrature
/// are accurate, and a uniform `m'` is a good importance-sampling reference. θ' edges also include
/// the images of uniform θ_m edges so that Lambertian lobes are resolved too.
struct HalfGrid {
    /// `wo` mirrored above the surface.
    wo: DVec3,
    /// `-1` when `wo` was below the surface.
    sign: f64,
    /// `η_i/η_o` for the side of `wo`.
    eta: Option<f64>,
    ax: f64,
    ay: f64,
    theta: Vec<f64>,
    nphi: usize,
    /// Share of the reference's microfacet component that reflects (dielectrics).
    reflect_share: f64,
}

#[derive(Clone, Copy, PartialEq)]
enum Side {
    Reflect,
    Transmit,
}

const SIDES: [Side; 2] = [Side::Reflect, Side::Transmit];

impl HalfGrid {
    fn new(case: &Case, wo_l: DVec3) -> Self {
        Self::with(wo_l, case.alpha, case.eta)
    }

    fn with(wo_l: DVec3, (ax, ay): (f64, f64), eta: Option<f64>) -> Self {
        let sign = if wo_l.z < 0.0 { -1.0 } else { 1.0 };
        let wo = DVec3::new(wo_l.x, wo_l.y, wo_l.z * sign);
        let eta = eta.map(|e| if sign > 0.0 { e } else { 1.0 / e });
        let ag = (ax * ay).sqrt();
        let mut th: Vec<f64> = (1..16).map(|i| i as f64 * PI / 32.0).collect();
        // Images of θ_m edges (uniform, then halving down to the roughness) resolve broad lobes
        // (Lambert), which the stretch squeezes toward the equator of m'.
        let mut tm_edges: Vec<f64> = (1..16).map(|k| k as f64 * PI / 32.0).collect();
        let mut tm = PI / 64.0;
        while tm > 0.5 * ag {
            tm_edges.push(tm);
            tm *= 0.5;
        }
        th.extend(tm_edges.iter().map(|tm| (tm.tan() / ag).atan()));
        let reflect_share = if eta.is_some() { 0.5 } else { 1.0 };
        Self {
            wo,
            sign,
            eta,
            ax,
            ay,
            theta: edges(th, 0.0, PI / 2.0),
            nphi: 24,
            reflect_share,
        }
    }

    /// Set the reference's reflection share from cell masses (of [`HalfGrid::integrate`]).
    fn tune_reference(&mut self, mass: &[f64]) {
        if self.eta.is_some() {
            let (r, t) = mass.split_at(self.per_side());
            let (r, t): (f64, f64) = (r.iter().sum(), t.iter().sum());
            if r + t > 0.0 {
                self.reflect_share = (r / (r + t)).clamp(0.1, 0.9);
            }
        }
    }

    fn unorient(&self, w: DVec3) -> DVec3 {
        DVec3::new(w.x, w.y, w.z * self.sign)
    }

    /// `m` and `J_m = dω_m/dω_m'` of an unstretched normal `m'`.
    fn stretch(&self, mp: DVec3) -> (DVec3, f64) {
        let a = DVec3::new(self.ax * mp.x, self.ay * mp.y, mp.z);
        let l = a.length();
        (a / l, self.ax * self.ay / (l * l * l))
    }

    fn jacobian_m(&self, m: DVec3) -> f64 {
        let l = DVec3::new(m.x / self.ax, m.y / self.ay, m.z).length();
        self.ax * self.ay * l * l * l
    }

    fn unstretch(&self, m: DVec3) -> DVec3 {
        DVec3::new(m.x / self.ax, m.y / self.ay, m.z).normalize()
    }

    /// The (oriented) direction of side `side` through microfacet `m`, with `dω_i/dω_m`.
    fn scatter(&self, side: Side, m: DVec3) -> Option<(DVec3, f64)> {
        let c = self.wo.dot(m);
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        match side {
            Side::Reflect => {
                let wi = m * (2.0 * c) - self.wo;
                (wi.z >= 0.0).then_some((wi, 4.0 * c))
            }
            Side::Transmit => {
                let eta = self.eta?;
                let wi = refract_about(self.wo, m, eta)?;
                let denom = c + eta * wi.dot(m);
                (wi.z < 0.0).then(|| (wi, denom * denom / (eta * eta * wi.dot(m).abs())))
            }
        }
    }

    /// Side and microfacet normal of an oriented direction (inverse of [`HalfGrid::scatter`]).
    fn normal_of(&self, wi: DVec3) -> Option<(Side, DVec3)> {
        if !wi.is_finite() {
            return None;
        }
        if wi.z >= 0.0 {
            let m = (self.wo + wi).normalize();
            return (m.z > 0.0 && self.wo.dot(m) > 0.0).then_some((Side::Reflect, m));
        }
        let eta = self.eta?;
        let m = (self.wo + wi * eta).normalize();
        let m = if m.z < 0.0 { -m } else { m };
        (m.z > 0.0 && self.wo.dot(m) > 0.0 && wi.dot(m) < 0.0).then_some((Side::Transmit, m))
    }

    fn per_side(&self) -> usize {
        (self.theta.len() - 1) * self.nphi
    }

    fn cells(&self) -> usize {
        2 * self.per_side()
    }

    /// Cell of a local direction.
    fn cell(&self, wl: DVec3) -> Option<usize> {
        let (side, m) = self.normal_of(DVec3::new(wl.x, wl.y, wl.z * self.sign))?;
        let mp = self.unstretch(m);
        let t = theta_of(mp);
        let i = self
            .theta
            .partition_point(|e| *e <= t)
            .checked_sub(1)?
            .min(self.theta.len() - 2);
        let j = ((phi_of(mp) / (2.0 * PI) * self.nphi as f64) as usize).min(self.nphi - 1);
        Some(usize::from(side == Side::Transmit) * self.per_side() + i * self.nphi + j)
    }

    /// Whether the direction scattered by `m` lands on the side's own hemisphere (`None` where
    /// the integrand vanishes continuously: back-facing microfacets, total internal reflection).
    fn on_side(&self, side: Side, m: DVec3) -> Option<bool> {
        let c = self.wo.dot(m);
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        match side {
            Side::Reflect => Some(2.0 * c * m.z - self.wo.z >= 0.0),
            Side::Transmit => refract_about(self.wo, m, self.eta?).map(|wi| wi.z < 0.0),
        }
    }

    /// Gauss–Legendre (4×4) integral over one `(θ', φ')` rectangle, subdivided (up to 4 times)
    /// where the scattered direction crosses the horizon inside it — the only discontinuity of
    /// the integrands (the density jumps to zero there).
    #[allow(clippy::too_many_arguments)]
    fn rect<const K: usize>(
        &self,
        side: Side,
        t0: f64,
        t1: f64,
        p0: f64,
        p1: f64,
        depth: u32,
        g: &dyn Fn(DVec3) -> [f64; K],
    ) -> [f64; K] {
        // 4-point Gauss–Legendre nodes and weights on [-1, 1].
        const X: [f64; 4] = [
            -0.861_136_311_594_052_6,
            -0.339_981_043_584_856_3,
            0.339_981_043_584_856_3,
            0.861_136_311_594_052_6,
        ];
        const W: [f64; 4] = [
            0.347_854_845_137_453_9,
            0.652_145_154_862_546_1,
            0.652_145_154_862_546_1,
            0.347_854_845_137_453_9,
        ];
        let (ht, ct) = (0.5 * (t1 - t0), 0.5 * (t1 + t0));
        let (hp, cp) = (0.5 * (p1 - p0), 0.5 * (p1 + p0));
        if depth < 4 {
            let (mut inside, mut outside) = (false, false);
            for t in [t0, ct, t1] {
                let (st, c) = t.sin_cos();
                for p in [p0, cp, p1] {
                    match self.on_side(
                        side,
                        self.stretch(DVec3::new(st * p.cos(), st * p.sin(), c)).0,
                    ) {
                        Some(true) => inside = true,
                        Some(false) => outside = true,
                        None => {}
                    }
                }
            }
            if inside && outside {
                let mut s = [0.0; K];
                for (a, b) in [(t0, ct), (ct, t1)] {
                    for (c, d) in [(p0, cp), (cp, p1)] {
                        let v = self.rect(side, a, b, c, d, depth + 1, g);
                        for k in 0..K {
                            s[k] += v[k];
                        }
                    }
                }
                return s;
            }
        }
        let mut s = [0.0; K];
        for (xa, wa) in X.iter().zip(W) {
            let (st, c) = (ct + ht * xa).sin_cos();
            for (xb, wb) in X.iter().zip(W) {
                let p = cp + hp * xb;
                let (m, jm) = self.stretch(DVec3::new(st * p.cos(), st * p.sin(), c));
                if let Some((wi, ji)) = self.scatter(side, m) {
                    let v = g(self.unorient(wi));
                    for (acc, v) in s.iter_mut().zip(v) {
                        let v = v * ji * jm;
                        if v.is_finite() {
                            *acc += wa * wb * st * v;
                        }
                    }
                }
            }
        }
        s.map(|v| v * ht * hp)
    }

    /// `∫_cell g(wi) dω_i` for every cell and component of `g`, by quadrature in `(θ', φ')` after
    /// the change of variables `wi ↦ m'` (see [`HalfGrid::rect`]).
    fn integrate_n<const K: usize>(&self, g: &dyn Fn(DVec3) -> [f64; K]) -> Vec<[f64; K]> {
        let mut out = Vec::with_capacity(self.cells());
        let dp = 2.0 * PI / self.nphi as f64;
        for side in SIDES {
            for ti in self.theta.windows(2) {
                for j in 0..self.nphi {
                    if side == Side::Transmit && self.eta.is_none() {
                        out.push([0.0; K]);
                    } else {
                        out.push(self.rect(
                            side,
                            ti[0],
                            ti[1],
                            j as f64 * dp,
                            (j + 1) as f64 * dp,
                            0,
                            g,
                        ));
                    }
                }
            }
        }
        out
    }

    /// `∫_cell g(wi) dω_i` for every cell.
    fn integrate(&self, g: &dyn Fn(DVec3) -> f64) -> Vec<f64> {
        self.integrate_n::<1>(&|w| [g(w)])
            .into_iter()
            .map(|[v]| v)
            .collect()
    }

    /// A reference law for importance sampling: with probability 0.2 uniform on the sphere, 0.3
    /// cosine-weighted on the side of `wo` (shared with the other side for dielectrics), and
    /// otherwise `m'` uniform on its hemisphere and `wi` its reflection (or, with probability
    /// `1 − reflect_share` for dielectrics, its refraction, falling back to the reflection about `m` when `m` is
    /// back-facing or totally reflects). Returns a local direction.
    fn sample_reference(&self, rng: &mut ChainRng) -> DVec3 {
        let (a, b, c) = (uniform(rng), uniform(rng), uniform(rng));
        if c < 0.2 {
            return dir(1.0 - 2.0 * a, 2.0 * PI * b);
        }
        if c < 0.5 {
            let below = self.eta.is_some() && c < 0.35;
            let z = if below { -a.sqrt() } else { a.sqrt() };
            return self.unorient(dir(z, 2.0 * PI * b));
        }
        let (m, _) = self.stretch(dir(1.0 - a, 2.0 * PI * b));
        let reflect = m * (2.0 * self.wo.dot(m)) - self.wo;
        let wi = if self.eta.is_some() && c >= 0.5 + 0.5 * self.reflect_share {
            let e = self.eta.unwrap_or(1.0);
            if self.wo.dot(m) > 0.0 {
                refract_about(self.wo, m, e).unwrap_or(reflect)
            } else {
                reflect
            }
        } else {
            reflect
        };
        self.unorient(wi.normalize())
    }

    /// Density of [`HalfGrid::sample_reference`] at a local direction.
    fn reference_density(&self, wl: DVec3) -> f64 {
        let wi = DVec3::new(wl.x, wl.y, wl.z * self.sign);
        let mut q = 0.2 / (4.0 * PI);
        q += if self.eta.is_some() {
            0.15 * wi.z.abs() / PI
        } else {
            0.3 * wi.z.max(0.0) / PI
        };
        let p_refl = self.reflect_share;
        // Reflection about m = ±normalize(wo + wi) (the one with m.z > 0).
        let h = (self.wo + wi).normalize();
        if h.is_finite() && h.z != 0.0 {
            let m = if h.z < 0.0 { -h } else { h };
            let r = 1.0 / (2.0 * PI) / (4.0 * self.wo.dot(m).abs() * self.jacobian_m(m));
            let fallback = self
                .eta
                .is_some_and(|e| self.wo.dot(m) <= 0.0 || refract_about(self.wo, m, e).is_none());
            q += 0.5 * r * (p_refl + if fallback { 1.0 - p_refl } else { 0.0 });
        }
        // Refraction through m = ±normalize(wo + η wi) (the one with m.z > 0), on either side.
        let t = self
            .eta
            .map(|e| (e, (self.wo + wi * e).normalize()))
            .filter(|(_, m)| m.is_finite());
        if let Some((e, m)) = t.map(|(e, m)| (e, if m.z < 0.0 { -m } else { m }))
            && m.z > 0.0
            && self.wo.dot(m) > 0.0
            && wi.dot(m) < 0.0
        {
            let ci = wi.dot(m);
            let denom = self.wo.dot(m) + e * ci;
            let jt = denom * denom / (e * e * ci.abs());
            q += 0.5 * (1.0 - p_refl) / (2.0 * PI) / (jt * self.jacobian_m(m));
        }
        q
    }
}

fn u3(rng: &mut ChainRng) -> (f64, [f64; 2]) {
    (uniform(rng), [uniform(rng), uniform(rng)])
}

// ---------------------------------------------------------------------------------------------
// 1. White furnace
// ---------------------------------------------------------------------------------------------

struct Furnace {
    /// Mean and variance of `f|cos|/pdf` for non-delta and delta samples (per channel).
    smooth: [(f64, f64); 3],
    delta: [(f64, f64); 3],
    /// `∫ f |cos|` by quadrature (per channel).
    quadrature: [f64; 3],
    /// Mean and variance of `4π f |cos|` for uniform directions (per channel).
    uniform: [(f64, f64); 3],
}

const MODES: [TransportMode; 2] = [TransportMode::Radiance, TransportMode::Importance];

/// Albedo estimates of one configuration in both modes.
fn furnace(case: &Case, wo_l: DVec3, n: usize, rng: &mut ChainRng) -> [Furnace; 2] {
    let b = &case.bsdf;
    let fr = b.frame;
    let wo = fr.to_world(wo_l);
    let stats = |a: [[f64; 2]; 3]| {
        a.map(|[m1, m2]| {
            let m = m1 / n as f64;
            (m, (m2 / n as f64 - m * m).max(0.0))
        })
    };
    let grid = HalfGrid::new(case, wo_l);
    let q = grid.integrate_n::<6>(&|wl| {
        let wi = fr.to_world(wl);
        let (r, i) = (
            b.eval(wo, wi, TransportMode::Radiance),
            b.eval(wo, wi, TransportMode::Importance),
        );
        [r[0], r[1], r[2], i[0], i[1], i[2]].map(|v| v * wl.z.abs())
    });
    let mut total = [0.0; 6];
    for v in &q {
        for k in 0..6 {
            total[k] += v[k];
        }
    }
    [0, 1].map(|k| {
        let mode = MODES[k];
        let mut s = [[0.0; 2]; 3];
        let mut d = [[0.0; 2]; 3];
        let mut r = [[0.0; 2]; 3];
        for _ in 0..n {
            let (ul, u) = u3(rng);
            if let Some(x) = b.sample(wo, ul, u, mode) {
                let w = x.f * (x.wi.dot(fr.n).abs() / x.pdf);
                let acc = if x.delta { &mut d } else { &mut s };
                for c in 0..3 {
                    acc[c][0] += w[c];
                    acc[c][1] += w[c] * w[c];
                }
            }
        }
        if case.broad {
            for _ in 0..n {
                let wl = dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
                let w = b.eval(wo, fr.to_world(wl), mode) * (wl.z.abs() * 4.0 * PI);
                for c in 0..3 {
                    r[c][0] += w[c];
                    r[c][1] += w[c] * w[c];
                }
            }
        }
        Furnace {
            smooth: stats(s),
            delta: stats(d),
            quadrature: [total[3 * k], total[3 * k + 1], total[3 * k + 2]],
            uniform: stats(r),
        }
    })
}

/// Relative accuracy allowed to the quadrature (cell integrals by 6×4-point Gauss–Legendre).
const QUADRATURE_TOLERANCE: f64 = 2e-3;

#[test]
fn white_furnace_sampling_and_quadrature_agree() {
    let n = 40_000;
    let mut rng = stream(101, 0);
    for case in cases() {
        for &wo in &case.wos {
            for (f, mode) in furnace(&case, wo, n, &mut rng).into_iter().zip(MODES) {
                for c in 0..3 {
                    let (ms, vs) = f.smooth[c];
                    let (md, vd) = f.delta[c];
                    let mq = f.quadrature[c];
                    let sigma = (vs / n as f64).sqrt();
                    assert!(
                        (ms - mq).abs() <= 6.0 * sigma + QUADRATURE_TOLERANCE * mq + 1e-12,
                        "{} wo {wo:?} {mode:?} channel {c}: sampling {ms} vs quadrature {mq} (σ {sigma})",
                        case.name
                    );
                    if case.broad {
                        let (mu, vu) = f.uniform[c];
                        let sigma = ((vs + vu) / n as f64).sqrt();
                        assert!(
                            (ms - mu).abs() <= 6.0 * sigma + 1e-12,
                            "{} wo {wo:?} {mode:?} channel {c}: sampling {ms} vs uniform sphere {mu} (σ {sigma})",
                            case.name
                        );
                    }
                    // Radiance mode scales refraction out of a dense medium by η² > 1.
                    let gains = case.eta.is_some() && wo.z < 0.0 && mode == TransportMode::Radiance;
                    if !gains {
                        let total = ms + md;
                        let sd = ((vs + vd) / n as f64).sqrt();
                        assert!(
                            total <= 1.0 + 6.0 * sd + 1e-9,
                            "{} wo {wo:?} {mode:?}: albedo {total} > 1",
                            case.name
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn exact_albedos() {
    let n = 20_000;
    let mut rng = stream(102, 0);
    let all = cases();
    let get = |name: &str| all.iter().find(|c| c.name == name).expect("case exists");
    for &wo in &standard() {
        // Lambert with Kd = 1 and the mirror: every sample weighs exactly 1.
        for name in ["lambert", "mirror"] {
            let [f, _] = furnace(get(name), wo, n, &mut rng);
            for c in 0..3 {
                let total = f.smooth[c].0 + f.delta[c].0;
                assert!(
                    (total - 1.0).abs() < 1e-12 && f.smooth[c].1 + f.delta[c].1 < 1e-12,
                    "{name} {total}"
                );
            }
        }
        // Textured Lambert: the texel value at uv, for every sample.
        let lt = get("lambert textured");
        let [f, _] = furnace(lt, wo, 1000, &mut rng);
        let kd = f.smooth.map(|(m, _)| m);
        assert!(
            kd.iter().all(|v| *v > 0.05 && *v < 0.95) && f.smooth.iter().all(|(_, v)| *v < 1e-12),
            "{kd:?}"
        );
    }
    // Smooth dielectric: R + T = 1 in importance mode; F + (1 − F)(η_o/η_i)² in radiance mode.
    for (name, eta) in [("glass 1.5", 1.5), ("glass 1.0001", 1.0001)] {
        for &wo in &with_tir() {
            let [rad, imp] = furnace(get(name), wo, n, &mut rng);
            let e = if wo.z > 0.0 { eta } else { 1.0 / eta };
            let f = light_transport::bsdf::fresnel::dielectric(wo.z.abs(), e);
            for c in 0..3 {
                assert!(
                    (imp.delta[c].0 - 1.0).abs() < 1e-12,
                    "{name} {wo:?}: {}",
                    imp.delta[c].0
                );
                // The radiance estimate mixes weights F/F = 1 and (1 − F)/(1 − F)/e²: compare means.
                let exact = f + (1.0 - f) / (e * e);
                let sd = (rad.delta[c].1 / n as f64).sqrt();
                assert!(
                    (rad.delta[c].0 - exact).abs() <= 6.0 * sd + 1e-12,
                    "{name} {wo:?}: {} vs {exact}",
                    rad.delta[c].0
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Reciprocity and the adjoint
// ---------------------------------------------------------------------------------------------

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-300
}

#[test]
fn reciprocity_and_adjoint() {
    let mut rng = stream(103, 0);
    let random_dir = |rng: &mut ChainRng| dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
    for case in cases() {
        let b = &case.bsdf;
        let fr = b.frame;
        let mut checked = [0usize; 2];
        for k in 0..6000 {
            // Random pairs, and pairs drawn by the BSDF itself (to reach sharp lobes).
            let lo = random_dir(&mut rng);
            let sampled = (k % 2 == 1)
                .then(|| {
                    let (ul, u) = u3(&mut rng);
                    b.sample(fr.to_world(lo), ul, u, TransportMode::Radiance)
                        .filter(|s| !s.delta)
                })
                .flatten();
            let li =
                sampled.map_or_else(|| random_dir(&mut rng), |s| fr.to_local(s.wi).normalize());
            let (wo, wi) = (fr.to_world(lo), fr.to_world(li));
            let f_oi = b.eval(wo, wi, TransportMode::Radiance);
            let f_io = b.eval(wi, wo, TransportMode::Radiance);
            let a_io = b.eval(wi, wo, TransportMode::Importance);
            // Transmission evaluates the generalised half vector from either end: allow rounding.
            let rel = if lo.z * li.z > 0.0 { 1e-9 } else { 1e-7 };
            for c in 0..3 {
                // Adjoint: f_radiance(wo, wi) = f_importance(wi, wo) always.
                assert!(
                    close(f_oi[c], a_io[c], rel),
                    "{}: adjoint {} vs {}",
                    case.name,
                    f_oi[c],
                    a_io[c]
                );
                if lo.z * li.z > 0.0 {
                    assert!(
                        close(f_oi[c], f_io[c], 1e-9),
                        "{}: reflection {} vs {}",
                        case.name,
                        f_oi[c],
                        f_io[c]
                    );
                } else if let Some(eta) = case.eta {
                    // f(wo, wi)/η_o² = f(wi, wo)/η_i².
                    let (eo, ei) = if lo.z > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                    assert!(
                        close(f_oi[c] / (eo * eo), f_io[c] / (ei * ei), rel),
                        "{}: transmission {} vs {}",
                        case.name,
                        f_oi[c],
                        f_io[c]
                    );
                } else {
                    assert_eq!(
                        f_oi[c], 0.0,
                        "{}: reflection-only BSDF transmits",
                        case.name
                    );
                }
            }
            if f_oi.max_component() > 0.0 {
                checked[usize::from(lo.z * li.z < 0.0)] += 1;
            }
        }
        assert!(
            b.is_delta_only() || checked[0] > 100,
            "{}: too few reflection pairs",
            case.name
        );
        assert!(
            case.eta.is_none() || b.is_delta_only() || checked[1] > 100,
            "{}: too few transmission pairs",
            case.name
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Sampling against pdf (chi-square) and consistency of sample/pdf/eval
// ---------------------------------------------------------------------------------------------

/// Chi-square goodness of fit of `n` directions sampled from `sampler` against the density
/// `pdf_of` on the refined grid; low-expectation cells (< 5) are pooled (Mitsuba's chi2 test).
/// Directions that are not non-delta samples form one more category with the remaining mass.
/// Returns the p-value (0 when a sample falls in a cell of zero expected mass).
fn chi_square(
    grid: &HalfGrid,
    n: usize,
    sampler: &mut dyn FnMut() -> Option<DVec3>,
    pdf_of: &dyn Fn(DVec3) -> f64,
) -> (f64, String) {
    let cells = grid.cells();
    let mut observed = vec![0.0; cells + 1];
    for _ in 0..n {
        match sampler().and_then(|w| grid.cell(w)) {
            Some(c) => observed[c] += 1.0,
            None => observed[cells] += 1.0,
        }
    }
    let mut expected: Vec<f64> = grid
        .integrate(pdf_of)
        .into_iter()
        .map(|p| p * n as f64)
        .collect();
    let mass: f64 = expected.iter().sum();
    expected.push((n as f64 - mass).max(0.0));
    // Samples where the quadrature sees no mass at all: a few can fall in slivers of support the
    // quadrature nodes miss (they are pooled below); many mean a real mismatch.
    let stray: f64 = (0..=cells)
        .filter(|&c| expected[c] < 1e-9 * n as f64)
        .map(|c| observed[c])
        .sum();
    if stray > 1e-3 * n as f64 {
        return (
            0.0,
            format!("{stray} samples in cells of zero expected mass"),
        );
    }
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    let mut cats: Vec<(f64, f64)> = Vec::new();
    for c in 0..=cells {
        if expected[c] < 5.0 {
            pool_o += observed[c];
            pool_e += expected[c];
        } else {
            cats.push((observed[c], expected[c]));
        }
    }
    if pool_e >= 5.0 || cats.is_empty() {
        cats.push((pool_o, pool_e));
    } else if let Some(smallest) = cats.iter_mut().min_by(|a, b| a.1.total_cmp(&b.1)) {
        smallest.0 += pool_o;
        smallest.1 += pool_e;
    }
    let stat: f64 = cats
        .iter()
        .filter(|c| c.1 > 0.0)
        .map(|(o, e)| (o - e) * (o - e) / e)
        .sum();
    let df = cats.len().saturating_sub(1);
    (
        chi_square_sf(stat, df),
        format!("χ² = {stat:.1}, {df} dof, ∫pdf = {:.6}", mass / n as f64),
    )
}

fn config_count() -> usize {
    cases().iter().map(|c| c.wos.len()).sum()
}

#[test]
fn sampled_directions_follow_the_pdf() {
    let n = 60_000;
    let configs = config_count();
    // Šidák: family-wise false-positive rate 1e-3 over all configurations.
    let level = 1.0 - (1.0 - 1e-3f64).powf(1.0 / configs as f64);
    let mut rng = stream(104, 0);
    let mut failures = Vec::new();
    for case in cases() {
        let b = &case.bsdf;
        let fr = b.frame;
        for &wo_l in &case.wos {
            let wo = fr.to_world(wo_l);
            let grid = HalfGrid::new(&case, wo_l);
            let mut sampler = || {
                let (ul, u) = u3(&mut rng);
                let s = b.sample(wo, ul, u, TransportMode::Radiance)?;
                // Consistency of what `sample` reports with `pdf`, `eval` and `eval_delta`.
                assert!(
                    s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0,
                    "{}: {s:?}",
                    case.name
                );
                assert!((s.wi.length() - 1.0).abs() < 1e-9);
                if s.delta {
                    let d = b
                        .eval_delta(wo, s.wi, TransportMode::Radiance)
                        .expect("delta reproduced");
                    assert!(
                        close(d.pdf, s.pdf, 1e-12) && (0..3).all(|c| close(d.f[c], s.f[c], 1e-12)),
                        "{}",
                        case.name
                    );
                    None
                } else {
                    let p = b.pdf(wo, s.wi);
                    let f = b.eval(wo, s.wi, TransportMode::Radiance);
                    assert!(
                        close(p, s.pdf, 1e-9),
                        "{}: pdf {p} vs sampled {}",
                        case.name,
                        s.pdf
                    );
                    assert!(
                        (0..3).all(|c| close(f[c], s.f[c], 1e-9)),
                        "{}: f {f:?} vs {:?}",
                        case.name,
                        s.f
                    );
                    Some(fr.to_local(s.wi))
                }
            };
            let pdf_of = |wl: DVec3| b.pdf(wo, fr.to_world(wl));
            let (p, detail) = chi_square(&grid, n, &mut sampler, &pdf_of);
            println!(
                "chi2 {:<32} wo=({:+.3},{:+.3},{:+.3}) p = {p:.3e} ({detail}, {} cells)",
                case.name,
                wo_l.x,
                wo_l.y,
                wo_l.z,
                grid.cells()
            );
            if p.is_nan() || p <= level {
                failures.push(format!("{} wo {wo_l:?}: p = {p:.3e} ({detail})", case.name));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "chi-square failures at level {level:.2e}:\n{}",
        failures.join("\n")
    );
}

/// Test of the test: directions sampled with α = 0.3 against the pdf of α = 0.315 must fail.
#[test]
fn chi_square_detects_a_wrong_pdf() {
    let a = build(&[metal(0.3, 0.3)], 0, [0.0; 2]);
    let b = build(&[metal(0.315, 0.315)], 0, [0.0; 2]);
    let fr = a.frame;
    let wo_l = oblique();
    let wo = fr.to_world(wo_l);
    let grid = HalfGrid::with(wo_l, (0.3, 0.3), None);
    let mut rng = stream(105, 0);
    let mut sampler = || {
        let (ul, u) = u3(&mut rng);
        a.sample(wo, ul, u, TransportMode::Radiance)
            .map(|s| fr.to_local(s.wi))
    };
    let (p, detail) = chi_square(&grid, 60_000, &mut sampler, &|wl| {
        b.pdf(wo, fr.to_world(wl))
    });
    assert!(
        p < 1e-6,
        "a 5% roughness error went unnoticed: p = {p} ({detail})"
    );
}

// ---------------------------------------------------------------------------------------------
// 4. invert, checked by the mcmc-charts chart checker
// ---------------------------------------------------------------------------------------------

/// A direction and whether a delta lobe produced it (the chart's target space: solid angle plus
/// the atoms of delta lobes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Dir {
    w: DVec3,
    delta: bool,
}

#[derive(Clone, Copy, PartialEq)]
enum Inverse {
    Exact,
    /// Deliberately wrong: choose among the lobes that can produce the direction with equal
    /// probabilities instead of by their density shares.
    UniformLobes,
}

/// A BSDF's sampling routine for a fixed `wo` as a chart `[0,1)³ → S²`.
struct BsdfChart<'a> {
    bsdf: &'a Bsdf,
    wo: DVec3,
    inverse: Inverse,
    name: String,
}

impl Chart<Dir> for BsdfChart<'_> {
    fn dim(&self) -> usize {
        3
    }
    fn forward(&self, u: &[f64], x: &mut Dir) -> bool {
        match self
            .bsdf
            .sample(self.wo, u[0], [u[1], u[2]], TransportMode::Radiance)
        {
            Some(s) => {
                *x = Dir {
                    w: s.wi,
                    delta: s.delta,
                };
                true
            }
            None => false,
        }
    }
    fn ln_density(&self, x: &Dir) -> f64 {
        if x.delta {
            self.bsdf
                .eval_delta(self.wo, x.w, TransportMode::Radiance)
                .map_or(f64::NEG_INFINITY, |s| s.pdf.ln())
        } else {
            self.bsdf.pdf(self.wo, x.w).ln()
        }
    }
    fn invert(&self, x: &Dir, u: &mut [f64], rng: &mut ChainRng) -> bool {
        let r = match self.inverse {
            Inverse::Exact => self.bsdf.invert(self.wo, x.w, x.delta, rng),
            Inverse::UniformLobes => {
                let w = self.bsdf.lobe_weights(self.wo, x.w, x.delta);
                let candidates: Vec<usize> = (0..w.len).filter(|&j| w.weights[j] > 0.0).collect();
                if candidates.is_empty() {
                    None
                } else {
                    let k = ((uniform(rng) * candidates.len() as f64) as usize)
                        .min(candidates.len() - 1);
                    self.bsdf.invert_lobe(self.wo, x.w, candidates[k], rng)
                }
            }
        };
        match r {
            Some(v) => {
                u.copy_from_slice(&v);
                v.iter().all(|x| (0.0..1.0).contains(x))
            }
            None => false,
        }
    }
    fn name(&self) -> String {
        self.name.clone()
    }
}

fn distance(a: &Dir, b: &Dir) -> f64 {
    if a.delta == b.delta {
        (a.w - b.w).length()
    } else {
        f64::INFINITY
    }
}

const CHECKER: CheckerConfig = CheckerConfig {
    samples: 30_000,
    alpha: 1e-4,
    tolerance: 1e-8,
};

/// Run the checker on one configuration; the density test uses the defensive reference and the
/// half-vector grid with cells of small expected count merged.
fn check(
    case: &Case,
    wo_l: DVec3,
    inverse: Inverse,
    seed: u64,
) -> mcmc_charts::checker::ChartReport {
    let b = &case.bsdf;
    let fr = b.frame;
    let wo = fr.to_world(wo_l);
    let chart = BsdfChart {
        bsdf: b,
        wo,
        inverse,
        name: format!(
            "{} wo=({:+.3},{:+.3},{:+.3})",
            case.name, wo_l.x, wo_l.y, wo_l.z
        ),
    };
    let mut rng = stream(106, seed);
    let mut grid = HalfGrid::new(case, wo_l);
    // Merge fine cells until each merged cell expects ≥ 1000 of the checker's samples, so that the
    // importance-sampling estimate of each cell's mass (and of its variance, which the checker's
    // z-test uses) rests on enough reference samples.
    let mass = grid.integrate(&|wl| b.pdf(wo, fr.to_world(wl)));
    grid.tune_reference(&mass);
    let grid = grid;
    let mut map = vec![0usize; mass.len()];
    let mut merged = 0usize;
    let mut acc = 0.0;
    for (c, m) in mass.iter().enumerate() {
        map[c] = merged;
        acc += m * CHECKER.samples as f64;
        if acc >= 1000.0 {
            merged += 1;
            acc = 0.0;
        }
    }
    let cells = merged + 1;
    let sample = |rng: &mut ChainRng| Dir {
        w: fr.to_world(grid.sample_reference(rng)),
        delta: false,
    };
    let ln_q = |x: &Dir| grid.reference_density(fr.to_local(x.w)).ln();
    let cell = |x: &Dir| {
        if x.delta {
            None
        } else {
            grid.cell(fr.to_local(x.w)).map(|c| map[c])
        }
    };
    let density = DensityReference {
        sample: &sample,
        ln_density: &ln_q,
        cell: &cell,
        cells,
    };
    let with_density = b.has_non_delta();
    check_chart(
        &chart,
        &distance,
        with_density.then_some(&density),
        &CHECKER,
        &mut rng,
    )
    .expect("checker ran")
}

/// The `wo` directions used with the chart checker (a subset, to bound the running time).
fn checker_wos(case: &Case) -> Vec<DVec3> {
    let mut v = vec![oblique(), grazing(), below()];
    if case.eta.is_some() {
        v.push(tir());
    }
    v
}

fn run_checker(filter: &dyn Fn(&Case) -> bool) {
    let mut failures = Vec::new();
    for (i, case) in cases().into_iter().enumerate().filter(|(_, c)| filter(c)) {
        for (k, wo) in checker_wos(&case).into_iter().enumerate() {
            let report = check(&case, wo, Inverse::Exact, (i * 10 + k) as u64);
            print!("{report}");
            if !report.passed() {
                failures.push(report.to_string());
            }
        }
    }
    assert!(
        failures.is_empty(),
        "chart checker failures:\n{}",
        failures.join("\n")
    );
}

#[test]
fn non_delta_charts_pass_the_checker() {
    run_checker(&|c| !c.bsdf.has_delta());
}

/// Mirror, smooth conductor, smooth glass, and BSDFs that mix delta and non-delta lobes: round
/// trip and uniformity of `U' = R(T(U))` (the lobe number inside each lobe's interval and the
/// unused direction numbers); the density test runs on the non-delta part only.
#[test]
fn delta_charts_round_trip_with_uniform_inverse() {
    run_checker(&|c| c.bsdf.has_delta());
}

/// Test of the test: choosing the lobe uniformly among those that can produce the direction
/// instead of by density share must fail the checker for the layered material, the mixes, and two
/// delta lobes producing the same direction (non-injective charts).
#[test]
fn a_wrong_lobe_choice_fails_the_checker() {
    for name in [
        "layered a=0.2",
        "mix layered+conductor",
        "nested mix",
        "mix mirror+glass",
    ] {
        let all = cases();
        let case = all.iter().find(|c| c.name == name).expect("case exists");
        let wrong = check(case, oblique(), Inverse::UniformLobes, 999);
        let right = check(case, oblique(), Inverse::Exact, 998);
        println!("wrong inverse: {wrong}");
        assert!(right.passed(), "{right}");
        assert!(wrong.round_trip.passed, "{wrong}");
        assert!(
            !wrong.inverse_uniformity.passed,
            "a 50/50 lobe choice went unnoticed:\n{wrong}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4b. Shading frames tilted away from the geometric normal
// ---------------------------------------------------------------------------------------------

/// A geometric normal `degrees` away from the shading normal of `fr`, toward `(s + t)/√2`.
fn tilted_ng(fr: &Frame, degrees: f64) -> DVec3 {
    let a = degrees.to_radians();
    (fr.n * a.cos() + (fr.s + fr.t).normalize() * a.sin()).normalize()
}

/// Every configuration with its geometric normal tilted 30° from the shading normal.
fn tilted_cases() -> Vec<Case> {
    cases()
        .into_iter()
        .map(|mut c| {
            let ng = tilted_ng(&c.bsdf.frame, 30.0);
            c.bsdf = c.bsdf.with_geometric_normal(ng);
            c
        })
        .collect()
}

/// Whether `w` lies on the same side of the surface by shading normal `n` and geometric `ng`.
fn agrees(w: DVec3, n: DVec3, ng: DVec3) -> bool {
    let (a, b) = (w.dot(n), w.dot(ng));
    (a > 0.0 && b > 0.0) || (a < 0.0 && b < 0.0)
}

/// With a tilted geometric normal every face of the BSDF is the untilted BSDF restricted to the
/// directions both normals put on the same side (the documented rule of `bsdf/mod.rs`): `eval`,
/// `pdf`, `eval_delta`, `lobe_weights` and `invert` agree exactly there and vanish elsewhere, and
/// `sample` from the same numbers returns the same direction or fails. So the chi-square,
/// furnace and chart-checker results of the untilted configurations carry over to the tilted
/// ones, whose sampled law is the untilted law restricted (a sub-probability); the light that
/// leaks (directions valid for the shading normal but below the geometric surface) is none.
#[test]
fn tilted_frames_restrict_the_bsdf_to_agreeing_sides() {
    let mut rng = stream(110, 0);
    let random_dir = |rng: &mut ChainRng| dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
    let (mut kept, mut cut) = (0usize, 0usize);
    for (flat, tilted) in cases().into_iter().zip(tilted_cases()) {
        let (a, b) = (&flat.bsdf, &tilted.bsdf);
        let (n, ng) = (b.frame.n, b.ng);
        for _ in 0..2000 {
            let wo = random_dir(&mut rng);
            let (ul, u) = u3(&mut rng);
            for mode in MODES {
                // Sampling: the same numbers give the same sample, or none when a side disagrees.
                let sa = a.sample(wo, ul, u, mode);
                let sb = b.sample(wo, ul, u, mode);
                let expect = sa.filter(|x| agrees(wo, n, ng) && agrees(x.wi, n, ng));
                assert_eq!(sb, expect, "{}: sample from {wo:?}", flat.name);
                let wi = match sa {
                    Some(x) if uniform(&mut rng) < 0.5 => x.wi,
                    _ => random_dir(&mut rng),
                };
                let ok = agrees(wo, n, ng) && agrees(wi, n, ng);
                if ok {
                    kept += 1
                } else {
                    cut += 1
                }
                let (fa, fb) = (a.eval(wo, wi, mode), b.eval(wo, wi, mode));
                assert_eq!(fb, if ok { fa } else { Rgb::BLACK }, "{}", flat.name);
                let (pa, pb) = (a.pdf(wo, wi), b.pdf(wo, wi));
                assert_eq!(pb, if ok { pa } else { 0.0 }, "{}", flat.name);
                if let Some(x) = sa.filter(|x| x.delta) {
                    let d = b.eval_delta(wo, x.wi, mode);
                    let ok = agrees(wo, n, ng) && agrees(x.wi, n, ng);
                    assert_eq!(
                        d,
                        if ok {
                            a.eval_delta(wo, x.wi, mode)
                        } else {
                            None
                        }
                    );
                }
            }
            // The inverse: the same numbers from the same random state, or none.
            if let Some(x) = a.sample(wo, ul, u, TransportMode::Radiance) {
                let ok = agrees(wo, n, ng) && agrees(x.wi, n, ng);
                let mut r1 = stream(111, kept as u64);
                let mut r2 = stream(111, kept as u64);
                let ia = a.invert(wo, x.wi, x.delta, &mut r1);
                let ib = b.invert(wo, x.wi, x.delta, &mut r2);
                assert_eq!(ib, if ok { ia } else { None }, "{}: invert", flat.name);
            }
        }
    }
    println!("pairs on agreeing sides {kept}, cut by the geometric normal {cut}");
    assert!(
        kept > 10_000 && cut > 10_000,
        "both kinds of pairs are exercised"
    );
}

/// White furnace with tilted frames: the sampling estimate of `∫ f |cos θ_s|` over the agreeing
/// directions against uniform-sphere Monte Carlo of the same integral (broad lobes; 6σ, ≈ 2e-9
/// per comparison), and never above the untilted albedo. (The cell quadrature of the untilted
/// test is not used here: the side rule cuts cells along a curve it does not resolve.)
#[test]
fn white_furnace_with_tilted_frames() {
    let n = 40_000;
    let mut rng = stream(112, 0);
    for case in tilted_cases().into_iter().filter(|c| c.broad) {
        let b = &case.bsdf;
        let fr = b.frame;
        for &wo_l in &case.wos {
            let wo = fr.to_world(wo_l);
            for mode in MODES {
                let (mut s, mut r) = ([[0.0f64; 2]; 3], [[0.0f64; 2]; 3]);
                for _ in 0..n {
                    let (ul, u) = u3(&mut rng);
                    if let Some(x) = b.sample(wo, ul, u, mode).filter(|x| !x.delta) {
                        let w = x.f * (x.wi.dot(fr.n).abs() / x.pdf);
                        for c in 0..3 {
                            s[c][0] += w[c];
                            s[c][1] += w[c] * w[c];
                        }
                    }
                    let wl = dir(1.0 - 2.0 * uniform(&mut rng), 2.0 * PI * uniform(&mut rng));
                    let w = b.eval(wo, fr.to_world(wl), mode) * (wl.z.abs() * 4.0 * PI);
                    for c in 0..3 {
                        r[c][0] += w[c];
                        r[c][1] += w[c] * w[c];
                    }
                }
                for c in 0..3 {
                    let m = |a: [f64; 2]| {
                        let m = a[0] / n as f64;
                        (m, (a[1] / n as f64 - m * m).max(0.0))
                    };
                    let ((ms, vs), (mu, vu)) = (m(s[c]), m(r[c]));
                    let sigma = ((vs + vu) / n as f64).sqrt();
                    assert!(
                        (ms - mu).abs() <= 6.0 * sigma + 1e-12,
                        "{} tilted, wo {wo_l:?} {mode:?} channel {c}: sampling {ms} vs uniform {mu} (σ {sigma})",
                        case.name
                    );
                }
            }
        }
    }
}

/// Reciprocity and the adjoint with tilted frames: the restricted BSDF is still reciprocal,
/// because the side rule is symmetric in `wo` and `wi`. (The shading-normal factor of the path
/// integral is not, which is the adjoint correction tested in `tests/agreement.rs`.)
#[test]
fn reciprocity_with_tilted_frames() {
    let mut rng = stream(113, 0);
    let random_dir = |rng: &mut ChainRng| dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
    let mut nonzero = 0usize;
    for case in tilted_cases() {
        let b = &case.bsdf;
        for _ in 0..3000 {
            let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
            let (lo, li) = (b.frame.to_local(wo), b.frame.to_local(wi));
            let f_oi = b.eval(wo, wi, TransportMode::Radiance);
            let f_io = b.eval(wi, wo, TransportMode::Radiance);
            let a_io = b.eval(wi, wo, TransportMode::Importance);
            let rel = if lo.z * li.z > 0.0 { 1e-9 } else { 1e-7 };
            for c in 0..3 {
                assert!(close(f_oi[c], a_io[c], rel), "{}: adjoint", case.name);
                let (eo, ei) = match case.eta {
                    Some(eta) if lo.z * li.z < 0.0 => {
                        if lo.z > 0.0 {
                            (1.0, eta)
                        } else {
                            (eta, 1.0)
                        }
                    }
                    _ => (1.0, 1.0),
                };
                assert!(
                    close(f_oi[c] / (eo * eo), f_io[c] / (ei * ei), rel),
                    "{}: reciprocity {} vs {}",
                    case.name,
                    f_oi[c],
                    f_io[c]
                );
            }
            nonzero += usize::from(f_oi.max_component() > 0.0);
        }
    }
    assert!(nonzero > 20_000, "{nonzero} non-zero pairs");
}

// ---------------------------------------------------------------------------------------------
// 5. No NaN or infinity, ever
// ---------------------------------------------------------------------------------------------

#[test]
fn never_nan_or_infinite() {
    let mut rng = stream(107, 0);
    let special = [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::Y,
        dir(1e-300, 0.3),
        dir(-1e-300, 0.3),
        dir(1e-16, 1.0),
        dir(-1e-16, 1.0),
        dir(1.0 - 1e-16, 2.0),
        dir(1e-3, 2.1),
        dir(-0.5, 1.3),
        DVec3::ZERO,
        DVec3::new(f64::NAN, 0.0, 1.0),
        DVec3::new(0.0, 0.0, f64::INFINITY),
    ];
    // Every corner and the middle of the primary cube, for the special directions.
    let us = [0.0, 0.5, 1.0 - f64::EPSILON / 2.0, 1e-300, 0.999_999_999];
    let mut corners: Vec<[f64; 3]> = Vec::new();
    for a in us {
        for b in us {
            for c in us {
                corners.push([a, b, c]);
            }
        }
    }
    for case in cases() {
        let b = &case.bsdf;
        let fr = b.frame;
        let mut pairs: Vec<(DVec3, DVec3)> = Vec::new();
        for &a in &special {
            for &c in &special {
                pairs.push((a, c));
            }
            pairs.push((a, -a));
            pairs.push((a, mirror_z(a)));
            if let Some(t) = case.eta.and_then(|e| refraction(a, e)) {
                pairs.push((a, t));
            }
        }
        let specials = pairs.len();
        for _ in 0..3000 {
            let a = dir(1.0 - 2.0 * uniform(&mut rng), 2.0 * PI * uniform(&mut rng));
            let c = dir(1.0 - 2.0 * uniform(&mut rng), 2.0 * PI * uniform(&mut rng));
            pairs.push((a, c));
            pairs.push((a, -a));
        }
        for (k, (lo, li)) in pairs.into_iter().enumerate() {
            let (wo, wi) = (fr.to_world(lo), fr.to_world(li));
            for mode in MODES {
                let f = b.eval(wo, wi, mode);
                assert!(
                    f.is_finite() && f.0.iter().all(|v| *v >= 0.0),
                    "{}: f({lo:?}, {li:?}) = {f:?}",
                    case.name
                );
                if let Some(d) = b.eval_delta(wo, wi, mode) {
                    assert!(
                        d.f.is_finite() && d.pdf.is_finite() && d.pdf > 0.0,
                        "{}",
                        case.name
                    );
                }
            }
            let p = b.pdf(wo, wi);
            assert!(
                p.is_finite() && p >= 0.0,
                "{}: pdf({lo:?}, {li:?}) = {p}",
                case.name
            );
            for delta in [false, true] {
                if let Some(u) = b.invert(wo, wi, delta, &mut rng) {
                    assert!(
                        u.iter().all(|x| (0.0..1.0).contains(x)),
                        "{}: invert {u:?}",
                        case.name
                    );
                }
            }
            let random = [[uniform(&mut rng), uniform(&mut rng), uniform(&mut rng)]];
            let numbers: &[[f64; 3]] = if k < specials { &corners } else { &random };
            for &[ul, u0, u1] in numbers {
                if let Some(s) = b.sample(wo, ul, [u0, u1], TransportMode::Radiance) {
                    let ok =
                        s.f.is_finite() && s.pdf.is_finite() && s.pdf > 0.0 && s.wi.is_finite();
                    assert!(ok, "{}: sample {s:?}", case.name);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Construction, errors, classification
// ---------------------------------------------------------------------------------------------

#[test]
fn invalid_materials_are_errors_not_panics() {
    let f = frame();
    let tex = [texture()];
    let bad: Vec<Vec<MaterialDesc>> = vec![
        vec![matte(-0.1)],
        vec![MaterialDesc::Matte {
            kd: RgbTexture::Image {
                texture: 5,
                scale: Rgb::WHITE,
            },
        }],
        vec![metal(f64::NAN, 0.1)],
        vec![metal(-0.1, 0.1)],
        vec![glass(0.0, 0.1, 0.1)],
        vec![glass(f64::INFINITY, 0.0, 0.0)],
        vec![mix(0, 0, Rgb::splat(0.5))],
        vec![matte(0.5), mix(0, 7, Rgb::splat(0.5))],
        vec![matte(0.5), matte(0.5), mix(0, 1, Rgb::splat(1.5))],
    ];
    for m in &bad {
        let root = m.len() - 1;
        assert!(
            Bsdf::from_material(m, &tex, root, [0.5, 0.5], f).is_err(),
            "{m:?}"
        );
    }
    assert!(Bsdf::from_material(&[matte(0.5)], &tex, 3, [0.5, 0.5], f).is_err());
    // A broken texture.
    let mut t = texture();
    t.texels.pop();
    assert!(
        Bsdf::from_material(
            &[MaterialDesc::Matte { kd: textured() }],
            &[t],
            0,
            [0.5, 0.5],
            f
        )
        .is_err()
    );
    // Capacity: 16 layered materials (32 lobes) nested in mixes.
    let mut m: Vec<MaterialDesc> = (0..16)
        .map(|_| layered(RgbTexture::Constant(Rgb::splat(0.5)), 0.2, 0.2))
        .collect();
    let mut level: Vec<usize> = (0..16).collect();
    while level.len() > 1 {
        let mut next = Vec::new();
        for pair in level.chunks(2) {
            m.push(mix(pair[0], pair[1], Rgb::splat(0.5)));
            next.push(m.len() - 1);
        }
        level = next;
    }
    let err =
        Bsdf::from_material(&m, &tex, m.len() - 1, [0.5, 0.5], f).expect_err("too many lobes");
    assert!(err.to_string().contains("lobes"), "{err}");
    // Four layered materials (8 lobes) fit.
    let root = 16 + 8 + 2;
    assert!(Bsdf::from_material(&m, &tex, root, [0.5, 0.5], f).is_ok());
}

#[test]
fn classification_for_manifold_exploration() {
    let all = cases();
    let get = |name: &str| {
        &all.iter()
            .find(|c| c.name == name)
            .expect("case exists")
            .bsdf
    };
    assert_eq!(get("lambert").roughness(), None);
    assert!(get("lambert").has_non_delta() && !get("lambert").has_delta());
    assert_eq!(get("conductor a=(0.05,0.5)").roughness(), Some(0.05));
    assert_eq!(get("mix layered+conductor").roughness(), Some(0.1));
    assert!(get("mirror").is_delta_only() && get("glass 1.5").is_delta_only());
    let s = get("layered smooth coat").summary();
    assert!(s.diffuse && s.specular && !s.glossy && !s.transmission);
    let s = get("rough glass a=0.3").summary();
    assert!(s.glossy && s.transmission && s.min_alpha == Some(0.3));
    assert_eq!(get("rough glass a=0.3").eta(), Some(1.5));
    // A black material has no lobes and never samples.
    let black = build(&[matte(0.0)], 0, [0.0; 2]);
    assert!(
        black.is_black()
            && black
                .sample(DVec3::Z, 0.5, [0.5, 0.5], TransportMode::Radiance)
                .is_none()
    );
    // Microfacet normals: the half vector and the generalised half vector.
    let b = get("rough glass a=0.3");
    let fr = b.frame;
    let (wo, wi) = (oblique(), refraction(oblique(), 1.5).expect("enters"));
    let m = b
        .microfacet_normal(fr.to_world(wo), fr.to_world(wi))
        .expect("defined");
    assert!((m - fr.n).length() < 1e-9, "{m:?}");
    let m = b
        .microfacet_normal(fr.to_world(wo), fr.to_world(mirror_z(wo)))
        .expect("defined");
    assert!((m - fr.n).length() < 1e-9, "{m:?}");
}

/// `Bsdf::radiance_compression` is the ratio of a transmission's value in radiance transport to
/// its value in importance transport (what Russian roulette divides out of a camera path's
/// throughput), for smooth and rough glass seen from either side; 1 for reflections and for
/// BSDFs without a dielectric lobe.
#[test]
fn radiance_compression_is_the_ratio_of_radiance_to_importance_transport() {
    let mut checked = 0;
    for (materials, wos) in [
        (
            vec![glass(1.5, 0.0, 0.0)],
            vec![normal(), oblique(), below()],
        ),
        (
            vec![glass(1.33, 0.3, 0.3)],
            vec![normal(), oblique(), below()],
        ),
        (vec![matte(0.7)], vec![oblique()]),
    ] {
        let b = build(&materials, 0, [0.0; 2]);
        let fr = b.frame;
        for wo in wos {
            let wo = fr.to_world(wo);
            for k in 0..64 {
                let (u_lobe, u) = ((k as f64 + 0.5) / 64.0, [0.37, (k as f64 * 0.618) % 1.0]);
                let Some(s) = b.sample(wo, u_lobe, u, TransportMode::Radiance) else {
                    continue;
                };
                let f_importance = if s.delta {
                    b.eval_delta(wo, s.wi, TransportMode::Importance)
                        .expect("the same delta lobe")
                        .f
                } else {
                    b.eval(wo, s.wi, TransportMode::Importance)
                };
                let ratio = s.f[0] / f_importance[0];
                let c = b.radiance_compression(wo, s.wi);
                let transmits = wo.dot(b.ng) * s.wi.dot(b.ng) < 0.0;
                assert!(
                    (ratio - c).abs() < 1e-9 * c,
                    "{materials:?}: f ratio {ratio}, compression {c}"
                );
                assert_eq!(
                    transmits,
                    c != 1.0,
                    "{materials:?}: transmission {transmits}, compression {c}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "{checked} samples checked");
}

/// The densities of a pair in the BSDF's frame, both ways (`Bsdf::pdf_local` of a
/// `Bsdf::local_pair` and of its reverse, as a connection's MIS weight takes them:
/// `Vertex::connection_pdfs`), are two `Bsdf::pdf` calls, and `Bsdf::pdf` the total of
/// `Bsdf::lobe_weights`, bit for bit, on every configuration: random pairs
/// of directions on both sides and pairs the BSDF samples itself (so that sharp lobes give
/// nonzero densities).
#[test]
fn pdf_pair_is_both_pdfs() {
    let mut rng = stream(107, 0);
    let random_dir = |rng: &mut ChainRng| dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
    let mut nonzero = 0;
    for case in cases() {
        let b = &case.bsdf;
        for k in 0..2000 {
            let wa = b.frame.to_world(random_dir(&mut rng));
            let sampled = (k % 2 == 1)
                .then(|| {
                    let (ul, u) = u3(&mut rng);
                    b.sample(wa, ul, u, TransportMode::Radiance)
                })
                .flatten();
            let wb = sampled.map_or_else(|| b.frame.to_world(random_dir(&mut rng)), |s| s.wi);
            let (ab, ba) = b
                .local_pair(wa, wb)
                .map_or((0.0, 0.0), |l| (b.pdf_local(l), b.pdf_local(l.reversed())));
            assert_eq!(ab.to_bits(), b.pdf(wa, wb).to_bits(), "{}", case.name);
            assert_eq!(ba.to_bits(), b.pdf(wb, wa).to_bits(), "{}", case.name);
            // `pdf` (through `Bsdf::local_pair`) is the sum of the lobes' shares, as `invert`
            // weighs them.
            let total = b.lobe_weights(wa, wb, false).total();
            let total = if total.is_finite() { total } else { 0.0 };
            assert_eq!(ab.to_bits(), total.to_bits(), "{}", case.name);
            nonzero += usize::from(ab > 0.0 && ba > 0.0);
        }
    }
    assert!(
        nonzero > 10_000,
        "only {nonzero} pairs with both densities nonzero"
    );
}

/// `Bsdf::eval_pdf_local` (each lobe evaluated once for value and density; glossy lobes share
/// their half vector, `D(h)` and `Λ(wo)`) is `Bsdf::eval` and `Bsdf::pdf`, bit for bit, in both
/// transport modes, on every configuration: random pairs on both sides and pairs the BSDF
/// samples itself. `Bsdf::sample`'s value and density, computed the same way, are the two calls
/// at the sampled direction.
#[test]
fn eval_pdf_local_is_eval_and_pdf() {
    let mut rng = stream(109, 0);
    let random_dir = |rng: &mut ChainRng| dir(1.0 - 2.0 * uniform(rng), 2.0 * PI * uniform(rng));
    let (mut glossy_nonzero, mut sampled_checked) = (0, 0);
    for case in cases() {
        let b = &case.bsdf;
        for k in 0..2000 {
            let mode = if k % 4 < 2 {
                TransportMode::Radiance
            } else {
                TransportMode::Importance
            };
            let wa = b.frame.to_world(random_dir(&mut rng));
            let sampled = (k % 2 == 1)
                .then(|| {
                    let (ul, u) = u3(&mut rng);
                    b.sample(wa, ul, u, mode)
                })
                .flatten();
            let wb = sampled.map_or_else(|| b.frame.to_world(random_dir(&mut rng)), |s| s.wi);
            let (f, pdf) = b
                .local_pair(wa, wb)
                .map_or((Rgb::BLACK, 0.0), |l| b.eval_pdf_local(l, mode));
            let f_alone = b.eval(wa, wb, mode);
            for c in 0..3 {
                assert_eq!(f[c].to_bits(), f_alone[c].to_bits(), "{}", case.name);
            }
            assert_eq!(pdf.to_bits(), b.pdf(wa, wb).to_bits(), "{}", case.name);
            if let Some(s) = sampled.filter(|s| !s.delta) {
                for c in 0..3 {
                    assert_eq!(s.f[c].to_bits(), f[c].to_bits(), "{}", case.name);
                }
                assert_eq!(s.pdf.to_bits(), pdf.to_bits(), "{}", case.name);
                sampled_checked += 1;
            }
            let glossy = case.name.contains("conductor") || case.name.contains("layered");
            glossy_nonzero += usize::from(glossy && pdf > 0.0 && !f.is_black());
        }
    }
    assert!(
        sampled_checked > 5_000,
        "only {sampled_checked} samples checked"
    );
    assert!(glossy_nonzero > 1_000, "only {glossy_nonzero} glossy pairs");
}
