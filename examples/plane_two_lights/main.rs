//! The simplified light transport test of "Charted Metropolis light transport" (Pantaleoni 2017,
//! §7.1, Table 1): six MCMC algorithms at equal sample counts against a plain Monte Carlo
//! reference, on an orthographic view of a ground plane lit by two area lights.
//!
//! ```sh
//! cargo run --release --example plane_two_lights            # n = 16M and 128M (several minutes)
//! cargo run --release --example plane_two_lights -- --quick # n = 1M (seconds)
//! ```
//!
//! Prints a table like the paper's Table 1 (RMSE per algorithm and n, mean ± standard deviation
//! over independent runs), the checker results of both charts, and writes the images, error images
//! and a mosaic to `out/plane_two_lights/`.

#[allow(dead_code)] // only the colour ramp and the --quick flag are used here
#[path = "../support/mod.rs"]
mod support;

mod algorithms;
mod charts;
mod image;
mod scene;

use algorithms::{Algorithm, bootstrap, reference, run};
use mcmc_charts::checker::{CheckerConfig, DensityReference, check_chart};
use mcmc_core::rng::{stream, uniform};
use rayon::prelude::*;
use scene::Path;
use std::time::Instant;

fn main() {
    if let Err(e) = try_main() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// (algorithm, n, RMSE per run, acceptance, swap acceptance, seconds per run).
type TableRow = (Algorithm, usize, Vec<f64>, f64, Option<f64>, f64);

struct Plan {
    ns: Vec<(usize, usize)>, // (samples, independent runs)
    reference_spp: usize,
    bootstrap: usize,
}

fn check_charts() -> Result<(), String> {
    println!("== chart checker (100 000 samples, α = 1e-4)");
    let atlas = algorithms::atlas(false);
    // Reference law: uniform ground point; light 1 uniform (probability 1/2), else light 2 with
    // half its samples uniform and half in the square seen through the hole from the ground point,
    // where the cosine chart's density lives.
    let sample = |rng: &mut mcmc_core::ChainRng| {
        let g = [uniform(rng), uniform(rng)];
        if uniform(rng) < 0.5 {
            return Path {
                g,
                light: 1,
                l: [uniform(rng), uniform(rng)],
            };
        }
        let l = if uniform(rng) < 0.5 {
            [uniform(rng), uniform(rng)]
        } else {
            let (c, h) = scene::visible_square(&g);
            [
                c[0] + h * (2.0 * uniform(rng) - 1.0),
                c[1] + h * (2.0 * uniform(rng) - 1.0),
            ]
        };
        Path { g, light: 2, l }
    };
    let ln_q = |x: &Path| -> f64 {
        if x.light == 1 {
            return 0.5f64.ln();
        }
        let (c, h) = scene::visible_square(&x.g);
        let inside = (x.l[0] - c[0]).abs() < h && (x.l[1] - c[1]).abs() < h;
        (0.25 + if inside { 0.25 / (4.0 * h * h) } else { 0.0 }).ln()
    };
    // Cells: 4×4 on the ground times the light index; measure of the domain = 1 · 2 lights.
    let cell = |x: &Path| {
        let i = ((x.g[0] * 4.0) as usize).min(3) * 4 + ((x.g[1] * 4.0) as usize).min(3);
        Some(i * 2 + (x.light as usize - 1))
    };
    let reference = DensityReference {
        sample: &sample,
        ln_density: &ln_q,
        cell: &cell,
        cells: 32,
    };
    let dist = |a: &Path, b: &Path| {
        if a.light != b.light {
            return f64::INFINITY;
        }
        (0..2)
            .map(|i| (a.g[i] - b.g[i]).abs().max((a.l[i] - b.l[i]).abs()))
            .fold(0.0, f64::max)
    };
    for k in 0..2 {
        let chart = atlas.chart(k).ok_or("missing chart")?;
        let r = check_chart(
            chart,
            &dist,
            Some(&reference),
            &CheckerConfig {
                samples: 100_000,
                alpha: 1e-4,
                tolerance: 1e-9,
            },
            &mut stream(99, k as u64),
        )
        .map_err(|e| e.to_string())?;
        print!("{r}");
    }
    Ok(())
}

fn try_main() -> Result<(), String> {
    let quick = support::quick_flag()?;
    let plan = if quick {
        Plan {
            ns: vec![(1 << 20, 3)],
            reference_spp: 512,
            bootstrap: 1 << 20,
        }
    } else {
        Plan {
            ns: vec![(16_000_000, 4), (128_000_000, 2)],
            reference_spp: 65_536,
            bootstrap: 1 << 26,
        }
    };
    let dir = std::path::Path::new("out/plane_two_lights");
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    check_charts()?;

    let t = Instant::now();
    let (reference, ref_se, _) = reference(plan.reference_spp, 1);
    println!(
        "\n== reference: plain Monte Carlo (light 1: emission + cosine sampling, balance heuristic; light 2: the square seen through the hole), {} spp: {:.1} s, RMS standard error {:.2e}",
        plan.reference_spp,
        t.elapsed().as_secs_f64(),
        ref_se
    );
    let exposure = reference.auto_exposure();
    image::save(&reference.to_png(exposure), &dir.join("reference.png"))?;

    let norm = bootstrap(plan.bootstrap, &mut stream(2, 0));
    println!(
        "normalisation: b = {:.5} (relative standard error {:.1e}), b_(1,1) = {:.5}, b_(0,2) = {:.5}",
        norm.b, norm.rel_se, norm.b_chart[0], norm.b_chart[1]
    );

    let mut table: Vec<TableRow> = Vec::new();
    let mut channels: Vec<(Algorithm, usize, [f64; 3])> = Vec::new();
    for &(n, runs) in &plan.ns {
        let jobs: Vec<(Algorithm, usize)> = Algorithm::WITH_ST
            .iter()
            .flat_map(|&a| (0..runs).map(move |r| (a, r)))
            .collect();
        let t = Instant::now();
        let results: Vec<(Algorithm, usize, algorithms::Run, f64)> = jobs
            .par_iter()
            .map(|&(a, r)| {
                let t = Instant::now();
                let mut rng = mcmc_core::rng::substream(1000 + r as u64, a as u64, n as u64);
                let out = run(a, n, &norm, &mut rng);
                (a, r, out, t.elapsed().as_secs_f64())
            })
            .collect();
        println!(
            "n = {n}: {} runs in {:.1} s",
            jobs.len(),
            t.elapsed().as_secs_f64()
        );
        let mut tiles = vec![reference.to_png(exposure)];
        let best = results
            .iter()
            .map(|r| r.2.image.rmse(&reference))
            .fold(f64::INFINITY, f64::min);
        let mut errs = vec![reference.error_png(&reference, 1.0)];
        for &a in &Algorithm::WITH_ST {
            let mine: Vec<&(Algorithm, usize, algorithms::Run, f64)> =
                results.iter().filter(|r| r.0 == a).collect();
            let rmse: Vec<f64> = mine.iter().map(|r| r.2.image.rmse(&reference)).collect();
            let secs = mine.iter().map(|r| r.3).sum::<f64>() / mine.len() as f64;
            table.push((
                a,
                n,
                rmse,
                mine[0].2.acceptance,
                mine[0].2.swap_acceptance,
                secs,
            ));
            let mut ch = [0.0; 3];
            for r in &mine {
                for (c, v) in ch.iter_mut().enumerate() {
                    *v += r.2.image.rmse_channel(&reference, c) / mine.len() as f64;
                }
            }
            channels.push((a, n, ch));
            let first = &mine[0].2.image;
            let stem = format!("{}_n{}", a.name().to_lowercase(), n);
            image::save(&first.to_png(exposure), &dir.join(format!("{stem}.png")))?;
            image::save(
                &first.error_png(&reference, 5.0 * best),
                &dir.join(format!("{stem}_error.png")),
            )?;
            tiles.push(first.to_png(exposure));
            errs.push(first.error_png(&reference, 5.0 * best));
        }
        tiles.extend(errs);
        image::save(
            &image::mosaic(&tiles, 8),
            &dir.join(format!("mosaic_n{n}.png")),
        )?;
    }

    println!(
        "\n== Table 1: RMSE against the reference (mean ± sd over independent runs; the reference's own RMS error {ref_se:.1e} is included)"
    );
    print!("{:<12}", "algorithm");
    for &(n, runs) in &plan.ns {
        print!(" {:>26}", format!("n = {:.0e} ({runs} runs)", n as f64));
    }
    println!(" {:>10} {:>10} {:>9}", "accept", "swaps", "s/run");
    let stats = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let sd = if v.len() > 1 {
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        } else {
            f64::NAN
        };
        (m, sd)
    };
    for &a in &Algorithm::WITH_ST {
        print!("{:<12}", a.name());
        let mut last = None;
        for &(n, _) in &plan.ns {
            let row = table
                .iter()
                .find(|r| r.0 == a && r.1 == n)
                .ok_or("missing row")?;
            let (m, sd) = stats(&row.2);
            print!(" {:>26}", format!("{m:.3e} ± {sd:.1e}"));
            last = Some(row);
        }
        let row = last.ok_or("no rows")?;
        println!(
            " {:>9.1}% {:>10} {:>9.1}",
            100.0 * row.3,
            row.4
                .map(|s| format!("{:.1}%", 100.0 * s))
                .unwrap_or_else(|| "—".into()),
            row.5
        );
    }
    for &(n, _) in &plan.ns {
        let mean = |a: Algorithm| {
            table
                .iter()
                .find(|r| r.0 == a && r.1 == n)
                .map(|r| stats(&r.2).0)
                .unwrap_or(f64::NAN)
        };
        let (cmlt, mix, avg, ipsm) = (
            mean(Algorithm::Cmlt),
            mean(Algorithm::PssmltMix),
            mean(Algorithm::PssmltAvg),
            mean(Algorithm::CmltIpsm),
        );
        let best = Algorithm::ALL.iter().map(|&a| (mean(a), a)).fold(
            (f64::INFINITY, Algorithm::Cmlt),
            |b, x| {
                if x.0 < b.0 { x } else { b }
            },
        );
        println!(
            "n = {n}: best of the paper's six {} | CMLT best: {} | MIX < AVG: {} | IPSM between MIX and AVG: {} | CMLT-ST vs PSSMLT-2: {:.1}%",
            best.1.name(),
            best.1 == Algorithm::Cmlt,
            mix < avg,
            mix <= ipsm && ipsm <= avg,
            100.0 * (mean(Algorithm::CmltSt) / mean(Algorithm::Pssmlt2) - 1.0)
        );
        let _ = cmlt;
    }
    println!(
        "\n== RMSE per channel (mean over runs): green is light 2 seen through the hole; red and blue are mostly light 1"
    );
    for &(n, _) in &plan.ns {
        println!("n = {n}");
        for (a, _, ch) in channels.iter().filter(|c| c.1 == n) {
            println!(
                "  {:<12} R {:.3e}  G {:.3e}  B {:.3e}",
                a.name(),
                ch[0],
                ch[1],
                ch[2]
            );
        }
    }
    println!("\nimages: {}", dir.display());
    Ok(())
}
