//! The height field of the benchmarks' terrain (shared by `benches/render.rs` and the `terrain`
//! example, which writes it as a pbrt scene): `2 n²` triangles over `[0, 1]²`.

/// Height at grid point `(i, j)` of an `n × n` grid.
pub fn height(n: usize, i: usize, j: usize) -> f64 {
    let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
    0.05 * ((x * 37.0).sin() * (y * 23.0).cos() + (x * 91.0 + y * 57.0).sin() * 0.3)
}

/// Vertex `(i, j)`, `0 ≤ i, j ≤ n`, as `[x, y, z]` with `y` up.
pub fn vertex(n: usize, i: usize, j: usize) -> [f64; 3] {
    [i as f64 / n as f64, height(n, i, j), j as f64 / n as f64]
}

/// The two triangles of cell `(i, j)`, as grid points.
pub fn cell_triangles(i: usize, j: usize) -> [[(usize, usize); 3]; 2] {
    [
        [(i, j), (i + 1, j), (i + 1, j + 1)],
        [(i, j), (i + 1, j + 1), (i, j + 1)],
    ]
}
