//! Where path-space MLT's bootstrap weights come from: draws the bootstrap's independent samples
//! (Veach & Guibas 1997's initial paths: a bidirectional strategy chosen uniformly, weight
//! `(k + 1) I(f) / Σ_s p_s`, [`light_transport::pathspace::PathMlt`]) for many keys and prints,
//! per path length, the normalisation `b_k` and the largest weights with the vertices of their
//! paths. A weight that is a large share of `b_k` seeds most of that length's chains on one
//! path; if the chains cannot leave it, its pixel takes their whole budget.
//!
//! `cargo run --release --example seed_hunt [SCENE] [SAMPLES] [KEY]` (default `pool`, 1 000 000,
//! key offset 0), 256×256, at most 9 edges (`--max-depth 8`), paths of 3 edges and more (the
//! chains' share when direct lighting is rendered apart).

use light_transport::metropolis::{DIRECT_EDGES, DirectApart, Method};
use light_transport::pathspace::{Mutations, PathMlt, PathState};
use light_transport::scene::{Scene, builtin, pbrt};

const MAX_EDGES: usize = 9;
const TOP: usize = 3;

fn describe(scene: &Scene, state: &PathState) -> String {
    let mut out = String::new();
    let v = &state.path.vertices;
    for (i, x) in v.iter().enumerate() {
        let d = if i + 1 < v.len() {
            (v[i + 1].point.p - x.point.p).length()
        } else {
            0.0
        };
        out += &format!(
            "\n      v{i} prim {:>5} p ({:+.4}, {:+.4}, {:+.4}) n·ns {:.4}{} d→next {:.3e}",
            x.point.primitive,
            x.point.p.x,
            x.point.p.y,
            x.point.p.z,
            x.point.n.dot(x.point.ns),
            if x.delta { " delta" } else { "" },
            d
        );
    }
    let raster = state.path.raster(scene);
    out += &format!(
        "\n      raster {raster:?}, I(C*_s) {:?}",
        state
            .strategy
            .iter()
            .map(|i| format!("{i:.2e}"))
            .collect::<Vec<_>>()
    );
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let scene_arg = args.next().unwrap_or_else(|| "pool".into());
    let samples: u64 = args
        .next()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(1_000_000);
    let offset: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(0);
    let desc = match builtin::builtin(&scene_arg) {
        Some(d) => d,
        None => pbrt::load(std::path::Path::new(&scene_arg))?,
    };
    let scene = Scene::new(&desc, Some((256, 256)))?;
    let mut sum = [0.0f64; MAX_EDGES + 1];
    let mut top: Vec<Vec<(f64, u64)>> = vec![Vec::new(); MAX_EDGES + 1];
    // The method's own bootstrap: its chains' lengths (direct lighting apart), its weights.
    let mlt = PathMlt::new(Mutations::new(MAX_EDGES))?.without_direct();
    let mut weights = vec![(0, 0.0); mlt.groups()];
    for i in 0..samples {
        let key = mcmc_core::rng::mix64(offset + i);
        mlt.independent_all(&scene, key, &mut weights);
        for (g, &(_, w)) in weights.iter().enumerate() {
            let k = g + 1;
            if w > 0.0 && k <= MAX_EDGES {
                sum[k] += w;
                let t = &mut top[k];
                t.push((w, key));
                t.sort_by(|a, b| b.0.total_cmp(&a.0));
                t.truncate(TOP);
            }
        }
    }
    for k in DIRECT_EDGES + 1..=MAX_EDGES {
        let b = sum[k] / samples as f64;
        println!("k = {k}: b_k = {b:.4e}");
        for &(w, key) in &top[k] {
            let (state, _) = mlt.independent(&scene, k - 1, key);
            println!(
                "   weight {w:.3e} = {:.1}% of the length's sum{}",
                100.0 * w / sum[k],
                describe(&scene, &state)
            );
        }
    }
    Ok(())
}
