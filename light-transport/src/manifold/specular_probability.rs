//! The specular probability `ψ` of a vertex (Jakob & Marschner 2012, §5.2 and appendix A1,
//! eq. 28): the chance that the manifold perturbation treats a glossy vertex as part of a specular
//! chain — walking it on the offset manifold that keeps its microfacet normal fixed in its shading
//! frame — rather than as one of the chain's free ends.
//!
//! `ψ = (1 − cos θ_q) / (1 − cos(θ_q + Δθ))`: the solid angle of the cone holding the fraction `q`
//! of the microfacet normals (their density `D(m) cos θ_m`) over that of the same cone widened by
//! `Δθ`, the expected angular change of a microfacet normal during a perturbation that leaves the
//! vertex free. The paper writes `θ_q` for the Beckmann distribution; our glossy lobes are GGX
//! (Trowbridge–Reitz), whose `tan² θ_m` has the law `t / (α² + t)`, so
//! `θ_q = atan(α √(q / (1 − q)))` (the paper's own formula, as printed, lacks the square root of
//! Beckmann's quantile `tan² θ_q = −α² ln(1 − q)`). Diffuse vertices (any Lambertian lobe) and
//! endpoints have `ψ = 0`, ideal specular ones `ψ = 1`.

use crate::bsdf::Bsdf;

/// The parameters of `ψ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularProbability {
    /// Classify glossy vertices at random (the paper); `false`: glossy vertices are always free
    /// ends (`ψ = 0`), as the ideal-specular perturbation of §5.1 treats them.
    pub glossy: bool,
    /// The quantile `q` of the microfacet normals' angle (0.9).
    pub quantile: f64,
    /// `Δθ` in radians, the expected change of a free vertex's microfacet normal in a
    /// perturbation; `None`: measured by a pilot before rendering, as the paper does
    /// ([`crate::pathspace::normal_change`]; MEMLT, path-space MLT and MEPT run it), and
    /// [`DEFAULT_NORMAL_CHANGE`] where no pilot runs (CMLT).
    pub normal_change: Option<f64>,
}

/// `Δθ` where it is neither given nor measured (radians).
pub const DEFAULT_NORMAL_CHANGE: f64 = 0.05;

impl Default for SpecularProbability {
    fn default() -> Self {
        Self {
            glossy: true,
            quantile: 0.9,
            normal_change: None,
        }
    }
}

impl SpecularProbability {
    /// Whether the parameters make sense: `0 < q < 1`, `0 ≤ Δθ ≤ π`.
    pub fn is_valid(&self) -> bool {
        self.quantile > 0.0
            && self.quantile < 1.0
            && self
                .normal_change
                .is_none_or(|d| (0.0..=std::f64::consts::PI).contains(&d))
    }

    /// `Δθ` in use: the given or measured one, else [`DEFAULT_NORMAL_CHANGE`].
    pub fn delta_theta(&self) -> f64 {
        self.normal_change.unwrap_or(DEFAULT_NORMAL_CHANGE)
    }

    /// `θ_q` of GGX roughness `alpha`.
    pub fn quantile_angle(&self, alpha: f64) -> f64 {
        (alpha * (self.quantile / (1.0 - self.quantile)).sqrt()).atan()
    }

    /// `ψ` of a glossy lobe of GGX roughness `alpha` (eq. 28).
    pub fn of_roughness(&self, alpha: f64) -> f64 {
        if !self.glossy || !(alpha > 0.0) {
            return 0.0;
        }
        let theta = self.quantile_angle(alpha);
        let wide = (theta + self.delta_theta()).min(std::f64::consts::PI);
        let psi = (1.0 - theta.cos()) / (1.0 - wide.cos());
        if psi.is_finite() {
            psi.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// `ψ` of a non-delta vertex with BSDF `bsdf`: eq. 28 with its smallest GGX `α` when every
    /// non-delta lobe is glossy, 0 when one is diffuse.
    pub fn of_bsdf(&self, bsdf: &Bsdf) -> f64 {
        let s = bsdf.summary();
        match s.min_alpha {
            Some(alpha) if s.glossy && !s.diffuse => self.of_roughness(alpha),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psi_follows_eq_28() {
        let p = SpecularProbability::default();
        // tan θ_q = 3 α for q = 0.9.
        assert!((p.quantile_angle(0.1).tan() - 0.3).abs() < 1e-12);
        let t = 0.3f64.atan();
        let want = (1.0 - t.cos()) / (1.0 - (t + 0.05).cos());
        assert!((p.of_roughness(0.1) - want).abs() < 1e-12);
        // Smoother surfaces are more likely specular; Δθ = 0 makes every glossy vertex specular.
        assert!(p.of_roughness(0.01) < p.of_roughness(0.1));
        let still = SpecularProbability {
            normal_change: Some(0.0),
            ..p
        };
        assert_eq!(still.of_roughness(0.2), 1.0);
        let off = SpecularProbability { glossy: false, ..p };
        assert_eq!(off.of_roughness(0.2), 0.0);
    }
}
