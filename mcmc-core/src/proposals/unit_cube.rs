//! Random walks on the unit cube `[0,1)^n` with wrap-around: the primary-sample-space small steps of
//! Kelemen et al. 2002 (exponential offsets between `s1` and `s2`) and a wrapped Gaussian. Both are
//! symmetric, so they report a zero log ratio.
//!
//! Exponential small step, per coordinate: `y = x ± s2 · exp(−ln(s2/s1) · ξ)` (mod 1), `ξ ~ U[0,1)`,
//! sign uniform. The offset magnitude `d ∈ (s1, s2]` has density `1 / (d ln(s2/s1))`.

use crate::error::{check_positive, check_probability};
use crate::{ChainRng, McmcError, Proposal, Proposed, rng::uniform};
use rand::RngExt;
use rand_distr::StandardNormal;

/// The per-coordinate offset law of a [`CubeWalk`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SmallStep {
    /// Kelemen's exponential offsets with magnitudes between `s1` and `s2` (defaults 1/1024, 1/64).
    Exponential {
        /// Smallest offset.
        s1: f64,
        /// Largest offset (at most 1/2).
        s2: f64,
    },
    /// Wrapped Gaussian offsets with standard deviation `sigma` (default 0.01).
    Gaussian {
        /// Standard deviation.
        sigma: f64,
    },
}

impl Default for SmallStep {
    fn default() -> Self {
        SmallStep::Exponential {
            s1: 1.0 / 1024.0,
            s2: 1.0 / 64.0,
        }
    }
}

impl SmallStep {
    /// Check the parameters.
    pub fn validate(&self) -> Result<(), McmcError> {
        match *self {
            SmallStep::Exponential { s1, s2 } => {
                check_positive("s1", s1)?;
                check_positive("s2", s2)?;
                if !(s1 < s2 && s2 <= 0.5) {
                    return Err(McmcError::InvalidParameter {
                        name: "s2",
                        reason: format!("need 0 < s1 < s2 <= 1/2, got s1 = {s1}, s2 = {s2}"),
                    });
                }
                Ok(())
            }
            SmallStep::Gaussian { sigma } => check_positive("sigma", sigma),
        }
    }

    /// Perturb one coordinate in `[0,1)`.
    #[inline]
    pub fn perturb<R: rand::Rng + ?Sized>(&self, u: f64, rng: &mut R) -> f64 {
        PreparedStep::new(*self).perturb(u, rng)
    }

    /// Log density of moving one coordinate from `a` to `b` (on the circle `[0,1)`).
    pub fn ln_density(&self, a: f64, b: f64) -> f64 {
        let mut d = b - a;
        d -= d.round(); // signed offset in [-1/2, 1/2]
        match *self {
            SmallStep::Exponential { s1, s2 } => {
                let m = d.abs();
                // Rounding in the wrap can move m by an ulp across s1 or s2; accept that band.
                let eps = 1e-12;
                if m + eps < s1 || m > s2 + eps {
                    f64::NEG_INFINITY
                } else {
                    -(2.0 * m * (s2 / s1).ln()).ln()
                }
            }
            SmallStep::Gaussian { sigma } => {
                let mut p = 0.0;
                let k = (6.0 * sigma).ceil() as i64 + 1;
                for j in -k..=k {
                    let z = (d + j as f64) / sigma;
                    p += (-0.5 * z * z).exp();
                }
                (p / (sigma * (2.0 * std::f64::consts::PI).sqrt())).ln()
            }
        }
    }
}

/// A [`SmallStep`] with its constant computed once: the exponential step's `ln(s2/s1)`, which
/// every perturbation needs (a chain of primary samples perturbs each coordinate it reads, so
/// the logarithm per coordinate was a few percent of a Metropolis render). Perturbs exactly as
/// [`SmallStep::perturb`] does, number for number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedStep {
    step: SmallStep,
    /// `ln(s2/s1)` of an exponential step (unused for the Gaussian one).
    ln_ratio: f64,
}

impl PreparedStep {
    /// `step`, prepared.
    pub fn new(step: SmallStep) -> Self {
        let ln_ratio = match step {
            SmallStep::Exponential { s1, s2 } => (s2 / s1).ln(),
            SmallStep::Gaussian { .. } => 0.0,
        };
        Self { step, ln_ratio }
    }

    /// The step.
    pub fn step(&self) -> SmallStep {
        self.step
    }

    /// Perturb one coordinate in `[0,1)` ([`SmallStep::perturb`]).
    #[inline]
    pub fn perturb<R: rand::Rng + ?Sized>(&self, u: f64, rng: &mut R) -> f64 {
        let d = match self.step {
            SmallStep::Exponential { s2, .. } => {
                let mag = s2 * (-self.ln_ratio * uniform(rng)).exp();
                if rand::Rng::next_u32(rng) & 1 == 0 {
                    mag
                } else {
                    -mag
                }
            }
            SmallStep::Gaussian { sigma } => {
                let e: f64 = rng.sample(StandardNormal);
                sigma * e
            }
        };
        wrap(u + d)
    }
}

/// Wrap a real number into `[0, 1)`.
///
/// A step from `[0, 1)` lands in `[−1, 2)`, where the wrap is one addition, the number
/// `v − ⌊v⌋` gives, bit for bit (`v + 0.0` turns `−0` into the `+0` of `−0 − ⌊−0⌋`): `floor` is a
/// library call on baseline x86-64 (no SSE4.1), and a chain wraps every coordinate it perturbs.
#[inline]
pub fn wrap(v: f64) -> f64 {
    let w = if (0.0..1.0).contains(&v) {
        v + 0.0
    } else if (-1.0..0.0).contains(&v) {
        v + 1.0
    } else if (1.0..2.0).contains(&v) {
        v - 1.0
    } else {
        v - v.floor()
    };
    if w >= 1.0 { 0.0 } else { w }
}

/// A symmetric random walk on `[0,1)^n` perturbing every coordinate (or, with
/// [`CubeWalk::with_coordinate_probability`], each coordinate independently with probability `c`).
#[derive(Clone, Debug)]
pub struct CubeWalk {
    step: SmallStep,
    coordinate_probability: f64,
}

impl CubeWalk {
    /// Perturb every coordinate with `step`.
    pub fn new(step: SmallStep) -> Result<Self, McmcError> {
        step.validate()?;
        Ok(Self {
            step,
            coordinate_probability: 1.0,
        })
    }

    /// Perturb each coordinate independently with probability `c` (still symmetric).
    pub fn with_coordinate_probability(mut self, c: f64) -> Result<Self, McmcError> {
        check_probability("coordinate_probability", c)?;
        self.coordinate_probability = c;
        Ok(self)
    }

    /// The offset law.
    pub fn step(&self) -> SmallStep {
        self.step
    }
}

impl<S: AsRef<[f64]> + AsMut<[f64]>> Proposal<S> for CubeWalk {
    #[inline]
    fn propose(&self, x: &S, y: &mut S, rng: &mut ChainRng) -> Proposed {
        let (x, y) = (x.as_ref(), y.as_mut());
        let step = PreparedStep::new(self.step);
        for (yi, &xi) in y.iter_mut().zip(x) {
            *yi = if self.coordinate_probability >= 1.0
                || uniform(rng) < self.coordinate_probability
            {
                step.perturb(xi, rng)
            } else {
                xi
            };
        }
        Proposed::SYMMETRIC
    }

    fn ln_transition_density(&self, from: &S, to: &S) -> Option<f64> {
        if self.coordinate_probability < 1.0 {
            // A mixed discrete/continuous law: only the all-coordinates case has a plain density.
            return None;
        }
        Some(
            from.as_ref()
                .iter()
                .zip(to.as_ref())
                .map(|(&a, &b)| self.step.ln_density(a, b))
                .sum(),
        )
    }

    fn kinds(&self) -> Vec<String> {
        vec![
            match self.step {
                SmallStep::Exponential { .. } => "small_step_exponential",
                SmallStep::Gaussian { .. } => "small_step_gaussian",
            }
            .into(),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;

    /// A prepared exponential step is Kelemen's offset `± s2 · exp(−ln(s2/s1) · ξ)` with `ξ`
    /// and the sign drawn in that order, for the step it was prepared from (a constant cached
    /// for another step would give other offsets).
    #[test]
    fn a_prepared_step_is_kelemens_offset() {
        for (s1, s2) in [(1.0 / 1024.0, 1.0 / 64.0), (0.01, 0.3), (1e-6, 0.5)] {
            let step = SmallStep::Exponential { s1, s2 };
            let prepared = PreparedStep::new(step);
            assert_eq!(prepared.step(), step);
            let mut rng = stream(4, 1);
            for _ in 0..200 {
                let u = uniform(&mut rng);
                let mut draw = rng.clone();
                let xi = uniform(&mut draw);
                let negative = rand::Rng::next_u32(&mut draw) & 1 == 1;
                let mag = s2 * (-(s2 / s1).ln() * xi).exp();
                let expected = wrap(if negative { u - mag } else { u + mag });
                assert_eq!(prepared.perturb(u, &mut rng), expected, "s1 {s1}, s2 {s2}");
                assert_eq!(rng, draw, "the same numbers consumed");
            }
        }
    }

    /// The wrap without `floor` is `v − ⌊v⌋` (then `1 → 0`) bit for bit: random numbers over
    /// `[−3, 4)`, every boundary of its cases and their neighbours, signed zeros, infinities
    /// and NaN. Fails when `v + 0.0` is written `v` (−0 stays −0) or a boundary is put on the
    /// wrong side.
    #[test]
    fn wrap_is_the_floor_formula_bit_for_bit() {
        let reference = |v: f64| {
            let w = v - v.floor();
            if w >= 1.0 { 0.0 } else { w }
        };
        let mut rng = stream(17, 0);
        let mut cases: Vec<f64> = (0..200_000)
            .map(|_| uniform(&mut rng) * 7.0 - 3.0)
            .collect();
        for b in [-2.0f64, -1.0, 0.0, 1.0, 2.0, 3.0] {
            cases.extend([b, b.next_up(), b.next_down(), -b]);
        }
        cases.extend([
            -0.0,
            1e-300,
            -1e-300,
            -1e-17,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ]);
        for v in cases {
            assert_eq!(wrap(v).to_bits(), reference(v).to_bits(), "{v:e}");
        }
        assert!(wrap(f64::NAN).is_nan());
    }

    #[test]
    fn wrap_stays_in_unit_interval() {
        for v in [-1e-17, -0.5, 0.0, 0.999_999_999_999_999_9, 1.0, 3.25, -2.75] {
            let w = wrap(v);
            assert!((0.0..1.0).contains(&w), "{v} -> {w}");
        }
    }

    #[test]
    fn exponential_offsets_lie_between_s1_and_s2() {
        let step = SmallStep::default();
        let mut rng = stream(3, 0);
        for _ in 0..10_000 {
            let u = uniform(&mut rng);
            let v = step.perturb(u, &mut rng);
            let mut d = v - u;
            d -= d.round();
            assert!(d.abs() >= 1.0 / 1024.0 - 1e-12 && d.abs() <= 1.0 / 64.0 + 1e-12);
            assert!(step.ln_density(u, v).is_finite());
        }
    }

    #[test]
    fn densities_integrate_to_one() {
        for step in [
            SmallStep::default(),
            SmallStep::Gaussian { sigma: 0.05 },
            SmallStep::Gaussian { sigma: 0.4 },
        ] {
            let n = 400_000;
            let total: f64 = (0..n)
                .map(|i| step.ln_density(0.3, (i as f64 + 0.5) / n as f64).exp() / n as f64)
                .sum();
            assert!((total - 1.0).abs() < 2e-3, "{step:?}: {total}");
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        assert!(CubeWalk::new(SmallStep::Exponential { s1: 0.1, s2: 0.01 }).is_err());
        assert!(CubeWalk::new(SmallStep::Exponential { s1: 0.1, s2: 0.6 }).is_err());
        assert!(CubeWalk::new(SmallStep::Gaussian { sigma: f64::NAN }).is_err());
    }
}
