//! A complete light path `x̄ = v_0 … v_k` (light endpoint first, lens point last) as path-space MLT
//! sees it (Veach & Guibas 1997; overview paper §5.3), and its evaluation through every
//! bidirectional strategy.
//!
//! Every strategy `s` (light vertices `v_0 … v_{s−1}`, camera vertices `v_s … v_k`) that could have
//! produced the path gives an unweighted contribution `C*_s = f(x̄) / p_s(x̄)`, computed by
//! re-walking the path from both ends with the BDPT machinery (so delta factors cancel exactly as
//! they do in BDPT). Path-space mutations never need `f` or `p_s` on their own — only these
//! ratios — which keeps specular paths exact: `p_s / p_u = C*_u / C*_s`.

use crate::bsdf::TransportMode;
use crate::math::DVec3;
use crate::path::{DELTA_DENSITY, End, Vertex, VertexKind, join};
use crate::scene::Scene;
use crate::spectrum::Rgb;

/// A full path.
#[derive(Debug, Default)]
pub struct FullPath {
    /// Vertices from the light endpoint (`v_0`, kind [`VertexKind::Light`]) to the lens point
    /// (`v_k`, kind [`VertexKind::Camera`]); the scattering vertices in between carry their BSDF
    /// and whether they scatter through a delta lobe (`delta`).
    pub vertices: Vec<Vertex>,
}

impl Clone for FullPath {
    fn clone(&self) -> Self {
        Self {
            vertices: self.vertices.clone(),
        }
    }

    /// Keeps the vertex list's storage (a derived `clone_from` would allocate it anew).
    fn clone_from(&mut self, source: &Self) {
        self.vertices.clone_from(&source.vertices);
    }
}

/// The two walks of a path's evaluation ([`FullPath::strategies`]), kept with its chain state:
/// a candidate that keeps a run of the path's vertices at either end resumes the walks where its
/// own vertices begin ([`FullPath::strategies_resumed`]).
#[derive(Debug, Default)]
pub struct Walks {
    /// The walk from the light, `v_0 … v_k`.
    pub light: Vec<Traced>,
    /// The walk from the lens, `v_k … v_0`.
    pub camera: Vec<Traced>,
    /// How many leading entries of each walk are valid ([`walk`]'s results); `None` before a
    /// path was walked, or after [`Walks::forget`].
    valid: Option<(usize, usize)>,
    /// The position and delta flag of each vertex the walks were made from, `v_0` first: what a
    /// candidate's kept vertices are checked against before their entries are reused.
    vertices: Vec<(DVec3, bool)>,
}

impl Clone for Walks {
    fn clone(&self) -> Self {
        Self {
            light: self.light.clone(),
            camera: self.camera.clone(),
            valid: self.valid,
            vertices: self.vertices.clone(),
        }
    }

    /// Keeps the vectors' storage (charted MLT copies its current state into its candidate at
    /// every move; a derived `clone_from` would allocate the walks anew each time).
    fn clone_from(&mut self, source: &Self) {
        self.light.clone_from(&source.light);
        self.camera.clone_from(&source.camera);
        self.valid = source.valid;
        self.vertices.clone_from(&source.vertices);
    }
}

impl Walks {
    /// Forget the walks (their path changed without a new evaluation): nothing resumes them.
    pub fn forget(&mut self) {
        self.valid = None;
    }

    /// How many leading entries of the light and the camera walk are valid; `None` when no
    /// path's walks are held.
    pub fn valid(&self) -> Option<(usize, usize)> {
        self.valid
    }

    /// The throughput over density with which the light walk arrives at vertex `i` of
    /// `vertices`, bit for bit what [`arriving_throughput`] of `v_0 … v_i` gives (`Some(None)`
    /// where that is `None`), read from these walks when they were made from the same
    /// `v_0 … v_i` (the entry reads no later vertex); `None` when they were not, and the caller
    /// walks itself.
    pub fn light_arriving(&self, vertices: &[Vertex], i: usize) -> Option<Option<Rgb>> {
        let (valid, _) = self.valid?;
        if i >= vertices.len() || self.kept(vertices, i + 1, 0).0 != i + 1 {
            return None;
        }
        Some((valid > i).then(|| self.light[i].beta))
    }

    /// [`Walks::light_arriving`] of the camera walk: its throughput arriving at vertex `i` of
    /// `vertices`, walked from the lens `v_k` (what [`arriving_throughput`] of `v_k … v_i`
    /// gives), when these walks were made from the same `v_i … v_k`.
    pub fn camera_arriving(&self, vertices: &[Vertex], i: usize) -> Option<Option<Rgb>> {
        let (_, valid) = self.valid?;
        let j = vertices.len().checked_sub(i + 1)?;
        if self.kept(vertices, 0, j + 1).1 != j + 1 {
            return None;
        }
        Some((valid > j).then(|| self.camera[j].beta))
    }

    /// How many of `vertices`' leading (`light`) and trailing (`camera`) vertices, at most
    /// `light` and `camera`, are bit for bit where these walks' vertices were, with the same
    /// delta flags: the vertices whose walk entries can be reused.
    fn kept(&self, vertices: &[Vertex], light: usize, camera: usize) -> (usize, usize) {
        let same = |a: &(DVec3, bool), v: &Vertex| {
            a.1 == v.delta && a.0.to_array().map(f64::to_bits) == v.p().to_array().map(f64::to_bits)
        };
        let leading = (self.vertices.iter().zip(vertices))
            .take(light)
            .take_while(|(a, v)| same(a, v))
            .count();
        let trailing = (self.vertices.iter().rev().zip(vertices.iter().rev()))
            .take(camera)
            .take_while(|(a, v)| same(a, v))
            .count();
        (leading, trailing)
    }
}

/// The walks of a path a candidate was made from, and how many of its vertices the candidate
/// keeps at each end (a mutation's [`super::mutation::Change`]).
#[derive(Clone, Copy, Debug)]
pub struct Resume<'a> {
    /// The source path's walks.
    pub walks: &'a Walks,
    /// Leading vertices `v_0 …` the candidate keeps.
    pub light: usize,
    /// Trailing vertices `… v_k` the candidate keeps.
    pub camera: usize,
}

/// What a walk along a path leaves at one vertex ([`walk`]): the fields [`retrace`] writes into
/// a vertex, and the vertex's factor toward the next vertex of the walk.
#[derive(Clone, Copy, Debug, Default)]
pub struct Traced {
    /// Unit direction toward the previous vertex of the walk (zero at its start).
    pub wo: DVec3,
    /// Throughput up to this vertex over its density.
    pub beta: Rgb,
    /// Area density of this vertex from its predecessor (at the start: of the endpoint itself).
    pub pdf_fwd: f64,
    /// [`Vertex::f`] toward the next vertex of the walk, for scattering vertices that the walk
    /// left through a non-delta lobe (black otherwise).
    pub f_next: Rgb,
}

impl FullPath {
    /// Number of edges `k`.
    pub fn edges(&self) -> usize {
        self.vertices.len().saturating_sub(1)
    }

    /// The lens vertex `v_k`.
    pub fn lens(&self) -> &Vertex {
        &self.vertices[self.vertices.len() - 1]
    }

    /// Whether vertex `i` scatters through a delta lobe (endpoints never do).
    #[inline]
    pub fn specular(&self, i: usize) -> bool {
        self.vertices[i].delta
    }

    /// Where the path crosses the image: the raster position of the edge `v_k → v_{k−1}`.
    pub fn raster(&self, scene: &Scene) -> Option<[f64; 2]> {
        let n = self.vertices.len();
        if n < 2 {
            return None;
        }
        let lens = &self.vertices[n - 1];
        let w = (self.vertices[n - 2].p() - lens.p()).normalize_or_zero();
        scene.camera.importance(lens.p(), w).2
    }

    /// The path made by strategy `(s, t)` from a light and a camera subpath (in walk order). For
    /// `s = 0` the camera subpath's last vertex must lie on an area light and becomes the light
    /// endpoint; `None` otherwise. The two connection vertices are marked non-delta.
    pub fn from_subpaths(
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
    ) -> Option<Self> {
        let mut path = Self::default();
        path.set_from_subpaths(scene, light, camera, s, t)?;
        Some(path)
    }

    /// [`FullPath::from_subpaths`] reusing this path's storage.
    pub fn set_from_subpaths(
        &mut self,
        scene: &Scene,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
    ) -> Option<()> {
        if s > light.len() || t > camera.len() || t == 0 || s + t < 2 {
            return None;
        }
        // Into the slots this path has, each vertex copied by `clone_from` (only the lobes in
        // use; a cleared list refilled by `clone` copied every vertex whole, and moved it again).
        let v = &mut self.vertices;
        v.truncate(s + t);
        for (i, from) in light[..s]
            .iter()
            .chain(camera[..t].iter().rev())
            .enumerate()
        {
            match v.get_mut(i) {
                Some(slot) => slot.clone_from(from),
                None => v.push(from.clone()),
            }
        }
        self.mark_connection(scene, s)
    }

    /// [`FullPath::set_from_subpaths`] for subpaths walked in place: this path's first `s`
    /// vertices are the light subpath, the rest the camera subpath (a mutation that walks in
    /// its candidate's own slots copies no vertex out of a walk).
    pub fn closed_at(&mut self, scene: &Scene, s: usize) -> Option<()> {
        let n = self.vertices.len();
        if s >= n || n < 2 {
            return None;
        }
        self.mark_connection(scene, s)
    }

    /// Make this path a candidate of `len` vertices that keeps `source`'s first `head` and last
    /// `tail` vertices, in place (each vertex copied into the storage of the one it replaces);
    /// the `len − head − tail` slots between hold stale vertices for a walk to overwrite
    /// ([`super::walk::trace_into`], [`super::walk::extend_in_place`]).
    pub fn splice_from(&mut self, source: &FullPath, head: usize, len: usize, tail: usize) {
        let (x, v) = (&source.vertices, &mut self.vertices);
        assert!(
            head + tail <= len && head.max(tail) <= x.len() && (len == 0 || !x.is_empty()),
            "a splice keeps vertices the source has"
        );
        v.truncate(len);
        if v.len() < len {
            v.resize(len, x[0].clone());
        }
        v[..head].clone_from_slice(&x[..head]);
        v[len - tail..].clone_from_slice(&x[x.len() - tail..]);
    }

    /// The end of [`FullPath::set_from_subpaths`] once the vertices are in place: the light
    /// endpoint of a path made by strategy `s = 0`, the two connection vertices marked
    /// non-delta, and whether the path runs from a light to the camera.
    fn mark_connection(&mut self, scene: &Scene, s: usize) -> Option<()> {
        if s == 0 {
            let v0 = &mut self.vertices[0];
            let (light, kind) = scene.light_at(v0.point.primitive)?;
            if kind.is_delta_position() {
                return None;
            }
            v0.kind = VertexKind::Light {
                light: light as u32,
            };
            v0.delta = false;
        } else {
            self.vertices[s - 1].delta = false;
        }
        self.vertices[s].delta = false;
        let k = self.vertices.len() - 1;
        (self.vertices[k].kind == VertexKind::Camera
            && matches!(self.vertices[0].kind, VertexKind::Light { .. }))
        .then_some(())
    }

    /// Whether strategy `s` (light vertices `v_0 … v_{s−1}`) could have produced this path: the
    /// connecting edge must join two vertices that do not scatter through delta lobes, and for
    /// `s = 0` the light endpoint must be an area light (paths cannot hit a point light).
    pub fn strategy_valid(&self, scene: &Scene, s: usize) -> bool {
        let n = self.vertices.len();
        if s >= n || n < 2 {
            return false;
        }
        if s == 0 {
            return match self.vertices[0].kind {
                VertexKind::Light { light } => !scene.lights[light as usize].is_delta_position(),
                _ => false,
            };
        }
        !self.vertices[s - 1].delta && !self.vertices[s].delta
    }

    /// `C*_s` for every strategy `s = 0 … k` into `out` (`None` where the strategy is invalid or
    /// contributes nothing), without visibility tests (the path's edges are known to be clear);
    /// the walks it makes are left in `walks`.
    ///
    /// One walk from each end ([`walk`]) gives every prefix's throughput and every vertex's
    /// factor toward its neighbours, so each strategy is one product: `O(k)` BSDF evaluations
    /// per path, with no vertex copied. The numbers are those of connecting the two retraced
    /// subpaths strategy by strategy ([`retrace`], [`crate::path::connect_unoccluded`]), bit for
    /// bit (a test keeps that version to compare).
    pub fn strategies(&self, scene: &Scene, walks: &mut Walks, out: &mut Vec<Option<Rgb>>) {
        self.strategies_resumed(scene, None, walks, out);
    }

    /// [`FullPath::strategies`] of a candidate made from a path whose walks are `source`: the
    /// entries of each walk that read only vertices the candidate kept are copied, and the walk
    /// goes on from there ([`walk_resumed`]). A mutation that replaces the camera end keeps the
    /// light walk up to its first new vertex, and one that replaces a middle section (the
    /// bidirectional mutation) keeps both walks up to it. Kept vertices are checked against the
    /// source's (position and delta flag, bit for bit); the numbers are bit for bit those of
    /// walking anew (a test compares them for every mutation).
    pub fn strategies_resumed(
        &self,
        scene: &Scene,
        source: Option<Resume<'_>>,
        walks: &mut Walks,
        out: &mut Vec<Option<Rgb>>,
    ) {
        out.clear();
        walks.valid = None;
        let n = self.vertices.len();
        if n < 2 {
            return;
        }
        let k = n - 1;
        let v = &self.vertices;
        let resume = source.and_then(|r| {
            let (light, camera) = r.walks.valid?;
            let (kl, kc) = r.walks.kept(v, r.light, r.camera);
            Some((
                (&r.walks.light[..], light, kl),
                (&r.walks.camera[..], camera, kc),
            ))
        });
        let (light_from, camera_from) = resume.unzip();
        // The light side's prefixes end at `v_{k−1}` at the latest; its walk goes on to `v_k` only
        // for the factor of `v_{k−1}` toward the lens point.
        let lv_walked = walk_resumed(
            scene,
            n,
            |i| &v[i],
            TransportMode::Importance,
            light_from,
            &mut walks.light,
        );
        let lv = lv_walked.min(k);
        let cv = walk_resumed(
            scene,
            n,
            |j| &v[k - j],
            TransportMode::Radiance,
            camera_from,
            &mut walks.camera,
        );
        walks.valid = Some((lv_walked, cv));
        walks.vertices.clear();
        walks.vertices.extend(v.iter().map(|x| (x.p(), x.delta)));
        let (light, camera) = (&walks.light, &walks.camera);
        let end = |vertex, t: &Traced| End {
            vertex,
            beta: t.beta,
            pdf_fwd: t.pdf_fwd,
        };
        for s in 0..=k {
            let t = k + 1 - s;
            let c = (s <= lv && t <= cv && self.strategy_valid(scene, s))
                .then(|| {
                    join(
                        scene,
                        s.checked_sub(1).map(|i| end(&v[i], &light[i])),
                        end(&v[s], &camera[t - 1]),
                        (t >= 2).then(|| &v[s + 1]),
                        || (light[s - 1].f_next, None),
                        || (camera[t - 1].f_next, None),
                    )
                })
                .flatten()
                .map(|c| c.value)
                .filter(|v| v.is_finite() && !v.is_black());
            out.push(c);
        }
    }
}

/// Recompute the throughputs, forward densities and directions of a subpath whose vertex
/// positions, BSDFs and delta flags are known, walking from its endpoint exactly as the random
/// walks of [`crate::path`] would. Returns how many leading vertices are valid (a zero density
/// cuts the subpath there); only those are written.
pub fn retrace(scene: &Scene, sub: &mut [Vertex], mode: TransportMode) -> usize {
    TRACED.with_borrow_mut(|traced| {
        let valid = walk(scene, sub.len(), |i| &sub[i], mode, traced);
        for (v, t) in sub.iter_mut().zip(&traced[..valid]) {
            v.wo = t.wo;
            v.beta = t.beta;
            v.pdf_fwd = t.pdf_fwd;
            v.pdf_rev = 0.0;
        }
        valid
    })
}

thread_local! {
    // The walk's records, kept per thread (manifold and photon moves retrace per proposal).
    static TRACED: std::cell::RefCell<Vec<Traced>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The throughput over density with which the walk over `at(0) … at(n − 1)` (`n ≥ 1`) arrives at
/// its last vertex, as [`retrace`] of those vertices would write it there, with nothing copied or
/// written; `None` when the walk does not reach it.
pub fn arriving_throughput<'a>(
    scene: &Scene,
    n: usize,
    at: impl Fn(usize) -> &'a Vertex,
    mode: TransportMode,
) -> Option<Rgb> {
    TRACED.with_borrow_mut(|traced| {
        (n > 0 && walk(scene, n, at, mode, traced) >= n).then(|| traced[n - 1].beta)
    })
}

/// The walk of [`retrace`] over the `n` vertices `at(0) … at(n − 1)`, from `at(0)`, without
/// writing them: their walk quantities go to `out` (resized to `n`), and the factor of each
/// vertex toward the next is kept ([`Traced::f_next`]). Returns how many leading vertices are
/// valid; entries beyond them are meaningless.
pub fn walk<'a>(
    scene: &Scene,
    n: usize,
    at: impl Fn(usize) -> &'a Vertex,
    mode: TransportMode,
    out: &mut Vec<Traced>,
) -> usize {
    out.clear();
    out.resize(n, Traced::default());
    if n == 0 {
        return 0;
    }
    let start = at(0);
    match start.kind {
        VertexKind::Light { light } => {
            let l = &scene.lights[light as usize];
            let p = scene.light_distribution.pdf(light as usize) * l.pdf_position();
            if !(p > 0.0) {
                return 0;
            }
            out[0].pdf_fwd = p;
            out[0].beta = Rgb::splat(1.0 / p);
        }
        VertexKind::Camera => {
            out[0].pdf_fwd = scene.camera.pdf_lens();
            out[0].beta = Rgb::WHITE;
        }
        VertexKind::Surface => return 0,
    }
    if n == 1 {
        return 1;
    }
    let next = at(1);
    let w01 = (next.p() - start.p()).normalize_or_zero();
    let (weight, pdf_dir) = match start.kind {
        VertexKind::Light { light } => {
            let l = &scene.lights[light as usize];
            let pdf = l.pdf_direction(start.n(), w01);
            let cos = if l.is_delta_position() {
                1.0
            } else {
                start.n().dot(w01).abs()
            };
            (start.le(scene, next) * (cos / (out[0].pdf_fwd * pdf)), pdf)
        }
        _ => {
            let (we, pdf, _) = scene.camera.importance(start.p(), w01);
            let cos = scene.camera.forward().dot(w01).abs();
            (Rgb::splat(we * cos / (out[0].pdf_fwd * pdf)), pdf)
        }
    };
    if !(pdf_dir > 0.0) || !weight.is_finite() {
        return 1;
    }
    out[1].beta = weight;
    out[1].pdf_fwd = start.to_area(pdf_dir, next, scene);
    walk_on(scene, n, at, mode, out, 1)
}

/// [`walk`] resumed from `source = (entries, valid, kept)`: the walk of a path (its first `valid`
/// entries valid) whose first `kept` vertices are `at(0) … at(kept − 1)`; `None`, or fewer than
/// two kept vertices: [`walk`].
///
/// Step `i` of the walk reads vertices `i − 1`, `i` and `i + 1` only, so entries `0 … kept − 2`
/// and the throughput, density and direction of entry `kept − 1` are the source's; the walk goes
/// on from step `kept − 1`. A source walk that ended before that step ends here where it did.
pub fn walk_resumed<'a>(
    scene: &Scene,
    n: usize,
    at: impl Fn(usize) -> &'a Vertex,
    mode: TransportMode,
    source: Option<(&[Traced], usize, usize)>,
    out: &mut Vec<Traced>,
) -> usize {
    let Some((entries, valid, kept)) = source.filter(|&(_, _, kept)| kept >= 2 && kept <= n) else {
        return walk(scene, n, at, mode, out);
    };
    let r = kept - 1;
    out.clear();
    if valid <= r {
        out.extend_from_slice(&entries[..valid]);
        out.resize(n, Traced::default());
        return valid;
    }
    out.extend_from_slice(&entries[..=r]);
    out[r].f_next = Rgb::BLACK;
    out.resize(n, Traced::default());
    walk_on(scene, n, at, mode, out, r)
}

/// Steps `from … n − 1` of [`walk`] (`from ≥ 1`), entries `0 … from` already in `out` (of entry
/// `from` its throughput and density).
fn walk_on<'a>(
    scene: &Scene,
    n: usize,
    at: impl Fn(usize) -> &'a Vertex,
    mode: TransportMode,
    out: &mut [Traced],
    from: usize,
) -> usize {
    let mut beta = out[from].beta;
    let mut prev = at(from - 1);
    for i in from..n {
        let v = at(i);
        let wo = (prev.p() - v.p()).normalize_or_zero();
        out[i].wo = wo;
        out[i].beta = beta;
        if i + 1 == n {
            break;
        }
        let next = at(i + 1);
        let wi = (next.p() - v.p()).normalize_or_zero();
        let Some(b) = v.bsdf.as_ref() else {
            return i + 1;
        };
        let shading = v.shading_factor(scene, wo, wi, mode);
        let (f, pdf) = if v.delta {
            match b.eval_delta(wo, wi, mode) {
                Some(d) => (d.f, d.pdf),
                None => return i + 1,
            }
        } else {
            // Value and density from one change of frame, each lobe evaluated once for both.
            let (f, pdf) = b
                .local_pair(wo, wi)
                .map_or((Rgb::BLACK, 0.0), |l| b.eval_pdf_local(l, mode));
            out[i].f_next = f * shading;
            (f, pdf)
        };
        if !(pdf > 0.0) {
            return i + 1;
        }
        beta *= f * (shading * wi.dot(v.n()).abs() / pdf);
        if !beta.is_finite() {
            return i + 1;
        }
        out[i + 1].pdf_fwd = v.to_area(if v.delta { DELTA_DENSITY } else { pdf }, next, scene);
        prev = v;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::connect_unoccluded;
    use crate::pathspace::PathState;
    use crate::pathspace::walk::sample_path;
    use crate::sampler::IndependentStream;
    use crate::scene::builtin;
    use mcmc_core::rng::{stream, uniform};

    /// A splice keeps the source's first `head` and last `tail` vertices, has `len`, and leaves
    /// the slots between alone, whether the path grows, shrinks or keeps its length.
    #[test]
    fn a_splice_keeps_the_ends_it_names() {
        let at = |i: usize| {
            crate::pathspace::walk::endpoint(
                VertexKind::Camera,
                crate::geometry::SurfacePoint::flat(DVec3::splat(i as f64), DVec3::Z, i as u32),
            )
        };
        let source = FullPath {
            vertices: (0..6).map(at).collect(),
        };
        for (before, len) in [(0, 7), (3, 8), (6, 6), (9, 5)] {
            let mut path = FullPath {
                vertices: (100..100 + before).map(at).collect(),
            };
            path.splice_from(&source, 2, len, 3);
            let p: Vec<f64> = path.vertices.iter().map(|v| v.p().x).collect();
            assert_eq!(p.len(), len);
            assert_eq!(p[..2], [0.0, 1.0]);
            assert_eq!(p[len - 3..], [3.0, 4.0, 5.0]);
            for (i, &x) in p.iter().enumerate().take(len - 3).skip(2) {
                assert!(
                    x == 0.0 || x == 100.0 + i as f64,
                    "{before} → {len}: slot {i} is {x}"
                );
            }
        }
    }

    /// `C*_s` the long way: copy the path into its two subpaths, retrace each, connect strategy by
    /// strategy (what [`FullPath::strategies`] did before it kept one walk from each end).
    fn strategies_by_connection(path: &FullPath, scene: &Scene) -> Vec<Option<Rgb>> {
        let v = &path.vertices;
        let k = v.len() - 1;
        let mut light = v[..k].to_vec();
        let mut camera: Vec<Vertex> = v.iter().rev().cloned().collect();
        let lv = retrace(scene, &mut light, TransportMode::Importance);
        let cv = retrace(scene, &mut camera, TransportMode::Radiance);
        (0..=k)
            .map(|s| {
                let t = k + 1 - s;
                (s <= lv && t <= cv && path.strategy_valid(scene, s))
                    .then(|| connect_unoccluded(scene, &light, &camera, s, t))
                    .flatten()
                    .map(|c| c.value)
                    .filter(|v| v.is_finite() && !v.is_black())
            })
            .collect()
    }

    /// `per_scene` paths of every built-in scene, each of a random length `k` (1–6 edges) made by
    /// a random strategy `s`, handed to `each(name, scene, k, s, state)` once sampled; `seeds`
    /// seed the choices of `k` and `s` and the sampler. Returns nothing: `each` asserts.
    fn for_sampled_paths(
        seeds: (u64, u64),
        per_scene: usize,
        mut each: impl FnMut(&str, &Scene, usize, usize, &PathState),
    ) {
        let mut rng = stream(seeds.0, 0);
        for name in builtin::all() {
            let scene = Scene::new(&builtin::builtin(name).unwrap(), Some((32, 24))).unwrap();
            let mut sampler = IndependentStream::new(stream(seeds.1, 0));
            let mut paths = 0;
            for _ in 0..100_000 {
                if paths == per_scene {
                    break;
                }
                let k = 1 + (uniform(&mut rng) * 6.0) as usize;
                let s = ((uniform(&mut rng) * (k + 2) as f64) as usize).min(k + 1);
                let mut state = PathState::default();
                sampler.new_sample();
                if sample_path(&scene, k, s, &mut sampler, &mut state).is_none() {
                    continue;
                }
                each(name, &scene, k, s, &state);
                paths += 1;
            }
            assert_eq!(paths, per_scene, "{name}: too few paths sampled");
        }
    }

    /// The one-walk-per-end evaluation gives exactly (bit for bit) the contributions of retracing
    /// both subpaths and connecting each strategy, on paths of every length sampled by every
    /// strategy in every built-in scene (glass, mirrors, shading normals, point and area lights).
    #[test]
    fn strategies_equal_connecting_retraced_subpaths() {
        let (mut walks, mut out) = (Walks::default(), Vec::new());
        let bits = |c: &[Option<Rgb>]| -> Vec<Option<[u64; 3]>> {
            c.iter()
                .map(|c| c.map(|c| [0, 1, 2].map(|i| c[i].to_bits())))
                .collect()
        };
        let mut counts = std::collections::BTreeMap::<String, (usize, usize)>::new();
        for_sampled_paths((9, 10), 400, |name, scene, k, s, state| {
            let path = &state.path;
            path.strategies(scene, &mut walks, &mut out);
            let expected = strategies_by_connection(path, scene);
            assert_eq!(bits(&out), bits(&expected), "{name}, k = {k}, s = {s}");
            let c = counts.entry(name.to_string()).or_default();
            c.0 += out.iter().flatten().count();
            c.1 += usize::from((1..k).any(|i| path.specular(i)));
        });
        for (name, (nonzero, specular)) in counts {
            assert!(nonzero > 400, "{name}: {nonzero} values");
            println!("{name}: {nonzero} nonzero C*_s, {specular} specular");
        }
    }

    /// The throughputs a path's evaluation reads from its walks ([`Walks::light_arriving`],
    /// [`Walks::camera_arriving`]) are bit for bit what walking the path's ends again gives
    /// ([`arriving_throughput`]), at every vertex of paths of every length in every built-in
    /// scene, and walks of another path are refused. The test checks itself: the walk's
    /// neighbouring entry, which an index off by one would read, is another number.
    #[test]
    fn walks_give_the_arriving_throughputs() {
        let (mut walks, mut out) = (Walks::default(), Vec::new());
        let bits = |c: Option<Rgb>| c.map(|c| [0, 1, 2].map(|i| c[i].to_bits()));
        let mut counts = std::collections::BTreeMap::<String, (usize, usize)>::new();
        let mut previous: Option<FullPath> = None;
        for_sampled_paths((11, 12), 300, |name, scene, k, _, state| {
            let path = &state.path;
            let v = &path.vertices;
            path.strategies(scene, &mut walks, &mut out);
            let c = counts.entry(name.to_string()).or_default();
            for i in 0..v.len() {
                let light = arriving_throughput(scene, i + 1, |j| &v[j], TransportMode::Importance);
                let camera =
                    arriving_throughput(scene, k - i + 1, |j| &v[k - j], TransportMode::Radiance);
                let (Some(l), Some(cam)) =
                    (walks.light_arriving(v, i), walks.camera_arriving(v, i))
                else {
                    panic!("{name}: the path's own walks refused at vertex {i}");
                };
                assert_eq!(bits(l), bits(light), "{name}, k = {k}, light side at {i}");
                assert_eq!(
                    bits(cam),
                    bits(camera),
                    "{name}, k = {k}, camera side at {i}"
                );
                c.0 += usize::from(l.is_some()) + usize::from(cam.is_some());
                if l.is_some() && i + 1 < v.len() && bits(Some(walks.light[i + 1].beta)) != bits(l)
                {
                    c.1 += 1;
                }
            }
            if let Some(other) = &previous
                && other.vertices[0].p() != v[0].p()
            {
                let foreign = walks.light_arriving(&other.vertices, 0);
                assert!(foreign.is_none(), "{name}: walks of another path read");
            }
            previous = Some(path.clone());
        });
        for (name, (read, neighbours_differ)) in counts {
            assert!(
                read > 600 && neighbours_differ > 100,
                "{name}: {read} throughputs read, {neighbours_differ} neighbours differ"
            );
        }
    }
}
