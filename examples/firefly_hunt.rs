//! Where BDPT's variance comes from: renders a scene with BDPT (Veach 1997 ch. 10, all
//! strategies, power heuristic) and keeps, per strategy `(s, t)`, the sum and the sum of squares
//! of its weighted per-sample contributions (luminance), and the largest single contributions
//! with the vertices that made them. A strategy whose share of the second moment far exceeds its
//! share of the mean is where fireflies come from.
//!
//! `cargo run --release --example firefly_hunt [SCENE.pbrt|BUILT-IN] [PASSES] [SEED] [ROULETTE]`
//! (default `../shared/scenes/veach-bidir/scene.pbrt`, 256×144, maximum depth 7, passes `8`
//! (0..8; `A..B` for passes A to B−1), seed 1; ROULETTE `off`, `light` (default, as `charted
//! render`) or `both`: Russian roulette from the first surface vertex in light walks or in both).
//! Each sample draws exactly the numbers it draws in `charted render SCENE --algo bdpt --seed SEED
//! --resolution 256x144 --max-depth 7` (Sobol numbers), so a firefly seen in a render can be found
//! by bisecting its pass count and replayed here.

use light_transport::integrators::{Bdpt, Sampling, pass_stream};
use light_transport::path::{MisHeuristic, Roulette, Subpath, Vertex, VertexKind, WalkSettings};
use light_transport::sampler::PixelSampler;
use light_transport::scene::{Scene, builtin, pbrt};
use std::collections::BTreeMap;

#[derive(Default)]
struct Moments {
    sum: f64,
    sum2: f64,
    count: u64,
}

fn describe(v: &Vertex) -> String {
    let kind = match v.kind {
        VertexKind::Camera => "cam".to_string(),
        VertexKind::Light { light } => format!("light{light}"),
        VertexKind::Surface => format!("prim{}", v.point.primitive),
    };
    format!(
        "{kind}{} pf={:.2e} pr={:.2e} b={:.2e}",
        if v.delta { " delta" } else { "" },
        v.pdf_fwd,
        v.pdf_rev,
        v.beta.luminance()
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let scene_arg = args
        .next()
        .unwrap_or_else(|| "../shared/scenes/veach-bidir/scene.pbrt".into());
    let passes = args.next().unwrap_or_else(|| "8".into());
    let passes: std::ops::Range<u64> = match passes.split_once("..") {
        Some((a, b)) => a.parse()?..b.parse()?,
        None => 0..passes.parse()?,
    };
    let seed: u64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(1);
    let roulette = match args.next().as_deref() {
        Some("off") => None,
        None | Some("light") => Some(Roulette {
            from: 1,
            camera: false,
        }),
        Some("both") => Some(Roulette {
            from: 1,
            camera: true,
        }),
        Some(other) => {
            return Err(format!("ROULETTE must be off, light or both, not {other}").into());
        }
    };
    let desc = match builtin::builtin(&scene_arg) {
        Some(d) => d,
        None => pbrt::load(std::path::Path::new(&scene_arg))?,
    };
    let scene = Scene::new(&desc, Some((256, 144)))?;
    let bdpt = Bdpt {
        walk: WalkSettings { max_edges: 8 },
        heuristic: MisHeuristic::Power,
        roulette,
        shadow_roulette: None,
    };
    let npix = scene.camera.width * scene.camera.height;
    let mut moments: BTreeMap<(usize, usize), Moments> = BTreeMap::new();
    let mut top: Vec<(f64, String)> = Vec::new();
    let (mut camera, mut light) = (Subpath::new(), Subpath::new());
    let sampling = Sampling {
        seed,
        sampler: PixelSampler::Sobol,
    };
    for pass in passes.clone() {
        for pixel in 0..npix {
            let mut stream = pass_stream(sampling, pass, pixel);
            bdpt.trace_subpaths(&scene, &mut stream, Some(pixel), &mut camera, &mut light);
            bdpt.strategies(&scene, &light, &camera, None, |c| {
                let (s, t, w) = (c.s, c.t, c.weight);
                let y = c.value.luminance();
                if !(y > 0.0) {
                    return;
                }
                let m = moments.entry((s, t)).or_default();
                m.sum += y;
                m.sum2 += y * y;
                m.count += 1;
                if top.len() < 25 || y > top[top.len() - 1].0 {
                    let path: Vec<String> = light[..s]
                        .iter()
                        .chain(camera[..t].iter().rev())
                        .map(describe)
                        .collect();
                    top.push((
                        y,
                        format!(
                            "s={s} t={t} pixel={pixel} pass={pass} w={w:.3e} unweighted={:.3e}\n    {}",
                            c.unweighted.luminance(),
                            path.join("\n    ")
                        ),
                    ));
                    top.sort_by(|a, b| b.0.total_cmp(&a.0));
                    top.truncate(25);
                }
            });
        }
    }
    let n = ((passes.end - passes.start) * npix as u64) as f64;
    let total: f64 = moments.values().map(|m| m.sum).sum();
    let total2: f64 = moments.values().map(|m| m.sum2).sum();
    println!("mean luminance per sample {:.4e}", total / n);
    println!("| s | t | share of mean | share of second moment | count |");
    for ((s, t), m) in &moments {
        println!(
            "| {s} | {t} | {:.4} | {:.4} | {} |",
            m.sum / total,
            m.sum2 / total2,
            m.count
        );
    }
    for (y, d) in &top {
        println!("{y:.3e}  {d}");
    }
    Ok(())
}
