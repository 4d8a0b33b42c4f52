//! Fresnel reflectance of smooth interfaces: dielectric (real relative index `η`) and conductor
//! (complex index `η + ik`, per RGB channel), from the Fresnel equations for unpolarised light
//! (pbrt-v4 §9.3, `FrDielectric` / `FrComplex`), and the refraction of a direction (Snell's law).

use super::lobes::positive;
use crate::math::DVec3;
use crate::spectrum::Rgb;

/// Unpolarised Fresnel reflectance of a dielectric interface.
///
/// `cos_i ≥ 0` is the cosine of the incident direction on the incident side and `eta = η_t / η_i`
/// the index of the far side over the index of the incident side. Total internal reflection
/// returns 1.
pub fn dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 || sin2_t.is_nan() {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let f = 0.5 * (r_parl * r_parl + r_perp * r_perp);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// A minimal complex number for the conductor Fresnel equations.
#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn scale(self, s: f64) -> Self {
        Self::new(self.re * s, self.im * s)
    }
    fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn div(self, o: Self) -> Self {
        let d = o.norm();
        Self::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    /// Principal square root.
    fn sqrt(self) -> Self {
        let r = self.norm().sqrt();
        if r == 0.0 {
            return Self::new(0.0, 0.0);
        }
        let re = (0.5 * (r + self.re)).max(0.0).sqrt();
        let im = (0.5 * (r - self.re)).max(0.0).sqrt();
        Self::new(re, if self.im < 0.0 { -im } else { im })
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative index `eta + i k`.
pub fn conductor_channel(cos_i: f64, eta: f64, k: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let n = Complex::new(eta, k);
    let n2 = n.mul(n);
    if n2.norm() == 0.0 {
        return 1.0;
    }
    let sin2_t = Complex::new(1.0 - cos_i * cos_i, 0.0).div(n2);
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(cos_i, 0.0);
    let a = n.scale(cos_i);
    let b = n.mul(cos_t);
    let (pn, pd) = (a.sub(cos_t), a.add(cos_t));
    let (sn, sd) = (ci.sub(b), ci.add(b));
    if pd.norm() == 0.0 || sd.norm() == 0.0 {
        return 1.0;
    }
    let f = 0.5 * (pn.norm() / pd.norm() + sn.norm() / sd.norm());
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The Fresnel term of a reflecting lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// Reflects everything (pbrt's `FresnelNoOp`, used by `mirror`).
    One,
    /// A dielectric seen from outside, relative index `eta` (the coating of `plastic`).
    Dielectric {
        /// Inside over outside.
        eta: f64,
    },
    /// A conductor with complex relative index `eta + i k` per channel (`metal`).
    Conductor {
        /// Real part.
        eta: Rgb,
        /// Imaginary part (absorption).
        k: Rgb,
    },
}

impl Fresnel {
    /// Reflectance at incidence cosine `cos_i` (its absolute value is used).
    pub fn eval(&self, cos_i: f64) -> Rgb {
        let c = cos_i.abs();
        match *self {
            Fresnel::One => Rgb::WHITE,
            Fresnel::Dielectric { eta } => Rgb::splat(dielectric(c, eta)),
            Fresnel::Conductor { eta, k } => Rgb::new(
                conductor_channel(c, eta[0], k[0]),
                conductor_channel(c, eta[1], k[1]),
                conductor_channel(c, eta[2], k[2]),
            ),
        }
    }
}

/// Refract `wi` (pointing away from the surface on the side `n` points to) through the interface
/// with normal `n` and relative index `eta = η_t / η_i`; `None` on total internal reflection.
/// Returns the transmitted direction (pointing away on the other side, unit length).
pub fn refract(wi: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = wi.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 || sin2_t.is_nan() {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let wt = -wi / eta + n * (cos_i / eta - cos_t);
    let len2 = wt.length_squared();
    if !positive(len2) || !len2.is_finite() {
        return None;
    }
    Some(wt / len2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence_and_tir() {
        let f0 = ((1.5f64 - 1.0) / 2.5).powi(2);
        assert!((dielectric(1.0, 1.5) - f0).abs() < 1e-12);
        assert!((dielectric(1.0, 1.0 / 1.5) - f0).abs() < 1e-12);
        assert_eq!(dielectric(0.1, 1.0 / 1.5), 1.0);
        assert_eq!(dielectric(0.0, 1.5), 1.0);
        assert!(dielectric(0.7, 1.0).abs() < 1e-15);
    }

    #[test]
    fn conductor_reduces_to_dielectric_without_absorption() {
        for c in [0.05, 0.3, 0.8, 1.0] {
            let a = conductor_channel(c, 1.5, 0.0);
            let b = dielectric(c, 1.5);
            assert!((a - b).abs() < 1e-12, "{a} {b}");
        }
        let f0 = ((0.2f64 - 1.0).powi(2) + 9.0) / ((0.2f64 + 1.0).powi(2) + 9.0);
        assert!((conductor_channel(1.0, 0.2, 3.0) - f0).abs() < 1e-12);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = DVec3::Z;
        let wi = DVec3::new(0.6, 0.0, 0.8);
        let wt = refract(wi, n, 1.5).expect("no TIR entering");
        assert!((wt.length() - 1.0).abs() < 1e-12);
        assert!((0.6 - 1.5 * (1.0 - wt.z * wt.z).sqrt()).abs() < 1e-12);
        assert!(wt.z < 0.0);
        assert!(
            refract(
                DVec3::new(0.9, 0.0, 0.1f64.sqrt() * 1.378).normalize(),
                n,
                1.0 / 1.5
            )
            .is_none()
        );
    }
}
