//! Writes the benchmarks' terrain, a height field of `2 n²` triangles (1 057 058 for the default
//! `n = 727`), as a pbrt-v3 scene with a camera and a square area light above it, so that the
//! whole pipeline (parse, scene, BVH) can be measured on a large mesh, for example its peak
//! memory:
//!
//! ```text
//! cargo run --release --example terrain -- out/terrain.pbrt 727
//! /usr/bin/time -f '%M KB' target/release/charted render out/terrain.pbrt --algo pt --spp 1 \
//!     --resolution 64x36 -o out/terrain.exr
//! ```
//!
//! Both arguments are optional (defaults: `out/terrain.pbrt`, `727`).

mod height;

use std::error::Error;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(args.next().unwrap_or_else(|| "out/terrain.pbrt".into()));
    let n: usize = match args.next() {
        Some(s) => s
            .parse()
            .map_err(|e| format!("grid size {s:?} is not a positive integer: {e}"))?,
        None => 727,
    };
    if n == 0 || n > 4000 {
        return Err(format!("grid size {n} is outside 1..=4000").into());
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut w = BufWriter::new(File::create(&path)?);
    writeln!(w, "# Terrain of the benchmarks: {} triangles.", 2 * n * n)?;
    writeln!(w, "LookAt 0.5 1.2 -0.6  0.5 0 0.5  0 1 0")?;
    writeln!(w, "Camera \"perspective\" \"float fov\" 45")?;
    writeln!(
        w,
        "Film \"image\" \"integer xresolution\" 512 \"integer yresolution\" 288"
    )?;
    writeln!(w, "WorldBegin")?;
    writeln!(w, "AttributeBegin")?;
    writeln!(w, "  AreaLightSource \"diffuse\" \"rgb L\" [ 20 20 20 ]")?;
    writeln!(w, "  Material \"matte\" \"rgb Kd\" [ 0 0 0 ]")?;
    writeln!(
        w,
        "  Shape \"trianglemesh\" \"integer indices\" [ 0 1 2  0 2 3 ]"
    )?;
    writeln!(
        w,
        "    \"point P\" [ 0.3 1 0.3  0.7 1 0.3  0.7 1 0.7  0.3 1 0.7 ]"
    )?;
    writeln!(w, "AttributeEnd")?;
    writeln!(w, "Material \"matte\" \"rgb Kd\" [ 0.5 0.45 0.4 ]")?;
    write!(w, "Shape \"trianglemesh\" \"integer indices\" [")?;
    let index = |(i, j): (usize, usize)| i * (n + 1) + j;
    for i in 0..n {
        for j in 0..n {
            for t in height::cell_triangles(i, j) {
                write!(w, " {} {} {}", index(t[0]), index(t[1]), index(t[2]))?;
            }
        }
        writeln!(w)?;
    }
    write!(w, "]\n  \"point P\" [")?;
    for i in 0..=n {
        for j in 0..=n {
            let [x, y, z] = height::vertex(n, i, j);
            write!(w, " {x} {y} {z}")?;
        }
        writeln!(w)?;
    }
    writeln!(w, "]")?;
    writeln!(w, "WorldEnd")?;
    w.flush()?;
    println!("wrote {} ({} triangles)", path.display(), 2 * n * n);
    Ok(())
}
