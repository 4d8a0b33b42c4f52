//! BSDFs with four faces each — `sample`, `eval`, `pdf` and `invert` — built per hit from a
//! material description.
//!
//! # Interface contract
//!
//! * Directions are **world-space unit vectors pointing away from the surface**. `wo` is the
//!   direction the random walk arrived from (toward the previous vertex); `wi` the new direction.
//! * [`TransportMode::Radiance`] (camera subpaths) evaluates `f(wo, wi)` for light flowing from
//!   `wi` to `wo`; [`TransportMode::Importance`] (light subpaths) evaluates the adjoint. They differ
//!   only for refraction: radiance is scaled by `(η_o/η_i)²` (`η_o`, `η_i` the indices on the sides
//!   of `wo` and `wi`), importance is not (Veach 1997 ch. 5, pbrt-v3/v4). Hence
//!   `f_radiance(wo, wi) = f_importance(wi, wo)` and `f_radiance(wo, wi)/η_o² = f_radiance(wi, wo)/η_i²`.
//! * `eval` and `pdf` cover the non-delta lobes only (delta lobes evaluate to zero there);
//!   `pdf(wo, wi)` is the solid-angle density of `sample` producing `wi` from `wo` (all non-delta
//!   lobes together: `Σ_j P_j(wo) pdf_j(wo, wi)`), so the reverse density is `pdf(wi, wo)`. The
//!   density integrates to the probability that `sample` succeeds with a non-delta direction
//!   (GGX samples reflected below the horizon fail).
//! * `sample(wo, u_lobe, u, mode)` reads the vertex block's lobe number and two direction numbers
//!   (see [`crate::sampler`]). A non-delta sample returns `f = eval(wo, wi)` and `pdf = pdf(wo, wi)`
//!   (one-sample MIS over the lobes). A delta sample returns `delta = true`, `pdf` = the
//!   probability of choosing it (summed over the delta lobes and branches producing that same
//!   direction, e.g. a mirror mixed with glass) and `f` such that `f · |cos θ_i| / pdf` is its
//!   weight; [`Bsdf::eval_delta`] reproduces both for a given pair.
//! * `invert(wo, wi, delta, rng)` draws `(u_lobe, u0, u1)` from the **exact conditional law** of the
//!   numbers given that `sample` produced `wi` (DESIGN §3): a lobe is chosen with probability
//!   proportional to its share of the density at `wi` (`P_j pdf_j / Σ_k P_k pdf_k`; for delta:
//!   among the delta lobes that produce `wi`, by probability), `u_lobe` is uniform within that
//!   lobe's interval (or the branch's sub-interval for dielectrics), the lobe's own inverse gives
//!   `(u0, u1)`, and numbers a lobe does not use are uniform. `None` when `wi` cannot be produced.
//! * The local frame is the **shading** frame (shading normal, shading tangent); reflection lobes
//!   are two-sided (they work for `wo` below the surface by mirroring), dielectrics choose `η` by
//!   the side of `wo`. The **geometric** normal decides the sides: a direction that the shading
//!   normal puts on one side of the surface and the geometric normal on the other carries
//!   nothing — `eval`, `pdf` and `eval_delta` are zero, `sample` fails, `invert` has no answer.
//!   This closes the light leaks of shading normals (light arriving from behind the geometric
//!   surface) at the price of black facets where the two normals disagree near grazing angles
//!   (Veach 1997 §5.3 discusses both; pbrt makes the same choice for the side of `wi`). Without
//!   shading normals the rule only removes the exact tangent directions.
//!
//! # Models and conventions
//!
//! | material | lobes | file |
//! |---|---|---|
//! | `matte` | Lambert, `(θ, φ) = (acos √u1, 2π u0)` | [`lambert`] |
//! | `metal` | GGX reflection, conductor Fresnel, anisotropic, visible normals | [`conductor`], [`microfacet`], [`fresnel`] |
//! | `mirror`, roughness-0 `metal` | delta reflection | [`mirror`] |
//! | `glass` (roughness 0 or `η = 1`) | delta reflection + refraction by Fresnel | [`dielectric`] |
//! | `glass` (rough) | GGX reflection + transmission (Walter 2007), visible normals | [`rough_dielectric`] |
//! | `plastic`/`substrate` | Lambert + GGX dielectric coating (pbrt-v3 plastic) | [`layered`] |
//! | `mix` | flattened lobes, per-channel amounts | [`material`], [`lobes`] |
//!
//! Smith masking is **height-correlated**, `G2 = 1/(1 + Λ(wo) + Λ(wi))`, in every GGX lobe; the
//! sampling density uses the visible-normal distribution with `G1(wo)` (Heitz 2018). Roughness
//! values are GGX `α` (the loader applies pbrt's remapping); positive values below
//! [`microfacet::MIN_ALPHA`] are clamped to it, zero on both axes means a delta lobe. Lobe choice:
//! see [`lobes`] (groups of mixes) and [`layered`] (Fresnel-weighted albedos).

pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod lambert;
pub mod layered;
pub mod lobes;
pub mod material;
pub mod microfacet;
pub mod mirror;
pub(crate) mod prebuilt;
pub mod rough_dielectric;
pub mod texture;

use crate::math::{DVec3, Frame};
use crate::scene::{MaterialDesc, TextureDesc};
use crate::spectrum::Rgb;
use lobes::{LobeKind, Lobes, MAX_LOBES, positive};
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;
pub use prebuilt::PrebuiltLobes;

/// Which quantity a random walk carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera subpaths (radiance flows toward the camera).
    Radiance,
    /// Light subpaths (importance flows toward the lights).
    Importance,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The new direction (world space).
    pub wi: DVec3,
    /// The BSDF value (see the module contract for delta lobes).
    pub f: Rgb,
    /// Solid-angle density, or the lobe probability for a delta lobe.
    pub pdf: f64,
    /// Whether a delta lobe produced it.
    pub delta: bool,
}

/// What kinds of lobes a BSDF has (for manifold exploration and path classification).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LobeSummary {
    /// A Lambertian lobe.
    pub diffuse: bool,
    /// A rough (GGX) lobe.
    pub glossy: bool,
    /// A delta lobe.
    pub specular: bool,
    /// A lobe that transmits (dielectric).
    pub transmission: bool,
    /// Smallest GGX `α` of the glossy lobes.
    pub min_alpha: Option<f64>,
}

/// Per-lobe shares of the density at a direction (see [`Bsdf::lobe_weights`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeWeights {
    /// `P_j(wo) pdf_j(wo, wi)` (non-delta) or `P_j(wo) · branch probability` (delta), per lobe.
    pub weights: [f64; MAX_LOBES],
    /// Number of lobes.
    pub len: usize,
}

impl LobeWeights {
    /// The weights.
    pub fn as_slice(&self) -> &[f64] {
        &self.weights[..self.len]
    }
    /// Their sum (the density, or the delta probability, of `wi`).
    pub fn total(&self) -> f64 {
        self.as_slice().iter().sum()
    }
}

/// Two directions in a BSDF's local frame, normalised ([`Bsdf::local_pair`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalPair {
    wo: DVec3,
    wi: DVec3,
}

impl LocalPair {
    /// The pair with `wo` and `wi` exchanged.
    #[inline]
    pub fn reversed(self) -> Self {
        Self {
            wo: self.wi,
            wi: self.wo,
        }
    }
}

/// A BSDF at one surface point. Two BSDFs are equal when their frames, geometric normals and
/// lobes are (storage beyond the lobes in use is ignored).
#[derive(Debug, PartialEq)]
pub struct Bsdf {
    /// Shading frame (normal = shading normal; first tangent = anisotropy direction).
    pub frame: Frame,
    /// Geometric normal (decides on which side of the surface a direction lies).
    pub ng: DVec3,
    lobes: Lobes,
}

impl Clone for Bsdf {
    fn clone(&self) -> Self {
        Self {
            frame: self.frame,
            ng: self.ng,
            lobes: self.lobes.clone(),
        }
    }

    /// Keeps the lobes' storage and copies only those in use (a derived `clone_from` copies
    /// every inline slot).
    fn clone_from(&mut self, source: &Self) {
        self.frame = source.frame;
        self.ng = source.ng;
        self.lobes.clone_from(&source.lobes);
    }
}

/// The sum of density terms, non-finite terms and totals counted as 0.
#[inline]
fn finite_total(terms: &[f64]) -> f64 {
    let total: f64 = terms
        .iter()
        .map(|&w| if w.is_finite() { w } else { 0.0 })
        .sum();
    if total.is_finite() { total } else { 0.0 }
}

/// A world direction in the local frame, normalised; `None` when degenerate.
fn local(frame: &Frame, w: DVec3) -> Option<DVec3> {
    crate::math::renormalize(frame.to_local(w))
}

impl Bsdf {
    /// The BSDF of `materials[material]` at texture coordinates `uv` with local frame `frame`
    /// (use [`Frame::from_normal_tangent`] with `dpdu` for anisotropic materials).
    ///
    /// Errors: an out-of-range material or texture index, invalid parameters (negative or
    /// non-finite reflectances, roughness or indices), mixes nested deeper than 16 or cyclic, or
    /// more than [`lobes::MAX_LOBES`] lobes after flattening mixes.
    ///
    /// ```
    /// use light_transport::bsdf::{Bsdf, TransportMode};
    /// use light_transport::math::{DVec3, Frame};
    /// use light_transport::scene::{MaterialDesc, RgbTexture};
    /// use light_transport::Rgb;
    /// let m = [MaterialDesc::Matte { kd: RgbTexture::Constant(Rgb::splat(0.5)) }];
    /// let bsdf = Bsdf::from_material(&m, &[], 0, [0.0, 0.0], Frame::from_normal(DVec3::Z)).unwrap();
    /// let s = bsdf.sample(DVec3::Z, 0.3, [0.2, 0.7], TransportMode::Radiance).unwrap();
    /// assert!((s.f[0] * s.wi.z / s.pdf - 0.5).abs() < 1e-12);
    /// let u = bsdf.invert(DVec3::Z, s.wi, false, &mut mcmc_core::rng::stream(1, 0)).unwrap();
    /// assert!((u[1] - 0.2).abs() < 1e-12 && (u[2] - 0.7).abs() < 1e-12);
    /// ```
    pub fn from_material(
        materials: &[MaterialDesc],
        textures: &[TextureDesc],
        material: usize,
        uv: [f64; 2],
        frame: Frame,
    ) -> crate::Result<Bsdf> {
        let mut bsdf = Bsdf::empty(frame);
        bsdf.rebuild(materials, textures, material, uv, frame)?;
        Ok(bsdf)
    }

    /// The lobes.
    pub fn lobes(&self) -> &Lobes {
        &self.lobes
    }

    /// A BSDF without lobes (black) in `frame`.
    pub fn empty(frame: Frame) -> Bsdf {
        Bsdf {
            ng: frame.n,
            frame,
            lobes: Lobes::default(),
        }
    }

    /// [`Bsdf::from_material`] in place: this BSDF becomes that of `materials[material]` at `uv`
    /// with local frame `frame` (geometric normal `frame.n`), reusing its storage. On error its
    /// lobes are unspecified.
    pub fn rebuild(
        &mut self,
        materials: &[MaterialDesc],
        textures: &[TextureDesc],
        material: usize,
        uv: [f64; 2],
        frame: Frame,
    ) -> crate::Result<()> {
        self.frame = frame;
        self.ng = frame.n;
        material::build(&mut self.lobes, materials, textures, material, uv)
    }

    /// This BSDF with the lobes `lobes` (a material's, built once: [`PrebuiltLobes`]) in frame
    /// `frame` (geometric normal `frame.n`), copied into its storage.
    pub fn rebuild_from(&mut self, lobes: &Lobes, frame: Frame) {
        self.frame = frame;
        self.ng = frame.n;
        self.lobes.clone_from(lobes);
    }

    /// The same BSDF on a surface whose geometric normal is `ng` (the frame's normal being the
    /// shading normal).
    pub fn with_geometric_normal(mut self, ng: DVec3) -> Self {
        self.ng = ng;
        self
    }

    /// Whether the world direction `w`, `l` in the local frame, lies on the same side of the
    /// surface by the shading normal and by the geometric normal.
    #[inline]
    fn sides_agree(&self, w: DVec3, l: DVec3) -> bool {
        let g = w.dot(self.ng);
        (g > 0.0 && l.z > 0.0) || (g < 0.0 && l.z < 0.0)
    }

    /// `wo` and `wi` in the local frame, when both lie on a side the two normals agree on.
    #[inline(always)]
    fn locals(&self, wo: DVec3, wi: DVec3) -> Option<(DVec3, DVec3)> {
        let (lo, li) = (local(&self.frame, wo)?, local(&self.frame, wi)?);
        (self.sides_agree(wo, lo) && self.sides_agree(wi, li)).then_some((lo, li))
    }

    /// Sample a direction from the lobe number `u_lobe` and direction numbers `u`.
    pub fn sample(
        &self,
        wo: DVec3,
        u_lobe: f64,
        u: [f64; 2],
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        self.sample_local(wo, u_lobe, u, mode).map(|(s, _)| s)
    }

    /// [`Bsdf::sample`], with the pair `(wo, wi)` in the local frame that
    /// [`Bsdf::local_pair`]`(wo, s.wi)` would give, bit for bit: a random walk takes the reverse
    /// density `pdf(s.wi, wo)` from it as [`Bsdf::pdf_local`]`(pair.reversed())`, without
    /// bringing the two directions into the frame again.
    pub fn sample_local(
        &self,
        wo: DVec3,
        u_lobe: f64,
        u: [f64; 2],
        mode: TransportMode,
    ) -> Option<(BsdfSample, LocalPair)> {
        let wo_world = wo;
        let wo = local(&self.frame, wo)?;
        if wo.z == 0.0 || !self.sides_agree(wo_world, wo) {
            return None;
        }
        let p = self.lobes.probabilities(wo);
        let (j, u_sub) = self.lobes.choose(&p, u_lobe)?;
        let s = self.lobes.sample(j, wo, u_sub, u, mode)?;
        // Value and density at the world direction handed out, so that `eval` and `pdf` called
        // with it reproduce them exactly.
        let wi = self.frame.to_world(s.wi);
        let wl = local(&self.frame, wi)?;
        if !self.sides_agree(wi, wl) {
            return None;
        }
        let (f, pdf) = if s.delta {
            let t = self.lobes.delta_terms(&p, wo, wl, mode);
            t.iter()
                .fold((Rgb::BLACK, 0.0), |(f, q), (tf, tq)| (f + *tf, q + tq))
        } else if let [lobe] = self.lobes.as_slice() {
            // One lobe: the sum below is its term (or zero, which is refused either way).
            lobe.eval_pdf_sum(p[0], wo, wl, mode)
        } else {
            let (f, t) = self.lobes.eval_pdf_terms(&p, wo, wl, mode);
            (f, t.iter().sum())
        };
        if !positive(pdf) || !pdf.is_finite() || !f.is_finite() {
            return None;
        }
        Some((
            BsdfSample {
                wi,
                f,
                pdf,
                delta: s.delta,
            },
            LocalPair { wo, wi: wl },
        ))
    }

    /// `wo` and `wi` in the local frame, what [`Bsdf::eval`] and [`Bsdf::pdf`] compute first:
    /// with [`Bsdf::eval_local`] and [`Bsdf::pdf_local`] a caller needing both computes it once.
    /// `None` when either direction is degenerate or on a side the two normals disagree on (both
    /// are then zero).
    #[inline]
    pub fn local_pair(&self, wo: DVec3, wi: DVec3) -> Option<LocalPair> {
        self.locals(wo, wi).map(|(wo, wi)| LocalPair { wo, wi })
    }

    /// [`Bsdf::eval`] of the pair.
    #[inline]
    pub fn eval_local(&self, l: LocalPair, mode: TransportMode) -> Rgb {
        let f = self.lobes.eval(l.wo, l.wi, mode);
        if f.is_finite() { f } else { Rgb::BLACK }
    }

    /// [`Bsdf::pdf`] of the pair.
    #[inline]
    pub fn pdf_local(&self, l: LocalPair) -> f64 {
        if let Some((lobe, p)) = self.lobes.single(l.wo) {
            return finite_total(&[lobe.pdf_term(p, l.wo, l.wi)]);
        }
        let p = self.lobes.probabilities(l.wo);
        self.finite_total(&self.lobes.pdf_terms(&p, l.wo, l.wi))
    }

    /// The sum of the lobes' density terms, non-finite terms and totals counted as 0.
    #[inline]
    fn finite_total(&self, terms: &lobes::Probabilities) -> f64 {
        finite_total(&terms[..self.lobes.as_slice().len()])
    }

    /// `(`[`Bsdf::eval_local`]`, `[`Bsdf::pdf_local`]`)` of the pair, bit for bit, each lobe
    /// evaluated once for both.
    #[inline]
    pub fn eval_pdf_local(&self, l: LocalPair, mode: TransportMode) -> (Rgb, f64) {
        if let Some((lobe, p)) = self.lobes.single(l.wo) {
            let (f, t) = lobe.eval_pdf_sum(p, l.wo, l.wi, mode);
            return (
                if f.is_finite() { f } else { Rgb::BLACK },
                finite_total(&[t]),
            );
        }
        let p = self.lobes.probabilities(l.wo);
        let (f, terms) = self.lobes.eval_pdf_terms(&p, l.wo, l.wi, mode);
        (
            if f.is_finite() { f } else { Rgb::BLACK },
            self.finite_total(&terms),
        )
    }

    /// Evaluate the non-delta part.
    ///
    /// Always inlined: called, it took its two directions through memory, where the caller had
    /// stored each as one f64 and a pair and it read them back as a pair and one f64; a load
    /// spanning two stores is not forwarded, and a sampling profile of BDPT put a fifth of this
    /// function's time on that wait.
    #[inline(always)]
    pub fn eval(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Rgb {
        match self.locals(wo, wi) {
            Some((wo, wi)) => self.eval_local(LocalPair { wo, wi }, mode),
            None => Rgb::BLACK,
        }
    }

    /// Density of sampling `wi` from `wo` (non-delta part).
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        self.local_pair(wo, wi).map_or(0.0, |l| self.pdf_local(l))
    }

    /// `(f, probability)` of the delta lobes producing `wi` from `wo`, as [`Bsdf::sample`] would
    /// report them; `None` when no delta lobe produces `wi`.
    pub fn eval_delta(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Option<BsdfSample> {
        let (lo, li) = self.locals(wo, wi)?;
        let p = self.lobes.probabilities(lo);
        let t = self.lobes.delta_terms(&p, lo, li, mode);
        let (f, pdf) = t
            .iter()
            .fold((Rgb::BLACK, 0.0), |(f, q), (tf, tq)| (f + *tf, q + tq));
        (pdf > 0.0 && pdf.is_finite() && f.is_finite()).then_some(BsdfSample {
            wi,
            f,
            pdf,
            delta: true,
        })
    }

    /// The direction a delta lobe sends `wo` to: the mirror direction (`transmit = false`) or the
    /// refracted one through the first dielectric lobe (`transmit = true`); `None` when no delta
    /// lobe produces it (no such lobe, total internal reflection). Specular chains keep their
    /// reflection/refraction pattern under perturbation this way (Veach & Guibas 1997, §5.3).
    pub fn delta_direction(&self, wo: DVec3, transmit: bool, mode: TransportMode) -> Option<DVec3> {
        let lo = local(&self.frame, wo)?;
        if lo.z == 0.0 {
            return None;
        }
        let li = if transmit {
            let (up, sign, eta) = dielectric::orient(lo, self.eta()?);
            let t = fresnel::refract(up, DVec3::Z, eta)?;
            DVec3::new(t.x, t.y, t.z * sign)
        } else {
            mirror::mirror_z(lo)
        };
        let wi = self.frame.to_world(li);
        self.eval_delta(wo, wi, mode).map(|s| s.wi)
    }

    /// Each lobe's share of the density at `wi` (`delta = false`: `P_j pdf_j`) or of the delta
    /// probability (`delta = true`): the branch probabilities of [`Bsdf::invert`].
    pub fn lobe_weights(&self, wo: DVec3, wi: DVec3, delta: bool) -> LobeWeights {
        let len = self.lobes.as_slice().len();
        let mut out = LobeWeights {
            weights: [0.0; MAX_LOBES],
            len,
        };
        let Some((wo, wi)) = self.locals(wo, wi) else {
            return out;
        };
        let p = self.lobes.probabilities(wo);
        if delta {
            let t = self.lobes.delta_terms(&p, wo, wi, TransportMode::Radiance);
            for (o, (_, q)) in out.weights.iter_mut().zip(t.iter()) {
                *o = *q;
            }
        } else {
            out.weights = self.lobes.pdf_terms(&p, wo, wi);
        }
        for w in &mut out.weights {
            if !w.is_finite() {
                *w = 0.0;
            }
        }
        out
    }

    /// The numbers `(u_lobe, u0, u1)` of lobe `lobe` producing `wi`: `u_lobe` within the lobe's
    /// interval, drawn from the lobe's own conditional law. [`Bsdf::invert`] is this after choosing
    /// `lobe` by [`Bsdf::lobe_weights`].
    pub fn invert_lobe(
        &self,
        wo: DVec3,
        wi: DVec3,
        lobe: usize,
        rng: &mut ChainRng,
    ) -> Option<[f64; 3]> {
        let (wo, wi) = self.locals(wo, wi)?;
        if lobe >= self.lobes.as_slice().len() {
            return None;
        }
        let p = self.lobes.probabilities(wo);
        if !positive(p[lobe]) {
            return None;
        }
        let [u_sub, u0, u1] = self.lobes.invert(lobe, wo, wi, rng)?;
        Some([self.lobes.lobe_number(&p, lobe, u_sub), u0, u1])
    }

    /// Exact conditional inverse of `sample`.
    pub fn invert(
        &self,
        wo: DVec3,
        wi: DVec3,
        delta: bool,
        rng: &mut ChainRng,
    ) -> Option<[f64; 3]> {
        let w = self.lobe_weights(wo, wi, delta);
        let total = w.total();
        if !positive(total) || !total.is_finite() {
            return None;
        }
        let target = uniform(rng) * total;
        let mut acc = 0.0;
        let mut chosen = None;
        for (j, &v) in w.as_slice().iter().enumerate() {
            if v > 0.0 {
                chosen = Some(j);
                acc += v;
                if target < acc {
                    break;
                }
            }
        }
        self.invert_lobe(wo, wi, chosen?, rng)
    }

    /// Whether some lobe is a delta (specular) lobe.
    pub fn has_delta(&self) -> bool {
        self.lobes.as_slice().iter().any(|l| l.kind.is_delta())
    }

    /// Whether every lobe is a delta lobe (connections through this vertex are impossible).
    pub fn is_delta_only(&self) -> bool {
        let l = self.lobes.as_slice();
        !l.is_empty() && l.iter().all(|l| l.kind.is_delta())
    }

    /// Whether the BSDF has no lobe at all (black: every sample fails, `eval` is zero).
    pub fn is_black(&self) -> bool {
        self.lobes.as_slice().is_empty()
    }

    /// Whether some lobe is diffuse or glossy (not delta).
    pub fn has_non_delta(&self) -> bool {
        self.lobes.as_slice().iter().any(|l| !l.kind.is_delta())
    }

    /// Smallest GGX `α` (over both axes) of the glossy lobes; `None` without glossy lobes.
    pub fn roughness(&self) -> Option<f64> {
        self.lobes
            .as_slice()
            .iter()
            .filter_map(|l| l.kind.alpha())
            .map(|(a, b)| a.min(b))
            .reduce(f64::min)
    }

    /// The kinds of lobes present.
    pub fn summary(&self) -> LobeSummary {
        let mut s = LobeSummary {
            min_alpha: self.roughness(),
            ..LobeSummary::default()
        };
        for l in self.lobes.as_slice() {
            match l.kind {
                LobeKind::Lambert(_) => s.diffuse = true,
                LobeKind::Glossy(_) => s.glossy = true,
                LobeKind::Specular(_) => s.specular = true,
                LobeKind::Dielectric(_) => {
                    s.specular = true;
                    s.transmission = true;
                }
                LobeKind::RoughDielectric(_) => {
                    s.glossy = true;
                    s.transmission = true;
                }
            }
        }
        s
    }

    /// The factor by which radiance transport ([`TransportMode::Radiance`]) scales the value of
    /// a transmission from `wo` to `wi`: `1/η²` with `η` the relative index seen from `wo`
    /// ([`dielectric::transmission_scale`]); 1 for a reflection or without a dielectric lobe.
    /// Russian roulette divides it out of the throughput it looks at (pbrt's `etaScale`), so a
    /// camera path inside glass does not stop more often than outside.
    pub fn radiance_compression(&self, wo: DVec3, wi: DVec3) -> f64 {
        let (Some(eta), Some(lo), Some(li)) =
            (self.eta(), local(&self.frame, wo), local(&self.frame, wi))
        else {
            return 1.0;
        };
        if lobes::same_side(lo, li) {
            return 1.0;
        }
        let (_, _, eta) = dielectric::orient(lo, eta);
        dielectric::transmission_scale(eta, TransportMode::Radiance)
    }

    /// Index of refraction (inside over outside) of the first dielectric lobe.
    pub fn eta(&self) -> Option<f64> {
        self.lobes.as_slice().iter().find_map(|l| match l.kind {
            LobeKind::Dielectric(d) => Some(d.eta),
            LobeKind::RoughDielectric(d) => Some(d.eta),
            _ => None,
        })
    }

    /// The microfacet normal (world space, on `wo`'s side) that maps `wo` to `wi`: the half vector
    /// for a reflection, the generalised half vector `±normalize(η_o wo + η_i wi)` for a
    /// refraction (using [`Bsdf::eta`]); `None` when undefined.
    pub fn microfacet_normal(&self, wo: DVec3, wi: DVec3) -> Option<DVec3> {
        let (lo, li) = (local(&self.frame, wo)?, local(&self.frame, wi)?);
        let m = if lobes::same_side(lo, li) {
            let h = lo + li;
            let len2 = h.length_squared();
            if !(positive(len2) && len2.is_finite()) {
                return None;
            }
            h / len2.sqrt()
        } else {
            rough_dielectric::microfacet_normal(lo, li, self.eta()?)?
        };
        Some(self.frame.to_world(m))
    }
}
