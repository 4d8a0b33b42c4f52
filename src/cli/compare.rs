//! `charted compare`: render a scene with several algorithms for the same wall-clock time, record
//! the error against a reference at checkpoints, and write a CSV, a plot of error against time, the
//! final images with their error images, and one side-by-side PNG.

use super::CliError;
use super::duration::parse_duration;
use super::options::RenderOptions;
use super::plot::{Series, error_plot};
use super::registry::{self, AlgoArgs, Entry};
use super::render::write_outputs;
use super::run::run_renderer;
use super::scene_arg;
use clap::Args;
use light_transport::Budget;
use light_transport::film::FilmView;
use light_transport::film::{Image, error_image, metrics, read_image, write_bytes_png};
use light_transport::renderer::{Passes, Progress};
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

/// Options of `compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Scene: a built-in name or a pbrt-v3 file.
    pub scene: String,
    /// Algorithms, comma-separated.
    #[arg(long, value_delimiter = ',', value_parser = registry::algo_parser(), default_value = "pt,bdpt")]
    pub algos: Vec<&'static Entry>,
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
    /// The algorithms' options.
    #[command(flatten)]
    pub algo_options: AlgoArgs,
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
    fn see(&mut self, film: FilmView<'_>, elapsed: Duration, spp: u64) -> bool {
        self.record(film, elapsed, spp, false)
    }

    /// Record the checkpoints `elapsed` has reached (all the remaining ones when `last`: a time
    /// budget's fractional last pass may end a hair before the budget).
    fn record(&mut self, film: FilmView<'_>, elapsed: Duration, spp: u64, last: bool) -> bool {
        while self.next < self.marks.len() && (last || elapsed >= self.marks[self.next]) {
            match metrics(&film.image(), self.reference) {
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

/// Render one algorithm for the comparison's time, recording the checkpoints. For Metropolis
/// methods the clock includes the bootstrap and seeding.
fn track(
    scene: &light_transport::scene::Scene,
    entry: &'static Entry,
    a: &CompareArgs,
    reference: &Image,
    rows: &mut Vec<Row>,
) -> Result<(Image, bool), CliError> {
    let renderer = registry::build(entry, scene, &a.options.common(), &a.algo_options)?;
    let mut cp = Checkpoints::new(a, entry.name, reference, rows);
    let (film, report) = run_renderer(
        scene,
        renderer.as_ref(),
        Budget::Time(a.time),
        a.options.seed,
        true,
        |film: FilmView<'_>, p: &Progress| cp.see(film, p.elapsed, p.samples_per_pixel as u64),
    )?;
    cp.record(
        FilmView::One(&film),
        report.elapsed,
        report.samples_per_pixel as u64,
        true,
    );
    cp.finish()?;
    let secs = report.elapsed.as_secs_f64().max(1e-9);
    eprintln!(
        "  {}: {} per pixel in {:.1} s, {:.2} M samples/s, {:.2} M rays/s{}",
        entry.name,
        super::render::spp_text(report.samples_per_pixel),
        secs,
        report.samples as f64 / secs / 1e6,
        report.rays as f64 / secs / 1e6,
        if report.interrupted {
            " (interrupted)"
        } else {
            ""
        }
    );
    for line in &report.details {
        eprintln!("    {line}");
    }
    Ok((Image::from_film(&film), report.interrupted))
}

pub fn run(a: CompareArgs) -> Result<(), CliError> {
    if a.algos.is_empty() {
        return Err(CliError::Usage(
            "--algos needs at least one algorithm".into(),
        ));
    }
    let mut loaded = scene_arg::load(&a.scene)?;
    let (scene, _) =
        scene_arg::build_taking(&mut loaded, a.options.resolution, a.options.compact())?;
    let dir = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/compare-{}", loaded.name)));
    std::fs::create_dir_all(&dir).map_err(|source| CliError::Io {
        path: dir.clone(),
        source,
    })?;
    let reference = match &a.reference {
        Some(p) => read_image(p)?,
        None => {
            let t = a.time * 4;
            eprintln!(
                "no --reference: rendering one with bdpt for {:.0} s",
                t.as_secs_f64()
            );
            let bdpt = Passes::new(super::algos::bdpt::bdpt(&a.options.common()));
            let (film, _) = run_renderer(
                &scene,
                &bdpt,
                Budget::Time(t),
                a.options.seed ^ super::reference::REFERENCE_SEED,
                false,
                |_: FilmView<'_>, _: &Progress| true,
            )?;
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
    let mut interrupted = false;
    for &entry in &a.algos {
        if interrupted {
            break;
        }
        eprintln!("rendering {} for {:.1} s", entry.name, a.time.as_secs_f64());
        let (img, stopped) = track(&scene, entry, &a, &reference, &mut rows)?;
        interrupted = stopped;
        write_outputs(
            &img,
            &dir.join(format!("{}.exr", entry.name)),
            &dir.join(format!("{}.png", entry.name)),
            a.options.exposure,
        )?;
        finals.push((entry.name, img));
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
    if interrupted {
        return Err(CliError::Interrupted);
    }
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
