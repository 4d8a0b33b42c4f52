//! `charted render`: render a scene with one algorithm, with a progress bar, periodic writes of
//! the current image, and a summary.

use super::CliError;
use super::duration::parse_duration;
use super::options::RenderOptions;
use super::registry::{self, AlgoArgs, Entry};
use super::run::run_renderer;
use super::scene_arg;
use clap::Args;
use light_transport::Budget;
use light_transport::film::{FilmView, Image, write_exr, write_png};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Options of `render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene: a built-in name (cornell, caustic, door, ring, pool, pool-lamp, rooms, lantern, box) or a pbrt-v3 file.
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// Algorithm.
    #[arg(long, value_parser = registry::algo_parser(), default_value = "bdpt")]
    pub algo: &'static Entry,
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
    /// The algorithms' options.
    #[command(flatten)]
    pub algos: AlgoArgs,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
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
        (Some(n), _) => Budget::SamplesPerPixel(n as f64),
        (None, Some(t)) => Budget::Time(t),
        (None, None) => Budget::SamplesPerPixel(16.0),
    };
    let mut loaded = scene_arg::load(&a.scene)?;
    let (scene, build_time) =
        scene_arg::build_taking(&mut loaded, a.options.resolution, a.options.compact())?;
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
    let (exr, png) = output_paths(&a.output, &loaded.name, a.algo.name);
    let renderer = registry::build(a.algo, &scene, &a.options.common(), &a.algos)?;
    let mut last_write = Instant::now();
    let every = |film: FilmView<'_>, _: &light_transport::renderer::Progress| {
        if last_write.elapsed() >= a.write_every {
            let _ = write_outputs(&film.image(), &exr, &png, a.options.exposure);
            last_write = Instant::now();
        }
        true
    };
    let (film, report) = run_renderer(
        &scene,
        renderer.as_ref(),
        budget,
        a.options.seed,
        a.quiet,
        every,
    )?;
    let t = Instant::now();
    let img = Image::from_film(&film);
    write_outputs(&img, &exr, &png, a.options.exposure)?;
    super::shard::write_info(
        &exr,
        &super::shard::ShardInfo {
            samples: report.samples_per_pixel,
            seed: a.options.seed,
            algo: a.algo.name.into(),
        },
    )?;
    let write_time = t.elapsed();
    let secs = report.elapsed.as_secs_f64().max(1e-9);
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
        a.algo.name, a.options.max_depth, a.options.mis
    );
    println!(
        "time       parse {:.2} s, build {:.2} s, render {:.2} s, write {:.2} s",
        loaded.parse_time.as_secs_f64(),
        build_time.as_secs_f64(),
        secs,
        write_time.as_secs_f64()
    );
    println!(
        "samples    {} spp, {:.2} M samples/s{}",
        spp_text(report.samples_per_pixel),
        report.samples as f64 / secs / 1e6,
        if report.interrupted {
            " (interrupted)"
        } else {
            ""
        }
    );
    println!(
        "rays       {:.1} M, {:.2} M rays/s",
        report.rays as f64 / 1e6,
        report.rays as f64 / secs / 1e6
    );
    println!("discarded  {} non-finite samples", report.discarded);
    if let Some(peak) = super::memory::peak_resident_bytes() {
        println!("memory     peak {:.1} MB resident", peak as f64 / 1e6);
    }
    for line in &report.details {
        println!("{line}");
    }
    println!("wrote      {} and {}", exr.display(), png.display());
    if report.interrupted {
        return Err(CliError::Interrupted);
    }
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
