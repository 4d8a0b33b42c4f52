//! The layered material of the charted-MLT paper (§6): a Lambertian base under a GGX dielectric
//! coating, in pbrt-v3 `plastic` form for compatibility with pbrt scenes:
//!
//! `f = Kd/π + Ks · F(wo·h) D(h) G2(wo, wi) / (4 |cos θo| |cos θi|)`,
//!
//! with the dielectric Fresnel of the coating (index `η`, seen from outside) and **no `(1 − F)`
//! factors on the diffuse term** (pbrt-v3 `PlasticMaterial` is exactly `LambertianReflection(Kd)`
//! plus `MicrofacetReflection(Ks, FresnelDielectric(1, η))`; it neither attenuates the base by the
//! coating's transmittance nor conserves energy when `Kd + Ks > 1`). Two lobes that can produce
//! the same direction, so `invert` must choose between them by their density shares (the paper's
//! Algorithm 1).
//!
//! **Lobe choice (Fresnel-weighted albedos).** The two lobes form one group with selection weights
//! `w_diffuse = avg(Kd)` and `w_coating = F(|cos θo|) · avg(Ks)` — each lobe's (approximate)
//! albedo, so the one-sample estimator `f |cos θi| / Σ P_j pdf_j` stays bounded. (Weighting the
//! diffuse lobe by `1 − F(cos θo)` would starve it at grazing angles, where `F → 1` while the
//! diffuse albedo of this model stays `Kd`.) A roughness of zero makes the coating a delta
//! reflection.

use super::conductor::MicrofacetReflection;
use super::fresnel::Fresnel;
use super::lambert::Lambert;
use super::lobes::{Lobe, LobeKind, Weight};
use super::microfacet::Ggx;
use super::mirror::SpecularReflection;
use crate::spectrum::Rgb;

/// The (at most two) lobes of a layered material with factor `scale`, in group `group`.
pub fn layered_lobes(
    kd: Rgb,
    ks: Rgb,
    alpha_u: f64,
    alpha_v: f64,
    eta: f64,
    scale: Rgb,
    group: usize,
) -> [Option<Lobe>; 2] {
    let diffuse = (kd.average() > 0.0).then_some(Lobe {
        kind: LobeKind::Lambert(Lambert { r: kd }),
        scale,
        group,
        weight: Weight::Constant(kd.average()),
    });
    let fresnel = Fresnel::Dielectric { eta };
    let kind = if alpha_u == 0.0 && alpha_v == 0.0 {
        LobeKind::Specular(SpecularReflection { fresnel, tint: ks })
    } else {
        LobeKind::Glossy(MicrofacetReflection {
            ggx: Ggx::new(alpha_u, alpha_v),
            fresnel,
            tint: ks,
        })
    };
    // With η = 1 the coating reflects nothing.
    let coating = (ks.average() > 0.0 && eta != 1.0).then_some(Lobe {
        kind,
        scale,
        group,
        weight: Weight::Fresnel {
            eta,
            scale: ks.average(),
        },
    });
    [diffuse, coating]
}
