//! Vectors (glam `DVec3`), orthonormal frames and spherical helpers.

pub use glam::{DMat4, DVec2, DVec3};

/// An orthonormal frame `(s, t, n)`; local coordinates have the normal along `+z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: DVec3,
    /// Second tangent.
    pub t: DVec3,
    /// Normal.
    pub n: DVec3,
}

impl Frame {
    /// A frame around the unit normal `n` (Duff et al. 2017, branchless and continuous almost
    /// everywhere).
    pub fn from_normal(n: DVec3) -> Self {
        let sign = 1f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = DVec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// A frame with normal `n` and first tangent along the projection of `dpdu` (for anisotropy).
    pub fn from_normal_tangent(n: DVec3, dpdu: DVec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        if s.length_squared() < 1e-20 {
            return Self::from_normal(n);
        }
        let s = s.normalize();
        Self {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World → local.
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// `cos θ` of a local direction.
#[inline]
pub fn cos_theta(w: DVec3) -> f64 {
    w.z
}

/// The direction of spherical angles `(θ, φ)` in local coordinates.
#[inline]
pub fn spherical_direction(sin_theta: f64, cos_theta: f64, phi: f64) -> DVec3 {
    DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// `(cos 2πu, sin 2πu)`: the azimuth of a sampled direction, from its number `u` (a fraction of
/// a turn). Sampling reads it once or twice per vertex, and libm's `sincos` of `2πu` costs about
/// 130 instructions; this reduces `u` exactly to the nearest quarter turn (`4u − k`, exact by
/// Sterbenz's lemma) and evaluates the Taylor series of `sin` and `cos` on the remaining
/// `|θ| ≤ π/4` (terms to the 17th power, whose remainder is below 1e-17), within a few units in the
/// last place of libm's values. Quarter turns come out exact (`turn(0.25) = (0, 1)`). Numbers
/// beyond `|u| ≥ 2⁴⁸` fall back to libm.
#[inline]
pub fn turn(u: f64) -> (f64, f64) {
    // Adding and subtracting 1.5·2⁵² rounds to the nearest integer (ties to even) for |x| < 2⁵¹.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let x = 4.0 * u;
    if !(u.abs() < (1u64 << 48) as f64) {
        let (s, c) = (std::f64::consts::TAU * u).sin_cos();
        return (c, s);
    }
    let k = (x + ROUND) - ROUND;
    let t = (x - k) * std::f64::consts::FRAC_PI_2;
    let t2 = t * t;
    // sin t = t (1 − t²/3! + t⁴/5! − …), cos t = 1 − t²/2! + t⁴/4! − …, Horner in t².
    const S: [f64; 8] = [
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5_040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    const C: [f64; 8] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
    ];
    let horner = |c: &[f64; 8]| c.iter().rev().fold(0.0, |acc, &ci| acc * t2 + ci);
    let sin = t + t * t2 * horner(&S);
    let cos = 1.0 + t2 * horner(&C);
    match (k as i64) & 3 {
        0 => (cos, sin),
        1 => (-sin, cos),
        2 => (-cos, -sin),
        _ => (sin, -cos),
    }
}

/// `φ ∈ [0, 2π)` of a local direction.
#[inline]
pub fn phi(w: DVec3) -> f64 {
    let p = w.y.atan2(w.x);
    if p < 0.0 {
        p + 2.0 * std::f64::consts::PI
    } else {
        p
    }
}

/// Clamp a number to `[0, 1)` (the primary-sample-space interval) after rounding.
#[inline]
pub fn clamp_unit(v: f64) -> f64 {
    v.clamp(0.0, 1.0 - f64::EPSILON / 2.0)
}

/// Mirror `w` about `n`.
#[inline]
pub fn reflect(w: DVec3, n: DVec3) -> DVec3 {
    -w + n * (2.0 * w.dot(n))
}

/// How far from 1 the squared length of a vector may lie for [`renormalize`] to take its Newton
/// step: there the step's error, `(3/8)(x − 1)²` for `x` the squared length, is below
/// `4 · 10⁻¹⁷`, a third of half an ulp of 1 (`2⁻⁵³`).
const NEAR_UNIT: f64 = 1e-8;

/// The unit vector along `v`; `None` for a zero or non-finite `v`.
///
/// A `v` already of unit length up to rounding (a unit direction brought into an orthonormal
/// frame, [`Frame::to_local`]) is scaled by one Newton step of `1/√x` from `x = 1`, `1.5 − x/2`,
/// accurate to below half an ulp there: as accurate as dividing by `√x`, without the square root
/// and the division, whose latency every BSDF evaluation waited on twice (docs/performance.md: BDPT 1.041×
/// faster side by side). Any other `v` is divided by its length.
#[inline]
pub fn renormalize(v: DVec3) -> Option<DVec3> {
    renormalize_within(v, NEAR_UNIT)
}

/// [`renormalize`] with the Newton step taken where `|x − 1| < near` (the tests try a bound too
/// wide).
#[inline(always)]
fn renormalize_within(v: DVec3, near: f64) -> Option<DVec3> {
    let len2 = v.length_squared();
    if (len2 - 1.0).abs() < near {
        return Some(v * (1.5 - 0.5 * len2));
    }
    (len2 > 0.0 && len2.is_finite()).then(|| v / len2.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `turn` agrees with libm's `sin_cos` of `2πu` to 3e-16 over a million numbers in `[0, 1)`,
    /// at the ends and the quarter turns (exact there), and beyond the unit interval; and
    /// `cos² + sin² = 1` to the same order.
    #[test]
    fn turn_is_libms_sine_and_cosine_of_a_fraction_of_a_turn() {
        let mut rng = mcmc_core::rng::stream(12, 0);
        let specials = [
            0.0,
            0.125,
            0.25,
            0.375,
            0.5,
            0.625,
            0.75,
            0.875,
            1.0 - f64::EPSILON / 2.0,
        ];
        let randoms = (0..1_000_000).map(|_| mcmc_core::rng::uniform(&mut rng));
        let beyond = [-0.3, -1.7, 3.2, 1e6 + 0.1, 3e14];
        let mut worst = 0.0f64;
        for u in specials.into_iter().chain(randoms).chain(beyond) {
            let (c, s) = turn(u);
            let (ls, lc) = (std::f64::consts::TAU * u).sin_cos();
            // libm's argument `2πu` is itself rounded: allow for that beyond the unit interval.
            let slack = (std::f64::consts::TAU * u).abs() * f64::EPSILON;
            worst = worst.max(((c - lc).abs().max((s - ls).abs()) - slack).max(0.0));
            let norm = (c * c + s * s - 1.0).abs();
            let libm_norm = (lc * lc + ls * ls - 1.0).abs();
            assert!(
                norm <= 4.5e-16,
                "u = {u}: {c}² + {s}² (libm's {libm_norm:e} off)"
            );
        }
        println!("largest difference from libm: {worst:e}");
        assert!(worst < 3e-16, "largest difference from libm {worst:e}");
        assert_eq!(turn(0.0), (1.0, 0.0));
        assert_eq!(turn(0.25), (-0.0, 1.0));
        assert_eq!(turn(0.5), (-1.0, -0.0));
        assert_eq!(turn(0.75), (0.0, -1.0));
    }

    /// `renormalize` agrees with dividing by the length to two ulps and returns unit vectors to
    /// two ulps, for unit directions brought into random frames (the Newton step) and for
    /// vectors of length `1 ± 10⁻⁹ … 10⁻³` and far from 1 (both sides of its bound); zero and
    /// non-finite vectors give `None`. A bound of `10⁻³` in place of `10⁻⁸` fails it.
    #[test]
    fn renormalize_is_as_accurate_as_a_division() {
        let worst = |near: f64| {
            let mut rng = mcmc_core::rng::stream(31, 0);
            let mut u = || mcmc_core::rng::uniform(&mut rng) * 2.0 - 1.0;
            let mut worst = 0.0f64;
            for k in 0..200_000 {
                let dir = DVec3::new(u(), u(), u()).normalize();
                let frame = Frame::from_normal(DVec3::new(u(), u(), u()).normalize());
                let v = match k % 4 {
                    0 => frame.to_local(dir),
                    1 => dir * (1.0 + u() * 10f64.powf(-3.0 - 6.0 * u().abs())),
                    2 => dir * (1.0 + 2.0 * u().abs()) * 10f64.powf(3.0 * u()),
                    _ => frame.to_local(dir) * (1.0 + 1e-8 * u()),
                };
                let r = renormalize_within(v, near).expect("a finite non-zero vector");
                let exact = v / v.length();
                let ulps = ((r - exact).abs().max_element() / f64::EPSILON)
                    .max((r.length() - 1.0).abs() / f64::EPSILON);
                worst = worst.max(ulps);
            }
            worst
        };
        let w = worst(NEAR_UNIT);
        println!("largest difference from a division: {w} ulps");
        assert!(w <= 2.0, "{w} ulps from a division");
        assert!(worst(1e-3) > 2.0, "a bound of 1e-3 went unnoticed");
        assert_eq!(renormalize(DVec3::ZERO), None);
        assert_eq!(renormalize(DVec3::new(f64::NAN, 0.0, 1.0)), None);
        assert_eq!(renormalize(DVec3::new(f64::INFINITY, 0.0, 0.0)), None);
        assert_eq!(renormalize(DVec3::Z), Some(DVec3::Z));
    }

    #[test]
    fn frames_are_orthonormal_for_every_normal() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(0.3, -0.5, 0.8).normalize(),
            DVec3::new(1e-9, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-12 && (f.t.length() - 1.0).abs() < 1e-12);
            assert!(
                f.s.dot(f.t).abs() < 1e-12 && f.s.dot(n).abs() < 1e-12 && f.t.dot(n).abs() < 1e-12
            );
            let v = DVec3::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-12);
            assert!((f.s.cross(f.t) - n).length() < 1e-12, "right-handed");
        }
    }
}
