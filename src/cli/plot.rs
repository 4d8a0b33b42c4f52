//! Error-against-time plots (log–log) as PNG and SVG. Labels need a TrueType font; the DejaVu
//! fonts of most Linux systems are used. Without one, no plot is drawn (the CSV has the data).

use plotters::prelude::*;
use std::path::Path;

/// One curve.
pub struct Series {
    /// Label.
    pub name: String,
    /// `(seconds, error)` points.
    pub points: Vec<(f64, f64)>,
}

const FONTS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

/// Register a sans-serif font for bitmap text; false if none was found.
fn register_font() -> bool {
    static DONE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *DONE.get_or_init(|| {
        for f in FONTS {
            if let Ok(bytes) = std::fs::read(f) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let pts = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0 < x1) {
        x1 = x0 * 2.0 + 1e-3;
    }
    if !(y0 < y1) {
        y1 = y0 * 2.0 + 1e-9;
    }
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 * 0.9..x1 * 1.1).log_scale(),
            (y0 * 0.8..y1 * 1.25).log_scale(),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc(y_label)
        .draw()
        .map_err(err)?;
    for (i, s) in series.iter().enumerate() {
        let c = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(err)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Write `<stem>.png` and `<stem>.svg`. Returns the files written (none when no font was found).
pub fn error_plot(
    stem: &Path,
    title: &str,
    y_label: &str,
    series: &[Series],
) -> Result<Vec<std::path::PathBuf>, String> {
    if !register_font() {
        eprintln!(
            "note: no DejaVu font found ({}); skipping the plot, the CSV has the data",
            FONTS.join(", ")
        );
        return Ok(vec![]);
    }
    let png = stem.with_extension("png");
    draw(
        BitMapBackend::new(&png, (800, 560)).into_drawing_area(),
        title,
        y_label,
        series,
    )?;
    let svg = stem.with_extension("svg");
    draw(
        SVGBackend::new(&svg, (800, 560)).into_drawing_area(),
        title,
        y_label,
        series,
    )?;
    Ok(vec![png, svg])
}
