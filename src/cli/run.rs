//! Running a renderer from the command line: a progress bar, periodic callbacks, interrupts.

use super::CliError;
use indicatif::{ProgressBar, ProgressStyle};
use light_transport::Budget;
use light_transport::film::{Film, FilmView};
use light_transport::renderer::{Control, Progress, Renderer, Report};
use light_transport::scene::Scene;

/// Run `renderer` on `scene` with a progress bar (hidden when `quiet`); `every(film, progress)`
/// sees the film after every pass or round and may stop the render by returning `false`.
/// Interrupts (SIGINT, SIGTERM) stop it at the end of the current pass.
pub fn run_renderer(
    scene: &Scene,
    renderer: &dyn Renderer,
    budget: Budget,
    seed: u64,
    quiet: bool,
    mut every: impl FnMut(FilmView<'_>, &Progress) -> bool,
) -> Result<(Film, Report), CliError> {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        match budget {
            Budget::SamplesPerPixel(n) => ProgressBar::new((n * 1000.0) as u64),
            Budget::Time(t) => ProgressBar::new(t.as_millis() as u64),
        }
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message("starting");
    let mut progress = |film: FilmView<'_>, p: &Progress| {
        match budget {
            Budget::SamplesPerPixel(_) => bar.set_position((p.samples_per_pixel * 1000.0) as u64),
            Budget::Time(_) => bar.set_position(p.elapsed.as_millis() as u64),
        }
        let secs = p.elapsed.as_secs_f64().max(1e-9);
        let rays = if p.rays > 0 {
            format!(", {:.1} Mrays/s", p.rays as f64 / secs / 1e6)
        } else {
            String::new()
        };
        bar.set_message(format!("{:.1} per pixel{rays}", p.samples_per_pixel));
        every(film, p)
    };
    let mut control = Control {
        progress: &mut progress,
        stop: super::interrupt::stop_flag(),
    };
    let out = renderer.render(scene, budget, seed, &mut control);
    bar.finish_and_clear();
    Ok(out?)
}
