//! Multiple importance sampling weights of the bidirectional strategies (Veach 1997 §10.2; the
//! ratio formulation of pbrt-v3's BDPT): the weight of `(s, t)` is
//! `p_{s,t}^β / Σ_i p_{i, k+1−i}^β`, computed from ratios of the forward and reverse area densities
//! stored in the vertices, after recomputing the reverse densities at the connection. Delta
//! densities are remapped to 1 and no strategy connects at a delta vertex or a point light's
//! position.

use super::vertex::Vertex;
use crate::light::LightKind;
use crate::scene::Scene;

/// Which heuristic combines the strategies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MisHeuristic {
    /// `β = 1`.
    Balance,
    /// `β = 2` (Veach's recommended default).
    #[default]
    Power,
}

#[derive(Clone, Copy)]
pub(crate) struct Densities {
    fwd: f64,
    rev: f64,
    delta: bool,
}

#[inline]
fn remap(p: f64) -> f64 {
    if p != 0.0 { p } else { 1.0 }
}

/// The MIS weight of strategy `(s, t)` for the path formed by `light[..s]` and `camera[..t]`.
/// Strategies `(0, 2)` and `(1, 1)` alone make paths of one edge; BDPT evaluates only `(0, 2)`
/// there, which then has weight 1 (pbrt's convention).
pub fn mis_weight(
    scene: &Scene,
    light: &[Vertex],
    camera: &[Vertex],
    s: usize,
    t: usize,
    heuristic: MisHeuristic,
) -> f64 {
    if s + t == 2 {
        return 1.0;
    }
    let pow = |r: f64| match heuristic {
        MisHeuristic::Balance => r,
        MisHeuristic::Power => r * r,
    };
    // Copy the densities of the path's vertices (small stack buffers; paths are short).
    let mut cam: smallvec_like::Buf = smallvec_like::Buf::new();
    let mut lit: smallvec_like::Buf = smallvec_like::Buf::new();
    for v in &camera[..t] {
        cam.push(Densities {
            fwd: v.pdf_fwd,
            rev: v.pdf_rev,
            delta: v.delta,
        });
    }
    for v in &light[..s] {
        lit.push(Densities {
            fwd: v.pdf_fwd,
            rev: v.pdf_rev,
            delta: v.delta,
        });
    }
    let pt = &camera[t - 1];
    let pt_minus = if t > 1 { Some(&camera[t - 2]) } else { None };
    let qs = if s > 0 { Some(&light[s - 1]) } else { None };
    let qs_minus = if s > 1 { Some(&light[s - 2]) } else { None };
    // Reverse densities at the connection.
    cam[t - 1].rev = match qs {
        Some(q) => q.pdf(scene, qs_minus, pt),
        None => pt.pdf_light_origin(scene),
    };
    cam[t - 1].delta = false;
    if let Some(pm) = pt_minus {
        cam[t - 2].rev = match qs {
            Some(q) => pt.pdf(scene, Some(q), pm),
            None => pt.pdf_light(scene, pm),
        };
    }
    if let Some(q) = qs {
        lit[s - 1].rev = pt.pdf(scene, pt_minus, q);
        lit[s - 1].delta = false;
        if let Some(qm) = qs_minus {
            lit[s - 2].rev = q.pdf(scene, Some(pt), qm);
        }
    }
    let mut sum = 0.0;
    let mut ri = 1.0;
    for i in (1..t).rev() {
        ri *= remap(cam[i].rev) / remap(cam[i].fwd);
        if !cam[i].delta && !cam[i - 1].delta {
            sum += pow(ri);
        }
    }
    ri = 1.0;
    let light_is_delta = match light.first().map(|v| v.kind) {
        Some(super::VertexKind::Light { light: l }) => {
            matches!(scene.lights[l as usize], LightKind::Point { .. })
        }
        _ => false,
    };
    for i in (0..s).rev() {
        ri *= remap(lit[i].rev) / remap(lit[i].fwd);
        let delta_before = if i > 0 {
            lit[i - 1].delta
        } else {
            light_is_delta
        };
        if !lit[i].delta && !delta_before {
            sum += pow(ri);
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() { w } else { 0.0 }
}

/// A fixed-capacity buffer, falling back to the heap for very long paths.
mod smallvec_like {
    use super::Densities;

    pub(crate) struct Buf {
        inline: [Densities; 32],
        len: usize,
        heap: Vec<Densities>,
    }

    impl Buf {
        pub fn new() -> Self {
            Self {
                inline: [Densities {
                    fwd: 0.0,
                    rev: 0.0,
                    delta: false,
                }; 32],
                len: 0,
                heap: Vec::new(),
            }
        }
        pub fn push(&mut self, d: Densities) {
            if self.len < 32 {
                self.inline[self.len] = d;
            } else {
                if self.heap.is_empty() {
                    self.heap.extend_from_slice(&self.inline);
                }
                self.heap.push(d);
            }
            self.len += 1;
        }
    }

    impl std::ops::Index<usize> for Buf {
        type Output = Densities;
        fn index(&self, i: usize) -> &Densities {
            if self.len <= 32 {
                &self.inline[i]
            } else {
                &self.heap[i]
            }
        }
    }

    impl std::ops::IndexMut<usize> for Buf {
        fn index_mut(&mut self, i: usize) -> &mut Densities {
            if self.len <= 32 {
                &mut self.inline[i]
            } else {
                &mut self.heap[i]
            }
        }
    }
}
