//! The manifold walk on the built-in scenes with specular chains (and any pbrt files given):
//! chains from the lights through ideal specular surfaces to the first diffuse one, walked to a
//! target 0.2% of the scene's diagonal away and back — the walk columns of Jakob & Marschner
//! 2012, Table 1 (converged, mean iterations, mean and largest chain, non-reversible walks).
//!
//! `cargo run --release --example manifold_walks [SCENE.pbrt …]`

use light_transport::manifold::ManifoldSettings;
use light_transport::manifold::probe::{failures, probe, probe_cases};
use light_transport::scene::{Scene, builtin, pbrt};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut scenes: Vec<(String, Scene)> = Vec::new();
    for name in ["pool", "pool-lamp", "caustic", "cornell", "ring"] {
        let desc = builtin::builtin(name).ok_or("missing built-in")?;
        scenes.push((name.to_string(), Scene::new(&desc, None)?));
    }
    for path in std::env::args().skip(1) {
        let desc = pbrt::load(std::path::Path::new(&path))?;
        scenes.push((path.clone(), Scene::new(&desc, None)?));
    }
    println!(
        "| scene | walks | converged | mean iterations | mean / largest chain | not reversible | walks/s | failures |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let settings = ManifoldSettings::default();
    for (name, scene) in &scenes {
        let cases = probe_cases(scene, 4000, 8, 0.002, 1);
        if cases.is_empty() {
            println!("| {name} | 0 | | | | | | no specular chain from the lights |");
            continue;
        }
        let t = Instant::now();
        let stats = probe(scene, &cases, &settings);
        let secs = t.elapsed().as_secs_f64();
        println!(
            "| {name} | {} | {:.1}% | {:.2} | {:.2} / {} | {:.2}% | {:.0} k | {} |",
            stats.walks,
            100.0 * stats.success_rate(),
            stats.mean_iterations(),
            stats.vertices as f64 / stats.walks as f64,
            stats.max_vertices,
            100.0 * stats.non_reversible as f64 / stats.converged.max(1) as f64,
            // Each converged walk is walked back too: count both.
            (stats.walks + stats.converged) as f64 / secs / 1e3,
            failures(&stats)
        );
    }
    Ok(())
}
