//! A perceptually ordered false-colour ramp (viridis-like) for error images.

/// Colour of `t ∈ [0, 1]` as sRGB bytes (dark purple → teal → yellow).
pub fn false_colour(t: f64) -> [u8; 3] {
    const RAMP: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let s = t * (RAMP.len() - 1) as f64;
    let k = (s.floor() as usize).min(RAMP.len() - 2);
    let f = s - k as f64;
    let c = |n: usize| (RAMP[k][n] + f * (RAMP[k + 1][n] - RAMP[k][n])).round() as u8;
    [c(0), c(1), c(2)]
}
