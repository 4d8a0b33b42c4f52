//! Shards: every render writes beside its EXR a small sidecar (`<image>.exr.samples`) with the
//! number of samples and the seed, so `charted merge` can combine partial renders of one scene made
//! on different machines with correct weights: `Σ n_i I_i / Σ n_i`, each shard being an unbiased
//! estimate with `n_i` samples per pixel.

use super::CliError;
use clap::Args;
use light_transport::film::{Image, read_image, write_exr, write_png};
use std::path::{Path, PathBuf};

/// What a shard's sidecar records.
#[derive(Clone, Debug, PartialEq)]
pub struct ShardInfo {
    /// Samples per pixel (or per-pixel equivalent).
    pub samples: f64,
    /// Master seed.
    pub seed: u64,
    /// Algorithm.
    pub algo: String,
}

fn sidecar(exr: &Path) -> PathBuf {
    let mut s = exr.as_os_str().to_owned();
    s.push(".samples");
    PathBuf::from(s)
}

/// Write the sidecar of `exr`.
pub fn write_info(exr: &Path, info: &ShardInfo) -> Result<(), CliError> {
    let p = sidecar(exr);
    std::fs::write(
        &p,
        format!(
            "samples={}\nseed={}\nalgo={}\n",
            info.samples, info.seed, info.algo
        ),
    )
    .map_err(|source| CliError::Io { path: p, source })
}

/// Read the sidecar of `exr`.
pub fn read_info(exr: &Path) -> Result<ShardInfo, CliError> {
    let p = sidecar(exr);
    let text = std::fs::read_to_string(&p).map_err(|source| CliError::Io {
        path: p.clone(),
        source,
    })?;
    let mut info = ShardInfo {
        samples: f64::NAN,
        seed: 0,
        algo: String::new(),
    };
    for (i, line) in text.lines().enumerate() {
        let Some((k, v)) = line.split_once('=') else {
            continue;
        };
        let bad = || {
            CliError::Usage(format!(
                "{}:{}: bad value {v:?} for {k}",
                p.display(),
                i + 1
            ))
        };
        match k.trim() {
            "samples" => info.samples = v.trim().parse().map_err(|_| bad())?,
            "seed" => info.seed = v.trim().parse().map_err(|_| bad())?,
            "algo" => info.algo = v.trim().to_string(),
            _ => {}
        }
    }
    if !(info.samples.is_finite() && info.samples > 0.0) {
        return Err(CliError::Usage(format!(
            "{}: no positive sample count",
            p.display()
        )));
    }
    Ok(info)
}

/// Options of `merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Partial renders (EXR files written by `charted render`, each with its `.samples` sidecar).
    #[arg(required = true, num_args = 2..)]
    pub shards: Vec<PathBuf>,
    /// Output EXR (a PNG is written beside it).
    #[arg(short = 'o', long, default_value = "out/merged.exr")]
    pub output: PathBuf,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f64,
}

pub fn run(a: MergeArgs) -> Result<(), CliError> {
    let mut total = 0.0;
    let mut acc: Option<Image> = None;
    let mut seeds = Vec::new();
    let mut algos = Vec::new();
    for s in &a.shards {
        let info = read_info(s)?;
        let img = read_image(s)?;
        if seeds.contains(&info.seed) {
            return Err(CliError::Usage(format!(
                "{}: seed {} was already used by another shard — the shards would be correlated; render shards with different --seed values",
                s.display(),
                info.seed
            )));
        }
        seeds.push(info.seed);
        algos.push(info.algo.clone());
        match &mut acc {
            None => {
                acc = Some(Image {
                    width: img.width,
                    height: img.height,
                    pixels: img.pixels.iter().map(|&p| p * info.samples).collect(),
                })
            }
            Some(m) => {
                if (m.width, m.height) != (img.width, img.height) {
                    return Err(CliError::Usage(format!(
                        "{} is {}×{}, the first shard {}×{}",
                        s.display(),
                        img.width,
                        img.height,
                        m.width,
                        m.height
                    )));
                }
                for (q, p) in m.pixels.iter_mut().zip(&img.pixels) {
                    *q += *p * info.samples;
                }
            }
        }
        total += info.samples;
    }
    let Some(mut merged) = acc else {
        return Err(CliError::Usage("no shards".into()));
    };
    for p in &mut merged.pixels {
        *p = *p / total;
    }
    if algos.iter().any(|x| x != &algos[0]) {
        eprintln!(
            "note: shards come from different algorithms ({}); all are unbiased estimates, so the weighted mean is still correct",
            algos.join(", ")
        );
    }
    if let Some(d) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|source| CliError::Io {
            path: d.to_path_buf(),
            source,
        })?;
    }
    write_exr(&merged, &a.output)?;
    write_png(&merged, a.exposure, &a.output.with_extension("png"))?;
    write_info(
        &a.output,
        &ShardInfo {
            samples: total,
            seed: seeds[0],
            algo: algos[0].clone(),
        },
    )?;
    println!(
        "merged {} shards ({} samples per pixel in all) into {}",
        a.shards.len(),
        total,
        a.output.display()
    );
    Ok(())
}
