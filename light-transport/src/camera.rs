//! The perspective camera (pinhole or thin lens) as a path endpoint: ray sampling from two film and
//! two lens numbers, its importance `W_e`, positional and directional densities, direct sampling
//! toward a scene point (light tracing, `t = 1` connections), and the exact inverse.
//!
//! Importance follows Veach (thesis §10.3.2) and pbrt-v3: with `A` the area of the image rectangle at
//! distance 1 and `A_lens` the lens area (1 for a pinhole),
//! `W_e(ω) = 1 / (A · A_lens · cos⁴θ)`, `p_pos = 1/A_lens`, `p_dir(ω) = 1 / (A cos³θ)`, so that the
//! measurement of the whole film is 1 and a pixel's value is `W·H` times its share.

use crate::geometry::{NO_PRIMITIVE, Ray};
use crate::math::{DMat4, DVec3};
use crate::scene::{CameraDesc, Projection};
use crate::{Error, Result};
use std::f64::consts::PI;

/// A perspective camera.
#[derive(Clone, Debug)]
pub struct Camera {
    to_world: DMat4,
    to_camera: DMat4,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Half-extent of the image rectangle at distance 1 along x and y.
    half: [f64; 2],
    /// Lens radius (0: pinhole).
    pub lens_radius: f64,
    /// Distance of the plane in focus.
    pub focal_distance: f64,
}

/// A sampled camera ray with the quantities a path vertex needs.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    /// The ray.
    pub ray: Ray,
    /// Importance `W_e` along the ray.
    pub we: f64,
    /// Density of the lens point (area measure).
    pub pdf_pos: f64,
    /// Density of the direction (solid angle).
    pub pdf_dir: f64,
}

/// Importance arriving at a scene point from a lens point.
#[derive(Clone, Copy, Debug)]
pub struct CameraConnection {
    /// The lens point.
    pub p: DVec3,
    /// Unit direction from the scene point to the lens point.
    pub wi: DVec3,
    /// Distance.
    pub dist: f64,
    /// Importance `W_e` of the ray from the lens point toward the scene point.
    pub we: f64,
    /// Solid-angle density at the scene point of choosing this lens point.
    pub pdf: f64,
    /// Raster position of the ray.
    pub raster: [f64; 2],
}

impl Camera {
    /// A camera from its description and image size.
    pub fn new(desc: &CameraDesc, width: usize, height: usize) -> Result<Self> {
        let Projection::Perspective {
            fov,
            lens_radius,
            focal_distance,
        } = desc.projection;
        if !(fov > 0.0 && fov < PI) {
            return Err(Error::InvalidParameter {
                name: "fov".into(),
                reason: format!("must be in (0°, 180°), got {}°", fov.to_degrees()),
            });
        }
        if !(lens_radius >= 0.0
            && lens_radius.is_finite()
            && focal_distance > 0.0
            && focal_distance.is_finite())
        {
            return Err(Error::InvalidParameter {
                name: "lensradius/focaldistance".into(),
                reason: format!(
                    "need lens radius ≥ 0 and focal distance > 0, got {lens_radius} and {focal_distance}"
                ),
            });
        }
        if width == 0 || height == 0 {
            return Err(Error::InvalidParameter {
                name: "resolution".into(),
                reason: "must be positive".into(),
            });
        }
        let det = desc.camera_to_world.determinant();
        if !(det.is_finite() && det.abs() > 1e-12) {
            return Err(Error::InvalidParameter {
                name: "camera transform".into(),
                reason: "is singular".into(),
            });
        }
        let t = (fov / 2.0).tan();
        let aspect = width as f64 / height as f64;
        let half = if aspect >= 1.0 {
            [t * aspect, t]
        } else {
            [t, t / aspect]
        };
        Ok(Self {
            to_world: desc.camera_to_world,
            to_camera: desc.camera_to_world.inverse(),
            width,
            height,
            half,
            lens_radius,
            focal_distance,
        })
    }

    /// Camera position (lens centre).
    pub fn position(&self) -> DVec3 {
        self.to_world.transform_point3(DVec3::ZERO)
    }

    /// Viewing direction.
    pub fn forward(&self) -> DVec3 {
        self.to_world.transform_vector3(DVec3::Z).normalize()
    }

    /// The surface point of a lens position `p` (normal: the viewing direction).
    pub fn lens_point(&self, p: DVec3) -> crate::geometry::SurfacePoint {
        crate::geometry::SurfacePoint::flat(p, self.forward(), NO_PRIMITIVE)
    }

    fn image_area(&self) -> f64 {
        4.0 * self.half[0] * self.half[1]
    }

    fn lens_area(&self) -> f64 {
        if self.lens_radius > 0.0 {
            PI * self.lens_radius * self.lens_radius
        } else {
            1.0
        }
    }

    /// Sample a ray: `film` in `[0,1)²` over the whole image (x right, y down), `lens` in `[0,1)²`.
    pub fn sample_ray(&self, film: [f64; 2], lens: [f64; 2]) -> CameraSample {
        let p_img = DVec3::new(
            (2.0 * film[0] - 1.0) * self.half[0],
            (1.0 - 2.0 * film[1]) * self.half[1],
            1.0,
        );
        let (o_cam, d_cam) = if self.lens_radius > 0.0 {
            let l = concentric_disk(lens).map(|v| v * self.lens_radius);
            let o = DVec3::new(l[0], l[1], 0.0);
            let focus = p_img * self.focal_distance;
            (o, (focus - o).normalize())
        } else {
            (DVec3::ZERO, p_img.normalize())
        };
        let o = self.to_world.transform_point3(o_cam);
        let d = self.to_world.transform_vector3(d_cam).normalize();
        let (we, pdf_dir, _) = self.importance_camera_space(o_cam, d_cam);
        CameraSample {
            ray: Ray::new(o, d),
            we,
            pdf_pos: 1.0 / self.lens_area(),
            pdf_dir,
        }
    }

    /// Film `[0,1)²` position of a sample in `pixel` (row-major index), `jitter` in `[0,1)²` inside
    /// the pixel.
    #[inline]
    pub fn film_position(&self, pixel: usize, jitter: [f64; 2]) -> [f64; 2] {
        let (w, h) = (self.width, self.height);
        let (x, y) = (pixel % w, pixel / w);
        [
            crate::math::clamp_unit((x as f64 + jitter[0]) / w as f64),
            crate::math::clamp_unit((y as f64 + jitter[1]) / h as f64),
        ]
    }

    /// The raster position (pixels from the left and top edges) of film position `film`.
    #[inline]
    pub fn raster_of_film(&self, film: [f64; 2]) -> [f64; 2] {
        [film[0] * self.width as f64, film[1] * self.height as f64]
    }

    /// Density of the lens point (area measure): `1 / A_lens` (1 for a pinhole).
    pub fn pdf_lens(&self) -> f64 {
        1.0 / self.lens_area()
    }

    /// The ray leaving the world lens point `lens` through raster position `raster` (pixels from the
    /// left and top edges), for mutations that keep the lens point and move the image position;
    /// `None` outside the image or for a point off the lens plane.
    pub fn ray_through(&self, lens: DVec3, raster: [f64; 2]) -> Option<CameraSample> {
        let (w, h) = (self.width as f64, self.height as f64);
        if !(raster[0] >= 0.0 && raster[0] < w && raster[1] >= 0.0 && raster[1] < h) {
            return None;
        }
        let p_img = DVec3::new(
            (2.0 * raster[0] / w - 1.0) * self.half[0],
            (1.0 - 2.0 * raster[1] / h) * self.half[1],
            1.0,
        );
        let o_cam = self.to_camera.transform_point3(lens);
        if !(o_cam.z.abs() <= 1e-9 * (1.0 + o_cam.length())) {
            return None;
        }
        let d_cam = if self.lens_radius > 0.0 {
            (p_img * self.focal_distance - o_cam).normalize()
        } else {
            p_img.normalize()
        };
        let (we, pdf_dir, _) = self.importance_camera_space(o_cam, d_cam);
        if we == 0.0 {
            return None;
        }
        Some(CameraSample {
            ray: Ray::new(lens, self.to_world.transform_vector3(d_cam).normalize()),
            we,
            pdf_pos: self.pdf_lens(),
            pdf_dir,
        })
    }

    /// `(W_e, p_dir, raster)` of a camera-space ray from lens point `o` in unit direction `d`;
    /// zero and `None` outside the image. The image position is where the ray crosses the plane in
    /// focus (for a pinhole, the image plane at distance 1).
    fn importance_camera_space(&self, o: DVec3, d: DVec3) -> (f64, f64, Option<[f64; 2]>) {
        let cos = d.z;
        if cos <= 0.0 || !cos.is_finite() {
            return (0.0, 0.0, None);
        }
        let q = if self.lens_radius > 0.0 {
            (o + d * (self.focal_distance / cos)) / self.focal_distance
        } else {
            d / cos
        };
        let raster = [
            (q.x / self.half[0] + 1.0) / 2.0 * self.width as f64,
            (1.0 - q.y / self.half[1]) / 2.0 * self.height as f64,
        ];
        let inside = raster[0] >= 0.0
            && raster[0] < self.width as f64
            && raster[1] >= 0.0
            && raster[1] < self.height as f64;
        if !inside {
            return (0.0, 0.0, None);
        }
        let a = self.image_area();
        let c2 = cos * cos;
        (
            1.0 / (a * self.lens_area() * c2 * c2),
            1.0 / (a * c2 * cos),
            Some(raster),
        )
    }

    /// `(W_e, p_dir, raster)` of a ray leaving the lens point `p` in world direction `w`.
    pub fn importance(&self, p: DVec3, w: DVec3) -> (f64, f64, Option<[f64; 2]>) {
        let o = self.to_camera.transform_point3(p);
        let d = self.to_camera.transform_vector3(w).normalize();
        self.importance_camera_space(o, d)
    }

    /// Sample a lens point toward scene point `r` (`lens` in `[0,1)²`), for connecting `r` to the
    /// camera.
    pub fn sample_connection(&self, r: DVec3, lens: [f64; 2]) -> Option<CameraConnection> {
        let l = if self.lens_radius > 0.0 {
            concentric_disk(lens).map(|v| v * self.lens_radius)
        } else {
            [0.0, 0.0]
        };
        let p = self.to_world.transform_point3(DVec3::new(l[0], l[1], 0.0));
        let v = p - r;
        let dist = v.length();
        if dist <= 0.0 || !dist.is_finite() {
            return None;
        }
        let wi = v / dist;
        let (we, _, raster) = self.importance(p, -wi);
        let raster = raster?;
        let cos = self.forward().dot(-wi).abs();
        let pdf = dist * dist / (cos * self.lens_area());
        Some(CameraConnection {
            p,
            wi,
            dist,
            we,
            pdf,
            raster,
        })
    }

    /// The film and lens numbers that [`Camera::sample_ray`] maps to the ray leaving lens point `p`
    /// in direction `w` (`None` outside the image). For a pinhole the lens numbers are free and are
    /// drawn uniformly from `free`.
    pub fn invert(&self, p: DVec3, w: DVec3, free: [f64; 2]) -> Option<([f64; 2], [f64; 2])> {
        let (_, _, raster) = self.importance(p, w);
        let raster = raster?;
        let film = [
            crate::math::clamp_unit(raster[0] / self.width as f64),
            crate::math::clamp_unit(raster[1] / self.height as f64),
        ];
        Some((film, self.invert_lens(p, free)))
    }

    /// The lens numbers of world lens point `p` (for a pinhole they are free: `free`).
    pub fn invert_lens(&self, p: DVec3, free: [f64; 2]) -> [f64; 2] {
        if self.lens_radius > 0.0 {
            let o = self.to_camera.transform_point3(p);
            invert_concentric_disk([o.x / self.lens_radius, o.y / self.lens_radius])
        } else {
            free
        }
    }

    /// Raster position of a world point seen through the lens centre (for tests and info).
    pub fn raster_of(&self, p: DVec3) -> Option<[f64; 2]> {
        let c = self.position();
        self.importance(c, (p - c).normalize()).2
    }
}

/// Shirley–Chiu concentric map from the unit square to the unit disk.
pub fn concentric_disk(u: [f64; 2]) -> [f64; 2] {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, theta) = if a.abs() > b.abs() {
        (a, PI / 4.0 * (b / a))
    } else {
        (b, PI / 2.0 - PI / 4.0 * (a / b))
    };
    [r * theta.cos(), r * theta.sin()]
}

/// Inverse of [`concentric_disk`].
pub fn invert_concentric_disk(p: [f64; 2]) -> [f64; 2] {
    let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
    if r == 0.0 {
        return [0.5, 0.5];
    }
    let mut phi = p[1].atan2(p[0]);
    if phi < -PI / 4.0 {
        phi += 2.0 * PI;
    }
    let (a, b) = if phi < PI / 4.0 {
        (r, phi * r / (PI / 4.0))
    } else if phi < 3.0 * PI / 4.0 {
        (-(phi - PI / 2.0) * r / (PI / 4.0), r)
    } else if phi < 5.0 * PI / 4.0 {
        (-r, -(phi - PI) * r / (PI / 4.0))
    } else {
        ((phi - 3.0 * PI / 2.0) * r / (PI / 4.0), -r)
    };
    [
        crate::math::clamp_unit((a + 1.0) / 2.0),
        crate::math::clamp_unit((b + 1.0) / 2.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(lens_radius: f64) -> Camera {
        let desc = CameraDesc {
            camera_to_world: DMat4::from_translation(DVec3::new(0.5, -1.0, 2.0))
                * DMat4::from_rotation_y(0.3),
            projection: Projection::Perspective {
                fov: 0.8,
                lens_radius,
                focal_distance: 3.0,
            },
        };
        Camera::new(&desc, 64, 48).unwrap()
    }

    #[test]
    fn sampling_inverts_and_importance_normalises() {
        for lr in [0.0, 0.2] {
            let c = camera(lr);
            for (film, lens) in [
                ([0.1, 0.9], [0.3, 0.7]),
                ([0.5, 0.5], [0.9, 0.05]),
                ([0.99, 0.01], [0.5, 0.2]),
            ] {
                let s = c.sample_ray(film, lens);
                let (f2, l2) = c.invert(s.ray.o, s.ray.d, lens).unwrap();
                assert!(
                    (f2[0] - film[0]).abs() < 1e-9 && (f2[1] - film[1]).abs() < 1e-9,
                    "{film:?} {f2:?}"
                );
                assert!(
                    (l2[0] - lens[0]).abs() < 1e-9 && (l2[1] - lens[1]).abs() < 1e-9,
                    "{lens:?} {l2:?}"
                );
                // W_e cos / (p_pos p_dir) = 1: uniform film sampling has unit weight.
                let cos = s.ray.d.dot(c.forward());
                assert!((s.we * cos / (s.pdf_pos * s.pdf_dir) - 1.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn concentric_disk_round_trip() {
        for u in [
            [0.1, 0.2],
            [0.9, 0.4],
            [0.3, 0.95],
            [0.6, 0.05],
            [0.5, 0.5001],
        ] {
            let v = invert_concentric_disk(concentric_disk(u));
            assert!(
                (v[0] - u[0]).abs() < 1e-12 && (v[1] - u[1]).abs() < 1e-12,
                "{u:?} {v:?}"
            );
        }
    }

    /// ∫ W_e over directions = 1 / A_lens: the film's total measurement is normalised.
    #[test]
    fn importance_integrates_over_the_sphere() {
        let c = camera(0.0);
        let n = 400_000;
        let mut rng = mcmc_core::rng::stream(1, 0);
        let mut sum = 0.0;
        for _ in 0..n {
            let z = 1.0 - 2.0 * mcmc_core::rng::uniform(&mut rng);
            let phi = 2.0 * PI * mcmc_core::rng::uniform(&mut rng);
            let r = (1.0 - z * z).sqrt();
            let w = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            let (we, _, _) = c.importance(c.position(), w);
            sum += we * w.dot(c.forward()).max(0.0) * 4.0 * PI;
        }
        let est = sum / n as f64;
        assert!((est - 1.0).abs() < 0.02, "{est}");
    }
}
