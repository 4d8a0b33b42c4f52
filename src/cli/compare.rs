//! `charted compare`: render a scene with several algorithms for the same wall-clock time, record
//! the error against a reference at checkpoints, and write a CSV, a plot of error against time, the
//! final images with their error images, and one side-by-side PNG.

use super::CliError;
use super::algo::{self, Algo, RenderOptions};
use super::duration::parse_duration;
use super::metropolis::{MetropolisArgs, run_method};
use super::plot::{Series, error_plot};
use super::render::write_outputs;
use super::scene_arg;
use clap::Args;
use light_transport::film::Film;
use light_transport::film::{Image, error_image, metrics, read_image, write_bytes_png};
use light_transport::integrators::{Budget, Estimator, render};
use light_transport::metropolis::Method;
use light_transport::scene::Scene;
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

/// Options of `compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Scene: a built-in name or a pbrt-v3 file.
    pub scene: String,
    /// Algorithms, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "pt,bdpt")]
    pub algos: Vec<Algo>,
    /// Time per algorithm.
    #[arg(long, value_parser = parse_duration, default_value = "30s")]
    pub time: Duration,
    /// Reference image (EXR) of the same size; rendered first with BDPT for 4× the time if absent.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Number of checkpoints.
    #[arg(long, default_value_t = 5)]
    pub checkpoints: usize,
    /// Seed, depth, resolution, exposure, MIS.
    #[command(flatten)]
    pub options: RenderOptions,
    /// Metropolis options (pssmlt, mmlt, mlt, cmlt).
    #[command(flatten)]
    pub metropolis: MetropolisArgs,
    /// Path-space options (mlt, erpt).
    #[command(flatten)]
    pub pathspace: super::pathspace::PathSpaceArgs,
    /// Charted MLT options (cmlt).
    #[command(flatten)]
    pub cmlt: super::cmlt::CmltArgs,
    /// Output folder. Default: `out/compare-<scene>`.
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
}

/// One checkpoint of one algorithm.
struct Row {
    algo: &'static str,
    checkpoint: usize,
    seconds: f64,
    spp: u64,
    rmse: f64,
    rel_mse: f64,
}

/// Records the error against the reference whenever the elapsed time passes a checkpoint.
struct Checkpoints<'a> {
    marks: Vec<Duration>,
    next: usize,
    name: &'static str,
    reference: &'a Image,
    rows: &'a mut Vec<Row>,
    err: Option<CliError>,
}

impl<'a> Checkpoints<'a> {
    fn new(
        a: &CompareArgs,
        name: &'static str,
        reference: &'a Image,
        rows: &'a mut Vec<Row>,
    ) -> Self {
        let n = a.checkpoints.max(1);
        let marks = (1..=n)
            .map(|k| a.time.mul_f64(k as f64 / n as f64))
            .collect();
        Self {
            marks,
            next: 0,
            name,
            reference,
            rows,
            err: None,
        }
    }

    /// Record any checkpoint passed; `false` once the time is up or on error.
    fn see(&mut self, film: &Film, elapsed: Duration, spp: u64) -> bool {
        self.record(film, elapsed, spp, false)
    }

    /// Record the checkpoints `elapsed` has reached (all the remaining ones when `last`: a time
    /// budget's fractional last pass may end a hair before the budget).
    fn record(&mut self, film: &Film, elapsed: Duration, spp: u64, last: bool) -> bool {
        while self.next < self.marks.len() && (last || elapsed >= self.marks[self.next]) {
            match metrics(&Image::from_film(film), self.reference) {
                Ok(m) => self.rows.push(Row {
                    algo: self.name,
                    checkpoint: self.next + 1,
                    seconds: elapsed.as_secs_f64(),
                    spp,
                    rmse: m.rmse,
                    rel_mse: m.rel_mse,
                }),
                Err(e) => self.err = Some(e.into()),
            }
            self.next += 1;
        }
        self.err.is_none() && self.next < self.marks.len()
    }

    fn finish(self) -> Result<(), CliError> {
        self.err.map_or(Ok(()), Err)
    }
}

fn track<E: Estimator>(
    scene: &Scene,
    est: &E,
    a: &CompareArgs,
    name: &'static str,
    reference: &Image,
    rows: &mut Vec<Row>,
) -> Result<Image, CliError> {
    let mut cp = Checkpoints::new(a, name, reference, rows);
    let (film, stats) = render(
        scene,
        est,
        Budget::Time(a.time),
        a.options.seed,
        |film, p| cp.see(film, p.elapsed, p.passes),
    );
    cp.record(&film, stats.elapsed, stats.passes, true);
    cp.finish()?;
    eprintln!(
        "  {name}: {} samples per pixel in {:.1} s, {:.2} M rays/s",
        super::render::spp_text(stats.samples_per_pixel),
        stats.elapsed.as_secs_f64(),
        stats.rays as f64 / stats.elapsed.as_secs_f64().max(1e-9) / 1e6
    );
    Ok(Image::from_film(&film))
}

/// A Metropolis method at equal time: the clock includes its bootstrap and seeding.
fn track_metropolis<M: Method>(
    scene: &Scene,
    method: &M,
    a: &CompareArgs,
    name: &'static str,
    reference: &Image,
    rows: &mut Vec<Row>,
) -> Result<Image, CliError> {
    let start = std::time::Instant::now();
    let pixels = (scene.camera.width * scene.camera.height) as u64;
    let settings = a.metropolis.settings(
        light_transport::metropolis::Budget::Time(a.time),
        a.options.seed,
    );
    let mut cp = Checkpoints::new(a, name, reference, rows);
    let (film, s) = run_method(scene, method, &settings, true, |film, mutations, _| {
        cp.see(film, start.elapsed(), mutations / pixels.max(1))
    })?;
    cp.finish()?;
    let acc = s.stats.total();
    eprintln!(
        "  {name}: {:.1} mutations per pixel, bootstrap {:.1} s, acceptance {:.1}%, {:.2} M mutations/s",
        s.mutations as f64 / pixels as f64,
        s.bootstrap_time.as_secs_f64(),
        100.0 * acc.acceptance_rate(),
        s.mutations as f64 / s.chain_time.as_secs_f64().max(1e-9) / 1e6
    );
    if s.kinds.len() > 1 {
        eprint!("{}", s.stats.table(&s.kinds));
    }
    Ok(Image::from_film(&film))
}

pub fn run(a: CompareArgs) -> Result<(), CliError> {
    if a.algos.is_empty() {
        return Err(CliError::Usage(
            "--algos needs at least one algorithm".into(),
        ));
    }
    let loaded = scene_arg::load(&a.scene)?;
    let (scene, _) = scene_arg::build(&loaded, a.options.resolution)?;
    let dir = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/compare-{}", loaded.name)));
    std::fs::create_dir_all(&dir).map_err(|source| CliError::Io {
        path: dir.clone(),
        source,
    })?;
    let common = a.options.common();
    let reference = match &a.reference {
        Some(p) => read_image(p)?,
        None => {
            let t = a.time * 4;
            eprintln!(
                "no --reference: rendering one with bdpt for {:.0} s",
                t.as_secs_f64()
            );
            let (film, _) = render(
                &scene,
                &algo::bdpt(&common),
                Budget::Time(t),
                a.options.seed ^ 0xABCD,
                |_, _| true,
            );
            let img = Image::from_film(&film);
            write_outputs(
                &img,
                &dir.join("reference.exr"),
                &dir.join("reference.png"),
                a.options.exposure,
            )?;
            img
        }
    };
    if (reference.width, reference.height) != (scene.camera.width, scene.camera.height) {
        return Err(CliError::Usage(format!(
            "the reference is {}×{} but the render is {}×{}: pass --resolution {}x{}",
            reference.width,
            reference.height,
            scene.camera.width,
            scene.camera.height,
            reference.width,
            reference.height
        )));
    }
    let mut rows = Vec::new();
    let mut finals = Vec::new();
    for algo in &a.algos {
        eprintln!(
            "rendering {} for {:.1} s",
            algo.name(),
            a.time.as_secs_f64()
        );
        let img = match algo {
            Algo::Pt => track(
                &scene,
                &algo::path_tracer(&common),
                &a,
                "pt",
                &reference,
                &mut rows,
            )?,
            Algo::Lt => track(
                &scene,
                &algo::light_tracer(&common),
                &a,
                "lt",
                &reference,
                &mut rows,
            )?,
            Algo::Bdpt => track(
                &scene,
                &algo::bdpt(&common),
                &a,
                "bdpt",
                &reference,
                &mut rows,
            )?,
            Algo::Pssmlt => track_metropolis(
                &scene,
                &algo::pssmlt(&common, &a.metropolis)?,
                &a,
                "pssmlt",
                &reference,
                &mut rows,
            )?,
            Algo::Mmlt => track_metropolis(
                &scene,
                &algo::mmlt(&common, &a.metropolis)?,
                &a,
                "mmlt",
                &reference,
                &mut rows,
            )?,
            Algo::Mlt => track_metropolis(
                &scene,
                &a.pathspace.mlt(&common, &a.metropolis)?,
                &a,
                "mlt",
                &reference,
                &mut rows,
            )?,
            Algo::Cmlt => track_metropolis(
                &scene,
                &a.cmlt.cmlt(&scene, &common, &a.metropolis, &a.pathspace)?,
                &a,
                "cmlt",
                &reference,
                &mut rows,
            )?,
            Algo::Erpt => {
                let e = a.pathspace.erpt(&scene, &common, &a.metropolis)?;
                let img = track(&scene, &e, &a, "erpt", &reference, &mut rows)?;
                let (stats, chains) = e.statistics();
                let names = light_transport::pathspace::Mutations::kinds();
                eprintln!(
                    "  erpt: e_d = {:.3e}, {chains} chains of {} mutations, acceptance {:.1}%\n{}",
                    e.quantum,
                    e.settings.chain_length,
                    100.0 * stats.total().acceptance_rate(),
                    stats.table(&names)
                );
                img
            }
        };
        write_outputs(
            &img,
            &dir.join(format!("{}.exr", algo.name())),
            &dir.join(format!("{}.png", algo.name())),
            a.options.exposure,
        )?;
        finals.push((algo.name(), img));
    }
    // CSV.
    let csv = dir.join("errors.csv");
    let mut f = std::fs::File::create(&csv).map_err(|source| CliError::Io {
        path: csv.clone(),
        source,
    })?;
    let io = |source| CliError::Io {
        path: csv.clone(),
        source,
    };
    writeln!(f, "algorithm,checkpoint,seconds,spp,rmse,relmse").map_err(io)?;
    for r in &rows {
        writeln!(
            f,
            "{},{},{:.3},{},{:.6e},{:.6e}",
            r.algo, r.checkpoint, r.seconds, r.spp, r.rmse, r.rel_mse
        )
        .map_err(|source| CliError::Io {
            path: csv.clone(),
            source,
        })?;
    }
    // Plot.
    let series: Vec<Series> = finals
        .iter()
        .map(|(n, _)| Series {
            name: n.to_string(),
            points: rows
                .iter()
                .filter(|r| r.algo == *n)
                .map(|r| (r.seconds, r.rmse))
                .collect(),
        })
        .collect();
    let plots = error_plot(
        &dir.join("rmse"),
        &format!("{}: RMSE against time", loaded.name),
        "RMSE",
        &series,
    )
    .map_err(CliError::Usage)?;
    // Side by side: reference | each algorithm, and the error images underneath.
    let mut tiles: Vec<Vec<[u8; 3]>> = vec![to_srgb(&reference, a.options.exposure)];
    let mut errs: Vec<Vec<[u8; 3]>> = vec![error_image(&reference, &reference, 1.0)?];
    for (_, img) in &finals {
        tiles.push(to_srgb(img, a.options.exposure));
        errs.push(error_image(img, &reference, 0.5)?);
    }
    tiles.extend(errs);
    let (w, h) = (reference.width, reference.height);
    let cols = finals.len() + 1;
    let (mw, mh) = (cols * (w + 4) - 4, 2 * (h + 4) - 4);
    let mut mosaic = vec![[255u8; 3]; mw * mh];
    for (i, t) in tiles.iter().enumerate() {
        let (ox, oy) = ((i % cols) * (w + 4), (i / cols) * (h + 4));
        for y in 0..h {
            mosaic[(oy + y) * mw + ox..(oy + y) * mw + ox + w]
                .copy_from_slice(&t[y * w..(y + 1) * w]);
        }
    }
    let side = dir.join("side_by_side.png");
    write_bytes_png(mw, mh, &mosaic, &side)?;
    println!(
        "{:<8} {:>10} {:>8} {:>12} {:>12}",
        "algo", "seconds", "spp", "RMSE", "relMSE"
    );
    for r in rows.iter().filter(|r| r.checkpoint == a.checkpoints.max(1)) {
        println!(
            "{:<8} {:>10.1} {:>8} {:>12.4e} {:>12.4e}",
            r.algo, r.seconds, r.spp, r.rmse, r.rel_mse
        );
    }
    println!(
        "wrote {}, {}, {} (top: reference and images; bottom: relative error, yellow = 50%)",
        csv.display(),
        plots
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "),
        side.display()
    );
    Ok(())
}

fn to_srgb(img: &Image, exposure: f64) -> Vec<[u8; 3]> {
    let s = 2f64.powf(exposure);
    let to8 = |v: f64| {
        (light_transport::film::srgb_encode((v * s).clamp(0.0, 1.0)) * 255.0).round() as u8
    };
    img.pixels
        .iter()
        .map(|p| [to8(p[0]), to8(p[1]), to8(p[2])])
        .collect()
}
