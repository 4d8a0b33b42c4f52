//! The pbrt-v3 loader: the three real scenes, hand-written scenes covering every supported
//! directive and material (`tests/scenes/`, plus PLY and image files generated into a temporary
//! directory), malformed inputs that must give located errors, and property tests that random
//! input never panics.

use light_transport::Rgb;
use light_transport::math::{DMat4, DVec3};
use light_transport::scene::pbrt::{self, ply, roughness_to_alpha_v3};
use light_transport::scene::{
    AreaLightDesc, LightDesc, MaterialDesc, MeshDesc, Projection, RgbTexture, SceneDescription,
};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

// ---- helpers ------------------------------------------------------------------------------------

fn shared_scene(name: &str) -> PathBuf {
    PathBuf::from(format!(
        "{}/../../shared/scenes/{name}/scene.pbrt",
        env!("CARGO_MANIFEST_DIR")
    ))
}

fn test_scene(name: &str) -> PathBuf {
    PathBuf::from(format!(
        "{}/tests/scenes/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
}

/// A unique temporary directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        static N: AtomicUsize = AtomicUsize::new(0);
        let p = std::env::temp_dir().join(format!(
            "charted-pbrt-{}-{tag}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
    }

    fn path(&self) -> &Path {
        &self.0
    }

    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9
}

fn assert_positions(mesh: &MeshDesc, expected: &[[f64; 3]]) {
    assert_eq!(mesh.positions.len(), expected.len());
    for (p, e) in mesh.positions.iter().zip(expected) {
        assert!(close(*p, DVec3::from_array(*e)), "{p:?} != {e:?}");
    }
}

/// Oriented geometric normal of a triangle, as the renderer computes it.
fn normal(mesh: &MeshDesc, t: usize) -> DVec3 {
    let [a, b, c] = mesh.indices[t].map(|i| mesh.positions[i as usize]);
    let n = (b - a).cross(c - a).normalize();
    if mesh.flip_normals { -n } else { n }
}

/// Pixel position of a world point through a pinhole camera, following the convention documented
/// on `CameraDesc::camera_to_world`.
fn project(scene: &SceneDescription, p: DVec3) -> [f64; 2] {
    let cam = scene.camera.as_ref().unwrap();
    let Projection::Perspective { fov, .. } = cam.projection;
    let (w, h) = (scene.film.width as f64, scene.film.height as f64);
    let a = (fov / 2.0).tan();
    let (sx, sy) = if w >= h {
        (a * w / h, a)
    } else {
        (a, a * h / w)
    };
    let q = cam.camera_to_world.inverse().transform_point3(p);
    let (x, y) = (q.x / q.z / sx, q.y / q.z / sy);
    [(x + 1.0) / 2.0 * w, (1.0 - y) / 2.0 * h]
}

fn triangles(s: &SceneDescription) -> usize {
    s.meshes.iter().map(|m| m.indices.len()).sum()
}

fn area_lights(s: &SceneDescription) -> usize {
    s.meshes.iter().filter(|m| m.area_light.is_some()).count()
        + s.spheres.iter().filter(|m| m.area_light.is_some()).count()
}

fn load_text(text: &str) -> light_transport::Result<SceneDescription> {
    let dir = TempDir::new("text");
    pbrt::load_str(text, dir.path(), "bad.pbrt")
}

/// `text` must fail with a message naming `bad.pbrt`, `line` and every needle.
fn expect_error(text: &str, line: usize, needles: &[&str]) {
    let err = load_text(text).expect_err("the scene must be rejected");
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("bad.pbrt:{line}:")),
        "expected bad.pbrt:{line} in: {msg}"
    );
    for n in needles {
        assert!(msg.contains(n), "expected `{n}` in: {msg}");
    }
}

const HEADER: &str = "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\"\nWorldBegin\n";

fn metal_alpha(m: &MaterialDesc) -> (f64, f64) {
    match m {
        MaterialDesc::Metal {
            alpha_u, alpha_v, ..
        } => (*alpha_u, *alpha_v),
        other => panic!("not a metal: {other:?}"),
    }
}

// ---- (a) the real scenes --------------------------------------------------------------------

#[test]
fn cornell_box_loads() {
    let s = pbrt::load(&shared_scene("cornell-box")).unwrap();
    assert_eq!((s.film.width, s.film.height), (1024, 1024));
    assert_eq!(s.film.filename.as_deref(), Some("cornell-box_path.png"));
    let cam = s.camera.as_ref().unwrap();
    let Projection::Perspective {
        fov, lens_radius, ..
    } = cam.projection;
    assert!((fov.to_degrees() - 19.5).abs() < 1e-9);
    assert_eq!(lens_radius, 0.0);
    // The camera sits at (0, 1, 6.8) looking down world -z.
    assert!(close(
        cam.camera_to_world.transform_point3(DVec3::ZERO),
        DVec3::new(0.0, 1.0, 6.8)
    ));
    assert!(close(
        cam.camera_to_world.transform_vector3(DVec3::Z),
        -DVec3::Z
    ));
    assert_eq!(s.meshes.len(), 8);
    assert_eq!(triangles(&s), 2 * 5 + 12 + 12 + 2);
    assert!(s.spheres.is_empty() && s.lights.is_empty());
    assert_eq!(s.materials.len(), 8);
    assert!(
        s.materials
            .iter()
            .all(|m| matches!(m, MaterialDesc::Matte { .. }))
    );
    let names: Vec<&str> = s.ignored.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "Integrator \"path\"",
            "Sampler \"sobol\"",
            "PixelFilter \"triangle\""
        ]
    );
    assert_eq!(s.ignored[1].1.line, 3);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // One area light, facing down into the box.
    assert_eq!(area_lights(&s), 1);
    let light = s.meshes.iter().find(|m| m.area_light.is_some()).unwrap();
    assert_eq!(
        light.area_light,
        Some(AreaLightDesc {
            radiance: Rgb::new(17.0, 12.0, 4.0),
            two_sided: false
        })
    );
    for t in 0..2 {
        assert!(normal(light, t).dot(-DVec3::Y) > 0.999);
    }
    // Every oriented geometric normal agrees with the scene's normals "N" (pbrt's orientation).
    for m in &s.meshes {
        let ns = m.normals.as_ref().unwrap();
        for (t, tri) in m.indices.iter().enumerate() {
            assert!(normal(m, t).dot(ns[tri[0] as usize]) > 0.999);
        }
    }
    // Not mirrored: the red wall (x = -1) is on the image's left, the green one on its right, as in
    // the reference image.
    let red = &s.meshes[4];
    assert_eq!(
        s.materials[red.material],
        MaterialDesc::Matte {
            kd: RgbTexture::Constant(Rgb::new(0.63, 0.065, 0.05))
        }
    );
    assert!(project(&s, DVec3::new(-1.0, 1.0, 0.0))[0] < 100.0);
    assert!(project(&s, DVec3::new(1.0, 1.0, 0.0))[0] > 924.0);
}

#[test]
fn veach_bidir_loads_binary_plys() {
    let s = pbrt::load(&shared_scene("veach-bidir")).unwrap();
    assert_eq!((s.film.width, s.film.height), (1024, 1024));
    let Projection::Perspective { fov, .. } = s.camera.as_ref().unwrap().projection;
    assert!((fov.to_degrees() - 35.0).abs() < 1e-9);
    assert_eq!(s.meshes.len(), 14);
    // Twelve binary little-endian PLY files (11540 faces) and two light quads.
    assert_eq!(triangles(&s), 11540 + 4);
    assert_eq!(
        s.meshes.iter().filter(|m| m.normals.is_some()).count(),
        7 + 2
    );
    assert!(s.meshes.iter().filter(|m| m.uvs.is_some()).count() >= 12);
    assert_eq!(area_lights(&s), 2);
    let lamp = s.meshes.iter().filter_map(|m| m.area_light).nth(1).unwrap();
    assert_eq!(
        lamp.radiance,
        Rgb::new(12048.178711, 8605.841797, 6196.206055)
    );
    // Materials: diffuse, glass, rough metal (roughness not remapped), wood.
    assert!(matches!(s.materials[0], MaterialDesc::Matte { .. }));
    assert_eq!(
        s.materials[1],
        MaterialDesc::Glass {
            eta: 1.5,
            alpha_u: 0.0,
            alpha_v: 0.0,
            kr: Rgb::WHITE,
            kt: Rgb::WHITE
        }
    );
    assert_eq!(metal_alpha(&s.materials[2]), (0.25, 0.25));
    let glass_mesh = s.meshes.iter().find(|m| m.material == 1).unwrap();
    assert_eq!(glass_mesh.indices.len(), 7936);
    assert_eq!(s.ignored.len(), 3);
    assert_eq!(s.ignored[0].0, "Integrator \"bdpt\"");
    // The egg's smooth normals are read (and used: no warning any more).
    assert_eq!(
        glass_mesh.normals.as_ref().map(|n| n.len()),
        Some(glass_mesh.positions.len())
    );
    assert!(
        !s.warnings.iter().any(|(w, _)| w.contains("Mesh002.ply")),
        "{:?}",
        s.warnings
    );
    for m in s.meshes.iter().filter(|m| m.normals.is_some()) {
        let ns = m.normals.as_ref().unwrap();
        for t in 0..m.indices.len() {
            let sum: DVec3 = m.indices[t].iter().map(|&i| ns[i as usize]).sum();
            assert!(sum.dot(normal(m, t)) >= 0.0);
        }
    }
}

#[test]
fn veach_mis_loads_spheres_and_mixes() {
    let s = pbrt::load(&shared_scene("veach-mis")).unwrap();
    assert_eq!((s.film.width, s.film.height), (1280, 720));
    let Projection::Perspective { fov, .. } = s.camera.as_ref().unwrap().projection;
    assert!((fov.to_degrees() - 20.114293).abs() < 1e-9);
    assert_eq!(s.spheres.len(), 3);
    assert_eq!(area_lights(&s), 3);
    let radii: Vec<f64> = s.spheres.iter().map(|s| s.radius).collect();
    assert_eq!(radii, [1.0, 0.5, 0.05]);
    assert!(close(s.spheres[2].center, DVec3::new(0.0, 6.5, 2.7)));
    assert_eq!(
        s.spheres[2].area_light.unwrap().radiance,
        Rgb::splat(3039.64)
    );
    // The spheres' material is the black matte "Null".
    assert_eq!(
        s.materials[s.spheres[0].material],
        MaterialDesc::Matte {
            kd: RgbTexture::Constant(Rgb::BLACK)
        }
    );
    // Four plates: a mix of rough metal (weight 0.3) and black matte.
    assert_eq!(s.meshes.len(), 6);
    assert_eq!(triangles(&s), 4 * 12 + 2 * 2);
    let mut alphas = Vec::new();
    for plate in &s.meshes[..4] {
        let MaterialDesc::Mix { a, b, amount } = &s.materials[plate.material] else {
            panic!("plate is not a mix");
        };
        assert_eq!(*amount, Rgb::splat(0.3));
        assert!(matches!(s.materials[*b], MaterialDesc::Matte { .. }));
        alphas.push(metal_alpha(&s.materials[*a]).0);
    }
    assert_eq!(alphas, [0.01, 0.05, 0.1, 0.25]);
    assert_eq!(s.ignored.len(), 3);
    // Not mirrored: the three lights appear where the reference image shows them.
    for (sphere, x) in s.spheres.iter().zip([841.0, 640.0, 446.0]) {
        let [px, py] = project(&s, sphere.center);
        assert!(
            (px - x).abs() < 3.0 && (py - 144.0).abs() < 3.0,
            "{px} {py}"
        );
    }
}

// ---- (b) hand-written scenes ----------------------------------------------------------------

#[test]
fn transforms_are_applied_numerically() {
    let s = pbrt::load(&test_scene("transforms.pbrt")).unwrap();
    let cam = s.camera.as_ref().unwrap();
    // LookAt from (0,0,-5) towards the origin with y up: pbrt's frame is a pure translation here.
    assert!(
        cam.camera_to_world
            .abs_diff_eq(DMat4::from_translation(DVec3::new(0.0, 0.0, -5.0)), 1e-12)
    );
    assert_eq!(
        cam.projection,
        Projection::Perspective {
            fov: 45f64.to_radians(),
            lens_radius: 0.1,
            focal_distance: 5.0
        }
    );
    assert_eq!((s.film.width, s.film.height), (64, 32));
    let ignored: Vec<&str> = s.ignored.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        ignored,
        [
            "Sampler \"halton\"",
            "Integrator \"path\"",
            "PixelFilter \"box\""
        ]
    );
    let m = &s.meshes;
    assert_eq!(m.len(), 6);
    assert_positions(&m[0], &[[11., 0., 0.], [10., 1., 0.], [10., 0., 1.]]);
    assert_positions(&m[1], &[[0., 1., 0.], [-1., 0., 0.], [0., 0., 1.]]);
    assert_positions(&m[2], &[[2., 0., 0.], [0., 3., 0.], [0., 0., 4.]]);
    assert_positions(&m[3], &[[7., 6., 7.], [5., 8., 7.], [5., 6., 9.]]);
    assert_positions(&m[4], &[[0., 1., -3.], [-1., 0., -3.], [0., 0., -2.]]);
    assert_positions(&m[5], &[[-1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]);
    assert!(m[..5].iter().all(|m| !m.flip_normals));
    // A mirroring transform flips the orientation, so the normal still points away from the
    // origin, as the object-space normal (1,1,1)/√3 does.
    assert!(m[5].flip_normals);
    assert!(normal(&m[5], 0).dot(DVec3::new(-1.0, 1.0, 1.0)) > 0.0);
    assert_eq!(s.spheres.len(), 2);
    assert!(close(s.spheres[0].center, DVec3::new(10.0, 1.0, 0.0)));
    assert!((s.spheres[0].radius - 0.5).abs() < 1e-12 && !s.spheres[0].flip_normals);
    assert!(close(s.spheres[1].center, DVec3::ZERO));
    assert!((s.spheres[1].radius - 2.0).abs() < 1e-12 && s.spheres[1].flip_normals);
    // Locations point at the Shape lines.
    assert_eq!(m[0].location.as_ref().unwrap().line, 14);
}

#[test]
fn every_material_and_named_material_scoping() {
    let s = pbrt::load(&test_scene("materials.pbrt")).unwrap();
    let mat = |i: usize| &s.materials[s.meshes[i].material];
    let matte = |r, g, b| MaterialDesc::Matte {
        kd: RgbTexture::Constant(Rgb::new(r, g, b)),
    };
    // pbrt's default material, then named and anonymous ones with block scoping.
    assert_eq!(*mat(0), matte(0.5, 0.5, 0.5));
    assert_eq!(*mat(1), matte(0.8, 0.1, 0.1));
    assert_eq!(*mat(2), matte(0.1, 0.8, 0.1));
    assert_eq!(
        *mat(3),
        MaterialDesc::Layered {
            kd: RgbTexture::Constant(Rgb::splat(0.25)),
            ks: Rgb::splat(0.25),
            alpha_u: roughness_to_alpha_v3(0.1),
            alpha_v: roughness_to_alpha_v3(0.1),
            eta: 1.5
        }
    );
    assert_eq!(*mat(4), matte(0.8, 0.1, 0.1));
    assert_eq!(*mat(5), matte(0.8, 0.1, 0.1));
    let m = &s.materials;
    assert_eq!(m.len(), 18);
    assert_eq!(m[2], matte(0.1, 0.2, 0.3)); // Kd from a constant texture
    assert_eq!(
        m[3],
        MaterialDesc::Metal {
            eta: Rgb::new(0.200438, 0.924033, 1.10221),
            k: Rgb::new(3.91295, 2.45285, 2.14219),
            alpha_u: roughness_to_alpha_v3(0.1),
            alpha_v: roughness_to_alpha_v3(0.1)
        }
    );
    assert_eq!(
        m[4],
        MaterialDesc::Metal {
            eta: Rgb::new(0.2, 0.4, 1.4),
            k: Rgb::new(3.9, 2.4, 1.8),
            alpha_u: 0.1,
            alpha_v: 0.3
        }
    );
    assert_eq!(
        m[5],
        MaterialDesc::Mirror {
            kr: Rgb::new(0.9, 0.8, 0.7)
        }
    );
    assert_eq!(
        m[6],
        MaterialDesc::Glass {
            eta: 1.33,
            alpha_u: 0.0,
            alpha_v: 0.0,
            kr: Rgb::WHITE,
            kt: Rgb::WHITE
        }
    );
    assert_eq!(
        m[7],
        MaterialDesc::Glass {
            eta: 1.7,
            alpha_u: roughness_to_alpha_v3(0.2),
            alpha_v: roughness_to_alpha_v3(0.25), // 0.5 × float texture "half"
            kr: Rgb::WHITE,
            kt: Rgb::new(0.9, 0.9, 0.5)
        }
    );
    assert_eq!(
        m[8],
        MaterialDesc::Layered {
            kd: RgbTexture::Constant(Rgb::new(0.2, 0.3, 0.4)),
            ks: Rgb::splat(0.5),
            alpha_u: 0.05,
            alpha_v: 0.05,
            eta: 1.5
        }
    );
    assert_eq!(
        m[9],
        MaterialDesc::Layered {
            kd: RgbTexture::Constant(Rgb::new(0.6, 0.5, 0.4)),
            ks: Rgb::splat(0.04),
            alpha_u: roughness_to_alpha_v3(0.1),
            alpha_v: roughness_to_alpha_v3(0.2),
            eta: 1.5
        }
    );
    assert_eq!(
        m[10],
        MaterialDesc::Mix {
            a: 1,
            b: 5,
            amount: Rgb::new(0.25, 0.5, 0.75)
        }
    );
    assert_eq!(
        m[11],
        MaterialDesc::Mix {
            a: 4,
            b: 6,
            amount: Rgb::splat(0.3)
        }
    );
    assert_eq!(m[12], matte(0.3, 0.3, 0.3)); // uber reducible to matte
    assert_eq!(m[13], matte(0.7, 0.7, 0.7)); // pbrt-v4 diffuse
    assert_eq!(
        m[14],
        MaterialDesc::Glass {
            eta: 1.5,
            alpha_u: 0.2,
            alpha_v: 0.2,
            kr: Rgb::WHITE,
            kt: Rgb::WHITE
        }
    );
    assert_eq!(
        m[15],
        MaterialDesc::Metal {
            eta: Rgb::WHITE,
            k: Rgb::splat(2.0),
            alpha_u: 0.0,
            alpha_v: 0.0
        }
    );
    // pbrt-v3's remapping polynomial: 0.1 ↦ α ≈ 0.4618, 1e-3 (its clamp) ↦ α ≈ 0.0473.
    assert!((roughness_to_alpha_v3(0.1) - 0.46176).abs() < 1e-4);
    assert!((roughness_to_alpha_v3(0.0) - 0.04727).abs() < 1e-4);
}

#[test]
fn include_resolves_against_the_including_file() {
    let s = pbrt::load(&test_scene("include_main.pbrt")).unwrap();
    assert_eq!((s.film.width, s.film.height), (320, 240));
    assert_eq!(s.film.filename.as_deref(), Some("included.exr"));
    assert_eq!(s.meshes.len(), 1);
    let light = &s.meshes[0];
    assert!(light.positions.iter().all(|p| (p.z - 5.0).abs() < 1e-12));
    assert_eq!(light.area_light.unwrap().radiance, Rgb::splat(4.0));
    assert_eq!(
        s.materials[light.material],
        MaterialDesc::Mirror {
            kr: Rgb::splat(0.9)
        }
    );
    let loc = light.location.as_ref().unwrap();
    assert!(
        loc.file.ends_with("inc/deeper/light.pbrt") && loc.line == 3,
        "{loc}"
    );
    // After the included AttributeEnd: no area light, default material.
    assert_eq!(s.spheres.len(), 1);
    assert!(s.spheres[0].area_light.is_none());
    assert!(matches!(
        s.materials[s.spheres[0].material],
        MaterialDesc::Matte { .. }
    ));
}

#[test]
fn lights_and_nested_attributes() {
    let s = pbrt::load(&test_scene("lights.pbrt")).unwrap();
    assert_eq!(
        s.lights,
        vec![
            LightDesc::Infinite {
                radiance: Rgb::new(0.1, 0.2, 0.3)
            },
            LightDesc::Infinite {
                radiance: Rgb::splat(0.5)
            },
            LightDesc::Point {
                position: DVec3::new(1.0, 2.0, 3.0),
                intensity: Rgb::new(10.0, 20.0, 30.0)
            },
            LightDesc::Point {
                position: DVec3::new(-1.0, -2.0, -3.0),
                intensity: Rgb::new(2.0, 3.0, 4.0)
            },
        ]
    );
    let (outer, inner) = (&s.meshes[0], &s.meshes[1]);
    assert_eq!(
        outer.area_light,
        Some(AreaLightDesc {
            radiance: Rgb::new(5.0, 6.0, 7.0),
            two_sided: true
        })
    );
    assert!(!outer.flip_normals && normal(outer, 0).dot(DVec3::Z) > 0.999);
    assert_eq!(
        inner.area_light,
        Some(AreaLightDesc {
            radiance: Rgb::splat(3.0),
            two_sided: false
        })
    );
    assert!(inner.flip_normals && normal(inner, 0).dot(-DVec3::Z) > 0.999);
    assert_eq!(s.spheres[0].area_light, outer.area_light);
    assert!(!s.spheres[0].flip_normals);
    assert!(s.spheres[1].area_light.is_none());
}

/// An ASCII PLY with normals (given opposite to the winding), `s t` coordinates and a quad.
const ASCII_PLY: &str = "ply\nformat ascii 1.0\ncomment a unit square in z = 0\n\
element vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n\
property float ny\nproperty float nz\nproperty float s\nproperty float t\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0 0 0 -1 0 0\n1 0 0 0 0 -1 1 0\n1 1 0 0 0 -1 1 1\n0 1 0 0 0 -1 0 1\n4 0 1 2 3\n";

/// A binary PLY: positions of type `pos` ("float" or "double"), faces as `(count, index)` types,
/// an extra element and property to skip, triangles and quads.
fn binary_ply(big_endian: bool, pos: &str, count: &str, index: &str) -> Vec<u8> {
    let fmt = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut out = format!(
        "ply\nformat {fmt} 1.0\nelement vertex 5\nproperty {pos} x\nproperty {pos} y\n\
         property {pos} z\nproperty uchar flags\nproperty float u\nproperty float v\n\
         element face 2\nproperty list {count} {index} vertex_indices\nproperty int tag\n\
         element extra 1\nproperty list uchar float stuff\nend_header\n"
    )
    .into_bytes();
    let mut put = |bytes: &[u8]| {
        let mut b = bytes.to_vec();
        if big_endian {
            b.reverse();
        }
        out.extend_from_slice(&b);
    };
    fn num(ty: &str, v: f64) -> Vec<u8> {
        match ty {
            "float" => (v as f32).to_le_bytes().to_vec(),
            "double" => v.to_le_bytes().to_vec(),
            "uchar" => vec![v as u8],
            "ushort" => (v as u16).to_le_bytes().to_vec(),
            "int" => (v as i32).to_le_bytes().to_vec(),
            "uint" => (v as u32).to_le_bytes().to_vec(),
            _ => unreachable!(),
        }
    }
    let verts = [
        [0., 0., 0.],
        [2., 0., 0.],
        [2., 2., 0.],
        [0., 2., 0.],
        [1., 1., 3.],
    ];
    for (i, v) in verts.iter().enumerate() {
        for c in v {
            put(&num(pos, *c));
        }
        put(&[7]);
        put(&num("float", i as f64 / 4.0));
        put(&num("float", 1.0 - i as f64 / 4.0));
    }
    // a quad and a triangle
    put(&num(count, 4.0));
    for i in [0, 1, 2, 3] {
        put(&num(index, i as f64));
    }
    put(&num("int", 42.0));
    put(&num(count, 3.0));
    for i in [0, 1, 4] {
        put(&num(index, i as f64));
    }
    put(&num("int", 43.0));
    put(&[2]);
    put(&num("float", 1.0));
    put(&num("float", 2.0));
    out
}

#[test]
fn plymesh_ascii_and_binary_both_endians() {
    let dir = TempDir::new("ply");
    dir.write("ascii.ply", ASCII_PLY);
    dir.write("le.ply", binary_ply(false, "float", "uchar", "int"));
    dir.write("be.ply", binary_ply(true, "double", "uchar", "ushort"));
    dir.write("le_uint.ply", binary_ply(false, "float", "int", "uint"));
    let text = format!(
        "{HEADER}Translate 0 0 1\n\
         Shape \"plymesh\" \"string filename\" \"ascii.ply\"\n\
         Shape \"plymesh\" \"string filename\" \"le.ply\"\n\
         Shape \"plymesh\" \"string filename\" \"be.ply\"\n\
         Shape \"plymesh\" \"string filename\" [ \"le_uint.ply\" ]\nWorldEnd\n"
    );
    let s = pbrt::load_str(&text, dir.path(), "ply.pbrt").unwrap();
    assert_eq!(s.meshes.len(), 4);
    // ASCII: the quad is split as pbrt splits it, st read as uv, normals kept (and translated
    // scenes keep unit normals); the normals point to -z, so both triangles are wound to face -z.
    let a = &s.meshes[0];
    assert_eq!(a.indices.len(), 2);
    assert_eq!(a.uvs.as_ref().unwrap()[2], [1.0, 1.0]);
    assert!(
        a.normals
            .as_ref()
            .unwrap()
            .iter()
            .all(|n| close(*n, -DVec3::Z))
    );
    assert!((0..2).all(|t| normal(a, t).dot(-DVec3::Z) > 0.999));
    assert!(a.positions.iter().all(|p| (p.z - 1.0).abs() < 1e-12));
    for m in &s.meshes[1..] {
        assert_eq!(m.indices, vec![[0, 1, 2], [3, 0, 2], [0, 1, 4]]);
        assert!(close(m.positions[4], DVec3::new(1.0, 1.0, 4.0)));
        assert_eq!(m.uvs.as_ref().unwrap()[1], [0.25, 0.75]);
        assert!(m.normals.is_none());
    }
    assert_eq!(s.meshes[1].positions, s.meshes[2].positions);
    // ply::parse is usable on its own.
    assert_eq!(ply::parse(ASCII_PLY.as_bytes()).unwrap().triangles.len(), 2);
}

#[test]
fn image_textures_png_tga_exr() {
    let dir = TempDir::new("tex");
    // 2×2: red, green / blue, mid grey (row 0 is the top of the image).
    let img = image::RgbImage::from_raw(2, 2, vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128])
        .unwrap();
    img.save(dir.path().join("checks.png")).unwrap();
    img.save(dir.path().join("checks.tga")).unwrap();
    image::Rgb32FImage::from_raw(1, 1, vec![2.0, 0.5, 0.25])
        .unwrap()
        .save(dir.path().join("hdr.exr"))
        .unwrap();
    let text = format!(
        "{HEADER}Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"checks.png\"\n\
           \"float uscale\" 2 \"float vdelta\" 0.5 \"float scale\" 0.5\n\
         Texture \"c2\" \"color\" \"imagemap\" \"string filename\" \"checks.png\"\n\
           \"float uscale\" 2 \"float vdelta\" 0.5\n\
         Texture \"lin\" \"spectrum\" \"imagemap\" \"string filename\" \"checks.tga\" \"bool gamma\" \"false\"\n\
         Texture \"hdr\" \"spectrum\" \"imagemap\" \"string filename\" \"hdr.exr\"\n\
         Texture \"tinted\" \"spectrum\" \"scale\" \"texture tex1\" \"hdr\" \"rgb tex2\" [ 1 2 4 ]\n\
         Material \"matte\" \"texture Kd\" \"c\"\n\
         Shape \"trianglemesh\" \"point P\" [ 0 0 1 1 0 1 0 1 1 ] \"float uv\" [ 0 0 1 0 0 1 ]\n\
         Material \"plastic\" \"texture Kd\" \"c2\"\n\
         Shape \"trianglemesh\" \"point P\" [ 0 0 1 1 0 1 0 1 1 ] \"float st\" [ 0 0 .5 0 0 .5 ]\n\
         Material \"substrate\" \"texture Kd\" \"lin\"\n\
         Shape \"trianglemesh\" \"point P\" [ 0 0 1 1 0 1 0 1 1 ]\n\
         Material \"matte\" \"texture Kd\" \"tinted\"\n\
         Shape \"trianglemesh\" \"point P\" [ 0 0 1 1 0 1 0 1 1 ]\nWorldEnd\n"
    );
    let s = pbrt::load_str(&text, dir.path(), "tex.pbrt").unwrap();
    // "c" and "c2" share one decoded image; "lin" and "hdr" are separate.
    assert_eq!(s.textures.len(), 3);
    let t = &s.textures[0];
    assert_eq!((t.width, t.height), (2, 2));
    assert_eq!((t.uv_scale, t.uv_offset), ([2.0, 1.0], [0.0, 0.5]));
    assert_eq!(t.texels[0], Rgb::new(1.0, 0.0, 0.0));
    assert_eq!(t.texels[2], Rgb::new(0.0, 0.0, 1.0));
    assert!(
        (t.texels[3].0[0] - 0.2158605).abs() < 1e-5,
        "sRGB 128 decodes to linear"
    );
    assert!(
        (s.textures[1].texels[3].0[0] - 128.0 / 255.0).abs() < 1e-6,
        "gamma false"
    );
    assert_eq!(
        s.textures[2].texels[0],
        Rgb::new(2.0, 0.5, 0.25),
        "EXR is linear"
    );
    assert_eq!(
        s.materials[s.meshes[0].material],
        MaterialDesc::Matte {
            kd: RgbTexture::Image {
                texture: 0,
                scale: Rgb::splat(0.5)
            }
        }
    );
    let MaterialDesc::Layered { kd, .. } = &s.materials[s.meshes[1].material] else {
        panic!()
    };
    assert_eq!(
        *kd,
        RgbTexture::Image {
            texture: 0,
            scale: Rgb::WHITE
        }
    );
    assert_eq!(
        s.materials[s.meshes[3].material],
        MaterialDesc::Matte {
            kd: RgbTexture::Image {
                texture: 2,
                scale: Rgb::new(1.0, 2.0, 4.0)
            }
        }
    );
    assert_eq!(s.meshes[0].uvs.as_ref().unwrap()[1], [1.0, 0.0]);
    assert_eq!(s.meshes[1].uvs.as_ref().unwrap()[1], [0.5, 0.0]);
    assert!(s.meshes[2].uvs.is_none());
}

#[test]
fn degenerate_triangles_are_dropped_with_a_warning() {
    let text = format!(
        "{HEADER}Shape \"trianglemesh\" \"point P\" [ 0 0 0  1 0 0  0 1 0  2 0 0 ]\n\
         \"integer indices\" [ 0 1 2  0 1 3  1 1 2  0 2 1 ]\nWorldEnd\n"
    );
    let s = load_text(&text).unwrap();
    assert_eq!(s.meshes[0].indices, vec![[0, 1, 2], [0, 2, 1]]);
    assert_eq!(s.warnings.len(), 1);
    let (w, loc) = &s.warnings[0];
    assert!(
        w.contains("dropped 2 of 4 triangles") && w.contains("degenerate"),
        "{w}"
    );
    assert!(loc.file.ends_with("bad.pbrt") && loc.line == 4);
}

/// Vertex normals that deviate from the geometric normal are shading normals now: kept,
/// normalised, and no longer reported.
#[test]
fn shading_normals_are_kept_and_normalised() {
    let text = format!(
        "{HEADER}Shape \"trianglemesh\" \"point P\" [ 0 0 0  1 0 0  0 1 0 ] \
         \"normal N\" [ 0 0 1  0 0.6 0.8  0 0 1 ]\n\
         Shape \"trianglemesh\" \"point P\" [ 0 0 0  1 0 0  0 1 0 ] \"normal N\" [ 0 0 2  0 0 1  0 0 1 ]\n\
         WorldEnd\n"
    );
    let s = load_text(&text).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(close(
        s.meshes[0].normals.as_ref().unwrap()[1],
        DVec3::new(0.0, 0.6, 0.8)
    ));
    assert!(close(s.meshes[1].normals.as_ref().unwrap()[0], DVec3::Z));
}

// ---- (c) malformed input ----------------------------------------------------------------

#[test]
fn truncated_and_out_of_range_plys_name_the_file() {
    let dir = TempDir::new("badply");
    let good = binary_ply(false, "float", "uchar", "int");
    dir.write("trunc.ply", &good[..good.len() - 20]);
    let mut bad = binary_ply(true, "float", "uchar", "uint");
    let n = bad.len();
    bad[n - 14] = 99; // last byte (big endian) of the second face's third index: 4 → 99
    dir.write("oob.ply", &bad);
    dir.write("notply.ply", "hello\n");
    for (file, needle) in [
        ("trunc.ply", "truncated"),
        ("oob.ply", "refers to vertex 99"),
        ("notply.ply", "bad header"),
        ("missing.ply", "cannot read PLY file"),
    ] {
        let text =
            format!("{HEADER}\nShape \"plymesh\" \"string filename\" \"{file}\"\nWorldEnd\n");
        let msg = pbrt::load_str(&text, dir.path(), "bad.pbrt")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("bad.pbrt:5:") && msg.contains(file) && msg.contains(needle),
            "{msg}"
        );
    }
}

#[test]
fn syntax_errors_are_located() {
    expect_error("WorldBegin\n\nFoo 1 2 3\n", 3, &["unknown", "`Foo`"]);
    expect_error(
        "Translate 1\n x 3\nWorldBegin\n",
        2,
        &["Translate", "finite number", "`x`"],
    );
    expect_error(
        "Camera \"perspective\"\n  \"float fov\" [ 3x5 ]\nWorldBegin\n",
        2,
        &["fov", "finite number", "3x5"],
    );
    expect_error(
        &format!("{HEADER}Shape \"sphere\"\n \"float radius\" [ nan ]\n"),
        5,
        &["radius", "finite number", "nan"],
    );
    expect_error(
        &format!("{HEADER}Translate 1 inf 0\n"),
        4,
        &["finite number", "inf"],
    );
    expect_error(
        &format!("{HEADER}Shape \"sphere\" \"flaot radius\" 1\n"),
        4,
        &["unknown parameter type", "flaot"],
    );
    expect_error(
        &format!("{HEADER}Shape \"trianglemesh\" \"point P\" [ 0 0 0 1 0 0 0 1\n"),
        4,
        &["`[`", "never closed"],
    );
    expect_error(
        "Film \"image\" \"string filename\" \"x.exr\n",
        1,
        &["unterminated string"],
    );
    expect_error(
        &format!("{HEADER}\"Shape\" \"sphere\"\n"),
        4,
        &["expected a directive"],
    );
    expect_error("LookAt 0 0 0 0 0 0 0 1 0\n", 1, &["LookAt", "coincide"]);
    expect_error("Rotate 30 0 0 0\n", 1, &["zero axis"]);
    expect_error("Scale 1e300 1 1\nScale 1e300 1 1\n", 2, &["non-finite"]);
    expect_error(
        "WorldBegin\nCoordSysTransform \"nowhere\"\n",
        2,
        &["unknown coordinate system"],
    );
}

#[test]
fn block_and_phase_errors_are_located() {
    expect_error(
        &format!("{HEADER}AttributeBegin\nAttributeEnd\nAttributeEnd\n"),
        6,
        &["AttributeEnd without a matching AttributeBegin"],
    );
    expect_error(
        &format!("{HEADER}AttributeBegin\nTransformEnd\n"),
        5,
        &["TransformEnd closes the AttributeBegin opened at"],
    );
    expect_error(
        &format!("{HEADER}\nAttributeBegin\nShape \"sphere\"\n"),
        5,
        &["AttributeBegin is never closed"],
    );
    expect_error(
        &format!("{HEADER}TransformBegin\nWorldEnd\n"),
        5,
        &["still open"],
    );
    expect_error(
        &format!("{HEADER}Camera \"perspective\"\n"),
        4,
        &["Camera is only allowed before WorldBegin"],
    );
    expect_error(
        "Shape \"sphere\"\nWorldBegin\n",
        1,
        &["Shape is only allowed between WorldBegin and WorldEnd"],
    );
    expect_error("Camera \"perspective\"\n\n", 2, &["without WorldBegin"]);
    expect_error(
        &format!("{HEADER}WorldEnd\nShape \"sphere\"\n"),
        5,
        &["after WorldEnd"],
    );
}

#[test]
fn missing_files_and_include_cycles() {
    expect_error(
        &format!("{HEADER}\n\nInclude \"nope/missing.pbrt\"\n"),
        6,
        &["cannot read included file", "missing.pbrt"],
    );
    let dir = TempDir::new("cycle");
    dir.write("a.pbrt", "WorldBegin\nInclude \"sub/b.pbrt\"\nWorldEnd\n");
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    dir.write("sub/b.pbrt", "# b includes c\nInclude \"c.pbrt\"\n");
    dir.write("sub/c.pbrt", "\n\n\nInclude \"../a.pbrt\"\n");
    let msg = pbrt::load(&dir.path().join("a.pbrt"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("c.pbrt:4:") && msg.contains("Include cycle"),
        "{msg}"
    );
    assert!(msg.contains("a.pbrt") && msg.contains("b.pbrt"), "{msg}");
    // A file that includes itself.
    dir.write("self.pbrt", "WorldBegin\n\nInclude \"self.pbrt\"\n");
    let msg = pbrt::load(&dir.path().join("self.pbrt"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("self.pbrt:3:") && msg.contains("Include cycle"),
        "{msg}"
    );
    // A missing top-level file is an I/O error naming it.
    let msg = pbrt::load(&dir.path().join("absent.pbrt"))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("absent.pbrt"), "{msg}");
    // Missing texture image.
    expect_error(
        &format!(
            "{HEADER}Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"no.png\"\n"
        ),
        4,
        &["cannot read texture image", "no.png"],
    );
}

#[test]
fn unsupported_or_inconsistent_content_is_an_error() {
    let e = |body: &str, line: usize, needles: &[&str]| {
        expect_error(&format!("{HEADER}{body}\n"), line, needles)
    };
    // The brief's list.
    e(
        "AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\nShape \"trianglemesh\" \"point P\" [ 0 0 0 1 1 1 2 2 2 ]",
        5,
        &["area light with zero total area"],
    );
    e(
        "AreaLightSource \"diffuse\"\nShape \"sphere\" \"float radius\" 0",
        5,
        &["radius"],
    );
    expect_error(
        "Film \"image\" \"integer xresolution\" [ 100000 ]\nWorldBegin\n",
        1,
        &["absurd", "xresolution"],
    );
    expect_error(
        "Film \"image\"\n \"integer yresolution\" [ 0 ]\nWorldBegin\n",
        2,
        &["absurd", "yresolution"],
    );
    e(
        "Scale 1 2 1\nShape \"sphere\"",
        5,
        &["similarity", "ellipsoid"],
    );
    e(
        "Material \"matte\" \"float sigma\" [ 20 ]",
        4,
        &["Oren–Nayar", "sigma"],
    );
    e(
        "Material \"matte\"\n \"spectrum Kd\" [ 300 .3 800 .3 ]",
        5,
        &["Kd", "spectrum"],
    );
    e(
        "LightSource \"point\" \"blackbody I\" [ 5500 ]",
        4,
        &["\"I\"", "blackbody"],
    );
    // Unused parameters that would change the look.
    e(
        "Material \"mirror\" \"rgb Kd\" [ 1 0 0 ]",
        4,
        &["rgb Kd", "mirror"],
    );
    e(
        "Shape \"sphere\" \"float radius\" 1 \"float zmin\" 0",
        4,
        &["partial spheres"],
    );
    e(
        "Material \"matte\" \"texture bumpmap\" \"b\"",
        4,
        &["bumpmap", "not supported"],
    );
    // Unknown types.
    e("Shape \"cone\"", 4, &["unsupported shape", "cone"]);
    e("Material \"hair\"", 4, &["unsupported material", "hair"]);
    e("LightSource \"spot\"", 4, &["unsupported light", "spot"]);
    e(
        "AreaLightSource \"blackbody\"",
        4,
        &["unsupported area light"],
    );
    e(
        "LightSource \"infinite\" \"string mapname\" \"sky.exr\"",
        4,
        &["environment map"],
    );
    e("ObjectBegin \"x\"", 4, &["instancing"]);
    expect_error(
        "Camera \"orthographic\"\nWorldBegin\n",
        1,
        &["unsupported camera"],
    );
    // Array lengths, required and wrong-typed parameters.
    e(
        "Material \"matte\" \"rgb Kd\" [ 1 0 ]",
        4,
        &["exactly 3 values"],
    );
    e(
        "Shape \"trianglemesh\" \"point P\" [ 0 0 0 1 0 0 0 1 ]",
        4,
        &["multiple of 3"],
    );
    e(
        "Shape \"trianglemesh\"\n \"point P\" [ 0 0 0 1 0 0 0 1 0 1 1 0 ] \"integer indices\" [ 0 1 4 ]",
        5,
        &["index 4 is out of range"],
    );
    e(
        "Shape \"trianglemesh\" \"point P\" [ 0 0 0 1 0 0 0 1 0 ] \"normal N\" [ 0 0 1 ]",
        4,
        &["\"N\" has 1 normals"],
    );
    e(
        "Shape \"trianglemesh\" \"point P\" [ 0 0 0 1 0 0 0 1 0 ] \"float uv\" [ 0 0 1 ]",
        4,
        &["even number"],
    );
    e(
        "Shape \"trianglemesh\" \"integer indices\" [ 0 1 2 ]",
        4,
        &["needs \"point3 P\""],
    );
    e("Shape \"plymesh\"", 4, &["needs \"string filename\""]);
    e(
        "Shape \"sphere\" \"integer radius\" 1",
        4,
        &["\"radius\" must be given as \"float\""],
    );
    e(
        "MakeNamedMaterial \"m\" \"rgb Kd\" [ 1 1 1 ]",
        4,
        &["needs \"string type\""],
    );
    e("NamedMaterial \"nope\"", 4, &["unknown material \"nope\""]);
    e(
        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string namedmaterial1\" \"x\" \"string namedmaterial2\" \"y\"",
        4,
        &["unknown named material \"x\""],
    );
    e(
        "Material \"matte\" \"texture Kd\" \"nope\"",
        4,
        &["unknown texture \"nope\""],
    );
    e(
        "Material \"metal\" \"rgb eta\" [ 1 1 1 ] \"rgb eta\" [ 2 2 2 ]",
        4,
        &["given twice"],
    );
    e(
        "Material \"plastic\" \"float roughness\" -1",
        4,
        &["must not be negative"],
    );
    e(
        "Material \"uber\" \"rgb Kd\" [ .5 .5 .5 ]",
        4,
        &["uber is supported only"],
    );
    e(
        "Shape \"trianglemesh\" \"point P\" [ 0 0 0 1 0 0 0 1 0 ] \"float alpha\" 0.5",
        4,
        &["cut-outs"],
    );
    e(
        "Shape \"sphere\" \"float alpha\" 0.5",
        4,
        &["\"float alpha\" is not supported"],
    );
}

#[test]
fn default_camera_and_film_follow_pbrt() {
    let s = load_text("WorldBegin\nShape \"sphere\"\nWorldEnd\n").unwrap();
    assert_eq!((s.film.width, s.film.height), (1280, 720));
    let cam = s.camera.unwrap();
    assert_eq!(cam.camera_to_world, DMat4::IDENTITY);
    assert!(s.warnings.iter().any(|(w, _)| w.contains("no Camera")));
    // pbrt-v4 style: no WorldEnd is fine.
    assert!(load_text("WorldBegin\nShape \"sphere\"\n").is_ok());
}

// ---- property tests: never panic ------------------------------------------------------------

const VOCABULARY: &[&str] = &[
    "WorldBegin",
    "WorldEnd",
    "AttributeBegin",
    "AttributeEnd",
    "TransformBegin",
    "TransformEnd",
    "Shape",
    "Material",
    "MakeNamedMaterial",
    "NamedMaterial",
    "Texture",
    "LightSource",
    "AreaLightSource",
    "Camera",
    "Film",
    "Include",
    "LookAt",
    "Translate",
    "Rotate",
    "Scale",
    "Transform",
    "ConcatTransform",
    "CoordinateSystem",
    "CoordSysTransform",
    "ReverseOrientation",
    "Identity",
    "Sampler",
    "ObjectBegin",
    "\"trianglemesh\"",
    "\"sphere\"",
    "\"plymesh\"",
    "\"matte\"",
    "\"mix\"",
    "\"glass\"",
    "\"metal\"",
    "\"diffuse\"",
    "\"point\"",
    "\"infinite\"",
    "\"perspective\"",
    "\"image\"",
    "\"imagemap\"",
    "\"spectrum\"",
    "\"float\"",
    "\"constant\"",
    "\"point P\"",
    "\"integer indices\"",
    "\"normal N\"",
    "\"float uv\"",
    "\"float radius\"",
    "\"rgb L\"",
    "\"rgb Kd\"",
    "\"texture Kd\"",
    "\"string type\"",
    "\"string filename\"",
    "\"float fov\"",
    "\"integer xresolution\"",
    "\"bool twosided\"",
    "\"spectrum Kd\"",
    "\"string namedmaterial1\"",
    "\"float amount\"",
    "\"float value\"",
    "\"x\"",
    "\"\"",
    "\"true\"",
    "\"missing.ply\"",
    "\"missing.png\"",
    "[",
    "]",
    "[",
    "]",
    "0",
    "1",
    "2",
    "-1",
    "0.5",
    "3",
    "1e308",
    "-1e308",
    "1e-320",
    "nan",
    "inf",
    "99999999999999999999",
    "4294967296",
    "#",
    "\n",
    "\"\\\"",
    "\"a\nb\"",
    "\u{e9}",
    "\"\u{1F600}\"",
];

fn soup() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(VOCABULARY), 0..80).prop_map(|t| t.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn token_soup_never_panics(prefix in any::<bool>(), text in soup()) {
        let text = if prefix { format!("{HEADER}{text}") } else { text };
        let _ = pbrt::load_str(&text, Path::new("/nonexistent-charted-dir"), "soup.pbrt");
    }

    #[test]
    fn truncated_scenes_never_panic(cut in 0usize..100_000, which in 0usize..4) {
        let path = [
            shared_scene("cornell-box"),
            shared_scene("veach-mis"),
            test_scene("materials.pbrt"),
            test_scene("lights.pbrt"),
        ][which].clone();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut cut = cut % (text.len() + 1);
        while !text.is_char_boundary(cut) {
            cut -= 1;
        }
        let dir = path.parent().unwrap();
        let _ = pbrt::load_str(&text[..cut], dir, "cut.pbrt");
    }

    #[test]
    fn corrupted_plys_never_panic(
        cut in 0usize..1000,
        flips in prop::collection::vec((0usize..1000, any::<u8>()), 0..4),
        which in 0usize..3,
    ) {
        let mut data = match which {
            0 => ASCII_PLY.as_bytes().to_vec(),
            1 => binary_ply(false, "float", "uchar", "int"),
            _ => binary_ply(true, "double", "int", "ushort"),
        };
        for (at, byte) in flips {
            let n = data.len();
            data[at % n] = byte;
        }
        let cut = cut % (data.len() + 1);
        let _ = ply::parse(&data[..cut]);
    }
}
