//! Scenes compiled into the binary, so the renderer works with no files:
//!
//! * `cornell` — the Cornell box (Bitterli's 2×2×2 RGB variant) with a mirror sphere and a glass
//!   sphere instead of the two blocks;
//! * `caustic` — a glass sphere on a diffuse floor under a small light: a caustic (LSDE paths);
//! * `door` — a room lit only through a door left ajar into a brightly lit neighbouring room
//!   (after Veach's "door ajar"); a plastic (layered) table and a rough metal panel in the room;
//! * `ring` — a faceted mirror ring on a diffuse floor under a small low light, seen from close
//!   up: the reflection caustic inside the ring fills the frame (after the zoomed ring of the
//!   practical-MLT paper, Figure 11), paths of the form `L S D E` that BDPT samples poorly and the
//!   caustic perturbation samples well;
//! * `pool` — a pool of water (a wavy surface of 2048 triangles with smooth interpolated normals,
//!   a dielectric of η = 1.33) over a diffuse floor between walls, under a small bright light, seen
//!   from above the water: the floor's caustic is seen through the surface, `L S D S E` paths (the
//!   specular-chain case of manifold exploration);
//! * `pool-lamp` — the same pool lit also by a small lamp under water on the far wall, itself seen
//!   through the surface (`L S E`, and `L D S E` light on the floor);
//! * `rooms`, `lantern`, `box` — the situations of Metropolis photon sampling
//!   ([`super::photon_scenes`]).

use super::description::*;
use crate::math::{DMat4, DVec3};
use crate::spectrum::Rgb;

/// Names of the built-in scenes the Metropolis methods' convergence tests cover.
pub const BUILTIN: [&str; 6] = ["cornell", "caustic", "door", "ring", "pool", "pool-lamp"];

/// Every built-in scene: [`BUILTIN`] and the photon-mapping scenes
/// ([`super::photon_scenes::PHOTON_SCENES`]).
pub fn all() -> Vec<&'static str> {
    BUILTIN
        .iter()
        .chain(super::photon_scenes::PHOTON_SCENES.iter())
        .copied()
        .collect()
}

/// The built-in scene called `name`.
pub fn builtin(name: &str) -> Option<SceneDescription> {
    match name {
        "cornell" => Some(cornell()),
        "caustic" => Some(caustic()),
        "door" => Some(door()),
        "ring" => Some(ring()),
        "pool" => Some(pool(false)),
        "pool-lamp" => Some(pool(true)),
        "rooms" => Some(super::photon_scenes::rooms()),
        "lantern" => Some(super::photon_scenes::lantern()),
        "box" => Some(super::photon_scenes::mirror_box()),
        _ => None,
    }
}

/// Camera-to-world for a camera at `eye` looking at `target` (camera space: `+x` right, `+y` up,
/// `+z` forward).
pub fn look_at(eye: DVec3, target: DVec3, up: DVec3) -> DMat4 {
    let f = (target - eye).normalize();
    let r = f.cross(up).normalize();
    let u = r.cross(f);
    DMat4::from_cols(r.extend(0.0), u.extend(0.0), f.extend(0.0), eye.extend(1.0))
}

/// A small programmatic scene builder (what the built-ins are made with): a pinhole camera, then
/// materials, quads, boxes and spheres in world space.
///
/// ```
/// use light_transport::scene::builtin::SceneBuilder;
/// use light_transport::math::DVec3;
/// use light_transport::Rgb;
/// let mut b = SceneBuilder::new(64, 48, DVec3::new(0.0, 1.0, 3.0), DVec3::ZERO, 40.0);
/// let white = b.matte(0.7, 0.7, 0.7);
/// b.quad(DVec3::new(-1.0, 0.0, -1.0), DVec3::Z * 2.0, DVec3::X * 2.0, white, None);
/// b.quad(DVec3::new(-0.2, 2.0, -0.2), DVec3::X * 0.4, DVec3::Z * 0.4, white, Some(Rgb::splat(10.0)));
/// let scene = light_transport::scene::Scene::new(&b.finish(), None).unwrap();
/// assert_eq!(scene.lights.len(), 2); // one light per triangle of the quad
/// ```
pub struct SceneBuilder {
    d: SceneDescription,
}

impl SceneBuilder {
    /// A scene of `width × height` pixels seen by a pinhole camera at `eye` looking at `target`
    /// (world `+y` up) with a field of view of `fov_degrees` along the shorter image axis.
    pub fn new(width: usize, height: usize, eye: DVec3, target: DVec3, fov_degrees: f64) -> Self {
        let d = SceneDescription {
            camera: Some(CameraDesc {
                camera_to_world: look_at(eye, target, DVec3::Y),
                projection: Projection::Perspective {
                    fov: fov_degrees.to_radians(),
                    lens_radius: 0.0,
                    focal_distance: 1.0,
                },
            }),
            film: FilmDesc {
                width,
                height,
                filename: None,
            },
            ..Default::default()
        };
        Self { d }
    }

    /// The description built so far.
    pub fn finish(self) -> SceneDescription {
        self.d
    }

    /// Add a material; returns its index.
    pub fn material(&mut self, m: MaterialDesc) -> usize {
        self.d.materials.push(m);
        self.d.materials.len() - 1
    }

    /// Add a Lambertian material of reflectance `(r, g, b)`; returns its index.
    pub fn matte(&mut self, r: f64, g: f64, b: f64) -> usize {
        self.material(MaterialDesc::Matte {
            kd: RgbTexture::Constant(Rgb::new(r, g, b)),
        })
    }

    /// A quad `p, p + a, p + a + b, p + b` (normal along `a × b`), emitting `light` (one-sided,
    /// along the normal) when given.
    pub fn quad(&mut self, p: DVec3, a: DVec3, b: DVec3, material: usize, light: Option<Rgb>) {
        self.d.meshes.push(MeshDesc {
            positions: vec![p, p + a, p + a + b, p + b],
            normals: None,
            tangents: None,
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material,
            area_light: light.map(|radiance| AreaLightDesc {
                radiance,
                two_sided: false,
            }),
            flip_normals: false,
            location: None,
        });
    }

    /// A triangle mesh with optional per-vertex shading normals (geometric normals along
    /// `(p1 − p0) × (p2 − p0)`).
    pub fn mesh(
        &mut self,
        positions: Vec<DVec3>,
        normals: Option<Vec<DVec3>>,
        indices: Vec<[u32; 3]>,
        material: usize,
    ) {
        self.d.meshes.push(MeshDesc {
            positions,
            normals,
            tangents: None,
            uvs: None,
            indices,
            material,
            area_light: None,
            flip_normals: false,
            location: None,
        });
    }

    /// An axis-aligned box `[lo, hi]` with outward normals.
    pub fn cuboid(&mut self, lo: DVec3, hi: DVec3, material: usize) {
        let e = hi - lo;
        let (x, y, z) = (DVec3::X * e.x, DVec3::Y * e.y, DVec3::Z * e.z);
        self.quad(lo, y, x, material, None); // z = lo (−z)
        self.quad(lo + z, x, y, material, None); // z = hi (+z)
        self.quad(lo, z, y, material, None); // x = lo (−x)
        self.quad(lo + x, y, z, material, None); // x = hi (+x)
        self.quad(lo, x, z, material, None); // y = lo (−y)
        self.quad(lo + y, z, x, material, None); // y = hi (+y)
    }

    /// A sphere tessellated into `2 nu nv` triangles (`nu` around the `z` axis, `nv` from pole to
    /// pole) carrying the sphere's exact normals at its vertices, and texture coordinates
    /// `(φ/2π, θ/π)`: the mesh sphere of a modelling tool, shaded smooth. Coarse tessellations
    /// make shading normals far from the facets' geometric normals.
    pub fn mesh_sphere(
        &mut self,
        center: DVec3,
        radius: f64,
        nu: usize,
        nv: usize,
        material: usize,
    ) {
        let (mut positions, mut normals, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..=nv {
            for i in 0..=nu {
                let (u, v) = (i as f64 / nu as f64, j as f64 / nv as f64);
                let (phi, theta) = (u * std::f64::consts::TAU, v * std::f64::consts::PI);
                let n = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                positions.push(center + n * radius);
                normals.push(n);
                uvs.push([u, v]);
            }
        }
        let at = |i: usize, j: usize| (j * (nu + 1) + i) as u32;
        let mut indices = Vec::new();
        for j in 0..nv {
            for i in 0..nu {
                // Wound outward (∂p/∂θ × ∂p/∂φ); at the poles one triangle of each pair would
                // have two coincident vertices and is left out.
                if j > 0 {
                    indices.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
                }
                if j + 1 < nv {
                    indices.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
                }
            }
        }
        self.d.meshes.push(MeshDesc {
            positions,
            normals: Some(normals),
            tangents: None,
            uvs: Some(uvs),
            indices,
            material,
            area_light: None,
            flip_normals: false,
            location: None,
        });
    }

    /// The inward-facing walls of the Cornell box `[−1, 1] × [0, 2] × [−1, 1]`, open at `z = +1`,
    /// with materials `[floor, ceiling, back, left, right]` (in that order).
    pub fn cornell_walls(&mut self, m: [usize; 5]) {
        let (x2, y2, z2) = (DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0);
        let corner = DVec3::new(-1.0, 0.0, -1.0);
        self.quad(corner, z2, x2, m[0], None); // floor (+y)
        self.quad(DVec3::new(-1.0, 2.0, -1.0), x2, z2, m[1], None); // ceiling (−y)
        self.quad(corner, x2, y2, m[2], None); // back (+z)
        self.quad(corner, y2, z2, m[3], None); // left (+x)
        self.quad(DVec3::new(1.0, 0.0, -1.0), z2, y2, m[4], None); // right (−x)
    }

    /// A sphere.
    pub fn sphere(&mut self, center: DVec3, radius: f64, material: usize) {
        self.d.spheres.push(SphereDesc {
            center,
            radius,
            material,
            area_light: None,
            flip_normals: false,
            location: None,
        });
    }
}

fn cornell() -> SceneDescription {
    let mut s = SceneBuilder::new(
        256,
        256,
        DVec3::new(0.0, 1.0, 6.8),
        DVec3::new(0.0, 1.0, 0.0),
        19.5,
    );
    let white = s.matte(0.725, 0.71, 0.68);
    let red = s.matte(0.63, 0.065, 0.05);
    let green = s.matte(0.14, 0.45, 0.091);
    let black = s.matte(0.0, 0.0, 0.0);
    let mirror = s.material(MaterialDesc::Mirror {
        kr: Rgb::splat(0.95),
    });
    let glass = s.material(MaterialDesc::Glass {
        eta: 1.5,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    s.cornell_walls([white, white, white, red, green]);
    s.quad(
        DVec3::new(-0.24, 1.98, -0.22),
        DVec3::X * 0.47,
        DVec3::Z * 0.38,
        black,
        Some(Rgb::new(17.0, 12.0, 4.0)),
    );
    s.sphere(DVec3::new(-0.42, 0.35, -0.35), 0.35, mirror);
    s.sphere(DVec3::new(0.45, 0.35, 0.3), 0.35, glass);
    s.d
}

fn caustic() -> SceneDescription {
    let mut s = SceneBuilder::new(
        320,
        240,
        DVec3::new(0.0, 2.2, 4.5),
        DVec3::new(0.0, 0.3, 0.0),
        35.0,
    );
    let floor = s.matte(0.7, 0.7, 0.7);
    let wall = s.matte(0.5, 0.55, 0.6);
    let black = s.matte(0.0, 0.0, 0.0);
    let glass = s.material(MaterialDesc::Glass {
        eta: 1.5,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    s.quad(
        DVec3::new(-4.0, 0.0, -3.0),
        DVec3::Z * 7.0,
        DVec3::X * 8.0,
        floor,
        None,
    );
    s.quad(
        DVec3::new(-4.0, 0.0, -3.0),
        DVec3::X * 8.0,
        DVec3::Y * 5.0,
        wall,
        None,
    );
    s.sphere(DVec3::new(0.0, 0.6, 0.0), 0.6, glass);
    // A small bright light up and to the side: the sphere focuses it onto the floor.
    s.quad(
        DVec3::new(-1.5, 3.0, -1.2),
        DVec3::X * 0.3,
        DVec3::Z * 0.3,
        black,
        Some(Rgb::splat(400.0)),
    );
    s.d
}

fn door() -> SceneDescription {
    let mut s = SceneBuilder::new(
        320,
        240,
        DVec3::new(-1.6, 1.3, 1.7),
        DVec3::new(0.5, 1.0, -2.0),
        55.0,
    );
    let wall = s.matte(0.6, 0.6, 0.6);
    let floor = s.matte(0.5, 0.45, 0.4);
    let door = s.matte(0.55, 0.5, 0.45);
    let black = s.matte(0.0, 0.0, 0.0);
    let plastic = s.material(MaterialDesc::Layered {
        kd: RgbTexture::Constant(Rgb::new(0.35, 0.15, 0.1)),
        ks: Rgb::splat(0.8),
        alpha_u: 0.08,
        alpha_v: 0.08,
        eta: 1.5,
    });
    let metal = s.material(MaterialDesc::Metal {
        eta: Rgb::new(0.2, 0.92, 1.1),
        k: Rgb::new(3.9, 2.45, 2.14),
        alpha_u: 0.15,
        alpha_v: 0.15,
    });
    // Room A (camera): x ∈ [−2, 2], y ∈ [0, 2.5], z ∈ [−2, 2], inward normals.
    s.quad(
        DVec3::new(-2.0, 0.0, -2.0),
        DVec3::Z * 4.0,
        DVec3::X * 4.0,
        floor,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 2.5, -2.0),
        DVec3::X * 4.0,
        DVec3::Z * 4.0,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 0.0, 2.0),
        DVec3::Y * 2.5,
        DVec3::X * 4.0,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 0.0, -2.0),
        DVec3::Y * 2.5,
        DVec3::Z * 4.0,
        wall,
        None,
    );
    s.quad(
        DVec3::new(2.0, 0.0, -2.0),
        DVec3::Z * 4.0,
        DVec3::Y * 2.5,
        wall,
        None,
    );
    // Wall z = −2 with a doorway x ∈ [0.3, 1.1], y ∈ [0, 2]: three pieces, one quad each for
    // both rooms (Lambertian surfaces reflect on both sides; a second, coincident quad for room
    // B's side would make the closest hit ambiguous, and paths not replayable).
    for (lo, hi) in [
        ((-2.0, 0.0), (0.3, 2.5)),
        ((1.1, 0.0), (2.0, 2.5)),
        ((0.3, 2.0), (1.1, 2.5)),
    ] {
        let p = DVec3::new(lo.0, lo.1, -2.0);
        let (a, b) = (DVec3::X * (hi.0 - lo.0), DVec3::Y * (hi.1 - lo.1));
        s.quad(p, a, b, wall, None);
    }
    // The door: a thin slab hinged at x = 1.1, turned 8° into room B.
    let angle = 8f64.to_radians();
    let (w, t) = (0.8, 0.04);
    let dir = DVec3::new(-angle.cos(), 0.0, -angle.sin());
    let thick = DVec3::new(angle.sin(), 0.0, -angle.cos()) * t;
    let hinge = DVec3::new(1.1, 0.0, -2.0);
    let (a, h) = (dir * w, DVec3::Y * 2.0);
    s.quad(hinge, h, a, door, None);
    s.quad(hinge + thick, a, h, door, None);
    s.quad(hinge + a, h, thick, door, None);
    s.quad(hinge, thick, h, door, None);
    // Room B: x ∈ [−2, 2], z ∈ [−5, −2], lit by a bright ceiling panel.
    s.quad(
        DVec3::new(-2.0, 0.0, -5.0),
        DVec3::Z * 3.0,
        DVec3::X * 4.0,
        floor,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 2.5, -5.0),
        DVec3::X * 4.0,
        DVec3::Z * 3.0,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 0.0, -5.0),
        DVec3::X * 4.0,
        DVec3::Y * 2.5,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-2.0, 0.0, -5.0),
        DVec3::Y * 2.5,
        DVec3::Z * 3.0,
        wall,
        None,
    );
    s.quad(
        DVec3::new(2.0, 0.0, -5.0),
        DVec3::Z * 3.0,
        DVec3::Y * 2.5,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-1.5, 2.49, -4.5),
        DVec3::X * 1.2,
        DVec3::Z * 1.0,
        black,
        Some(Rgb::splat(30.0)),
    );
    // Furniture in room A.
    s.cuboid(
        DVec3::new(-1.0, 0.0, -0.8),
        DVec3::new(0.2, 0.7, 0.2),
        plastic,
    );
    s.quad(
        DVec3::new(1.99, 0.3, -1.2),
        DVec3::Z * 1.2,
        DVec3::Y * 1.4,
        metal,
        None,
    );
    s.d
}

fn ring() -> SceneDescription {
    let mut s = SceneBuilder::new(
        256,
        256,
        DVec3::new(0.25, 1.6, 1.1),
        DVec3::new(0.1, 0.0, -0.15),
        28.0,
    );
    let floor = s.matte(0.75, 0.72, 0.68);
    let black = s.matte(0.0, 0.0, 0.0);
    let gold = s.material(MaterialDesc::Mirror {
        kr: Rgb::new(0.95, 0.8, 0.45),
    });
    s.quad(
        DVec3::new(-4.0, 0.0, -4.0),
        DVec3::Z * 8.0,
        DVec3::X * 8.0,
        floor,
        None,
    );
    // 32 facets of a ring of radius 1 and height 0.3; the mirror reflects on both sides (one quad
    // per facet: coincident quads would make the closest hit ambiguous).
    let (n, r, h) = (32, 1.0, 0.3);
    for i in 0..n {
        let a0 = std::f64::consts::TAU * i as f64 / n as f64;
        let a1 = std::f64::consts::TAU * (i + 1) as f64 / n as f64;
        let p0 = DVec3::new(r * a0.cos(), 0.0, r * a0.sin());
        let p1 = DVec3::new(r * a1.cos(), 0.0, r * a1.sin());
        s.quad(p0, p1 - p0, DVec3::Y * h, gold, None);
    }
    // A small bright light low on the far side (about 30° above the horizon).
    let c = DVec3::new(-3.0, 1.8, -1.5);
    let nrm = (DVec3::new(0.0, 0.15, 0.0) - c).normalize();
    let a = nrm.cross(DVec3::Y).normalize() * 0.2;
    let b = nrm.cross(a);
    s.quad(c - (a + b) * 0.5, a, b, black, Some(Rgb::splat(600.0)));
    s.d
}

/// Height of the pool's water surface at `(x, z)`, and its gradient `(∂h/∂x, ∂h/∂z)`.
pub fn pool_wave(x: f64, z: f64) -> (f64, [f64; 2]) {
    let a = 0.035;
    let h =
        1.0 + a * ((2.1 * x + 0.4).sin() + (1.7 * z - 0.3).sin() + 0.6 * (1.3 * x + 2.9 * z).sin());
    let c = 0.6 * (1.3 * x + 2.9 * z).cos();
    let dx = a * (2.1 * (2.1 * x + 0.4).cos() + 1.3 * c);
    let dz = a * (1.7 * (1.7 * z - 0.3).cos() + 2.9 * c);
    (h, [dx, dz])
}

fn pool(lamp: bool) -> SceneDescription {
    let mut s = SceneBuilder::new(
        320,
        240,
        DVec3::new(0.0, 3.0, 3.6),
        DVec3::new(0.0, 0.0, -0.2),
        42.0,
    );
    let tiles = s.matte(0.75, 0.78, 0.8);
    let wall = s.matte(0.35, 0.55, 0.65);
    let deck = s.matte(0.6, 0.58, 0.55);
    let black = s.matte(0.0, 0.0, 0.0);
    let water = s.material(MaterialDesc::Glass {
        eta: 1.33,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    let (half, depth) = (2.0, 1.3);
    // Floor of the basin, and its four walls (normals inward).
    s.quad(
        DVec3::new(-half, 0.0, -half),
        DVec3::Z * 2.0 * half,
        DVec3::X * 2.0 * half,
        tiles,
        None,
    );
    s.quad(
        DVec3::new(-half, 0.0, -half),
        DVec3::X * 2.0 * half,
        DVec3::Y * depth,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-half, 0.0, half),
        DVec3::Y * depth,
        DVec3::X * 2.0 * half,
        wall,
        None,
    );
    s.quad(
        DVec3::new(-half, 0.0, -half),
        DVec3::Y * depth,
        DVec3::Z * 2.0 * half,
        wall,
        None,
    );
    s.quad(
        DVec3::new(half, 0.0, -half),
        DVec3::Z * 2.0 * half,
        DVec3::Y * depth,
        wall,
        None,
    );
    // The deck around the pool, at the top of the walls.
    for (p, a, b) in [
        (
            DVec3::new(-6.0, depth, -6.0),
            DVec3::Z * 4.0,
            DVec3::X * 12.0,
        ),
        (
            DVec3::new(-6.0, depth, half),
            DVec3::Z * 4.0,
            DVec3::X * 12.0,
        ),
        (
            DVec3::new(-6.0, depth, -half),
            DVec3::Z * 2.0 * half,
            DVec3::X * 4.0,
        ),
        (
            DVec3::new(half, depth, -half),
            DVec3::Z * 2.0 * half,
            DVec3::X * 4.0,
        ),
    ] {
        s.quad(p, a, b, deck, None);
    }
    // The water: a 32 × 32 grid of the wave, smooth normals from its gradient.
    let n = 32;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let x = -half + 2.0 * half * i as f64 / n as f64;
            let z = -half + 2.0 * half * j as f64 / n as f64;
            let (h, [dx, dz]) = pool_wave(x, z);
            positions.push(DVec3::new(x, h, z));
            normals.push(DVec3::new(-dx, 1.0, -dz).normalize());
        }
    }
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            // Wound so that the geometric normal points up (+y), out of the water.
            indices.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            indices.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    s.mesh(positions, Some(normals), indices, water);
    // A small bright light above the water.
    s.quad(
        DVec3::new(-0.9, 3.6, -0.9),
        DVec3::X * 0.25,
        DVec3::Z * 0.25,
        black,
        Some(Rgb::new(700.0, 680.0, 640.0)),
    );
    if lamp {
        // A small lamp under water in the far wall, facing the camera.
        s.quad(
            DVec3::new(0.3, 0.45, -half + 1e-3),
            DVec3::X * 0.2,
            DVec3::Y * 0.12,
            black,
            Some(Rgb::new(120.0, 140.0, 160.0)),
        );
    }
    s.d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pool_surface_faces_up_with_smooth_normals() {
        let d = builtin("pool").unwrap();
        let water = d.meshes.iter().find(|m| m.normals.is_some()).unwrap();
        for t in &water.indices {
            let p = t.map(|i| water.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).y > 0.0);
        }
        // The wave's gradient against finite differences.
        let (x, z, e) = (0.3, -0.7, 1e-6);
        let (_, [dx, dz]) = pool_wave(x, z);
        let fx = (pool_wave(x + e, z).0 - pool_wave(x - e, z).0) / (2.0 * e);
        let fz = (pool_wave(x, z + e).0 - pool_wave(x, z - e).0) / (2.0 * e);
        assert!((dx - fx).abs() < 1e-8 && (dz - fz).abs() < 1e-8);
    }

    #[test]
    fn look_at_axes() {
        let m = look_at(
            DVec3::new(0.0, 1.0, 5.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::Y,
        );
        assert!((m.transform_vector3(DVec3::Z) - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        assert!((m.transform_vector3(DVec3::X) - DVec3::X).length() < 1e-12);
        assert!((m.transform_vector3(DVec3::Y) - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn every_builtin_builds() {
        for name in all() {
            let d = builtin(name).unwrap();
            crate::scene::Scene::new(&d, Some((32, 24))).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
