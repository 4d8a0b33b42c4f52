//! `charted diff`: error metrics of one image against another, and a false-colour error image.

use super::CliError;
use clap::Args;
use light_transport::film::{error_image, metrics, read_image, write_bytes_png};
use std::path::PathBuf;

/// Options of `diff`.
#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The image to measure (EXR or PNG).
    pub image: PathBuf,
    /// The reference (same size).
    pub reference: PathBuf,
    /// Write the relative-error image here (PNG; yellow = `--scale`).
    #[arg(long)]
    pub error_image: Option<PathBuf>,
    /// Box-filter the reference down to the image's size when it is an integer multiple of it.
    #[arg(long)]
    pub fit: bool,
    /// Relative error at the top of the colour ramp.
    #[arg(long, default_value_t = 0.5)]
    pub scale: f64,
}

pub fn run(a: DiffArgs) -> Result<(), CliError> {
    let img = read_image(&a.image)?;
    let mut reference = read_image(&a.reference)?;
    if a.fit && (reference.width, reference.height) != (img.width, img.height) {
        let k = reference.width / img.width.max(1);
        reference = reference
            .downsample(k)
            .filter(|r| (r.width, r.height) == (img.width, img.height))
            .ok_or_else(|| {
                CliError::Usage(format!(
                    "--fit: the reference ({}×{}) is not an integer multiple of the image ({}×{})",
                    reference.width, reference.height, img.width, img.height
                ))
            })?;
        println!(
            "reference box-filtered by {k} to {}×{}",
            img.width, img.height
        );
    }
    let m = metrics(&img, &reference)?;
    let (mi, mr) = (img.mean(), reference.mean());
    println!(
        "RMSE {:.5e}  MSE {:.5e}  relMSE {:.5e}  MAE {:.5e}  E_rms {:.5}",
        m.rmse, m.mse, m.rel_mse, m.mae, m.rel_luminance_rms
    );
    println!(
        "mean image {:.5} {:.5} {:.5}; reference {:.5} {:.5} {:.5}; ratio {:.4} {:.4} {:.4}",
        mi[0],
        mi[1],
        mi[2],
        mr[0],
        mr[1],
        mr[2],
        mi[0] / mr[0],
        mi[1] / mr[1],
        mi[2] / mr[2]
    );
    if let Some(p) = a.error_image {
        if !(a.scale > 0.0 && a.scale.is_finite()) {
            return Err(CliError::Usage("--scale must be positive".into()));
        }
        write_bytes_png(
            img.width,
            img.height,
            &error_image(&img, &reference, a.scale)?,
            &p,
        )?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
