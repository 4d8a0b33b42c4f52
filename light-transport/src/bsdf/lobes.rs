//! A fixed-capacity list of weighted lobes (no heap allocation per hit) and the dispatch of the
//! four faces — sample, eval, pdf, invert — to the lobe kinds.
//!
//! Lobe `j` is chosen with probability `P_j(wo) = g_{G(j)} · w_j(wo) / Σ_{k ∈ G(j)} w_k(wo)`: the
//! lobes of one material form a *group* `G` with a constant probability `g_G` (the product of the
//! mean `amount`s of the enclosing mixes, renormalised over non-empty groups) shared among its
//! lobes by their selection weights `w_j(wo)` (constant, or a Fresnel-weighted albedo for the
//! layered material). The lobe number `u_lobe` picks lobe `j` when it falls in
//! `[c_j, c_j + P_j)`, `c_j = Σ_{k<j} P_k`, and the lobe sees the rescaled number
//! `u_sub = (u_lobe − c_j)/P_j ∈ [0, 1)` (which dielectric lobes use for their own branch choice).

use super::TransportMode;
use super::conductor::MicrofacetReflection;
use super::dielectric::SmoothDielectric;
use super::fresnel::dielectric;
use super::lambert::Lambert;
use super::mirror::SpecularReflection;
use super::rough_dielectric::RoughDielectric;
use crate::math::DVec3;
use crate::spectrum::Rgb;
use mcmc_core::ChainRng;
use mcmc_core::rng::uniform;

/// Largest number of lobes of one BSDF (after flattening mixes).
pub const MAX_LOBES: usize = 8;

/// Largest angle (radians, as a chord length) between two directions that are considered the
/// same delta direction.
pub const DELTA_TOLERANCE: f64 = 1e-6;

/// What a lobe's sampler produced (local frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeSample {
    /// Direction.
    pub wi: DVec3,
    /// Whether it is a delta direction.
    pub delta: bool,
    /// For delta samples: `f` (times `|cos θi|` the lobe's weight times `prob`).
    pub f: Rgb,
    /// For delta samples: the probability of the branch within the lobe.
    pub prob: f64,
}

impl LobeSample {
    /// A non-delta direction (value and density are evaluated by the caller).
    pub fn smooth(wi: DVec3) -> Self {
        Self {
            wi,
            delta: false,
            f: Rgb::BLACK,
            prob: 0.0,
        }
    }
    /// A delta direction with value `f` chosen with probability `prob` inside the lobe.
    pub fn delta(wi: DVec3, f: Rgb, prob: f64) -> Self {
        Self {
            wi,
            delta: true,
            f,
            prob,
        }
    }
}

/// `x > 0` (false for NaN): the guard used before dividing by a density or a cosine.
#[inline]
pub fn positive(x: f64) -> bool {
    x > 0.0
}

/// `x < 0` (false for NaN).
#[inline]
pub fn negative(x: f64) -> bool {
    x < 0.0
}

/// Whether two local directions are strictly on the same side of the surface.
#[inline]
pub fn same_side(a: DVec3, b: DVec3) -> bool {
    (a.z > 0.0 && b.z > 0.0) || (a.z < 0.0 && b.z < 0.0)
}

/// Whether two unit directions coincide (to [`DELTA_TOLERANCE`]).
#[inline]
pub fn same_direction(a: DVec3, b: DVec3) -> bool {
    (a - b).length_squared() < DELTA_TOLERANCE * DELTA_TOLERANCE
}

/// Mirror both directions through the tangent plane when `wo` is below it (two-sided lobes).
#[inline]
pub fn to_upper(wo: DVec3, wi: DVec3) -> (DVec3, DVec3) {
    if wo.z < 0.0 {
        (DVec3::new(wo.x, wo.y, -wo.z), DVec3::new(wi.x, wi.y, -wi.z))
    } else {
        (wo, wi)
    }
}

/// A uniform number in `[a, b)` (`a < b`).
#[inline]
pub fn uniform_in(a: f64, b: f64, rng: &mut ChainRng) -> f64 {
    let v = a + (b - a) * uniform(rng);
    if v >= b {
        b.next_down().max(a)
    } else {
        v.max(a)
    }
}

/// The kinds of lobes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LobeKind {
    /// Lambertian reflection.
    Lambert(Lambert),
    /// GGX reflection (rough conductor or coating).
    Glossy(MicrofacetReflection),
    /// Delta reflection.
    Specular(SpecularReflection),
    /// Smooth dielectric (delta reflection and refraction).
    Dielectric(SmoothDielectric),
    /// Rough dielectric (GGX reflection and transmission).
    RoughDielectric(RoughDielectric),
}

impl LobeKind {
    /// Whether the lobe is a delta lobe.
    pub fn is_delta(&self) -> bool {
        matches!(self, LobeKind::Specular(_) | LobeKind::Dielectric(_))
    }

    /// GGX roughnesses of a glossy lobe.
    pub fn alpha(&self) -> Option<(f64, f64)> {
        match self {
            LobeKind::Glossy(g) => Some((g.ggx.alpha_x, g.ggx.alpha_y)),
            LobeKind::RoughDielectric(g) => Some((g.ggx.alpha_x, g.ggx.alpha_y)),
            _ => None,
        }
    }

    fn sample(
        &self,
        wo: DVec3,
        u_sub: f64,
        u: [f64; 2],
        mode: TransportMode,
    ) -> Option<LobeSample> {
        match self {
            LobeKind::Lambert(l) => l.sample(wo, u),
            LobeKind::Glossy(g) => g.sample(wo, u),
            LobeKind::Specular(s) => s.sample(wo),
            LobeKind::Dielectric(d) => d.sample(wo, u_sub, mode),
            LobeKind::RoughDielectric(d) => d.sample(wo, u_sub, u),
        }
    }

    fn eval(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Rgb {
        match self {
            LobeKind::Lambert(l) => l.eval(wo, wi),
            LobeKind::Glossy(g) => g.eval(wo, wi),
            LobeKind::RoughDielectric(d) => d.eval(wo, wi, mode),
            LobeKind::Specular(_) | LobeKind::Dielectric(_) => Rgb::BLACK,
        }
    }

    /// `(eval, pdf)` of a non-delta lobe, bit for bit the two calls (glossy lobes share their
    /// microfacet terms: [`MicrofacetReflection::eval_pdf`]).
    fn eval_pdf(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> (Rgb, f64) {
        match self {
            LobeKind::Glossy(g) => g.eval_pdf(wo, wi),
            _ => (self.eval(wo, wi, mode), self.pdf(wo, wi)),
        }
    }

    fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        match self {
            LobeKind::Lambert(l) => l.pdf(wo, wi),
            LobeKind::Glossy(g) => g.pdf(wo, wi),
            LobeKind::RoughDielectric(d) => d.pdf(wo, wi),
            LobeKind::Specular(_) | LobeKind::Dielectric(_) => 0.0,
        }
    }

    fn eval_delta(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Option<(Rgb, f64)> {
        match self {
            LobeKind::Specular(s) => s.eval_delta(wo, wi),
            LobeKind::Dielectric(d) => d.eval_delta(wo, wi, mode),
            _ => None,
        }
    }

    fn invert(&self, wo: DVec3, wi: DVec3, rng: &mut ChainRng) -> Option<[f64; 3]> {
        let two = |uv: Option<[f64; 2]>, rng: &mut ChainRng| {
            uv.map(|[a, b]| [uniform_in(0.0, 1.0, rng), a, b])
        };
        match self {
            LobeKind::Lambert(l) => two(l.invert(wo, wi), rng),
            LobeKind::Glossy(g) => two(g.invert(wo, wi), rng),
            LobeKind::Specular(s) => s.invert(wo, wi, rng),
            LobeKind::Dielectric(d) => d.invert(wo, wi, rng),
            LobeKind::RoughDielectric(d) => d.invert(wo, wi, rng),
        }
    }
}

/// How a lobe's selection weight depends on `wo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weight {
    /// A constant.
    Constant(f64),
    /// `scale · F_dielectric(|cos θo|, eta)` (a coating's reflected share).
    Fresnel {
        /// Coating index.
        eta: f64,
        /// Albedo scale (`avg(Ks)`).
        scale: f64,
    },
}

impl Weight {
    fn at(&self, wo: DVec3) -> f64 {
        match *self {
            Weight::Constant(c) => c,
            Weight::Fresnel { eta, scale } => scale * dielectric(wo.z.abs(), eta),
        }
    }
}

/// One lobe: its kind, the per-channel factor of enclosing mixes, its group and weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    /// The lobe.
    pub kind: LobeKind,
    /// Per-channel factor of `f` (product of mix amounts).
    pub scale: Rgb,
    /// Index of its group.
    pub group: usize,
    /// Selection weight within the group.
    pub weight: Weight,
}

impl Lobe {
    /// `P_j(wo) pdf_j(wo, wi)` of this lobe chosen with probability `pj` (0 for a delta lobe).
    #[inline]
    pub fn pdf_term(&self, pj: f64, wo: DVec3, wi: DVec3) -> f64 {
        if pj > 0.0 && !self.kind.is_delta() {
            pj * self.kind.pdf(wo, wi)
        } else {
            0.0
        }
    }

    /// `(scale f(wo, wi), P_j(wo) pdf(wo, wi))` of this lobe chosen with probability `pj`, the
    /// lobe evaluated once for both; `None` for a delta lobe.
    #[inline]
    pub fn eval_pdf_term(
        &self,
        pj: f64,
        wo: DVec3,
        wi: DVec3,
        mode: TransportMode,
    ) -> Option<(Rgb, f64)> {
        if self.kind.is_delta() {
            return None;
        }
        let (f, pdf) = self.kind.eval_pdf(wo, wi, mode);
        Some((self.scale * f, if pj > 0.0 { pj * pdf } else { 0.0 }))
    }

    /// [`Lobes::eval_pdf_terms`] of a one-lobe BSDF, bit for bit: the lobe's value added to
    /// black and its density term, `(black, 0)` for a delta lobe.
    #[inline]
    pub fn eval_pdf_sum(&self, pj: f64, wo: DVec3, wi: DVec3, mode: TransportMode) -> (Rgb, f64) {
        let mut f = Rgb::BLACK;
        let mut t = 0.0;
        if let Some((fj, tj)) = self.eval_pdf_term(pj, wo, wi, mode) {
            f += fj;
            t = tj;
        }
        (f, t)
    }
}

const EMPTY: Lobe = Lobe {
    kind: LobeKind::Lambert(Lambert { r: Rgb::BLACK }),
    scale: Rgb::BLACK,
    group: 0,
    weight: Weight::Constant(0.0),
};

/// Lobes kept inline in a [`Lobes`]: matte, metal, mirror and glass have one, the layered
/// materials (plastic, substrate) two, and a mix of two one-lobe materials two; a mix that
/// flattens to more moves them to the heap. Inline storage keeps a BSDF, and with it a path
/// vertex, small to copy: two lobes rather than four saved 320 bytes a vertex (path-space MLT
/// 1.01–1.07× and CMLT 1.02–1.05× side by side, 10% less peak memory; BDPT and MMLT unchanged).
const INLINE_LOBES: usize = 2;

/// Where the lobes of a [`Lobes`] live.
// The inline variant is large on purpose: boxing it would allocate per hit.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
enum Storage {
    Inline([Lobe; INLINE_LOBES]),
    Spilled(Box<[Lobe; MAX_LOBES]>),
}

/// The lobes of a BSDF.
#[derive(Debug)]
pub struct Lobes {
    items: Storage,
    len: usize,
    group_prob: [f64; MAX_LOBES],
    groups: usize,
    /// The entry of a scene's table of prebuilt lobes ([`super::PrebuiltLobes`]) these lobes are
    /// an unmodified copy of, or [`NO_ORIGIN`]: a copy into lobes that already hold the same
    /// entry's copy is skipped. Every method that changes the lobes resets it.
    origin: u64,
}

/// [`Lobes`] built in place, not copied from a table of prebuilt lobes.
pub const NO_ORIGIN: u64 = u64::MAX;

impl Clone for Lobes {
    fn clone(&self) -> Self {
        Self {
            items: self.items.clone(),
            len: self.len,
            group_prob: self.group_prob,
            groups: self.groups,
            origin: self.origin,
        }
    }

    /// Only the lobes in use, into the storage this list has where they fit: a hit on a material
    /// whose lobes were built once ([`super::PrebuiltLobes`]) copies them into its vertex's BSDF
    /// (a derived `clone_from` would copy every slot, and allocate again for spilled lists).
    ///
    /// Lobes that hold an unmodified copy of the same table entry as `source` are left as they are:
    /// a hit on the material of the vertex slot's previous hit, or a candidate path copied from a
    /// current path it was copied from before, copies nothing.
    fn clone_from(&mut self, source: &Self) {
        if source.origin != NO_ORIGIN && self.origin == source.origin {
            return;
        }
        self.origin = source.origin;
        let lobes = source.as_slice();
        match &mut self.items {
            Storage::Inline(a) if lobes.len() <= INLINE_LOBES => {
                a[..lobes.len()].copy_from_slice(lobes)
            }
            Storage::Spilled(b) => b[..lobes.len()].copy_from_slice(lobes),
            Storage::Inline(_) => self.items = source.items.clone(),
        }
        self.len = source.len;
        self.group_prob = source.group_prob;
        self.groups = source.groups;
    }
}

/// Equal lobes and groups (storage beyond them is ignored).
impl PartialEq for Lobes {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
            && self.group_prob[..self.groups] == other.group_prob[..other.groups]
    }
}

impl Default for Lobes {
    fn default() -> Self {
        Self {
            items: Storage::Inline([EMPTY; INLINE_LOBES]),
            len: 0,
            group_prob: [0.0; MAX_LOBES],
            groups: 0,
            origin: NO_ORIGIN,
        }
    }
}

/// Lobe selection probabilities at one `wo`.
pub type Probabilities = [f64; MAX_LOBES];

impl Lobes {
    /// Mark these lobes as entry `origin` of a table of prebuilt lobes (unique among all tables
    /// and entries, never [`NO_ORIGIN`]); any change to them clears the mark.
    pub(crate) fn set_origin(&mut self, origin: u64) {
        self.origin = origin;
    }

    /// The lobes.
    pub fn as_slice(&self) -> &[Lobe] {
        match &self.items {
            Storage::Inline(a) => &a[..self.len],
            Storage::Spilled(b) => &b[..self.len],
        }
    }

    /// Remove every lobe and group (keeping the storage).
    pub fn clear(&mut self) {
        self.origin = NO_ORIGIN;
        self.len = 0;
        self.groups = 0;
        self.group_prob = [0.0; MAX_LOBES];
    }

    /// Open a new group of probability `prob`; `None` when full.
    pub fn new_group(&mut self, prob: f64) -> Option<usize> {
        self.origin = NO_ORIGIN;
        if self.groups == MAX_LOBES {
            return None;
        }
        self.group_prob[self.groups] = prob;
        self.groups += 1;
        Some(self.groups - 1)
    }

    /// Add a lobe; `None` when the list is full.
    pub fn push(&mut self, lobe: Lobe) -> Option<()> {
        self.origin = NO_ORIGIN;
        if self.len == MAX_LOBES {
            return None;
        }
        if let Storage::Inline(a) = &self.items
            && self.len == INLINE_LOBES
        {
            let mut b = Box::new([EMPTY; MAX_LOBES]);
            b[..INLINE_LOBES].copy_from_slice(a);
            self.items = Storage::Spilled(b);
        }
        match &mut self.items {
            Storage::Inline(a) => a[self.len] = lobe,
            Storage::Spilled(b) => b[self.len] = lobe,
        }
        self.len += 1;
        Some(())
    }

    /// Renormalise group probabilities over the groups that hold lobes.
    pub fn finish(&mut self) {
        self.origin = NO_ORIGIN;
        let mut used = [false; MAX_LOBES];
        for l in self.as_slice() {
            used[l.group] = true;
        }
        let groups = &mut self.group_prob[..self.groups];
        let total: f64 = groups
            .iter()
            .zip(used)
            .filter(|(_, u)| *u)
            .map(|(p, _)| *p)
            .sum();
        for (p, u) in groups.iter_mut().zip(used) {
            *p = if u && total > 0.0 { *p / total } else { 0.0 };
        }
    }

    /// `P_0(wo)` of the only lobe `l` of a one-lobe list: its group's sum is its own weight; the
    /// arithmetic of [`Lobes::probabilities`] without the per-group sums.
    #[inline]
    fn single_probability(&self, l: &Lobe, wo: DVec3) -> f64 {
        let v = l.weight.at(wo);
        let s = if v.is_finite() && v > 0.0 { v } else { 0.0 };
        if s > 0.0 {
            self.group_prob[l.group] * s / s
        } else {
            0.0
        }
    }

    /// The lobe of a one-lobe list (most materials) and its probability `P_0(wo)`, bit for bit
    /// `probabilities(wo)[0]`; `None` for other lists. Callers evaluate the one lobe directly,
    /// without the per-lobe arrays.
    #[inline]
    pub fn single(&self, wo: DVec3) -> Option<(&Lobe, f64)> {
        let [l] = self.as_slice() else {
            return None;
        };
        Some((l, self.single_probability(l, wo)))
    }

    /// `P_j(wo)` for every lobe.
    pub fn probabilities(&self, wo: DVec3) -> Probabilities {
        let mut w = [0.0; MAX_LOBES];
        if let [l] = self.as_slice() {
            w[0] = self.single_probability(l, wo);
            return w;
        }
        let mut sums = [0.0; MAX_LOBES];
        for (j, l) in self.as_slice().iter().enumerate() {
            let v = l.weight.at(wo);
            w[j] = if v.is_finite() && v > 0.0 { v } else { 0.0 };
            sums[l.group] += w[j];
        }
        for (j, l) in self.as_slice().iter().enumerate() {
            let s = sums[l.group];
            w[j] = if s > 0.0 {
                self.group_prob[l.group] * w[j] / s
            } else {
                0.0
            };
        }
        w
    }

    /// Pick the lobe of `u_lobe`: `(j, u_sub)`.
    pub fn choose(&self, p: &Probabilities, u_lobe: f64) -> Option<(usize, f64)> {
        let mut c = 0.0;
        let mut last = None;
        for (j, &pj) in p[..self.len].iter().enumerate() {
            if pj <= 0.0 {
                continue;
            }
            if u_lobe < c + pj {
                return Some((j, ((u_lobe - c) / pj).clamp(0.0, 1.0_f64.next_down())));
            }
            c += pj;
            last = Some(j);
        }
        // Rounding: u_lobe beyond the (slightly short) total goes to the last lobe.
        last.map(|j| (j, 1.0_f64.next_down()))
    }

    /// `u_lobe` for lobe `j` and its rescaled number `u_sub` (inverse of [`Lobes::choose`]).
    pub fn lobe_number(&self, p: &Probabilities, j: usize, u_sub: f64) -> f64 {
        let c: f64 = p[..j].iter().filter(|&&v| v > 0.0).sum();
        let next = c + p[j];
        let u = c + p[j] * u_sub;
        // Stay inside [c, c + P_j) after rounding; the last lobe keeps [c, 1).
        let is_last = p[j + 1..self.len].iter().all(|&v| v <= 0.0);
        let hi = if is_last { 1.0 } else { next };
        if u >= hi {
            hi.next_down().max(c)
        } else {
            u.max(c)
        }
    }

    /// Sample lobe `j`.
    pub fn sample(
        &self,
        j: usize,
        wo: DVec3,
        u_sub: f64,
        u: [f64; 2],
        mode: TransportMode,
    ) -> Option<LobeSample> {
        self.as_slice()[j].kind.sample(wo, u_sub, u, mode)
    }

    /// `Σ_j scale_j f_j(wo, wi)` over non-delta lobes.
    pub fn eval(&self, wo: DVec3, wi: DVec3, mode: TransportMode) -> Rgb {
        let mut f = Rgb::BLACK;
        for l in self.as_slice() {
            if !l.kind.is_delta() {
                f += l.scale * l.kind.eval(wo, wi, mode);
            }
        }
        f
    }

    /// Per-lobe `P_j(wo) pdf_j(wo, wi)` over non-delta lobes.
    pub fn pdf_terms(&self, p: &Probabilities, wo: DVec3, wi: DVec3) -> Probabilities {
        let mut t = [0.0; MAX_LOBES];
        for (j, l) in self.as_slice().iter().enumerate() {
            t[j] = l.pdf_term(p[j], wo, wi);
        }
        t
    }

    /// [`Lobes::eval`] and [`Lobes::pdf_terms`] together, bit for bit, each lobe evaluated once
    /// for both.
    pub fn eval_pdf_terms(
        &self,
        p: &Probabilities,
        wo: DVec3,
        wi: DVec3,
        mode: TransportMode,
    ) -> (Rgb, Probabilities) {
        let mut f = Rgb::BLACK;
        let mut t = [0.0; MAX_LOBES];
        for (j, l) in self.as_slice().iter().enumerate() {
            if let Some((fj, tj)) = l.eval_pdf_term(p[j], wo, wi, mode) {
                f += fj;
                t[j] = tj;
            }
        }
        (f, t)
    }

    /// Per-lobe `(scale_j f_j, P_j · branch probability)` of the delta lobes producing `wi`.
    pub fn delta_terms(
        &self,
        p: &Probabilities,
        wo: DVec3,
        wi: DVec3,
        mode: TransportMode,
    ) -> [(Rgb, f64); MAX_LOBES] {
        let mut t = [(Rgb::BLACK, 0.0); MAX_LOBES];
        for (j, l) in self.as_slice().iter().enumerate() {
            if p[j] > 0.0
                && l.kind.is_delta()
                && let Some((f, prob)) = l.kind.eval_delta(wo, wi, mode)
            {
                t[j] = (l.scale * f, p[j] * prob);
            }
        }
        t
    }

    /// Lobe `j`'s inverse: `(u_sub, u0, u1)`.
    pub fn invert(&self, j: usize, wo: DVec3, wi: DVec3, rng: &mut ChainRng) -> Option<[f64; 3]> {
        self.as_slice()[j].kind.invert(wo, wi, rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lobes beyond the inline ones move to the heap in order, up to [`MAX_LOBES`].
    #[test]
    fn lobes_spill_past_the_inline_capacity_in_order() {
        let mut lobes = Lobes::default();
        let lobe = |k: usize| Lobe {
            kind: LobeKind::Lambert(Lambert {
                r: Rgb::splat(k as f64 / 10.0),
            }),
            scale: Rgb::WHITE,
            group: 0,
            weight: Weight::Constant(1.0),
        };
        for k in 0..MAX_LOBES {
            assert_eq!(lobes.push(lobe(k)), Some(()));
            assert_eq!(lobes.as_slice().len(), k + 1);
        }
        assert_eq!(lobes.push(lobe(99)), None);
        assert!(matches!(lobes.items, Storage::Spilled(_)));
        for (k, l) in lobes.as_slice().iter().enumerate() {
            assert_eq!(*l, lobe(k));
        }
        let copy = lobes.clone();
        assert_eq!(copy.as_slice(), lobes.as_slice());
    }
}
