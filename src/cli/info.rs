//! `charted info`: what a scene contains.

use super::CliError;
use super::scene_arg;
use clap::Args;
use light_transport::light::LightKind;
use light_transport::scene::MaterialDesc;

/// Options of `info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene: a built-in name or a pbrt-v3 file.
    pub scene: String,
    /// Build the compact BVH (as `render --compact-bvh`).
    #[arg(long)]
    pub compact_bvh: bool,
}

pub fn run(a: InfoArgs) -> Result<(), CliError> {
    let loaded = scene_arg::load(&a.scene)?;
    let (scene, build) = scene_arg::build(&loaded, None, super::options::compact(a.compact_bvh))?;
    let d = &loaded.description;
    let (tris, spheres) = scene.primitive_counts();
    println!("scene       {}", loaded.name);
    println!("image       {}×{}", scene.camera.width, scene.camera.height);
    println!(
        "camera      at {:.3}, looking {:.3}, lens radius {}",
        scene.camera.position(),
        scene.camera.forward(),
        scene.camera.lens_radius
    );
    println!(
        "geometry    {} meshes, {tris} triangles ({} smooth-shaded), {spheres} spheres; bounds {:.3} … {:.3}",
        d.meshes.len(),
        scene.bvh.shading.len(),
        scene.bounds.0,
        scene.bounds.1
    );
    let (area, point) = scene.lights.iter().fold((0, 0), |(a, p), l| match l {
        LightKind::Area { .. } => (a + 1, p),
        LightKind::Point { .. } => (a, p + 1),
    });
    println!("lights      {area} emissive primitives, {point} point lights");
    let mut kinds = std::collections::BTreeMap::new();
    for m in &scene.materials {
        let k = match m {
            MaterialDesc::Matte { .. } => "matte",
            MaterialDesc::Metal { .. } => "metal",
            MaterialDesc::Mirror { .. } => "mirror",
            MaterialDesc::Glass { alpha_u, .. } if *alpha_u > 0.0 => "rough glass",
            MaterialDesc::Glass { .. } => "glass",
            MaterialDesc::Layered { .. } => "layered (plastic/substrate)",
            MaterialDesc::Mix { .. } => "mix",
        };
        *kinds.entry(k).or_insert(0) += 1;
    }
    println!(
        "materials   {}",
        kinds
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!("textures    {}", d.textures.len());
    println!(
        "bvh         {} references to {} primitives{}",
        scene.bvh.references(),
        scene.bvh.primitives.len(),
        if a.compact_bvh { " (compact)" } else { "" }
    );
    println!(
        "load        parse {:.3} s, build {:.3} s",
        loaded.parse_time.as_secs_f64(),
        build.as_secs_f64()
    );
    for n in &scene.notes {
        println!("note        {n}");
    }
    Ok(())
}
