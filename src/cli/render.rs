//! `charted render`: render a scene with one algorithm, with a progress bar, periodic writes of
//! the current image, and a summary.

use super::CliError;
use super::algo::{self, Algo, RenderOptions};
use super::duration::parse_duration;
use super::metropolis::{MetropolisArgs, print_stats, run_method};
use super::pathspace::{PathSpaceArgs, print_erpt_stats};
use super::scene_arg;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use light_transport::film::{Film, Image, write_exr, write_png};
use light_transport::integrators::{Budget, Estimator, RenderStats, render};
use light_transport::metropolis;
use light_transport::path::MisHeuristic;
use light_transport::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Options of `render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene: a built-in name (cornell, caustic, door, ring) or a pbrt-v3 file.
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// Algorithm.
    #[arg(long, value_enum, default_value_t = Algo::Bdpt)]
    pub algo: Algo,
    /// Samples per pixel (mutations per pixel for Metropolis algorithms; default 16 when no
    /// --time is given).
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// Wall-clock budget, e.g. 30s, 2m, 1h.
    #[arg(long, value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Output file (.exr; a .png with the same stem is written beside it). Default:
    /// `out/<scene>-<algo>.exr`.
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// Write the current image this often during long renders.
    #[arg(long, value_parser = parse_duration, default_value = "30s")]
    pub write_every: Duration,
    /// Seed, depth, resolution, exposure, MIS.
    #[command(flatten)]
    pub options: RenderOptions,
    /// Metropolis options (pssmlt, mmlt, mlt, cmlt).
    #[command(flatten)]
    pub metropolis: MetropolisArgs,
    /// Path-space options (mlt, erpt).
    #[command(flatten)]
    pub pathspace: PathSpaceArgs,
    /// Charted MLT options (cmlt).
    #[command(flatten)]
    pub cmlt: super::cmlt::CmltArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// MIS heuristic option.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Heuristic {
    /// Balance heuristic.
    Balance,
    /// Power heuristic (β = 2).
    Power,
}

impl From<Heuristic> for MisHeuristic {
    fn from(h: Heuristic) -> Self {
        match h {
            Heuristic::Balance => MisHeuristic::Balance,
            Heuristic::Power => MisHeuristic::Power,
        }
    }
}

/// Where the EXR and PNG go.
pub fn output_paths(output: &Option<PathBuf>, scene: &str, algo: &str) -> (PathBuf, PathBuf) {
    let exr = output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("out/{scene}-{algo}.exr")));
    let exr = if exr.extension().is_some_and(|e| e == "png") {
        exr.with_extension("exr")
    } else {
        exr
    };
    (exr.clone(), exr.with_extension("png"))
}

/// Write an image as EXR and PNG, creating the folder.
pub fn write_outputs(img: &Image, exr: &Path, png: &Path, exposure: f64) -> Result<(), CliError> {
    if let Some(dir) = exr.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| CliError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    write_exr(img, exr)?;
    write_png(img, exposure, png)?;
    Ok(())
}

/// Run one integrator on a scene with a progress bar and periodic writes.
pub fn run_integrator<E: Estimator>(
    scene: &Scene,
    est: &E,
    budget: Budget,
    seed: u64,
    quiet: bool,
    mut every: impl FnMut(&Film),
) -> (Film, RenderStats) {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        match budget {
            Budget::SamplesPerPixel(n) => ProgressBar::new(n),
            Budget::Time(t) => ProgressBar::new(t.as_millis() as u64),
        }
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let out = render(scene, est, budget, seed, |film, p| {
        match budget {
            Budget::SamplesPerPixel(_) => bar.set_position(p.passes),
            Budget::Time(_) => bar.set_position(p.elapsed.as_millis() as u64),
        }
        let rate = p.rays as f64 / p.elapsed.as_secs_f64().max(1e-9) / 1e6;
        bar.set_message(format!("{} spp, {rate:.1} Mrays/s", p.passes));
        every(film);
        true
    });
    bar.finish_and_clear();
    out
}

pub fn run(a: RenderArgs) -> Result<(), CliError> {
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| CliError::Usage(format!("cannot set threads: {e}")))?;
    }
    if a.spp == Some(0) {
        return Err(CliError::Usage("--spp must be at least 1".into()));
    }
    let budget = match (a.spp, a.time) {
        (Some(n), _) => Budget::SamplesPerPixel(n),
        (None, Some(t)) => Budget::Time(t),
        (None, None) => Budget::SamplesPerPixel(16),
    };
    let loaded = scene_arg::load(&a.scene)?;
    let (scene, build_time) = scene_arg::build(&loaded, a.options.resolution)?;
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let (exr, png) = output_paths(&a.output, &loaded.name, a.algo.name());
    let common = a.options.common();
    let mut last_write = Instant::now();
    let every = |film: &Film| {
        if last_write.elapsed() >= a.write_every {
            let _ = write_outputs(&Image::from_film(film), &exr, &png, a.options.exposure);
            last_write = Instant::now();
        }
    };
    let mut mlt_stats = None;
    let mut erpt = None;
    let (film, stats) = match a.algo {
        Algo::Pt => run_integrator(
            &scene,
            &algo::path_tracer(&common),
            budget,
            a.options.seed,
            a.quiet,
            every,
        ),
        Algo::Lt => run_integrator(
            &scene,
            &algo::light_tracer(&common),
            budget,
            a.options.seed,
            a.quiet,
            every,
        ),
        Algo::Bdpt => run_integrator(
            &scene,
            &algo::bdpt(&common),
            budget,
            a.options.seed,
            a.quiet,
            every,
        ),
        Algo::Erpt => {
            let e = a.pathspace.erpt(&scene, &common, &a.metropolis)?;
            let out = run_integrator(&scene, &e, budget, a.options.seed, a.quiet, every);
            erpt = Some(e);
            out
        }
        Algo::Pssmlt | Algo::Mmlt | Algo::Mlt | Algo::Cmlt => {
            let mb = match budget {
                Budget::SamplesPerPixel(n) => metropolis::Budget::MutationsPerPixel(n as f64),
                Budget::Time(t) => metropolis::Budget::Time(t),
            };
            let settings = a.metropolis.settings(mb, a.options.seed);
            let mut every = every;
            let cb = |film: &Film, _m: u64, _e: std::time::Duration| {
                every(film);
                true
            };
            let (film, s) = match a.algo {
                Algo::Pssmlt => run_method(
                    &scene,
                    &algo::pssmlt(&common, &a.metropolis)?,
                    &settings,
                    a.quiet,
                    cb,
                )?,
                Algo::Mmlt => run_method(
                    &scene,
                    &algo::mmlt(&common, &a.metropolis)?,
                    &settings,
                    a.quiet,
                    cb,
                )?,
                Algo::Cmlt => run_method(
                    &scene,
                    &a.cmlt.cmlt(&scene, &common, &a.metropolis, &a.pathspace)?,
                    &settings,
                    a.quiet,
                    cb,
                )?,
                _ => run_method(
                    &scene,
                    &a.pathspace.mlt(&common, &a.metropolis)?,
                    &settings,
                    a.quiet,
                    cb,
                )?,
            };
            let pixels = (scene.camera.width * scene.camera.height) as u64;
            let rs = RenderStats {
                passes: s.mutations / pixels.max(1),
                samples_per_pixel: s.mutations as f64 / pixels.max(1) as f64,
                samples: s.mutations,
                rays: s.rays,
                elapsed: s.bootstrap_time + s.seed_time + s.chain_time,
                discarded: film.discarded,
            };
            mlt_stats = Some(s);
            (film, rs)
        }
    };
    let t = Instant::now();
    let img = Image::from_film(&film);
    write_outputs(&img, &exr, &png, a.options.exposure)?;
    super::shard::write_info(
        &exr,
        &super::shard::ShardInfo {
            samples: stats.samples_per_pixel,
            seed: a.options.seed,
            algo: a.algo.name().into(),
        },
    )?;
    let write_time = t.elapsed();
    let secs = stats.elapsed.as_secs_f64().max(1e-9);
    println!(
        "scene      {} ({}×{}, {} triangles, {} spheres, {} lights)",
        loaded.name,
        scene.camera.width,
        scene.camera.height,
        scene.primitive_counts().0,
        scene.primitive_counts().1,
        scene.lights.len()
    );
    println!(
        "algorithm  {} (max depth {}, {:?} heuristic)",
        a.algo.name(),
        a.options.max_depth,
        a.options.mis
    );
    println!(
        "time       parse {:.2} s, build {:.2} s, render {:.2} s, write {:.2} s",
        loaded.parse_time.as_secs_f64(),
        build_time.as_secs_f64(),
        secs,
        write_time.as_secs_f64()
    );
    println!(
        "samples    {} spp, {:.2} M samples/s",
        spp_text(stats.samples_per_pixel),
        stats.samples as f64 / secs / 1e6
    );
    println!(
        "rays       {:.1} M, {:.2} M rays/s",
        stats.rays as f64 / 1e6,
        stats.rays as f64 / secs / 1e6
    );
    println!("discarded  {} non-finite samples", stats.discarded);
    if let Some(s) = &mlt_stats {
        print_stats(s, (scene.camera.width * scene.camera.height) as f64);
    }
    if let Some(e) = &erpt {
        print_erpt_stats(e, (scene.camera.width * scene.camera.height) as f64);
    }
    println!("wrote      {} and {}", exr.display(), png.display());
    Ok(())
}

/// Samples per pixel for people: whole numbers as such, a fractional last pass with two decimals.
pub fn spp_text(spp: f64) -> String {
    if spp.fract() == 0.0 {
        format!("{spp}")
    } else {
        format!("{spp:.2}")
    }
}
