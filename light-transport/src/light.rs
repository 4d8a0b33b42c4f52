//! Lights as path endpoints: diffuse area lights on triangles and spheres (uniform area sampling)
//! and point lights; a light is chosen in proportion to its power. (A uniform infinite environment
//! is turned into an enclosing inward-emitting sphere by the scene, which is exact.)
//! Every sampling routine has its density and its exact inverse.
//!
//! Emission sampling (light subpaths) reads the light block of the sample layout: choice (1),
//! position (2), direction (2). Area lights emit cosine-distributed directions about the normal; a
//! two-sided light uses the first direction number to choose the side (front for `u < 1/2`) and
//! rescales it.

use crate::accel::{Bvh, Primitive};
use crate::geometry::Triangle;
use crate::geometry::{NO_PRIMITIVE, SurfacePoint};
use crate::math::{DVec3, Frame, clamp_unit};
use crate::spectrum::Rgb;
use std::f64::consts::PI;

/// What a light is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// A diffuse emitter on scene primitive `primitive`.
    Area {
        /// Index of the primitive in the scene.
        primitive: u32,
        /// Emitted radiance.
        radiance: Rgb,
        /// Emits on both sides.
        two_sided: bool,
        /// Surface area.
        area: f64,
    },
    /// An isotropic point light.
    Point {
        /// Position.
        position: DVec3,
        /// Radiant intensity.
        intensity: Rgb,
    },
}

/// A sampled emission: the first vertex of a light subpath and the direction leaving it.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// The point (for an infinite light: on a disk outside the scene).
    pub point: SurfacePoint,
    /// Direction of the emitted ray.
    pub w: DVec3,
    /// Emitted radiance (intensity for a point light) along `w`.
    pub le: Rgb,
    /// Density of the position (area measure; 1 for a point light).
    pub pdf_pos: f64,
    /// Density of the direction (solid angle).
    pub pdf_dir: f64,
    /// Whether the position is a delta (point light).
    pub delta_pos: bool,
}

impl LightKind {
    /// Emitted power (for light selection), from the primitive's geometry where needed.
    pub fn power(&self) -> f64 {
        match *self {
            LightKind::Area {
                radiance,
                two_sided,
                area,
                ..
            } => radiance.average() * area * PI * if two_sided { 2.0 } else { 1.0 },
            LightKind::Point { intensity, .. } => 4.0 * PI * intensity.average(),
        }
    }

    /// Whether the light is a point (no surface: paths cannot hit it).
    pub fn is_delta_position(&self) -> bool {
        matches!(self, LightKind::Point { .. })
    }

    /// Radiance leaving an area light at a point with normal `n` in direction `w`.
    pub fn radiance(&self, n: DVec3, w: DVec3) -> Rgb {
        match *self {
            LightKind::Area {
                radiance,
                two_sided,
                ..
            } => {
                let c = n.dot(w);
                if c > 0.0 || (two_sided && c < 0.0) {
                    radiance
                } else {
                    Rgb::BLACK
                }
            }
            LightKind::Point { .. } => Rgb::BLACK,
        }
    }

    /// Sample a point uniformly on the light (area measure), as for next-event estimation. A
    /// triangle's normal and tangent come from the BVH's per-thread cache ([`Bvh::frame`]).
    pub fn sample_point(&self, bvh: &Bvh, u: [f64; 2]) -> Option<(SurfacePoint, f64)> {
        match *self {
            LightKind::Area {
                primitive, area, ..
            } => {
                let p = match bvh.primitives.get(primitive as usize)? {
                    Primitive::Triangle(t) => {
                        let (b1, b2) = Triangle::sample_barycentrics(u);
                        t.point_framed(b1, b2, primitive, None, &bvh.frame(t, primitive))
                    }
                    Primitive::Sphere(s) => s.sample(u, primitive),
                };
                Some((p, 1.0 / area))
            }
            LightKind::Point { position, .. } => {
                Some((SurfacePoint::flat(position, DVec3::Z, NO_PRIMITIVE), 1.0))
            }
        }
    }

    /// Position and normal of [`LightKind::sample_point`]'s point, with its density: what
    /// next-event estimation needs, without the point's texture coordinates and derivatives.
    pub fn sample_position(&self, bvh: &Bvh, u: [f64; 2]) -> Option<(DVec3, DVec3, f64)> {
        match *self {
            LightKind::Area {
                primitive, area, ..
            } => {
                let (p, n) = match bvh.primitives.get(primitive as usize)? {
                    Primitive::Triangle(t) => {
                        let (b1, b2) = Triangle::sample_barycentrics(u);
                        (t.at(b1, b2), bvh.frame(t, primitive).n)
                    }
                    Primitive::Sphere(s) => s.sample_position(u),
                };
                Some((p, n, 1.0 / area))
            }
            LightKind::Point { position, .. } => Some((position, DVec3::Z, 1.0)),
        }
    }

    /// Sample an emitted ray from the position numbers `u_pos` and direction numbers `u_dir`.
    pub fn sample_emission(
        &self,
        bvh: &Bvh,
        u_pos: [f64; 2],
        u_dir: [f64; 2],
    ) -> Option<EmissionSample> {
        match *self {
            LightKind::Area { .. } => {
                let (point, pdf_pos) = self.sample_point(bvh, u_pos)?;
                let (w, pdf_dir) = self.sample_direction(point.n, u_dir)?;
                Some(EmissionSample {
                    point,
                    w,
                    le: self.radiance(point.n, w),
                    pdf_pos,
                    pdf_dir,
                    delta_pos: false,
                })
            }
            LightKind::Point {
                position,
                intensity,
            } => {
                let (w, pdf_dir) = self.sample_direction(DVec3::Z, u_dir)?;
                let point = SurfacePoint::flat(position, w, NO_PRIMITIVE);
                Some(EmissionSample {
                    point,
                    w,
                    le: intensity,
                    pdf_pos: 1.0,
                    pdf_dir,
                    delta_pos: true,
                })
            }
        }
    }

    /// Sample the direction of emission from a point of the light with normal `n` (ignored for a
    /// point light) from the direction numbers `u_dir`: `(w, density in solid angle)`.
    pub fn sample_direction(&self, n: DVec3, u_dir: [f64; 2]) -> Option<(DVec3, f64)> {
        match *self {
            LightKind::Area { two_sided, .. } => {
                let (front, v) = if two_sided {
                    if u_dir[0] < 0.5 {
                        (true, 2.0 * u_dir[0])
                    } else {
                        (false, 2.0 * u_dir[0] - 1.0)
                    }
                } else {
                    (true, u_dir[0])
                };
                let local = cosine_hemisphere([v, u_dir[1]]);
                let side = if front { n } else { -n };
                let w = Frame::from_normal(side).to_world(local);
                let pdf = local.z / PI * if two_sided { 0.5 } else { 1.0 };
                (pdf > 0.0).then_some((w, pdf))
            }
            LightKind::Point { .. } => Some((uniform_sphere(u_dir), 1.0 / (4.0 * PI))),
        }
    }

    /// Density of emitting direction `w` from a point with normal `n` (solid angle).
    pub fn pdf_direction(&self, n: DVec3, w: DVec3) -> f64 {
        match *self {
            LightKind::Area { two_sided, .. } => {
                let c = n.dot(w);
                if two_sided {
                    c.abs() / PI * 0.5
                } else if c > 0.0 {
                    c / PI
                } else {
                    0.0
                }
            }
            LightKind::Point { .. } => 1.0 / (4.0 * PI),
        }
    }

    /// Density of the emission position (area measure).
    pub fn pdf_position(&self) -> f64 {
        match *self {
            LightKind::Area { area, .. } => 1.0 / area,
            LightKind::Point { .. } => 1.0,
        }
    }

    /// The position and direction numbers that [`LightKind::sample_emission`] maps to the emission
    /// from surface point `p` (normal `n`) in direction `w`; numbers the light does not use are
    /// taken from `free`. `None` when the light cannot emit so.
    pub fn invert_emission(
        &self,
        prims: &[Primitive],
        p: DVec3,
        w: DVec3,
        free: [f64; 4],
    ) -> Option<([f64; 2], [f64; 2])> {
        match *self {
            LightKind::Area {
                primitive,
                two_sided,
                ..
            } => {
                let (u_pos, n) = match prims.get(primitive as usize)? {
                    Primitive::Triangle(t) => {
                        let (b1, b2) = t.barycentrics(p);
                        (t.invert(b1, b2), t.normal())
                    }
                    Primitive::Sphere(s) => (s.invert(p), s.point(p, primitive).n),
                };
                let c = n.dot(w);
                if c == 0.0 || (!two_sided && c < 0.0) {
                    return None;
                }
                let side_n = if c > 0.0 { n } else { -n };
                let local = Frame::from_normal(side_n).to_local(w);
                let [v, u1] = invert_cosine_hemisphere(local);
                let u0 = if two_sided {
                    if c > 0.0 { v / 2.0 } else { 0.5 + v / 2.0 }
                } else {
                    v
                };
                Some((u_pos, [clamp_unit(u0), u1]))
            }
            LightKind::Point { .. } => Some(([free[0], free[1]], invert_uniform_sphere(w))),
        }
    }
}

/// Cosine-weighted hemisphere about `+z`: `φ = 2π u0`, `cos θ = √u1` (the charted-MLT paper's
/// Lambert mapping, eq. 31).
pub fn cosine_hemisphere(u: [f64; 2]) -> DVec3 {
    let (cos_p, sin_p) = crate::math::turn(u[0]);
    let cos = u[1].sqrt();
    let sin = (1.0 - u[1]).max(0.0).sqrt();
    DVec3::new(sin * cos_p, sin * sin_p, cos)
}

/// Inverse of [`cosine_hemisphere`] (eq. 32).
pub fn invert_cosine_hemisphere(w: DVec3) -> [f64; 2] {
    [
        clamp_unit(crate::math::phi(w) / (2.0 * PI)),
        clamp_unit(w.z * w.z),
    ]
}

/// Uniform direction on the sphere: `z = 1 − 2 u0`, `φ = 2π u1`.
pub fn uniform_sphere(u: [f64; 2]) -> DVec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (cos_p, sin_p) = crate::math::turn(u[1]);
    DVec3::new(r * cos_p, r * sin_p, z)
}

/// Inverse of [`uniform_sphere`].
pub fn invert_uniform_sphere(w: DVec3) -> [f64; 2] {
    [
        clamp_unit((1.0 - w.z) / 2.0),
        clamp_unit(crate::math::phi(w) / (2.0 * PI)),
    ]
}

/// Choice of a light in proportion to power: a discrete distribution with its CDF, so the choice
/// number's interval for light `i` is `[cdf[i], cdf[i+1])`.
#[derive(Clone, Debug, Default)]
pub struct LightDistribution {
    cdf: Vec<f64>,
}

impl LightDistribution {
    /// From non-negative weights (powers).
    pub fn new(weights: &[f64]) -> Self {
        let total: f64 = weights.iter().sum();
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0);
        let mut acc = 0.0;
        for w in weights {
            acc += w / total;
            cdf.push(acc);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self { cdf }
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.cdf.len().saturating_sub(1)
    }

    /// Whether there are no lights.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Choose a light with the number `u`; returns the index and its probability.
    pub fn sample(&self, u: f64) -> Option<(usize, f64)> {
        if self.is_empty() {
            return None;
        }
        let i = (self.cdf.partition_point(|&c| c <= u) - 1).min(self.len() - 1);
        Some((i, self.pdf(i)))
    }

    /// Probability of light `i`.
    pub fn pdf(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A uniform number in light `i`'s interval (the exact inverse of the choice).
    pub fn invert(&self, i: usize, v: f64) -> f64 {
        clamp_unit(self.cdf[i] + v * self.pdf(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{NO_SHADING, Sphere};

    /// Next-event estimation's `sample_position` is `sample_point`'s position, normal and density,
    /// bit for bit, on triangles and spheres facing either way and on point lights.
    #[test]
    fn sample_position_is_sample_points() {
        let bvh = Bvh::new(vec![
            Primitive::Triangle(Triangle {
                p: [
                    DVec3::new(0.1, 0.2, 0.3),
                    DVec3::new(1.7, -0.4, 0.2),
                    DVec3::Y,
                ],
                uv: [[0.0; 2], [0.3, 0.9], [0.7, 0.1]],
                flip: false,
                shading: NO_SHADING,
            }),
            Primitive::Triangle(Triangle {
                p: [DVec3::ZERO, DVec3::X, DVec3::new(0.2, 0.9, -0.4)],
                uv: [[0.0; 2]; 3],
                flip: true,
                shading: NO_SHADING,
            }),
            Primitive::Sphere(Sphere {
                center: DVec3::new(3.0, -1.0, 0.5),
                radius: 0.7,
                flip: false,
            }),
            Primitive::Sphere(Sphere {
                center: DVec3::new(-2.0, 0.0, 1.0),
                radius: 1.3,
                flip: true,
            }),
        ]);
        let mut lights: Vec<LightKind> = (0..bvh.primitives.len() as u32)
            .map(|primitive| LightKind::Area {
                primitive,
                radiance: Rgb::WHITE,
                two_sided: false,
                area: 0.25 + f64::from(primitive),
            })
            .collect();
        lights.push(LightKind::Point {
            position: DVec3::new(0.5, 2.0, -1.0),
            intensity: Rgb::WHITE,
        });
        let mut rng = mcmc_core::rng::stream(5, 0);
        for light in &lights {
            for _ in 0..1000 {
                let u = [
                    mcmc_core::rng::uniform(&mut rng),
                    mcmc_core::rng::uniform(&mut rng),
                ];
                let (point, pdf) = light.sample_point(&bvh, u).expect("a point");
                let (p, n, pdf_p) = light.sample_position(&bvh, u).expect("a position");
                if let LightKind::Area { primitive, .. } = *light {
                    let own = match bvh.primitives[primitive as usize] {
                        Primitive::Triangle(t) => t.sample(u, primitive),
                        Primitive::Sphere(s) => s.sample(u, primitive),
                    };
                    assert_eq!(point, own);
                }
                let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                assert_eq!((bits(p), bits(n)), (bits(point.p), bits(point.n)));
                assert_eq!(pdf.to_bits(), pdf_p.to_bits());
            }
        }
    }

    #[test]
    fn emission_inverts() {
        let bvh = Bvh::new(vec![
            Primitive::Triangle(Triangle {
                p: [DVec3::ZERO, DVec3::X, DVec3::Y],
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            }),
            Primitive::Sphere(Sphere {
                center: DVec3::new(3.0, 0.0, 0.0),
                radius: 0.5,
                flip: false,
            }),
        ]);
        let triangle = bvh
            .primitives
            .iter()
            .position(|p| matches!(p, Primitive::Triangle(_)))
            .expect("a triangle") as u32;
        let sphere = 1 - triangle;
        let lights = [
            LightKind::Area {
                primitive: triangle,
                radiance: Rgb::WHITE,
                two_sided: false,
                area: 0.5,
            },
            LightKind::Area {
                primitive: triangle,
                radiance: Rgb::WHITE,
                two_sided: true,
                area: 0.5,
            },
            LightKind::Area {
                primitive: sphere,
                radiance: Rgb::WHITE,
                two_sided: false,
                area: PI,
            },
            LightKind::Point {
                position: DVec3::ONE,
                intensity: Rgb::WHITE,
            },
        ];
        for l in lights {
            for (up, ud) in [([0.2, 0.7], [0.3, 0.6]), ([0.9, 0.1], [0.8, 0.25])] {
                let e = l.sample_emission(&bvh, up, ud).unwrap();
                let (p2, d2) = l
                    .invert_emission(&bvh.primitives, e.point.p, e.w, [up[0], up[1], 0.0, 0.0])
                    .unwrap();
                for (a, b) in up.iter().chain(&ud).zip(p2.iter().chain(&d2)) {
                    assert!(
                        (a - b).abs() < 1e-9,
                        "{l:?}: {up:?} {ud:?} -> {p2:?} {d2:?}"
                    );
                }
                assert!(
                    (e.pdf_dir - l.pdf_direction(e.point.n, e.w)).abs() < 1e-12
                        || l.is_delta_position()
                );
            }
        }
    }

    #[test]
    fn light_choice_inverts() {
        let d = LightDistribution::new(&[1.0, 3.0, 0.0, 4.0]);
        assert_eq!(d.sample(0.2), Some((1, 3.0 / 8.0)));
        assert_eq!(d.sample(0.9).map(|s| s.0), Some(3));
        for i in [0, 1, 3] {
            for v in [0.0, 0.5, 0.999] {
                assert_eq!(d.sample(d.invert(i, v)).map(|s| s.0), Some(i));
            }
        }
    }
}
