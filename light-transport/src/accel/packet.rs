//! The primitives of a BVH leaf as one packet of up to eight f32 triangles, tested against a ray
//! all at once (structure of arrays, one AVX2 vector per coordinate; Wald, Benthin and Boulos
//! 2008), as a conservative filter in front of the exact f64 test: a lane whose triangle the
//! f64 test of Möller and Trumbore (1997) could accept is always a *candidate*, so testing the
//! candidates alone in f64 gives the hits, bit for bit, that testing every primitive would.
//!
//! The filter evaluates the same determinant and numerators as the f64 test, in f32 from f32
//! copies of the vertex, edges, origin and direction, and accepts unless a quantity lies beyond
//! its error bound on the side that rejects. With `P = |o|∞ + |v₀|∞` and `E` the larger edge's
//! `|·|∞`, the rounding of the copies and of the arithmetic moves the determinant by less than
//! `K ε E²`, the barycentric numerators by less than `K ε P E` and the distance's numerator by
//! less than `K ε P E²`: each is a sum of three products of quantities bounded by `P`, `2E` and
//! `2PE`, whose inputs are off by at most an ulp, which comes to about `30 ε` times the bound;
//! `K = 64` leaves a margin of two over that, and covers `P` and `E` being taken from the f32
//! copies. (The test shows a margin of 16: `K = 4` still passes, `K = 0` fails.) A determinant
//! within its bound may have either sign, so the lane is a candidate.
//!
//! A sphere's lane holds its centre and radius and passes when the ray's line comes within the
//! radius of the centre and the segment overlaps the chord, each within the same kind of
//! bound. Primitives too large for f32 arithmetic are *forced* candidates, as spheres of
//! infinite radius.

use super::wide;
use crate::math::DVec3;

/// Lanes of a packet.
pub const LANES: usize = 8;

/// Fields per lane: `v₀`, `e₁ = v₁ − v₀`, `e₂ = v₂ − v₀`, three each, then the two norms the
/// error bounds use, `|v₀|∞` and `E = max(|e₁|∞, |e₂|∞)`, of those f32 copies (stored, since they
/// depend on the lane alone: the filter would otherwise spend 16 of its vector operations on
/// them). A sphere's lane holds its centre, its radius as `e₁`'s x, a NaN as `e₂`'s x, which
/// marks it, and `|c|∞` as the first norm. (The primitive indices are kept apart: as floats
/// their bits would be subnormal numbers, which the lanes past a leaf's last read, and
/// subnormal arithmetic is slow.)
const FIELDS: usize = 11;

/// The field of `|v₀|∞` (a sphere's `|c|∞`).
const V0_NORM: usize = 9;

/// The field of the larger edge's `|·|∞` (0 for a sphere).
const EDGE: usize = 10;

/// The error bounds' constant (see the module comment), times `ε = 2⁻²³`.
const K_EPS: f32 = 64.0 * f32::EPSILON;

/// Coordinates beyond this magnitude make a primitive a forced candidate (so that no product in
/// the filter can overflow).
const LARGEST: f64 = 1e9;

/// The packets of a BVH's leaves: leaf `k` with `n` lanes starts at lane `at` and holds each
/// field's `n` values consecutively (`data[FIELDS · at + f · n + j]`), so a leaf takes
/// `FIELDS · n` floats; a vector load of a field reads up to seven values past it, which the
/// lane count masks off (and `LANES` floats of padding end the list).
#[derive(Debug, Default)]
pub struct Packets {
    data: Vec<f32>,
    /// Lanes stored.
    lanes: u32,
    /// The primitive index of each lane; empty while lane `k` holds primitive `k` (primitives
    /// are numbered in leaf order, so only split triangles, whose pieces lie in several leaves,
    /// make it necessary).
    index: Vec<u32>,
}

/// What a lane holds: a triangle's vertices, or a sphere's centre and radius.
pub enum Lane {
    /// A triangle with these vertices.
    Triangle([DVec3; 3]),
    /// A sphere with this centre and radius.
    Sphere(DVec3, f64),
}

/// The ray as the filter reads it: f32 origin and direction, and `|o|∞` rounded up.
#[derive(Clone, Copy, Debug)]
pub struct PacketRay {
    o: [f32; 3],
    d: [f32; 3],
    o_norm: f32,
}

impl PacketRay {
    /// The ray `o + t d` (`d` a unit vector).
    #[inline(always)]
    pub fn new(o: DVec3, d: DVec3) -> Self {
        Self::from_copies(&wide::RayCopies::new(o.to_array(), d.to_array()))
    }

    /// [`PacketRay::new`] from the ray's f32 copies.
    #[inline(always)]
    pub fn from_copies(copies: &wide::RayCopies) -> Self {
        Self {
            o: copies.o,
            d: copies.d,
            o_norm: copies.largest * (1.0 + f32::EPSILON),
        }
    }
}

/// An f32 no smaller than `x` (non-negative).
fn up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x { y.next_up() } else { y }
}

/// What a lane holds, field by field ([`FIELDS`]), and whether it is *special* (a sphere or a
/// forced candidate, which the filter must be told of).
pub type LaneFields = ([f32; FIELDS], bool);

/// The fields of one lane: a triangle's f32 vertex and edges (the edges from the f64 vertices),
/// or a sphere's centre and radius with a NaN as `e₂`'s x; a primitive too large for f32
/// arithmetic becomes a sphere of infinite radius. Then the two norms, from those f32 copies.
pub fn lane_fields(lane: &Lane) -> LaneFields {
    let mut field = [0.0f32; FIELDS];
    let fits = |v: &DVec3| v.is_finite() && v.abs().max_element() < LARGEST;
    let sphere = match lane {
        Lane::Triangle(p) => {
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            if [p[0], e1, e2].iter().all(fits) {
                for (k, v) in [p[0], e1, e2].iter().enumerate() {
                    field[3 * k] = v.x as f32;
                    field[3 * k + 1] = v.y as f32;
                    field[3 * k + 2] = v.z as f32;
                }
                None
            } else {
                Some((DVec3::ZERO, f32::INFINITY))
            }
        }
        Lane::Sphere(c, r) => Some(if fits(c) && r.abs() < LARGEST {
            (*c, up(r.abs()))
        } else {
            (DVec3::ZERO, f32::INFINITY)
        }),
    };
    if let Some((c, r)) = sphere {
        field[0] = c.x as f32;
        field[1] = c.y as f32;
        field[2] = c.z as f32;
        field[3] = r;
        field[6] = f32::NAN;
    }
    let triple = |f: usize| [field[f], field[f + 1], field[f + 2]];
    let v0_norm = norm(triple(0));
    let edge = if sphere.is_some() {
        0.0
    } else {
        norm(triple(3)).max(norm(triple(6)))
    };
    field[V0_NORM] = v0_norm;
    field[EDGE] = edge;
    (field, sphere.is_some())
}

/// Eight lanes held apart from the tree's packets, each set on its own (the shadow cache's
/// occluders, `super::occluders`), filtered at once as a leaf's are.
#[derive(Clone, Debug)]
pub struct LoosePacket {
    /// Field `f` of lane `j` at `f · LANES + j`, then the padding a vector load past the last
    /// field reads.
    data: [f32; FIELDS * LANES + LANES],
    /// The lanes holding spheres or forced candidates.
    special: u8,
}

impl LoosePacket {
    /// Eight lanes of zeros, none special.
    pub const fn new() -> Self {
        Self {
            data: [0.0; FIELDS * LANES + LANES],
            special: 0,
        }
    }

    /// Set lane `j` (below [`LANES`]).
    pub fn set(&mut self, j: usize, (fields, special): &LaneFields) {
        for (f, &v) in fields.iter().enumerate() {
            self.data[f * LANES + j] = v;
        }
        self.special = self.special & !(1 << j) | u8::from(*special) << j;
    }

    /// The candidates among the eight lanes for hits of `ray` before `t_max` (a bound at or
    /// above the f64 one), a bit per lane, as [`Packets::candidates`] gives a leaf's.
    #[inline(always)]
    pub fn candidates<const V3: bool>(&self, ray: &PacketRay, t_max: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if V3 {
            // SAFETY: `V3` is set only by the x86-64-v3 copies of the queries, which run only
            // when the CPU has their features; `data` holds `FIELDS · LANES + LANES` floats.
            return unsafe { candidates_v3(&self.data, LANES, self.special != 0, ray, t_max) };
        }
        candidates_lanes(&self.data, LANES, ray, t_max)
    }
}

impl Default for LoosePacket {
    fn default() -> Self {
        Self::new()
    }
}

impl Packets {
    /// Storage for `lanes` lanes in all, allocated once.
    pub fn with_capacity(lanes: usize) -> Self {
        Self {
            data: Vec::with_capacity(FIELDS * lanes + LANES),
            lanes: 0,
            index: Vec::new(),
        }
    }

    /// Store one leaf (1 to [`LANES`] primitives, each its index and what to filter); returns
    /// its first lane and whether it holds lanes other than triangles (spheres or forced
    /// candidates, which [`Packets::candidates`] must be told of: [`wide::LEAF_FLAG`]).
    pub fn push(&mut self, primitives: &[(u32, Lane)]) -> (u32, bool) {
        let n = primitives.len();
        assert!((1..=LANES).contains(&n), "a packet holds 1 to 8 primitives");
        let at = self.lanes;
        // The padding of the previous leaf becomes this one's start.
        self.data.truncate(FIELDS * at as usize);
        let base = self.data.len();
        self.data.resize(base + FIELDS * n + LANES, 0.0);
        let mut special = false;
        for (j, (index, lane)) in primitives.iter().enumerate() {
            let (fields, lane_special) = lane_fields(lane);
            for (f, v) in fields.into_iter().enumerate() {
                self.data[base + f * n + j] = v;
            }
            special |= lane_special;
            if *index != at + j as u32 && self.index.is_empty() {
                // The first lane that is not its own primitive: list every lane from here on.
                self.index.extend(0..at + j as u32);
            }
            if !self.index.is_empty() || *index != at + j as u32 {
                self.index.push(*index);
            }
        }
        self.lanes += n as u32;
        (at, special)
    }

    /// The primitive index of lane `j` of the packet of the leaf pointer `leaf` (its first lane
    /// and count as [`wide::leaf`] encodes them, [`wide::LEAF_FLAG`] if it holds lanes other
    /// than triangles).
    #[inline(always)]
    pub fn index(&self, leaf: u32, j: u32) -> u32 {
        let lane = wide::leaf_range(leaf).0 + j;
        if self.index.is_empty() {
            lane
        } else {
            self.index[lane as usize]
        }
    }

    /// The candidates among the lanes of the packet of `leaf` (as [`Packets::index`]) for hits
    /// of `ray` before `t_max` (a bound at or above the f64 one): a bit per lane.
    #[inline(always)]
    pub fn candidates<const V3: bool>(&self, leaf: u32, ray: &PacketRay, t_max: f32) -> u32 {
        let (at, n) = wide::leaf_range(leaf);
        let special = leaf & wide::LEAF_FLAG != 0;
        let base = FIELDS * at as usize;
        let n = n as usize;
        let block = &self.data[base..base + FIELDS * n + LANES];
        #[cfg(target_arch = "x86_64")]
        if V3 {
            // SAFETY: `V3` is set only by the x86-64-v3 copies of the queries, which run only
            // when the CPU has their features; `block` holds `FIELDS · n + LANES` floats.
            return unsafe { candidates_v3(block, n, special, ray, t_max) };
        }
        candidates_lanes(block, n, ray, t_max)
    }
}

/// The filter lane by lane (the portable copy).
#[inline(always)]
fn candidates_lanes(block: &[f32], n: usize, ray: &PacketRay, t_max: f32) -> u32 {
    let mut mask = 0;
    for j in 0..n {
        let f = |k: usize| block[k * n + j];
        let v0 = [f(0), f(1), f(2)];
        let norms = (f(V0_NORM), f(EDGE));
        let candidate = if f(6).is_nan() {
            sphere_candidate_lane(v0, f(3), norms.0, ray, t_max)
        } else {
            let edges = [[f(3), f(4), f(5)], [f(6), f(7), f(8)]];
            triangle_candidate_lane(v0, edges, norms, ray, t_max)
        };
        if candidate {
            mask |= 1 << j;
        }
    }
    mask
}

/// `|v|∞`.
#[inline(always)]
fn norm(v: [f32; 3]) -> f32 {
    v[0].abs().max(v[1].abs()).max(v[2].abs())
}

/// The triangle filter of one lane (module comment), with its stored norms `(|v₀|∞, E)`.
#[inline(always)]
fn triangle_candidate_lane(
    v0: [f32; 3],
    [e1, e2]: [[f32; 3]; 2],
    (v0_norm, edge): (f32, f32),
    ray: &PacketRay,
    t_max: f32,
) -> bool {
    let (o, d) = (ray.o, ray.d);
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let tv = [o[0] - v0[0], o[1] - v0[1], o[2] - v0[2]];
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    let u = dot(tv, pv);
    let qv = cross(tv, e1);
    let v = dot(d, qv);
    let tdet = dot(e2, qv);
    let m_uv = K_EPS * (ray.o_norm + v0_norm) * edge;
    let m_det = K_EPS * edge * edge;
    let m_t = m_uv * edge;
    let a = det.abs();
    let s = if det < 0.0 { -1.0 } else { 1.0 };
    let (us, vs, ts) = (u * s, v * s, tdet * s);
    a <= m_det
        || (us >= -m_uv
            && vs >= -m_uv
            && us + vs <= a + m_det + 2.0 * m_uv
            && ts > -m_t
            && ts < t_max * (a + m_det) + m_t)
}

/// The sphere filter of one lane: the ray's line passes within the radius of the centre, and
/// the segment overlaps the chord, each within the bound `K ε (|o|∞ + |c|∞ + r)` of the rounding
/// of the f32 copies and the arithmetic (the f64 test finds roots in `(0, t_max)` of the line
/// within `r` of the centre). An infinite radius passes every ray. `c_norm` is the stored `|c|∞`.
#[inline(always)]
fn sphere_candidate_lane(c: [f32; 3], r: f32, c_norm: f32, ray: &PacketRay, t_max: f32) -> bool {
    let (o, d) = (ray.o, ray.d);
    let w = [c[0] - o[0], c[1] - o[1], c[2] - o[2]];
    let x = [
        w[1] * d[2] - w[2] * d[1],
        w[2] * d[0] - w[0] * d[2],
        w[0] * d[1] - w[1] * d[0],
    ];
    let tc = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
    let reach = r + K_EPS * (ray.o_norm + c_norm + r);
    x[0] * x[0] + x[1] * x[1] + x[2] * x[2] <= reach * reach
        && tc + reach > 0.0
        && tc - reach < t_max
}

/// The filter on eight lanes at once (the x86-64-v3 copies); lanes from `n` on are masked off.
/// The same bounds as the lane-by-lane filter, with fused multiply-adds (within them).
///
/// # Safety
/// The CPU must have AVX2 and FMA, and `block` must hold `FIELDS · n + LANES` floats.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn candidates_v3(
    block: &[f32],
    n: usize,
    special: bool,
    ray: &PacketRay,
    t_max: f32,
) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees the features; field `k` starts at `k · n`, and eight
    // floats from there lie within `block` for every field.
    unsafe {
        let f = |k: usize| _mm256_loadu_ps(block.as_ptr().add(k * n));
        let splat = _mm256_set1_ps;
        let abs = |x| _mm256_andnot_ps(splat(-0.0), x);
        let (o, d) = (ray.o, ray.d);
        let (dx, dy, dz) = (splat(d[0]), splat(d[1]), splat(d[2]));
        let (v0x, v0y, v0z) = (f(0), f(1), f(2));
        let (e1x, e1y, e1z) = (f(3), f(4), f(5));
        let (e2x, e2y, e2z) = (f(6), f(7), f(8));
        let tvx = _mm256_sub_ps(splat(o[0]), v0x);
        let tvy = _mm256_sub_ps(splat(o[1]), v0y);
        let tvz = _mm256_sub_ps(splat(o[2]), v0z);
        // `a·b − c·d` and `a·b + c·d + e·f`, fused.
        let msub = |a, b, c, d| _mm256_fmsub_ps(a, b, _mm256_mul_ps(c, d));
        let dot = |ax, ay, az, bx, by, bz| {
            _mm256_fmadd_ps(az, bz, _mm256_fmadd_ps(ay, by, _mm256_mul_ps(ax, bx)))
        };
        let pvx = msub(dy, e2z, dz, e2y);
        let pvy = msub(dz, e2x, dx, e2z);
        let pvz = msub(dx, e2y, dy, e2x);
        let det = dot(e1x, e1y, e1z, pvx, pvy, pvz);
        let u = dot(tvx, tvy, tvz, pvx, pvy, pvz);
        let qvx = msub(tvy, e1z, tvz, e1y);
        let qvy = msub(tvz, e1x, tvx, e1z);
        let qvz = msub(tvx, e1y, tvy, e1x);
        let v = dot(dx, dy, dz, qvx, qvy, qvz);
        let tdet = dot(e2x, e2y, e2z, qvx, qvy, qvz);
        let (v0_norm, edge) = (f(V0_NORM), f(EDGE));
        let k = splat(K_EPS);
        let m_uv = _mm256_mul_ps(
            _mm256_mul_ps(k, _mm256_add_ps(splat(ray.o_norm), v0_norm)),
            edge,
        );
        let m_det = _mm256_mul_ps(_mm256_mul_ps(k, edge), edge);
        let m_t = _mm256_mul_ps(m_uv, edge);
        // The determinant's sign onto the numerators, its magnitude apart.
        let sign = _mm256_and_ps(det, splat(-0.0));
        let a = abs(det);
        let us = _mm256_xor_ps(u, sign);
        let vs = _mm256_xor_ps(v, sign);
        let ts = _mm256_xor_ps(tdet, sign);
        let inside = _mm256_and_ps(
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(us, _mm256_xor_ps(m_uv, splat(-0.0))),
                _mm256_cmp_ps::<_CMP_GE_OQ>(vs, _mm256_xor_ps(m_uv, splat(-0.0))),
            ),
            _mm256_cmp_ps::<_CMP_LE_OQ>(
                _mm256_add_ps(us, vs),
                _mm256_add_ps(_mm256_add_ps(a, m_det), _mm256_add_ps(m_uv, m_uv)),
            ),
        );
        let ahead = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(ts, _mm256_xor_ps(m_t, splat(-0.0))),
            _mm256_cmp_ps::<_CMP_LT_OQ>(
                ts,
                _mm256_fmadd_ps(splat(t_max), _mm256_add_ps(a, m_det), m_t),
            ),
        );
        let flat = _mm256_cmp_ps::<_CMP_LE_OQ>(a, m_det);
        let mut candidate = _mm256_or_ps(flat, _mm256_and_ps(inside, ahead));
        if special {
            // Sphere lanes (a NaN as `e₂`'s x): their own filter, as `sphere_candidate_lane`,
            // with `w = −tv`, in place of the triangle's.
            let is_sphere = _mm256_cmp_ps::<_CMP_UNORD_Q>(e2x, e2x);
            let r = e1x;
            let xx = msub(tvy, dz, tvz, dy);
            let xy = msub(tvz, dx, tvx, dz);
            let xz = msub(tvx, dy, tvy, dx);
            let tc = _mm256_xor_ps(dot(tvx, tvy, tvz, dx, dy, dz), splat(-0.0));
            let reach = _mm256_fmadd_ps(
                k,
                _mm256_add_ps(_mm256_add_ps(splat(ray.o_norm), v0_norm), r),
                r,
            );
            let near = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LE_OQ>(
                    dot(xx, xy, xz, xx, xy, xz),
                    _mm256_mul_ps(reach, reach),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_add_ps(tc, reach), _mm256_setzero_ps()),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_sub_ps(tc, reach), splat(t_max)),
                ),
            );
            candidate = _mm256_or_ps(
                _mm256_andnot_ps(is_sphere, candidate),
                _mm256_and_ps(is_sphere, near),
            );
        }
        let mask = _mm256_movemask_ps(candidate) as u32;
        mask & ((1u32 << n) - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;
    use mcmc_core::rng::{stream, uniform};

    /// Random triangles and rays, many grazing, near edges and vertices, with far origins and
    /// tiny triangles: every exact hit is a candidate in both copies, and most misses are not.
    #[test]
    fn every_hit_is_a_candidate() {
        let mut rng = stream(91, 0);
        let mut r = || uniform(&mut rng);
        let (mut hits, mut candidates, mut tests) = (0, 0, 0);
        let (mut misses, mut false_candidates) = (0u32, 0u32);
        for case in 0..40_000 {
            let scale = [1e-3, 1.0, 1e3][case % 3];
            let reach = [1.0, 100.0, 1e5][case / 3 % 3];
            let offset = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * reach;
            let tris: Vec<[DVec3; 3]> = (0..LANES)
                .map(|_| {
                    let p = |r: &mut dyn FnMut() -> f64| {
                        offset + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * scale
                    };
                    [p(&mut r), p(&mut r), p(&mut r)]
                })
                .collect();
            // Aim at a point of the first triangle: on it, near an edge or a vertex, or beyond.
            let t0 = tris[0];
            let (b1, b2) = match case % 4 {
                0 => (r(), 0.0),
                1 => (0.0, 0.0),
                _ => (r(), r()),
            };
            let wobble = (r() - 0.5) * 1e-6;
            let target = t0[0] + (t0[1] - t0[0]) * (b1 + wobble) + (t0[2] - t0[0]) * b2;
            let o = target
                + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize()
                    * scale
                    * (0.01 + 10.0 * r());
            let mut d = (target - o).normalize();
            if case % 5 == 0 {
                // Grazing: nearly in the triangle's plane.
                let n = (t0[1] - t0[0]).cross(t0[2] - t0[0]).normalize();
                d = (d - n * n.dot(d) * (1.0 - 1e-7)).normalize();
            }
            let t_max = if case % 2 == 0 {
                f64::INFINITY
            } else {
                (target - o).length() * (0.5 + r())
            };
            let mut packets = Packets::default();
            let lanes: Vec<(u32, Lane)> = tris
                .iter()
                .enumerate()
                .map(|(i, p)| (i as u32, Lane::Triangle(*p)))
                .collect();
            let n = 1 + case % LANES;
            let (at, _) = packets.push(&lanes[..n]);
            let leaf = wide::leaf(at, n as u32);
            let ray = PacketRay::new(o, d);
            let bound = crate::accel::wide::traversal_t_max(t_max);
            let portable = packets.candidates::<false>(leaf, &ray, bound);
            let v3 = if crate::accel::cpu::cpu_has_v3() {
                packets.candidates::<true>(leaf, &ray, bound)
            } else {
                portable
            };
            for (j, p) in tris[..n].iter().enumerate() {
                let tri = Triangle {
                    p: *p,
                    uv: [[0.0; 2]; 3],
                    flip: false,
                    shading: crate::geometry::NO_SHADING,
                };
                let hit = tri.intersect(o, d, t_max).is_some();
                tests += 1;
                if hit {
                    hits += 1;
                    assert!(
                        portable & (1 << j) != 0,
                        "case {case} lane {j}: a hit filtered out (portable)"
                    );
                    assert!(
                        v3 & (1 << j) != 0,
                        "case {case} lane {j}: a hit filtered out (v3)"
                    );
                }
                if v3 & (1 << j) != 0 {
                    candidates += 1;
                }
                // The filter's efficiency, on the lanes not aimed at, where f32 resolves the
                // triangles (offsets at most 100 times their size).
                if j > 0 && reach <= 100.0 * scale {
                    misses += u32::from(!hit);
                    false_candidates += u32::from(!hit && v3 >> j & 1 == 1);
                }
            }
            assert_eq!(portable >> n, 0);
            assert_eq!(v3 >> n, 0);
        }
        assert!(hits > 5_000, "{hits} hits");
        assert!(
            candidates < tests,
            "{candidates} candidates of {tests} lanes"
        );
        // The filter is a filter: few misses are candidates.
        assert!(
            false_candidates * 100 < misses,
            "{false_candidates} of {misses} misses are candidates"
        );
    }
}
